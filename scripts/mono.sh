#!/usr/bin/env bash
# Installs Mono's C# compiler and runtime (Debian packages mono-mcs and mono-runtime) for the C# example
# of the C library, unless `mcs` and `mono` are already there. Needs root (CI runs as root) or sudo.
set -euo pipefail
if command -v mcs >/dev/null && command -v mono >/dev/null; then
  exit 0
fi
SUDO=""
if [ "$(id -u)" != 0 ]; then
  SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get install -y -q --no-install-recommends mono-mcs mono-runtime >/dev/null 2>&1 || {
  $SUDO apt-get update -q >/dev/null
  $SUDO apt-get install -y -q --no-install-recommends mono-mcs mono-runtime >/dev/null
}
command -v mcs >/dev/null && command -v mono >/dev/null
