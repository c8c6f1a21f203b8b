#!/usr/bin/env bash
# The picture of the needle's pass with two hands (issue 39): on the 80-link suture `suture-held-80` of
# stitch.toml, the forceps (hand B) hold the tail while the driver (hand A) loads the needle and drives
# it through the tissue (its point cuts the holes), drawing the suture through both eyelets
# (`hand run --builtin needle-pass-held`, hands A and B). The last state is drawn by `watch --svg-last`
# into docs/needle-pass.svg, seen from the side and a little above (the tissue, which the service's
# describe carries, drawn as a box; the eyelets as crosses; the needle, grey, at the head); the hand's report of the eyelets and the tail is printed. Seconds after
# the release build.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build -q --release -p solver-service -p clients --bins
prefix="needle_pic_$$_"
tmp=$(mktemp -d)
trap 'kill $svc $watcher 2>/dev/null || true; rm -rf "$tmp"' EXIT
target/release/solver-service --prefix "$prefix" --scene solver-service/scenes/stitch.toml --no-persist \
  --wait event --state-buffer 4096 >"$tmp/service.log" 2>&1 &
svc=$!
target/release/watch --prefix "$prefix" --wait-for-service 30 --chain suture-held-80 --svg "$tmp/frames" \
  --svg-last --view=-90,10 >"$tmp/watch.log" 2>&1 &
watcher=$!
run() {
  target/release/hand --prefix "$prefix" --wait-for-service 30 run --builtin needle-pass-held \
    --quiet --turn-timeout 300 "$@"
}
run --hand B >"$tmp/b.log" &
b=$!
run --hand A --identify suture-held-80 | tee "$tmp/a.log"
wait $b
sleep 1
kill -INT $watcher
wait $watcher || true
last=$(ls "$tmp"/frames/*.svg | sort | tail -n 1)
cp "$last" docs/needle-pass.svg
echo "wrote docs/needle-pass.svg (from $(basename "$last"))"
