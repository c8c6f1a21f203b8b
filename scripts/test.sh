#!/usr/bin/env bash
# The project's test command (README): builds the binaries the end-to-end tests start and the C library,
# makes the Python client's venv, installs Mono and OSMesa, then runs every test of the workspace.
set -euo pipefail
cd "$(dirname "$0")/.."
# step NAME COMMAND...: runs COMMAND and says how long it took (the README's time per part).
step() {
  local name=$1 t0=$SECONDS rc=0
  shift
  "$@" || rc=$?
  echo "[test.sh] $name: $((SECONDS - t0)) s" >&2
  return "$rc"
}
# The binaries the end-to-end tests start, the C library (libtractrix_client.so and .a) that the C and
# C++ examples link against, and the Rust quick start (`--example hello`, built here, once: two tests run
# it at once, and one building it while the other started it failed under load, "Permission denied"
# executing the half-written file). One cargo command for the three: built one by one (`-p
# tractrix-client`, `-p clients`), cargo resolved fewer features for their dependencies and compiled
# nalgebra, the kernel, the world and the clients a second and a third time (3 minutes of a CI run).
step "the binaries, the C library and the Rust quick start (test profile)" \
  cargo build --workspace --lib --bins --example hello --profile test
# The Python client's venv (PyPI wheel iceoryx2==0.10.0) for the end-to-end test of the Python client,
# then Mono (the C# example of the C library) and OSMesa (MuJoCo's offscreen frames): downloads and
# installs, so they run in the background while the viewer compiles, and their output goes to a log.
setup_log=$(mktemp)
(
  step "the Python venv (iceoryx2, MuJoCo, rerun-sdk, Ray)" scripts/python-venv.sh
  step "Mono and OSMesa" scripts/system-packages.sh
) >"$setup_log" 2>&1 &
setup=$!
# `watch` with the Rerun viewer (cargo feature `rerun`, many dependencies): built once, here, into
# target/viewer/, in the profile `viewer` (no optimisation, no debug info: a much shorter build than the
# optimised test profile's). Built beside the test binaries (cargo locks each profile's directory
# apart), the two took 574 s on CI's fresh clone against 320 s and 221 s one after the other: no gain.
step "the Rerun viewer (watch --features rerun)" \
  cargo build -p clients --features rerun --bin watch --profile viewer
setup_rc=0
wait "$setup" || setup_rc=$?
cat "$setup_log" >&2
rm -f "$setup_log"
if [ "$setup_rc" != 0 ]; then
  echo "scripts/test.sh: the Python venv or the system packages failed (exit $setup_rc, output above)" >&2
  exit "$setup_rc"
fi
# The test binaries, built before any CPU hog starts: the hog loads the tests, not the compiler (built
# beside two hogs, they took 6 of the 21 minutes of a CI run).
step "the test binaries" cargo test --workspace --no-run "$@"
# TRACTRIX_TEST_LOAD=N runs the tests beside N busy-spinning processes, a CPU hog at normal priority (CI
# runs the suite beside two, one per core: no test may need an idle machine).
load=${TRACTRIX_TEST_LOAD:-0}
if ! [[ "$load" =~ ^[0-8]$ ]]; then
  echo "TRACTRIX_TEST_LOAD=$load: expected a number of spinning processes from 0 to 8" >&2
  exit 2
fi
hogs=()
if [ "$load" -gt 0 ]; then
  for _ in $(seq "$load"); do
    bash -c 'while :; do :; done' &
    hogs+=($!)
  done
  trap 'kill "${hogs[@]}" 2>/dev/null || true' EXIT
  echo "== the tests beside $load busy-spinning processes (TRACTRIX_TEST_LOAD=$load)"
fi
# Every test binary runs even when one fails (cargo stops at the first failing binary otherwise, and
# the failures after it go unseen).
# Skipped tests add a line each to this file (tests::skip): cargo shows nothing of a test that passed.
skips=$(mktemp)
export TRACTRIX_TEST_SKIPS=$skips
tests_rc=0
step "the tests" cargo test --workspace --no-fail-fast "$@" || tests_rc=$?
if [ -s "$skips" ]; then
  echo "== $(sort -u "$skips" | wc -l) skipped (the tests above that passed include them):" >&2
  sort -u "$skips" >&2
else
  echo "== nothing skipped" >&2
fi
rm -f "$skips"
exit "$tests_rc"
