#!/usr/bin/env bash
# What a change to contact handling bought on the knots' tying paths: the contact bench's first table
# (the service's own time per request along each built-in knot's tying path, `clients/benches/contact.rs`)
# with BASE's release binaries and with this checkout's, in interleaved rounds in one run, and the
# ratios new ÷ base of the medians over the rounds. Prints Markdown.
#
#   scripts/ab-contact.sh BASE [ROUNDS] [ROWS]   # ROWS as CONTACT_BENCH_ONLY (scripts or chains)
#
# BASE's binaries are built from a worktree into a target directory of their own (the first run
# builds every dependency there too; a worktree built into this checkout's target directory would
# overwrite this checkout's crates, which cargo hashes by their path in the workspace, and leave them
# looking fresh). The bench itself, and the scene it reads, are this checkout's.
set -euo pipefail
cd "$(dirname "$0")/.."
BASE=${1:?usage: scripts/ab-contact.sh BASE [ROUNDS] [ROWS]}
ROUNDS=${2:-3}
ROWS=${3:-overhand,square,square-held,instrument-tie,surgeons-knot,instrument-square}
WT=target/ab-contact-base
BIN=$PWD/target/ab-contact-target
[ -d "$WT" ] || git worktree add --detach "$WT" "$BASE" >/dev/null
(cd "$WT" && git checkout -q --detach "$BASE")
base_rev=$(git -C "$WT" rev-parse --short HEAD)
(cd "$WT" && CARGO_TARGET_DIR=$BIN cargo build -q --release --bins)
cargo build -q --release --bins
bench=$(cargo bench -q -p clients --bench contact --no-run --message-format json 2>/dev/null |
  python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "contact" and m.get("executable"):
        print(m["executable"])')
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Both sides run where config/iceoryx2.toml names one root path (iceoryx2 reads that file first): a BASE
# from before the per-user root (a22b1ab) would otherwise use another directory than this bench.
mkdir -p "$work/config"
printf '[global]\nroot-path = "/tmp/iceoryx2.ab-%s/"\n' "$(id -u)" > "$work/config/iceoryx2.toml"
here=$PWD
for r in $(seq "$ROUNDS"); do
  (cd "$work" && CARGO_TARGET_DIR=$BIN CONTACT_BENCH_ONLY=$ROWS "$bench") > "$work/base-$r.md"
  (cd "$work" && CARGO_TARGET_DIR=$here/target CONTACT_BENCH_ONLY=$ROWS "$bench") > "$work/new-$r.md"
done
echo "The contact bench's first table, $base_rev (base) against $(git rev-parse --short HEAD)$(git diff --quiet HEAD -- solver-service shared clients || echo ' with uncommitted changes') (new), medians over $ROUNDS interleaved rounds on $(sed -n 's/^model name\s*: //p' /proc/cpuinfo | head -1) (µs; refused requests and the knot of each round):"
echo
python3 - "$work" "$ROUNDS" <<'EOF'
import statistics, sys, pathlib
work, rounds = pathlib.Path(sys.argv[1]), int(sys.argv[2])
def rows(path):
    """(script, chain) -> the first table's cells, by its header's names."""
    out, header = {}, None
    for line in path.read_text().splitlines():
        if not line.startswith("|"):
            if header is not None and out:
                break  # the first table only
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[0] == "script":
            header = cells
        elif header and not set(cells[0]) <= set("-:"):
            out[(cells[0], cells[1])] = dict(zip(header, cells))
    return out
base = [rows(work / f"base-{r}.md") for r in range(1, rounds + 1)]
new = [rows(work / f"new-{r}.md") for r in range(1, rounds + 1)]
cols = ["p50 µs", "p99 µs", "p99.9 µs"]
print("| script | chain | what it has | " + " | ".join(f"base {c} | new {c} | new ÷ base" for c in cols)
      + " | refused base / new | knot base / new |")
print("|---|---|---|" + "---:|---:|---:|" * len(cols) + "---|---|")
for key in base[0]:
    med = lambda side, c: statistics.median(float(s[key][c]) for s in side)
    cells = [key[0], key[1], base[0][key]["what it has"]]
    for c in cols:
        b, n = med(base, c), med(new, c)
        cells += [f"{b:.1f}", f"{n:.1f}", f"{n / b:.2f}"]
    cells.append(" ".join(s[key]["refused"] for s in base) + " / " + " ".join(s[key]["refused"] for s in new))
    cells.append(" ".join(s[key]["knot"] for s in base) + " / " + " ".join(s[key]["knot"] for s in new))
    print("| " + " | ".join(cells) + " |")
EOF
