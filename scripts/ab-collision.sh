#!/usr/bin/env bash
# What a change to collision handling bought: the first table of the collision bench (capsules, µs per
# move on the overhand's tying path and on the free path, 40/160/320 links) at BASE and at this
# checkout, in interleaved rounds in one run, and the ratios new ÷ base. BASE is built in a worktree.
#
#   scripts/ab-collision.sh BASE [ROUNDS]      # about 10 minutes with the build of BASE
set -euo pipefail
cd "$(dirname "$0")/.."
BASE=${1:?usage: scripts/ab-collision.sh BASE [ROUNDS]}
ROUNDS=${2:-3}
WT=target/ab-collision-base
TGT=$PWD/target/ab-collision-target
[ -d "$WT" ] || git worktree add --detach "$WT" "$BASE" >/dev/null
(cd "$WT" && git checkout -q --detach "$BASE")
# The bench binary of each side (cargo prints the executable's path as JSON).
# The bench lives in the kernel since the knots crate; in clients before it.
bench_bin() { # dir target-dir
  local pkg=clients
  [ -f "$1/solver-service/kernel/benches/collision.rs" ] && pkg=tractrix
  (cd "$1" && CARGO_TARGET_DIR=$2 cargo bench -q -p "$pkg" --bench collision --no-run \
    --message-format json 2>/dev/null) |
    python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "collision" and m.get("executable"):
        print(m["executable"])'
}
base=$(bench_bin "$WT" "$TGT")
new=$(bench_bin . "$PWD/target")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for r in $(seq "$ROUNDS"); do
  COLLISION_BENCH_ROUNDS=1 COLLISION_BENCH_COST_ONLY=1 "$base" > "$work/base-$r.md"
  COLLISION_BENCH_ROUNDS=1 COLLISION_BENCH_COST_ONLY=1 "$new" > "$work/new-$r.md"
done
echo "Capsule collision, $BASE against $(git rev-parse --short HEAD), medians over $ROUNDS interleaved rounds of the collision bench's first table (µs per move):"
echo
python3 - "$work" "$ROUNDS" <<'EOF'
import statistics, sys, pathlib
work, rounds = pathlib.Path(sys.argv[1]), int(sys.argv[2])
def rows(path):
    out = {}
    for line in path.read_text().splitlines():
        f = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(f) >= 9 and f[2] == "capsules":
            out[(f[0], int(f[1]))] = (float(f[3]), float(f[4]), float(f[5]), int(f[7]))
        elif len(f) >= 9 and f[2] == "none":
            out[(f[0], int(f[1]), "none")] = (float(f[3]),)
    return out
base = [rows(work / f"base-{r}.md") for r in range(1, rounds + 1)]
new = [rows(work / f"new-{r}.md") for r in range(1, rounds + 1)]
m = statistics.median
print("| path | links | base median | new median | new ÷ base | base p99 | new p99 | new ÷ base | new median ÷ no collision's | locked moves base / new |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
for key in sorted(k for k in new[0] if len(k) == 2):
    bm, nm = m(b[key][0] for b in base), m(n[key][0] for n in new)
    bp, np_ = m(b[key][1] for b in base), m(n[key][1] for n in new)
    free = m(n[key + ("none",)][0] for n in new)
    print(f"| {key[0]} | {key[1]} | {bm:.2f} | {nm:.2f} | {nm/bm:.2f} | {bp:.2f} | {np_:.2f} | {np_/bp:.2f} | {nm/free:.2f} | {base[-1][key][3]} / {new[-1][key][3]} |")
EOF
