#!/usr/bin/env python3
"""Writes the headline figures at the top of BENCHMARKS.md from its own generated tables: each figure is
read from one cell (the table under a section heading, the row whose first cells match, the column by
its header), so nothing in the summary is typed by hand. `scripts/bench-report.sh` runs it after every
report; `--check` exits 1 if the summary in the file is not what the tables give (a test runs that).

Usage: scripts/bench-summary.py [--check] [BENCHMARKS.md]
"""

import pathlib
import re
import sys

# (what, section heading, row's first cells (prefixes), column header, unit)
PICKS = [
    ("Round trip of a move, 40 links, service spinning: p50 / p99",
     "## Latency on two cores", ["40", "service, iceoryx2", "spin"], ["p50", "p99"], "µs"),
    ("The same, service sleeping on an event: p50 / p99",
     "## Latency on two cores", ["40", "service, iceoryx2", "event"], ["p50", "p99"], "µs"),
    ("Service ÷ (raw iceoryx2 echo + solve), 40 links, spinning",
     "## Latency on two cores", ["40", "spin"], ["service ÷ (raw + solve)"], "×"),
    ("Kernel step, closed-form tractrix, 40 links (f64)",
     "## A lean step: the kernel against a minimal loop", ["40", "f64", "closed-form tractrix"],
     ["kernel `move_joint` (ns)"], "ns per link-step"),
    ("Kernel step ÷ the guard-free loop a user would write, 40 links (f64)",
     "## A lean step: the kernel against a minimal loop", ["40", "f64", "closed-form tractrix"],
     ["kernel ÷ minimal"], "×"),
    ("Capsule collision where nothing touches ÷ no collision, 160 links (detection beside the move)",
     "### Collision cost per move", ["free", "160", "capsules"], ["median ÷ no collision's"], "×"),
    ("Service's time per request along the instrument tie, 40 links: p99.9",
     "### Contact per request along every built-in knot's tying path", ["instrument-tie", "tie"],
     ["p99.9 µs"], "µs"),
    ("The same, the square knot with both ends held, 320 links: p99.9 (issue 40 aims at 1 ms)",
     "### Contact per request along every built-in knot's tying path", ["square-held", "hands-320"],
     ["p99.9 µs"], "µs"),
    ("Everything the service computes per request ÷ the kernel's move, 40 links",
     "## What the service adds to a move", ["40", "f64"], ["handle + payload ÷ kernel"], "×"),
    ("A tying move with capsule self-collision, 160 links: median / p99",
     "### Collision cost per move", ["tying", "160", "capsules"], ["median µs", "p99 µs"], "µs"),
    ("Slowest accepted request ÷ its budget's time, knot scene's finest instrument rope",
     "### Every request inside its budget", ["knots.toml", "tie-160"], ["slowest ÷ budget's time"], "×"),
    ("The square knot tied and tightened by two hands, 320 links: knotted stretch ÷ ideal (issue 38 aims at 1.5) / how the pulls ended",
     "## How tight the knots get", ["`square-held`", "`hands-320`"], ["stretch ÷ ideal", "how the pulls ended"], ""),
    ("The knot's name with every state, the surgeon's knot tied and tightened, 320 links: p99.9 / max",
     "## How tight the knots get", ["`surgeons-knot`", "`tie-320`"], ["p99.9", "max"], "µs"),
    ("Joint limits (bend radius) ÷ no limits, free rope, 40 links, one substep",
     "## What joint limits cost", ["rope, free", "40", "1"], ["limited ÷ free (p50)"], ""),
]


def tables(text):
    """Section heading -> list of tables (each a list of rows of cells), in order."""
    out, heading, current = {}, None, None
    for line in text.split("\n"):
        if line.startswith("#"):
            heading = line.strip()
            current = None
            continue
        if line.startswith("|"):
            cells = [c.strip().strip("*") for c in line.strip().strip("|").split("|")]
            if current is None:
                current = []
                out.setdefault(heading, []).append(current)
            if not all(re.fullmatch(r":?-+:?", c) for c in cells):
                current.append(cells)
        else:
            current = None
    return out


def pick(all_tables, section, row, columns):
    for table in all_tables.get(section, []):
        header = table[0]
        if not all(c in header for c in columns):
            continue
        for r in table[1:]:
            if all(r[i].startswith(v) for i, v in enumerate(row) if i < len(r)) and len(r) >= len(row):
                return [r[header.index(c)] for c in columns]
    raise SystemExit(f"bench-summary: no row {row} with {columns} under {section!r}")


def summary(text):
    t = tables(text)
    lines = ["| headline | figure | from the table under |", "|---|---|---|"]
    for what, section, row, columns, unit in PICKS:
        values = " / ".join(pick(t, section, row, columns))
        lines.append(f"| {what} | {values} {unit}".rstrip() + f" | {section.lstrip('#').strip()} |")
    return "\n".join(lines)


def main():
    args = [a for a in sys.argv[1:] if a != "--check"]
    path = pathlib.Path(args[0] if args else "BENCHMARKS.md")
    text = path.read_text()
    begin, end = "<!-- bench-summary -->", "<!-- /bench-summary -->"
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.S)
    if not pattern.search(text):
        raise SystemExit(f"bench-summary: {path} has no {begin} ... {end}")
    new = pattern.sub(lambda _: f"{begin}\n{summary(text)}\n{end}", text)
    if "--check" in sys.argv:
        if new != text:
            print(f"bench-summary: the summary in {path} is not what its tables give; run "
                  "scripts/bench-summary.py", file=sys.stderr)
            sys.exit(1)
        return
    path.write_text(new)


if __name__ == "__main__":
    main()
