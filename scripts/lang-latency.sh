#!/usr/bin/env bash
# The round trip of one move from each language's client, side by side in one run (issue 17): Rust
# (`latency client`), C++ (clients/c/examples/loop.cpp on the C library), C# (Move.cs by P/Invoke on
# Mono) and Python (clients/python/tractrix_client.py on the PyPI wheel), all against one service (the
# default scene, hybrid waits, no persistence), each moving the rope's head around the same small circle
# back to back. ROUNDS rounds interleave the languages; each cell is the median over rounds of the
# round's percentile (the max: the largest of any round). Prints the Markdown table BENCHMARKS.md shows.
#
#   scripts/lang-latency.sh [MOVES] [ROUNDS]     # default 5000 moves, 3 rounds
set -euo pipefail
cd "$(dirname "$0")/.."
MOVES=${1:-5000}
ROUNDS=${2:-3}
TARGET=${CARGO_TARGET_DIR:-target}

cargo build -q --release -p solver-service -p clients --bins
cargo build -q --release -p tractrix-client --lib
scripts/python-venv.sh >/dev/null
scripts/system-packages.sh
W=$TARGET/lang-latency
mkdir -p "$W"
LIB=$TARGET/release
c++ -std=c++17 -O2 -I shared/include -I clients/c/examples clients/c/examples/loop.cpp \
  "$LIB/libtractrix_client.a" -lpthread -ldl -lm -o "$W/loop"
mcs -out:"$W/move.exe" clients/c/examples/Move.cs >/dev/null

PREFIX="langlat$$_"
"$TARGET/release/solver-service" --prefix "$PREFIX" --no-persist >"$W/service.log" 2>&1 &
SVC=$!
trap 'kill $SVC 2>/dev/null; wait $SVC 2>/dev/null || true' EXIT
"$TARGET/release/chainctl" --prefix "$PREFIX" --wait-for-service 20 describe rope >/dev/null

# Each client prints "... round trip p50 X us, p99 Y us, max Z us" (the Rust one: JSON, in ns).
: >"$W/rows.txt"
for round in $(seq "$ROUNDS"); do
  "$TARGET/release/latency" client --prefix "$PREFIX" --chain rope --samples "$MOVES" \
    --warmup $((MOVES / 10)) --json | python3 -c '
import json, sys
r = json.loads(sys.stdin.readline())["round_trip"]
print("rust", r["p50"] / 1e3, r["p99"] / 1e3, r["max"] / 1e3)' >>"$W/rows.txt"
  for lang in cpp csharp python; do
    case $lang in
      cpp) line=$("$W/loop" "$PREFIX" "$MOVES" 0 | head -1) ;;
      csharp) line=$(LD_LIBRARY_PATH=$LIB mono "$W/move.exe" "$PREFIX" loop "$MOVES") ;;
      python) line=$(target/pyenv/bin/python clients/python/tractrix_client.py --prefix "$PREFIX" bench rope "$MOVES") ;;
    esac
    echo "$line" | sed -E "s/.*p50 ([0-9.]+) us, p99 ([0-9.]+) us, max ([0-9.]+) us.*/$lang \1 \2 \3/" >>"$W/rows.txt"
  done
  "$TARGET/release/chainctl" --prefix "$PREFIX" reset rope >/dev/null
done

python3 - "$W/rows.txt" "$MOVES" "$ROUNDS" <<'PY'
import statistics, sys
rows, moves, rounds = sys.argv[1], sys.argv[2], sys.argv[3]
data = {}
for line in open(rows):
    lang, p50, p99, mx = line.split()
    data.setdefault(lang, []).append((float(p50), float(p99), float(mx)))
names = {
    "rust": ("Rust", "`latency client` (the `clients` crate)"),
    "cpp": ("C++", "`loop.cpp` on `libtractrix_client.a`"),
    "csharp": ("C#", "`Move.cs` by P/Invoke on `libtractrix_client.so`, Mono"),
    "python": ("Python", "`tractrix_client.py` on the PyPI wheel"),
}
rust = statistics.median(r[0] for r in data["rust"])
print(f"Head moves of the default rope (40 links) around a small circle, back to back, {moves} counted "
      f"per round after {int(moves) // 10} uncounted, {rounds} rounds interleaving the languages, against "
      "one service (hybrid waits, no persistence); median over rounds of each round's percentile:\n")
print("| language | client | round trip p50 (µs) | p99 (µs) | max of any round (µs) | p50 ÷ Rust's p50 |")
print("|---|---|---:|---:|---:|---:|")
for key in ["rust", "cpp", "csharp", "python"]:
    r = data[key]
    p50 = statistics.median(x[0] for x in r)
    p99 = statistics.median(x[1] for x in r)
    mx = max(x[2] for x in r)
    print(f"| {names[key][0]} | {names[key][1]} | {p50:.1f} | {p99:.1f} | {mx:.1f} | {p50 / rust:.2f} |")
PY
