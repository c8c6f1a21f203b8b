#!/usr/bin/env bash
# Regenerates every table of BENCHMARKS.md from one run: runs each benchmark command, and writes what it
# prints (Markdown) between the file's markers
#
#   <!-- bench-report: NAME -->  ...  <!-- /bench-report: NAME -->
#
# together with the command itself; the `header` block gets the machine, the date and the commit. The
# prose around the blocks says what the tables show, with no figures of its own.
#
#   scripts/bench-report.sh                  # about an hour on a 2-core VM; rewrites BENCHMARKS.md
#   scripts/bench-report.sh --quick OUT.md   # a smoke run with tiny sizes, written to OUT.md instead
#   scripts/bench-report.sh --only kernel,ik # some blocks only (the header is always rewritten)
#
# Run it on an idle machine: nothing else spinning, no compiler beside it.
set -euo pipefail
cd "$(dirname "$0")/.."

QUICK=0
OUT=BENCHMARKS.md
ONLY=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) QUICK=1; OUT=${2:?--quick needs an output file}; shift ;;
    --only) ONLY=${2:?--only needs a list of blocks}; shift ;;
    *) echo "usage: $0 [--quick OUT.md] [--only NAME,NAME]" >&2; exit 2 ;;
  esac
  shift
done

WORK=target/bench-report
rm -rf "$WORK"
mkdir -p "$WORK"

echo "[bench-report] building (release)" >&2
cargo build -q --release --bins

if [ "$QUICK" = 1 ]; then
  export KERNEL_BENCH_SCALE=0.02 COLLISION_BENCH_ROUNDS=1 JOURNAL_BENCH_N=50 ACCURACY_BENCH_REPS=1
  export HOLDS_BENCH_ROUNDS=1 EYELET_BENCH_ROUNDS=1 EYELET_BENCH_MOVES=10000 KNOT_BENCH_RUNS=1 KNOT_BENCH_LINKS=40 CONTACT_BENCH_ONLY=paper
  export TIGHTEN_BENCH_ONLY=hands
  export LEAN_BENCH_SCALE=0.05 OVERHEAD_BENCH_SCALE=0.05 STRANDS_BENCH_SCALE=0.05 LIMITS_BENCH_SCALE=0.05
  LANG_ARGS="500 1"
  SWEEP_ARGS="4 1"
  LATENCY_ARGS="--samples 500 --warmup 100 --loaded-seconds 1"
  LOAD_SECONDS=1
  AB_ROUNDS=1
  DEVICE_RUNS=1
  DEVICE_FRAME_RUNS=1
  export DEVICE_BENCH_LINKS=40 DEVICE_BENCH_ONLY=square-held HOSTILE_BENCH_SECONDS=1 CRUMPLE_BENCH_MOVES=30
else
  LATENCY_ARGS=""
  LOAD_SECONDS=10
  AB_ROUNDS=3
  # Perturbed runs per row of the device sweep (the issue's 16 take about three hours here).
  DEVICE_RUNS=${DEVICE_RUNS:-4}
  DEVICE_FRAME_RUNS=${DEVICE_FRAME_RUNS:-2}
  LANG_ARGS=""
  SWEEP_ARGS=""
fi

COMMIT=$(git rev-parse --short HEAD)
# Prose (Markdown) does not change a figure; any other change does.
git diff --quiet HEAD -- . ':!*.md' || COMMIT="$COMMIT with uncommitted changes"
# Each block names the machine it ran on (the blocks of one file may come from different machines).
CPU=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')

wanted() { [ -z "$ONLY" ] || [[ ",$ONLY," == *",$1,"* ]]; }

# block NAME SHOWN-COMMAND COMMAND...: runs COMMAND, keeps its stdout as the block's body.
block() {
  local name=$1 shown=$2
  shift 2
  wanted "$name" || return 0
  echo "[bench-report] $name: $shown" >&2
  {
    printf '```sh\n%s\n```\n\n' "$shown"
    printf '_Run %s from commit %s on %s._\n\n' "$(date -u '+%Y-%m-%d %H:%M UTC')" "$COMMIT" "$CPU"
    "$@"
  } >"$WORK/$name.md"
}

block latency "target/release/latency bench $LATENCY_ARGS" \
  target/release/latency bench $LATENCY_ARGS
