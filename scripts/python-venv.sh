#!/usr/bin/env bash
# Makes target/pyenv: a Python venv with the PyPI wheel iceoryx2==0.10.0 (peers only connect when their
# iceoryx2 versions match exactly; the service is built on 0.10.0). Idempotent; scripts/test.sh runs it.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=target/pyenv
if [ -x "$VENV/bin/python" ] && "$VENV/bin/python" -c \
    'import importlib.metadata as m, sys; sys.exit(m.version("iceoryx2") != "0.10.0")' 2>/dev/null; then
    exit 0
fi
command -v python3 >/dev/null || { echo "python-venv: python3 is needed (apt install python3 python3-venv)" >&2; exit 1; }
python3 -m venv "$VENV" || { echo "python-venv: python3 -m venv failed (apt install python3-venv)" >&2; exit 1; }
"$VENV/bin/pip" install --quiet --disable-pip-version-check iceoryx2==0.10.0
"$VENV/bin/python" -c 'import iceoryx2' && echo "python-venv: $VENV ready (iceoryx2 0.10.0)" >&2
