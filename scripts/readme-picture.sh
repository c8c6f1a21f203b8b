#!/usr/bin/env bash
# The README's picture: the square knot two hand processes tie round each other on the chain `hands`
# of knots.toml (`hand run --builtin square-held`, hands A and B), its last state drawn by `watch`
# into docs/square-knot.svg. About a minute after the release build.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build -q --release -p solver-service -p clients --bins
prefix="readme_pic_$$_"
tmp=$(mktemp -d)
trap 'kill $svc $watcher 2>/dev/null || true; rm -rf "$tmp"' EXIT
target/release/solver-service --prefix "$prefix" --scene solver-service/scenes/knots.toml --no-persist \
  --wait event >"$tmp/service.log" 2>&1 &
svc=$!
target/release/watch --prefix "$prefix" --wait-for-service 30 --chain hands --svg "$tmp/frames" \
  --every 1 --view=-90,75 >"$tmp/watch.log" 2>&1 &
watcher=$!
target/release/hand --prefix "$prefix" --wait-for-service 30 run --builtin square-held --hand A --quiet &
a=$!
target/release/hand --prefix "$prefix" --wait-for-service 30 run --builtin square-held --hand B --quiet
wait $a
sleep 1
kill -INT $watcher
wait $watcher || true
last=$(ls "$tmp"/frames/*.svg | sort | tail -n 1)
cp "$last" docs/square-knot.svg
echo "wrote docs/square-knot.svg (from $(basename "$last"))"