block load "target/release/latency load --seconds $LOAD_SECONDS" \
  target/release/latency load --seconds "$LOAD_SECONDS"
block ab "scripts/ab-request-path.sh 9fe9eab $AB_ROUNDS" \
  scripts/ab-request-path.sh 9fe9eab "$AB_ROUNDS"
block kernel "cargo bench -p tractrix --bench kernel" \
  cargo bench -q -p tractrix --bench kernel
block lean "cargo bench -p tractrix --bench lean" \
  cargo bench -q -p tractrix --bench lean
block overhead "cargo bench -p solver-service --bench overhead" \
  cargo bench -q -p solver-service --bench overhead
block throughput "cargo bench -p tractrix --bench throughput" \
  cargo bench -q -p tractrix --bench throughput
block strands "cargo bench -p solver-service --bench strands" \
  cargo bench -q -p solver-service --bench strands
block ik "cargo bench -p tractrix --bench ik" \
  cargo bench -q -p tractrix --bench ik
block extremes "cargo bench -p tractrix --bench extremes" \
  cargo bench -q -p tractrix --bench extremes
block accuracy "cargo bench -p clients --bench accuracy" \
  cargo bench -q -p clients --bench accuracy
block collision "cargo bench -p tractrix --bench collision" \
  cargo bench -q -p tractrix --bench collision
block ab-collision "scripts/ab-collision.sh 5d2b880 $AB_ROUNDS" \
  scripts/ab-collision.sh 5d2b880 "$AB_ROUNDS"
block contact "cargo bench -p clients --bench contact" \
  cargo bench -q -p clients --bench contact
block ab-contact "scripts/ab-contact.sh c11c4fe $AB_ROUNDS" \
  scripts/ab-contact.sh c11c4fe "$AB_ROUNDS"
block ab-rope "scripts/ab-request-path.sh b0fd115 $AB_ROUNDS" \
  scripts/ab-request-path.sh b0fd115 "$AB_ROUNDS"
block ab-contact-rope "scripts/ab-contact.sh b0fd115 $AB_ROUNDS" \
  scripts/ab-contact.sh b0fd115 "$AB_ROUNDS"
block device "DEVICE_BENCH_RUNS=$DEVICE_RUNS cargo bench -p clients --bench device" \
  env DEVICE_BENCH_RUNS="$DEVICE_RUNS" cargo bench -q -p clients --bench device
# What a frame buys: the sweep of the square and surgeon's knots at a quarter and four times it.
FRAME_ONLY=${DEVICE_BENCH_ONLY:-square-held,surgeons-knot}
block device-frames "DEVICE_BENCH_RUNS=$DEVICE_FRAME_RUNS DEVICE_BENCH_ONLY=$FRAME_ONLY DEVICE_BENCH_FRAME=4000|64000 cargo bench -p clients --bench device" \
  bash -c "for f in 4000 64000; do DEVICE_BENCH_RUNS=$DEVICE_FRAME_RUNS DEVICE_BENCH_ONLY=$FRAME_ONLY DEVICE_BENCH_FRAME=\$f cargo bench -q -p clients --bench device || exit 1; echo; done"
# Tightened by the device hands too: the square and surgeon's knots at 160 and 320 links.
TIGHTEN_ONLY=${DEVICE_BENCH_ONLY:-square-held,surgeons-knot}
TIGHTEN_LINKS=${DEVICE_BENCH_LINKS:-160,320}
block device-tighten "DEVICE_BENCH_TIGHTEN=0.05 DEVICE_BENCH_RUNS=$DEVICE_FRAME_RUNS DEVICE_BENCH_LINKS=$TIGHTEN_LINKS DEVICE_BENCH_ONLY=$TIGHTEN_ONLY cargo bench -p clients --bench device" \
  env DEVICE_BENCH_TIGHTEN=0.05 DEVICE_BENCH_RUNS="$DEVICE_FRAME_RUNS" DEVICE_BENCH_LINKS="$TIGHTEN_LINKS" DEVICE_BENCH_ONLY="$TIGHTEN_ONLY" cargo bench -q -p clients --bench device
block hostile "cargo bench -p clients --bench hostile" \
  cargo bench -q -p clients --bench hostile
block crumple "cargo bench -p solver-service --bench crumple" \
  cargo bench -q -p solver-service --bench crumple
