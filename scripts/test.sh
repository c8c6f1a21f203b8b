#!/usr/bin/env bash
# The project's test command (README): builds the binaries the end-to-end tests start and the C library,
# makes the Python client's venv, installs Mono and OSMesa, then runs every test of the workspace.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --workspace --bins --profile test
# `watch` with the Rerun viewer (cargo feature `rerun`, many dependencies): built once, here, into
# target/viewer/, in the profile `viewer` (no optimisation, no debug info: a much shorter build than the
# optimised test profile's).
cargo build -p clients --features rerun --bin watch --profile viewer
# The C library (libtractrix_client.so and .a) that the C and C++ examples link against.
cargo build -p tractrix-client --lib --profile test
# The Python client's venv (PyPI wheel iceoryx2==0.10.0) for the end-to-end test of the Python client.
scripts/python-venv.sh
# Mono (the C# example of the C library) and OSMesa (MuJoCo's offscreen frames).
scripts/system-packages.sh
# Every test binary runs even when one fails (cargo stops at the first failing binary otherwise, and
# the failures after it go unseen).
cargo test --workspace --no-fail-fast "$@"
