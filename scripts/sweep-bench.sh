#!/usr/bin/env bash
# The sweeps of BENCHMARKS.md (issue 19), on a local Ray of this machine's two CPUs, with release binaries:
#   scripts/sweep-bench.sh scaling [EPISODES] [ROUNDS]   # episodes/s with 1 and 2 workers; cost of one episode
#   scripts/sweep-bench.sh knots [OUT.parquet]           # knot success over script × resolution (grid file
#                                                        # clients/python/grids/knots.json), through the service;
#                                                        # also draws docs/sweep-knots.svg; SWEEP_RESUME=1
#                                                        # resumes a stopped sweep if no code changed since
#   scripts/sweep-bench.sh accuracy [OUT.parquet]        # speed against accuracy (grid file
#                                                        # clients/python/grids/accuracy.json), episodes of
#                                                        # the `episode` binary
# Prints the Markdown table BENCHMARKS.md shows.
set -euo pipefail
cd "$(dirname "$0")/.."
TARGET=${CARGO_TARGET_DIR:-target}
cargo build -q --release -p solver-service -p clients --bins
scripts/python-venv.sh >/dev/null
PY=target/pyenv/bin/python
export RAY_TMPDIR=${RAY_TMPDIR:-$(realpath "$TARGET")/ray}
mkdir -p "$RAY_TMPDIR"
case "${1:-}" in
  scaling)
    "$PY" -m tractrix_sweep scaling --bin "$TARGET/release" --episodes "${2:-32}" --rounds "${3:-3}" 2>"$RAY_TMPDIR/sweep-bench.log" || { tail -20 "$RAY_TMPDIR/sweep-bench.log" >&2; exit 1; }
    ;;
  knots)
    OUT=${2:-$TARGET/sweep-knots.parquet}
    # SWEEP_RESUME=1 goes on with a sweep that stopped (a session ended): the episodes already in OUT are
    # kept, but only when no code an episode runs has changed since the sweep began (the commit in
    # OUT.commit, and nothing uncommitted); otherwise the sweep starts again.
    code=(solver-service/kernel/src solver-service/src shared/src clients/src clients/python/tractrix_sweep.py clients/python/grids/knots.json)
    if [ "${SWEEP_RESUME:-0}" = 1 ] && [ -f "$OUT" ] && [ -f "$OUT.commit" ] \
      && git diff --quiet "$(cat "$OUT.commit")" HEAD -- "${code[@]}" && git diff --quiet HEAD -- "${code[@]}"; then
      echo "sweep-bench: resuming $OUT, begun at commit $(cat "$OUT.commit")" >&2
    else
      rm -f "$OUT"
      git rev-parse --short HEAD > "$OUT.commit"
    fi
    "$PY" -m tractrix_sweep run clients/python/grids/knots.json --out "$OUT" --bin "$TARGET/release" \
      --num-cpus 2 --no-progress --by script,start,anchors,grasp,passes,length,links 2>"$RAY_TMPDIR/sweep-bench.log" || { tail -20 "$RAY_TMPDIR/sweep-bench.log" >&2; exit 1; }
    "$PY" -m tractrix_sweep plot "$OUT" --x link_length --series script,anchors,grasp --out docs/sweep-knots.svg
    printf '\n![Knot success over link length, one line per script and holds](docs/sweep-knots.svg)\n'
    ;;
  accuracy)
    OUT=${2:-$TARGET/sweep-accuracy.parquet}
    rm -f "$OUT"
    export TRACTRIX_TRUTH_CACHE=$RAY_TMPDIR/truth
    "$PY" -m tractrix_sweep run clients/python/grids/accuracy.json --out "$OUT" --bin "$TARGET/release" \
      --num-cpus 2 --no-progress 2>"$RAY_TMPDIR/sweep-bench.log" || { tail -20 "$RAY_TMPDIR/sweep-bench.log" >&2; exit 1; }
    ;;
  *)
    echo "usage: scripts/sweep-bench.sh scaling [EPISODES] [ROUNDS] | knots [OUT.parquet] | accuracy [OUT.parquet]" >&2
    exit 2
    ;;
esac
