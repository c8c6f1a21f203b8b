#!/usr/bin/env bash
# Installs the distribution's packages the tests and examples need, unless they are there: Mono's C#
# compiler and runtime (mono-mcs, mono-runtime: the C# example of the C library) and OSMesa (libosmesa6:
# MuJoCo's offscreen frames, headless). Debian packages; needs root (CI runs as root) or sudo.
set -euo pipefail
have() {
  command -v mcs >/dev/null && command -v mono >/dev/null && ldconfig -p | grep -q libOSMesa
}
if have; then
  exit 0
fi
SUDO=""
if [ "$(id -u)" != 0 ]; then
  SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
PACKAGES="mono-mcs mono-runtime libosmesa6"
$SUDO apt-get install -y -q --no-install-recommends $PACKAGES >/dev/null 2>&1 || {
  $SUDO apt-get update -q >/dev/null
  $SUDO apt-get install -y -q --no-install-recommends $PACKAGES >/dev/null
}
have
