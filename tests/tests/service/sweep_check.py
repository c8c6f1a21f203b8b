"""The sweep test's body (run by `sweep::a_sweep_on_a_local_ray_resumes_and_reports_failures`).

Usage: sweep_check.py BIN_DIR WORK_DIR

A sweep of 24 short episodes on a local Ray of two CPUs (22 knot episodes through the service, two of them
U scripts on a rope that starts hanging in a U, one with its tail anchored by the scene; 2 accuracy
episodes), in two parts: the first 11, then all 24 into the same Parquet file (the first 11 must not run
again). Two episodes fail on purpose (a rope of 0 links, an unknown script) and must be rows with their
error. Every row is checked here: the Parquet schema, the
knobs, the counts, and the link-length error recomputed from the service's final joints is small.
Exits non-zero with a message on the first failed check.
"""

import json
import math
import sys
from pathlib import Path

import pyarrow.parquet as pq
import ray

import tractrix_sweep as ts


def check(cond, what):
    if not cond:
        print(f"FAILED: {what}", file=sys.stderr)
        sys.exit(1)


def main():
    bin_dir, work = sys.argv[1], Path(sys.argv[2])
    out = work / "sweep.parquet"
    episodes = ts.grid({"script": "overhand", "max_step": 0.5}, links=[40, 80], seed=range(1, 8))
    episodes += ts.grid({"script": "square", "max_step": 0.5}, links=[80], seed=range(1, 5))
    episodes += [
        {"script": "overhand-u", "start": "u", "anchors": [0], "grasp": True, "links": 40, "max_step": 0.5,
         "seed": 1},
        {"script": "square-u", "start": "u", "grasp": False, "links": 40, "max_step": 0.5, "seed": 2},
        {"script": "overhand-wide", "links": 40, "max_step": 0.5, "seed": 3},
    ]
    for ep in episodes[-3:]:
        ep["id"] = ts.episode_id(ep)
    episodes += [
        {"id": "bad-links", "links": 0, "max_step": 0.5},
        {"id": "bad-script", "script": "bowline", "links": 40},
    ]
    episodes += ts.grid({"kind": "accuracy", "scenario": "helix", "reps": 1}, method=["tractrix", "ftl"],
                        substeps=[2])
    check(len(episodes) == 25, f"25 episodes, not {len(episodes)}")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)

    first = ts.sweep(episodes[:11], out, bin_dir=bin_dir, progress=False)
    check(len(first) == 11, f"first part: 11 rows, not {len(first)}")
    rows = ts.sweep(episodes, out, bin_dir=bin_dir, progress=False)
    check(len(rows) == 25, f"all: 25 rows, not {len(rows)}")

    # Resumed: the first part's rows are in the file as they were (a re-run would differ in its
    # timings and worker).
    on_disk = {r["id"]: r for r in pq.read_table(out).to_pylist()}
    check(len(on_disk) == 25, f"25 distinct ids in the file, not {len(on_disk)}")
    for r in first:
        d = on_disk[r["id"]]
        check(d["worker"] == r["worker"] and d["seconds"] == r["seconds"] or (math.isnan(d["seconds"]) and math.isnan(r["seconds"])),
              f"{r['id']} ran again on resume")

    schema = pq.read_schema(out)
    expected = ts._schema()
    check(schema.names == expected.names, f"columns {schema.names}")
    check(all(schema.field(n).type == expected.field(n).type for n in expected.names), "column types")

    for ep in episodes:
        r = on_disk[ts.episode_id(ep)]
        if ep["id"].startswith("bad-"):
            check(not r["ok"] and r["error"], f"{ep['id']}: a failed row with its error: {r}")
            continue
        if ep.get("kind") == "accuracy":
            check(r["ok"] and r["error"] == "", f"{ep['id']}: {r['error']}")
            check(r["kind"] == "accuracy" and r["scenario"] == "helix" and r["method"] == ep["method"]
                  and r["substeps"] == 2 and r["precision"] == "f64", f"{ep['id']}: knobs {r}")
            check(r["script"] is None and r["links"] is None, f"{ep['id']}: hand knobs are null: {r}")
            check(r["moves"] > 0 and r["us_per_move"] > 0, f"{ep['id']}: {r}")
            check(0 < r["error_links"] < 10, f"{ep['id']}: error {r['error_links']}")
            continue
        check(r["ok"] and r["error"] == "", f"{ep['id']}: {r['error']}")
        check(r["script"] == ep["script"] and r["links"] == ep["links"] and r["seed"] == ep["seed"],
              f"{ep['id']}: knobs {r}")
        check(r["max_step"] == 0.5, f"{ep['id']}: max_step {r['max_step']}")
        check(r["start"] == ep.get("start", "straight") and r["anchors"] == json.dumps(ep.get("anchors", []))
              and r["grasp"] == ep.get("grasp"), f"{ep['id']}: start and holds {r}")
        check(r["requests"] > 0 and r["moves_ok"] + r["locked"] + r["refused"] <= r["requests"],
              f"{ep['id']}: counts {r}")
        check(r["seconds"] > 0 and r["us_per_request"] > 0, f"{ep['id']}: timings {r}")
        check(r["startup_s"] > 0, f"{ep['id']}: startup {r['startup_s']}")
        check(r["knot"] in ("unknot", "trefoil", "square", "granny", "double-overhand", "surgeons", "other"), f"{ep['id']}: knot {r['knot']!r}")
        check(r["tied"] == (r["knot"] == ts.EXPECT[ep["script"]]), f"{ep['id']}: tied")
        check(0 <= r["length_error"] < 1e-9, f"{ep['id']}: length error {r['length_error']}")
    bad = on_disk["bad-links"]["error"]
    check("links 0" in bad, f"bad-links says why: {bad}")
    check("bowline" in on_disk["bad-script"]["error"], "bad-script says why")

    table = ts.summary(rows)
    check(table.count("\n") >= 3 and "| overhand | 40 |" in table, table)
    print(table)


if __name__ == "__main__":
    main()
