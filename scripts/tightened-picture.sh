#!/usr/bin/env bash
# The picture of a tightened knot: the overhand that two hand processes tie with the needle driver on
# the 320-link suture `tie-320` of knots.toml (`hand run --builtin instrument-tie`, hands A and B), then
# tighten (`--tighten 0.05`: each hand pulls its end away from the knot until it stops, twice round);
# the knotted stretch of the last state drawn by `watch --svg-last --svg-knot` into docs/tightened-overhand.svg, with the knot the
# service named in it and the knotted stretch the hand measured printed. About a minute after the
# release build.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build -q --release --bins
prefix="tight_pic_$$_"
tmp=$(mktemp -d)
trap 'kill $svc $watcher 2>/dev/null || true; rm -rf "$tmp"' EXIT
target/release/solver-service --prefix "$prefix" --scene solver-service/scenes/knots.toml --no-persist \
  --wait event --state-buffer 4096 >"$tmp/service.log" 2>&1 &
svc=$!
target/release/watch --prefix "$prefix" --wait-for-service 30 --chain tie-320 --svg "$tmp/frames" \
  --svg-last --svg-knot --view=-90,75 >"$tmp/watch.log" 2>&1 &
watcher=$!
run() {
  target/release/hand --prefix "$prefix" --wait-for-service 30 run --builtin instrument-tie \
    --chain tie-320 --tighten 0.05 --quiet --turn-timeout 300 "$@"
}
run --hand B >"$tmp/b.log" &
b=$!
run --hand A --identify tie-320 | tee "$tmp/a.log"
wait $b
sleep 1
kill -INT $watcher
wait $watcher || true
last=$(ls "$tmp"/frames/*.svg | sort | tail -n 1)
cp "$last" docs/tightened-overhand.svg
echo "wrote docs/tightened-overhand.svg (from $(basename "$last"))"
