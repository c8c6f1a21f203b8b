#!/usr/bin/env python3
"""The house's size rules, checked (run by .ci/run): no production Rust file over 1,200 lines (tests,
benches and unit-test files apart), and no function of the kernel or the world over 120 lines of code
(blank lines and comment lines not counted; unit tests apart). Prints what breaks a rule, exits 1 then."""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
MAX_FILE, MAX_FN = 1200, 120
FN_ROOTS = ["solver-service/kernel/src", "solver-service/world/src"]


def production(p: pathlib.Path) -> bool:
    parts = p.relative_to(ROOT).parts
    return not ({"target", "tests", "benches", "examples"} & set(parts)) and p.name != "tests.rs"


def long_functions(p: pathlib.Path):
    lines = p.read_text().split("\n")
    end = next((i for i, l in enumerate(lines) if l.startswith("#[cfg(test)]")), len(lines))
    for i, line in enumerate(lines[:end]):
        m = re.match(r"^(\s*)(pub(\([a-z]+\))? )?(const )?(unsafe )?fn (\w+)", line)
        if not m:
            continue
        close = m.group(1) + "}"
        j = next((k for k in range(i, end) if lines[k] == close), end - 1)
        code = [x for x in lines[i : j + 1] if x.strip() and not x.strip().startswith("//")]
        if len(code) > MAX_FN:
            yield i + 1, m.group(6), len(code)


broken = []
for p in sorted(ROOT.rglob("*.rs")):
    if production(p):
        n = len(p.read_text().split("\n")) - 1
        if n > MAX_FILE:
            broken.append(f"{p.relative_to(ROOT)}: {n} lines (at most {MAX_FILE})")
for root in FN_ROOTS:
    for p in sorted((ROOT / root).rglob("*.rs")):
        for line, name, n in long_functions(p):
            broken.append(f"{p.relative_to(ROOT)}:{line}: fn {name}: {n} lines of code (at most {MAX_FN})")
if broken:
    print("\n".join(broken))
    sys.exit(1)
print(f"house: no production file over {MAX_FILE} lines, no kernel or world function over {MAX_FN}")