block tighten "cargo bench -p clients --bench tighten" \
  cargo bench -q -p clients --bench tighten
block knots-topology "KNOT_BENCH_TABLES=topology KNOT_BENCH_RUNS=1000 cargo bench -p world --bench knots" \
  env KNOT_BENCH_TABLES=topology KNOT_BENCH_RUNS="${KNOT_BENCH_RUNS:-1000}" cargo bench -q -p world --bench knots
block budget "cargo bench -p solver-service --bench budget" \
  cargo bench -q -p solver-service --bench budget
block journal "cargo bench -p solver-service --bench journal" \
  cargo bench -q -p solver-service --bench journal
block languages "scripts/lang-latency.sh $LANG_ARGS" \
  scripts/lang-latency.sh $LANG_ARGS
block holds "cargo bench -p tractrix --bench holds" \
  cargo bench -q -p tractrix --bench holds
block knots "KNOT_BENCH_RUNS=8 cargo bench -p world --bench knots" \
  env KNOT_BENCH_RUNS="${KNOT_BENCH_RUNS:-8}" cargo bench -q -p world --bench knots
block sweep "scripts/sweep-bench.sh scaling $SWEEP_ARGS" \
  scripts/sweep-bench.sh scaling $SWEEP_ARGS
block knots-bend "KNOT_BENCH_TABLES=bend KNOT_BENCH_RUNS=4 cargo bench -p world --bench knots" \
  env KNOT_BENCH_TABLES=bend KNOT_BENCH_RUNS="${KNOT_BENCH_RUNS:-4}" cargo bench -q -p world --bench knots
block eyelets "cargo bench -p tractrix --bench eyelets" \
  cargo bench -q -p tractrix --bench eyelets
block stitch "cargo bench -p clients --bench stitch" \
  cargo bench -q -p clients --bench stitch
block limits "cargo bench -p tractrix --bench limits" \
  cargo bench -q -p tractrix --bench limits
block goals "cargo bench -p tractrix --bench goals" \
  cargo bench -q -p tractrix --bench goals
block smooth "cargo bench -p tractrix --bench smooth" \
  cargo bench -q -p tractrix --bench smooth
block sweep-knots "scripts/sweep-bench.sh knots" \
  scripts/sweep-bench.sh knots
block sweep-accuracy "scripts/sweep-bench.sh accuracy" \
  scripts/sweep-bench.sh accuracy

# The header: where and when.
{
  mem=$(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)
  commit=$COMMIT
  mode="full run"
  [ -n "$ONLY" ] && mode="last run: --only $ONLY; each table says when it was run"
  [ "$QUICK" = 1 ] && mode="QUICK SMOKE RUN (tiny sizes: not figures to quote)"
  printf 'Generated by `scripts/bench-report.sh` (%s) on %s from commit %s.\n' \
    "$mode" "$(date -u '+%Y-%m-%d %H:%M UTC')" "$commit"
  printf 'Machine of that run: %s, %s cores, %s, Linux %s, %s (tables whose stamp names no machine ran before 2026-11-27 21:00 UTC, on the 2-core AMD EPYC the headers then named).\n' \
    "$CPU" "$(nproc)" "$mem" "$(uname -r)" "$(rustc --version)"
} >"$WORK/header.md"

[ "$QUICK" = 1 ] && cp BENCHMARKS.md "$OUT"
python3 - "$OUT" "$WORK" <<'EOF'
import pathlib, re, sys
out, work = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
text = out.read_text()
for part in sorted(work.glob("*.md")):
    name = part.stem
    body = part.read_text().strip("\n")
    begin, end = f"<!-- bench-report: {name} -->", f"<!-- /bench-report: {name} -->"
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.S)
    if not pattern.search(text):
        sys.exit(f"bench-report: {out} has no block {name!r} ({begin} ... {end})")
    if not body:
        sys.exit(f"bench-report: {name} printed nothing")
    text = pattern.sub(lambda _: f"{begin}\n{body}\n{end}", text)
out.write_text(text)
print(f"bench-report: {len(list(work.glob('*.md')))} blocks written to {out}", file=sys.stderr)
EOF
# The headline figures on top, read from the tables just written.
python3 scripts/bench-summary.py "$OUT"
