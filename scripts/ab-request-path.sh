#!/usr/bin/env bash
# The request path of two commits side by side: builds the service of BASE (default 9fe9eab, before the
# typed request layer and the one serving loop) in a worktree, and this checkout's, both in the `test`
# profile; then, in interleaved rounds, starts each service pinned to core 0 (spin, no persistence) and
# this checkout's `latency client` pinned to core 1 against it, and prints a Markdown table of the
# medians of the round trip and of the service's own solve time (µs), and their ratios new ÷ base.
#
#   scripts/ab-request-path.sh [BASE] [ROUNDS]       # about 10 minutes with the build of BASE
set -euo pipefail
cd "$(dirname "$0")/.."
BASE=${1:-9fe9eab}
ROUNDS=${2:-3}
WT=target/ab-base
TGT=$PWD/target/ab-target
[ -d "$WT" ] || git worktree add --detach "$WT" "$BASE" >/dev/null
(cd "$WT" && git checkout -q --detach "$BASE" && CARGO_TARGET_DIR=$TGT cargo build -q --profile test --bins)
cargo build -q --profile test --bins
SCENE=$(mktemp)
# Both sides run in a directory whose config/iceoryx2.toml names one root path: iceoryx2 reads that file
# first, and a BASE from before the per-user root (a22b1ab) would otherwise use another directory.
IOXDIR=$(mktemp -d)
mkdir -p "$IOXDIR/config"
printf '[global]\nroot-path = "/tmp/iceoryx2.ab-%s/"\n' "$(id -u)" > "$IOXDIR/config/iceoryx2.toml"
trap 'rm -rf "$SCENE" "$IOXDIR"' EXIT
NEW=$PWD/target/debug
printf '[[chain]]\nname = "rope40"\nlinks = 40\nlink_length = 1.0\n\n[[chain]]\nname = "rope1000"\nlinks = 1000\nlink_length = 1.0\n' > "$SCENE"

# One measurement: medians of round trip and solve, in ns.
measure() { # svc-binary chain samples tag
  local prefix="ab_${4}_$$_"
  (cd "$IOXDIR" && exec "$1" --scene "$SCENE" --prefix "$prefix" --no-persist --wait spin --pin 0) >/dev/null 2>&1 &
  local pid=$!
  sleep 1   # the service's ready line is not read here; a second is ample on an idle machine
  (cd "$IOXDIR" && exec "$NEW/latency" client --prefix "$prefix" --wait spin --chain "$2" --samples "$3" --warmup 500 \
    --pin 1 --json 2>/dev/null) | tail -1 |
    python3 -c 'import json,sys; s=json.load(sys.stdin); print(s["round_trip"]["p50"], s["solve"]["p50"])'
  kill -TERM "$pid"; wait "$pid" 2>/dev/null || true
}

echo "Request path, $BASE against $(git rev-parse --short HEAD), spin, service on core 0, client on core 1, medians of $ROUNDS interleaved rounds (µs):"
echo
echo "| links | base round trip | new round trip | new ÷ base | base solve | new solve | new ÷ base |"
echo "|---:|---:|---:|---:|---:|---:|---:|"
for chain in rope40 rope1000; do
  samples=20000; [ "$chain" = rope1000 ] && samples=3000
  declare -a brt=() bsv=() nrt=() nsv=()
  for r in $(seq "$ROUNDS"); do
    read -r a b < <(measure "$TGT/debug/solver-service" "$chain" "$samples" "b$r")
    brt+=("$a"); bsv+=("$b")
    read -r a b < <(measure "$NEW/solver-service" "$chain" "$samples" "n$r")
    nrt+=("$a"); nsv+=("$b")
  done
  python3 - "$chain" "${brt[*]}" "${nrt[*]}" "${bsv[*]}" "${nsv[*]}" <<'EOF'
import statistics, sys
chain = sys.argv[1]
brt, nrt, bsv, nsv = ([float(x) for x in a.split()] for a in sys.argv[2:6])
m = statistics.median
print(f"| {chain[4:]} | {m(brt)/1e3:.1f} | {m(nrt)/1e3:.1f} | {m(nrt)/m(brt):.2f} | {m(bsv)/1e3:.1f} | {m(nsv)/1e3:.1f} | {m(nsv)/m(bsv):.2f} |")
EOF
done
