#!/usr/bin/env bash
# Installs the distribution's packages the tests and examples need, unless they are there: Mono's C#
# compiler and runtime (mono-mcs, mono-runtime: the C# example of the C library) and OSMesa (libosmesa6:
# MuJoCo's offscreen frames, headless). Debian packages, as root or with password-less sudo; without
# either it says so in one line and installs nothing (the tests that need them skip themselves).
set -euo pipefail
# ldconfig lives in /sbin, which a normal user's PATH may not have.
have() {
  command -v mcs >/dev/null && command -v mono >/dev/null \
    && PATH="$PATH:/sbin:/usr/sbin" ldconfig -p | grep -q libOSMesa
}
if have; then
  exit 0
fi
PACKAGES="mono-mcs mono-runtime libosmesa6"
SUDO=""
if [ "$(id -u)" != 0 ]; then
  if ! command -v sudo >/dev/null || ! sudo -n true 2>/dev/null || ! command -v apt-get >/dev/null; then
    # Without root (or an apt-get) nothing is installed; the tests that need these packages skip
    # themselves with a line each, except under CI=true, where nothing may be skipped.
    echo "scripts/system-packages.sh: no root, no password-less sudo or no apt-get: not installing $PACKAGES; the C# example tests and the MuJoCo loop's test are skipped" >&2
    [ "${CI:-}" = true ] && exit 1
    exit 0
  fi
  SUDO="sudo"
elif ! command -v apt-get >/dev/null; then
  echo "scripts/system-packages.sh: no apt-get: not installing $PACKAGES; the C# example tests and the MuJoCo loop's test are skipped" >&2
  [ "${CI:-}" = true ] && exit 1
  exit 0
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get install -y -q --no-install-recommends $PACKAGES >/dev/null 2>&1 || {
  $SUDO apt-get update -q >/dev/null
  $SUDO apt-get install -y -q --no-install-recommends $PACKAGES >/dev/null
}
have
