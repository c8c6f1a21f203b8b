#!/usr/bin/env bash
# The whole stitch (issue 39), one command: on `stitch.toml`'s 80-link suture `stitch-80`, the
# needle's pass (hand A alone: the needle loaded over the entry, driven round its circle through
# both sides, its point cutting the holes, the suture drawn through until its tail is 15.25 units
# long), then the instrument tie of a surgeon's knot over the bite by two hands (A the
# long end, B the tail with the needle driver riding on it), tightened (each hand pulls its end until
# it stops; the scene's tissue gives, so the pulls draw the eyelets toward the incision: the wound
# closes). `watch` reads every state: it saves a
# Rerun recording and draws one SVG of the key frames (the first state, the needle going in and out,
# each change of the hand that moves, the last). Prints each hand's report: the eyelets, the tail
# before the entry and, at the end, the knot. Seconds after the builds.
#
#   scripts/stitch.sh [OUT_DIR]      # default target/stitch: stitch.rrd, stitch.svg
#   PICTURE=docs/stitch.svg scripts/stitch.sh    # also copies the key frames there (the README's)
#   CHAIN=stitch-160 scripts/stitch.sh           # the 160-link suture
#
# Open the recording with `rerun target/stitch/stitch.rrd`. `--perturb SEED` perturbs both hands'
# turns (the bench `cargo bench -p clients --bench stitch` runs 16 seeds):
#   scripts/stitch.sh target/stitch --perturb 7
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/stitch}
shift || true
mkdir -p "$out"
cargo build -q --release -p solver-service -p clients --bins
# `watch` with the Rerun recorder (the feature `rerun`), in the test suite's profile for it.
cargo build -q -p clients --features rerun --bin watch --profile viewer
prefix="stitch_$$_"
CHAIN=${CHAIN:-stitch-80}
tmp=$(mktemp -d)
trap 'kill $svc $watcher 2>/dev/null || true; rm -rf "$tmp"' EXIT
target/release/solver-service --prefix "$prefix" --scene solver-service/scenes/stitch.toml --no-persist \
  --wait event --state-buffer 4096 >"$tmp/service.log" 2>&1 &
svc=$!
target/viewer/watch --prefix "$prefix" --wait-for-service 30 --chain "$CHAIN" --save "$out/stitch.rrd" \
  --sheet "$out/stitch.svg" --view=-90,20 >"$tmp/watch.log" 2>&1 &
watcher=$!
# Every state from the first: the hands start once `watch` listens.
for _ in $(seq 600); do
  grep -q "listening" "$tmp/watch.log" 2>/dev/null && break
  sleep 0.1
done
grep -q "listening" "$tmp/watch.log" || { cat "$tmp/watch.log"; echo "watch did not start" >&2; exit 1; }
hand() {
  target/release/hand --prefix "$prefix" --wait-for-service 30 run --chain "$CHAIN" --quiet \
    --turn-timeout 300 "$@"
}
echo "== the needle's pass (hand A)"
hand --builtin stitch-pass --identify "$CHAIN" "$@"
echo "== the surgeon's knot over the bite, tightened (hands A and B)"
hand --builtin surgeons-knot --hand A --tighten 0.05 "$@" >"$tmp/a.log" 2>&1 &
a=$!
hand --builtin surgeons-knot --hand B --tighten 0.05 --identify "$CHAIN" "$@"
wait $a || { cat "$tmp/a.log"; exit 1; }
grep -h "requests" "$tmp/a.log" || true
sleep 1
kill -INT $watcher
wait $watcher || true
grep -h "key frames\|missed" "$tmp/watch.log" || true
echo "wrote $out/stitch.rrd and $out/stitch.svg"
if [ -n "${PICTURE:-}" ]; then
  cp "$out/stitch.svg" "$PICTURE"
  echo "wrote $PICTURE"
fi
