#!/usr/bin/env bash
# Makes target/pyenv: a Python venv with the PyPI wheel iceoryx2==0.10.0 (peers only connect when their
# iceoryx2 versions match exactly; the service is built on 0.10.0) and the project's Python client
# installed as a package (`pip install clients/python`: the module tractrix_client and the command
# tractrix-client), MuJoCo for the simulator-loop example, and rerun-sdk 0.36.3 (the viewer `rerun` of
# `watch --rerun`, which must match the rerun crate, and the reader of the viewer test), and Ray, pyarrow
# and tqdm for the sweeps of tractrix_sweep. Idempotent;
# scripts/test.sh runs it.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=target/pyenv
# tractrix_sweep (clients/python): episodes on Ray, rows in Parquet, a progress bar.
SWEEP="ray==2.60.0 pyarrow tqdm matplotlib"
install_client() {
    # The client package from this checkout (no network: its one dependency is already there).
    "$VENV/bin/pip" install --quiet --disable-pip-version-check --no-deps --no-build-isolation \
        --force-reinstall ./clients/python >/dev/null
}
if [ -x "$VENV/bin/python" ] && "$VENV/bin/python" -c \
    'import importlib.metadata as m, sys; sys.exit(m.version("iceoryx2") != "0.10.0")' 2>/dev/null; then
    # `wheel` builds the client package without build isolation (no download per run).
    "$VENV/bin/python" -c 'import wheel' 2>/dev/null ||
        "$VENV/bin/pip" install --quiet --disable-pip-version-check wheel
    "$VENV/bin/python" -c 'import mujoco, OpenGL' 2>/dev/null ||
        "$VENV/bin/pip" install --quiet --disable-pip-version-check mujoco PyOpenGL
    "$VENV/bin/python" -c 'import importlib.metadata as m, sys; sys.exit(m.version("rerun-sdk") != "0.36.3")' 2>/dev/null ||
        "$VENV/bin/pip" install --quiet --disable-pip-version-check rerun-sdk==0.36.3
    "$VENV/bin/python" -c 'import ray, pyarrow, tqdm, matplotlib' 2>/dev/null ||
        "$VENV/bin/pip" install --quiet --disable-pip-version-check $SWEEP
    install_client
    exit 0
fi
command -v python3 >/dev/null || { echo "python-venv: python3 is needed (apt install python3 python3-venv)" >&2; exit 1; }
python3 -m venv "$VENV" || { echo "python-venv: python3 -m venv failed (apt install python3-venv)" >&2; exit 1; }
# MuJoCo (and PyOpenGL for its offscreen frames) for the simulator-loop example (clients/python/examples/mujoco_loop.py).
"$VENV/bin/pip" install --quiet --disable-pip-version-check iceoryx2==0.10.0 wheel mujoco PyOpenGL \
    rerun-sdk==0.36.3 $SWEEP
install_client
"$VENV/bin/python" -c 'import iceoryx2, tractrix_client' && echo "python-venv: $VENV ready (iceoryx2 0.10.0, tractrix-client, rerun-sdk 0.36.3, ray)" >&2
