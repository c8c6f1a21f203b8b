"""Parameter sweeps and episode farms on Ray.

An *episode* is a dict of knobs; :func:`grid` makes the Cartesian product of some knobs over a base
episode. :func:`sweep` runs the episodes as Ray tasks (one CPU each), one row per episode, and writes the
rows to a Parquet file, rewritten as rows arrive, so that a sweep that stops can be resumed: episodes whose
``id`` is already in the file are skipped. An episode that fails is a row whose ``error`` says why, never a
lost sweep.

Episode kind ``accuracy``: one configuration of the speed-against-accuracy measurement, run by the
``episode accuracy`` binary (the scenarios and code of ``cargo bench -p clients --bench accuracy``):
knobs ``scenario`` (helix, overhand, square), ``method``, ``precision`` (f64, f32), ``substeps``,
``reps``; row columns ``moves``, ``us_per_move``, ``error_links`` (largest joint error against the
ground truth, in links), ``truth_s``. The ground truth is computed once per scenario and shared through
``$TRACTRIX_TRUTH_CACHE`` (default: a directory in the system's temporary directory).

Episode kind ``hand`` (the default): the episode writes a scene of one rope (``links`` links,
``length`` long, ``thickness``, ``collision``, ``method``, ``substeps``), starts its own ``solver-service``
on a unique iceoryx2 prefix (event wait mode: it sleeps between requests, so two episodes share two cores),
runs the ``hand`` processes of a built-in ``script`` (both hands of a two-handed one) with the script
perturbed by ``seed`` (``hand run --perturb``), names the knot, reads the final joints with the Python
client and measures the link-length error here, from those joints. Knobs::

    script       built-in script: overhand, square, granny, their U forms overhand-u, square-u,
                 granny-u, overhand-wide (one wide loop: the overhand on unit links), or its held
                 form overhand-anchored (with anchors = [0]), the overhand by hand round B's finger,
                 overhand-held (finger = true), the two-handed knots tied round each other,
                 square-held and granny-held (finger = true), and
                 the instrument tie, instrument-tie, the surgeon's double wrap, surgeons-tie, and
                 the surgeon's knot, surgeons-knot, and the square knot by instrument tie,
                 instrument-square (all with driver = true; default overhand)
    expect       the knot the script ties (default: trefoil for the overhands, square, granny)
    start        straight (along x from the origin) or u (hanging in a U: a circular arc between ends
                 0.3 length apart on the x axis, both pointing up, +y; the start of the U scripts)
                 (default straight)
    links        links of the rope (default 160)
    length       rope length (default 40.0)
    thickness    (default 0.2)
    collision    none, spheres, capsules (default capsules)
    method       tractrix, paper, ftl (default tractrix)
    substeps     substeps per move (default 1)
    max_step     the hand's longest motion per request (default: the script's, 0.1)
    seed         perturbation of the script (0: as written)
    grasp        true / false: hands hold their joints (default: the script's)
    driver       true: the scene has knots.toml's needle driver, riding with the tail (for
                 instrument-tie; default false)
    finger       true: the scene has knots.toml's finger of hand B (chain ``hands``: a capsule of
                 radius 0.8 and length 6 riding with the tail), for square-held and granny-held
                 (default false)
    anchors      joints held by the scene for the whole episode, e.g. [0] (default none)
    passes       collision passes per substep before the rope is locked (the scene's
                 ``collision_iterations``; default 64, the service's)
    budget       the work one request may cost, in link-steps (the scene's ``budget``; default
                 2000000, knots.toml's: collision work is metered against it)
    timeout      seconds the episode may take (default 300)

Row columns: ``id``, every knob (as a string column ``knobs`` in JSON, plus the common ones as columns),
``ok`` (no error), ``error``, ``knot`` (the name the identification gave), ``tied`` (``knot`` equals
``expect``), ``requests``, ``moves_ok``, ``locked``, ``refused``, ``seconds`` (the hands' wall time),
``us_per_request``, ``rt_p50_us`` and ``rt_p99_us`` (the round trips of both hands' requests, from ``hand --timings``), ``length_error`` (largest relative link-length error of the final state, computed here),
``startup_s`` (the service's start until it answered), ``worker`` (host and pid that ran it).

Binaries: ``bin_dir`` (or ``$TRACTRIX_BIN``) must hold ``solver-service``, ``hand`` and ``episode`` on every worker
(a shared path, or the container image of the README).

Command line::

    tractrix-sweep run GRID.json --out results.parquet [--address ray://...] [--num-cpus 2]
    tractrix-sweep summary results.parquet [--by script,links]
    tractrix-sweep plot results.parquet --out knots.svg [--x links] [--series script]
    tractrix-sweep scaling [--episodes 32] [--rounds 3]     # episodes/s with 1 and 2 workers
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import uuid
from collections import Counter
from pathlib import Path
from typing import Any, Iterable, Sequence

KNOBS = ("script", "start", "links", "length", "thickness", "collision", "method", "substeps", "max_step",
         "seed", "anchors", "grasp", "driver", "finger", "passes")
# The knobs of an accuracy episode (the rest of KNOBS are null in its row).
ACCURACY_KNOBS = ("method", "substeps", "scenario", "precision", "reps")
DEFAULTS: dict[str, Any] = {
    "kind": "hand",
    "script": "overhand",
    "start": "straight",
    "links": 160,
    "length": 40.0,
    "thickness": 0.2,
    "collision": "capsules",
    "method": "tractrix",
    "substeps": 1,
    "max_step": None,
    "seed": 0,
    "grasp": None,
    "driver": False,
    "finger": False,
    "anchors": (),
    "passes": 64,
    "budget": 2_000_000,
    "timeout": 300.0,
    "scenario": "helix",
    "precision": "f64",
    "reps": 3,
}
EXPECT = {"overhand": "trefoil", "square": "square", "granny": "granny",
          "overhand-u": "trefoil", "square-u": "square", "granny-u": "granny",
          "overhand-wide": "trefoil", "overhand-anchored": "trefoil", "overhand-held": "trefoil",
          "square-held": "square", "granny-held": "granny", "overhands-held": "square",
          "instrument-tie": "trefoil", "instrument-granny": "granny",
          "surgeons-tie": "double-overhand", "surgeons-knot": "surgeons",
          "instrument-square": "square"}
HANDS = {"overhand": ["A"], "square": ["A", "B"], "granny": ["A", "B"],
         "overhand-u": ["A"], "square-u": ["A", "B"], "granny-u": ["A", "B"],
         "overhand-wide": ["A"], "overhand-anchored": ["A"], "overhand-held": ["A", "B"],
         "square-held": ["A", "B"], "granny-held": ["A", "B"], "overhands-held": ["A", "B"],
         "instrument-tie": ["A", "B"], "instrument-granny": ["A", "B"],
         "surgeons-tie": ["A", "B"], "surgeons-knot": ["A", "B"],
         "instrument-square": ["A", "B"]}


def episode_id(ep: dict[str, Any]) -> str:
    """A stable id from the knobs (so a resumed sweep recognises what it has done)."""
    if "id" in ep:
        return str(ep["id"])
    keys = sorted(k for k in ep if k not in ("id", "timeout"))
    return ",".join(f"{k}={ep[k]}" for k in keys)


def grid(base: dict[str, Any] | None = None, **axes: Sequence[Any]) -> list[dict[str, Any]]:
    """The Cartesian product of ``axes`` over ``base``: ``grid({"script": "overhand"}, links=[40, 80],
    seed=range(1, 7))`` is 12 episodes."""
    base = dict(base or {})
    names = list(axes)
    out = []
    for values in itertools.product(*(list(axes[n]) for n in names)):
        ep = dict(base)
        ep.update(zip(names, values))
        ep["id"] = episode_id(ep)
        out.append(ep)
    return out


def u_points(links: int, length: float) -> list[tuple[float, float, float]]:
    """A rope of ``links`` equal links hanging in a U: a circular arc of length ``length`` whose ends,
    ``0.3 length`` apart on the x axis (the tail at the origin), both point up (+y); joints at equal
    angles, so the links are the arc's equal chords (the start of the knot bench's U rows)."""
    chord = 0.3 * length
    # Half angle a of the arc: sin a / a = chord / length (bisection; above pi/2 it bulges below).
    lo, hi = 1e-6, math.pi - 1e-9
    for _ in range(200):
        a = 0.5 * (lo + hi)
        if math.sin(a) / a > chord / length:
            lo = a
        else:
            hi = a
    a = 0.5 * (lo + hi)
    r = length / (2.0 * a)
    cx, cy = chord / 2.0, r * math.cos(a)
    out = []
    for k in range(links + 1):
        t = -a + 2.0 * a * k / links - math.pi / 2.0
        out.append((cx + r * math.cos(t), cy + r * math.sin(t), 0.0))
    return out


def _start_points(ep: dict[str, Any]) -> list[tuple[float, float, float]] | None:
    """The explicit start joints of the episode's rope (None: straight along x)."""
    links = int(ep["links"])
    if not 1 <= links <= 100_000:
        raise ValueError(f"links {links} is not in 1..=100000")
    if ep["start"] == "straight":
        return None
    if ep["start"] == "u":
        return u_points(links, float(ep["length"]))
    raise ValueError(f"unknown start {ep['start']!r} (there are: straight, u)")


def _scene(ep: dict[str, Any]) -> str:
    links = int(ep["links"])
    length = float(ep["length"])
    points = _start_points(ep)
    shape = (
        [f"links = {links}", f"link_length = {length / links!r}", "base = [0.0, 0.0, 0.0]",
         'shape = "straight"', "axis = [1.0, 0.0, 0.0]"]
        if points is None
        else ['shape = "points"',
              "points = [" + ", ".join(f"[{x!r}, {y!r}, {z!r}]" for x, y, z in points) + "]"]
    )
    # The needle driver of `knots.toml`'s chain `tie` (the instrument tie): a capsule parked beside
    # the rope, riding with the tail once a hand moves it.
    driver = (
        ["[[instrument]]", 'name = "driver"', 'shape = "capsule"', "a = [0.0, -6.0, 0.0]",
         f"b = [{7 * math.sqrt(2)!r}, -6.0, {7 * math.sqrt(2)!r}]", "radius = 0.8", 'follows = "tail"', ""]
        if ep["driver"] else []
    )
    # Hand B's finger of `knots.toml`'s chain `hands` (the two-handed knots tied round each other).
    finger = (
        ["[[instrument]]", 'name = "finger"', 'shape = "capsule"', "a = [0.0, -6.0, 0.0]",
         f"b = [{3 * math.sqrt(2)!r}, -6.0, {3 * math.sqrt(2)!r}]", "radius = 0.8", 'follows = "tail"', ""]
        if ep["finger"] else []
    )
    return "\n".join(
        [
            f"budget = {int(ep['budget'])}",
            "",
            *driver,
            *finger,
            "[[chain]]",
            'name = "rope"',
            'kind = "free"',
            'space = "spatial"',
            *shape,
            f"thickness = {float(ep['thickness'])!r}",
            f'collision = "{ep["collision"]}"',
            f'method = "{ep["method"]}"',
            f"substeps = {int(ep['substeps'])}",
            f"collision_iterations = {int(ep['passes'])}",
            f"anchors = [{', '.join(str(int(j)) for j in ep['anchors'])}]",
            *(['instruments = ["driver"]'] if ep["driver"] else []),
            *(['instruments = ["finger"]'] if ep["finger"] else []),
            "",
        ]
    )


def _max_length_error(joints: list[list[float]], link_length: float) -> float:
    worst = 0.0
    for a, b in zip(joints, joints[1:]):
        d = math.sqrt(sum((y - x) ** 2 for x, y in zip(a, b)))
        worst = max(worst, abs(d - link_length) / link_length)
    return worst


_HAND_LINE = re.compile(r"hand (\w+): (\d+) requests, (\d+) ok, (\d+) locked(?:, refused: (.*))?")
_KNOT_LINE = re.compile(r"knot: ([\w-]+)")


def run_episode(ep: dict[str, Any], bin_dir: str | None = None) -> dict[str, Any]:
    """Runs one episode in this process and returns its row; never raises."""
    ep = {**DEFAULTS, **ep}
    row: dict[str, Any] = {
        "id": episode_id(ep),
        "knobs": json.dumps({k: ep[k] for k in sorted(ep) if k != "id"}, default=str),
        "ok": False,
        "error": "",
        "knot": "",
        "tied": False,
        "requests": 0,
        "moves_ok": 0,
        "locked": 0,
        "refused": 0,
        "seconds": math.nan,
        "us_per_request": math.nan,
        "rt_p50_us": math.nan,
        "rt_p99_us": math.nan,
        "length_error": math.nan,
        "startup_s": math.nan,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
    }
    row["kind"] = str(ep["kind"])
    accuracy = ep["kind"] == "accuracy"
    for k in KNOBS + ACCURACY_KNOBS:
        if accuracy and k not in ACCURACY_KNOBS or not accuracy and k not in KNOBS:
            row[k] = None
        elif k == "max_step":
            row[k] = math.nan if ep[k] is None else float(ep[k])
        elif k == "anchors":
            row[k] = json.dumps([int(j) for j in ep[k]])
        else:
            row[k] = ep[k]
    bins = Path(bin_dir or os.environ.get("TRACTRIX_BIN", "target/release"))
    service = None
    tmp: Path | None = None
    try:
        if accuracy:
            return _accuracy_episode(ep, row, bins)
        if ep["kind"] != "hand":
            raise ValueError(f"unknown episode kind {ep['kind']!r} (there are: hand, accuracy)")
        script = str(ep["script"])
        if script not in HANDS:
            raise ValueError(f"unknown script {script!r} (there are {sorted(HANDS)})")
        expect = ep.get("expect") or EXPECT[script]
        deadline = time.monotonic() + float(ep["timeout"])
        # Output goes to files, not pipes: a chatty process never blocks on a full pipe.
        tmp = Path(tempfile.mkdtemp(prefix="tractrix-sweep-"))
        scene = tmp / "scene.toml"
        scene.write_text(_scene(ep))
        prefix = f"sw{os.getpid()}_{uuid.uuid4().hex[:8]}_"
        t0 = time.monotonic()
        with open(tmp / "service.err", "w") as service_err:
            service = subprocess.Popen(
                [str(bins / "solver-service"), "--scene", str(scene), "--no-persist",
                 "--wait", "event", "--prefix", prefix],
                stdout=subprocess.DEVNULL, stderr=service_err,
            )
        import tractrix_client

        client = tractrix_client.Client(prefix=prefix, wait_for_service=30.0)
        client.call("query", 0)
        row["startup_s"] = time.monotonic() - t0
        # A hand waits for the other hand's turn as long as the episode may take: a long rope's turn
        # on a busy machine took more than the hand's default 120 s (surgeons-knot at 320 links).
        hand_args = ["run", "--builtin", script, "--chain", "rope", "--quiet",
                     "--perturb", str(int(ep["seed"])), "--prefix", prefix,
                     "--turn-timeout", str(float(ep["timeout"]))]
        if ep["max_step"] is not None:
            hand_args += ["--max-step", str(float(ep["max_step"]))]
        if ep["grasp"] is not None:
            hand_args += ["--grasp" if ep["grasp"] else "--no-grasp"]
        hands = HANDS[script]
        t1 = time.monotonic()
        procs = []
        for h in hands:
            with open(tmp / f"hand-{h}.out", "w") as out, open(tmp / f"hand-{h}.err", "w") as err:
                procs.append(subprocess.Popen(
                    [str(bins / "hand"), *hand_args, "--hand", h, "--timings", str(tmp / f"hand-{h}.us")]
                    + (["--identify", "rope"] if h == hands[-1] else []),
                    stdout=out, stderr=err,
                ))
        try:
            for p in procs:
                p.wait(timeout=max(1.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            raise TimeoutError(f"the episode took longer than {ep['timeout']} s")
        finally:
            for p in procs:
                if p.poll() is None:
                    p.kill()
                    p.wait()
        row["seconds"] = time.monotonic() - t1
        for h, p in zip(hands, procs):
            out = (tmp / f"hand-{h}.out").read_text()
            m = _HAND_LINE.search(out)
            if m is None:
                err = (tmp / f"hand-{h}.err").read_text()
                raise RuntimeError(f"hand {h} exited {p.returncode}: {(err or out).strip()[-300:]}")
            row["requests"] += int(m.group(2))
            row["moves_ok"] += int(m.group(3))
            row["locked"] += int(m.group(4))
            if m.group(5):
                row["refused"] += sum(int(x.split()[0]) for x in m.group(5).split(", "))
            k = _KNOT_LINE.search(out)
            if k:
                row["knot"] = k.group(1)
        if row["requests"]:
            row["us_per_request"] = row["seconds"] * 1e6 / row["requests"]
        # Every move and instrument request's round trip, as the hands waited for it (`hand --timings`:
        # round trip µs, the service's solve µs, the status, 1 for a tightening pull and the collision
        # passes per line, after a `#` header).
        trips = sorted(
            float(line.split()[0])
            for h in hands
            for line in (tmp / f"hand-{h}.us").read_text().splitlines()
            if line.strip() and not line.startswith("#")
        )
        if trips:
            row["rt_p50_us"] = trips[(len(trips) - 1) // 2]
            row["rt_p99_us"] = trips[min(len(trips) - 1, math.ceil(0.99 * len(trips)) - 1)]
        h, points = client.call("query", 0)
        joints = points[: h.n_joints]
        start = _start_points(ep)
        link = float(ep["length"]) / int(ep["links"]) if start is None else math.dist(start[0], start[1])
        row["length_error"] = _max_length_error(joints, link)
        row["tied"] = row["knot"] == expect
        row["ok"] = True
    except Exception as e:  # one episode's failure is its row
        row["error"] = f"{type(e).__name__}: {e}"[:500]
    finally:
        if service is not None:
            service.terminate()
            try:
                service.wait(timeout=10)
            except subprocess.TimeoutExpired:
                service.kill()
                service.wait()
            err = (tmp / "service.err").read_text().strip() if tmp is not None else ""
            if not row["ok"] and err:
                row["error"] = (row["error"] + " | service: " + err[-200:])[:700]
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
    return row


def _accuracy_episode(ep: dict[str, Any], row: dict[str, Any], bins: Path) -> dict[str, Any]:
    """Runs `episode accuracy` (one configuration of the speed-against-accuracy measurement) and fills
    the row; the ground truth is shared between episodes through a cache directory."""
    try:
        cache = ep.get("truth_cache") or os.environ.get("TRACTRIX_TRUTH_CACHE") or str(
            Path(tempfile.gettempdir()) / "tractrix-truth"
        )
        args = [str(bins / "episode"), "accuracy", "--scenario", str(ep["scenario"]),
                "--method", str(ep["method"]), "--precision", str(ep["precision"]),
                "--substeps", str(int(ep["substeps"])), "--reps", str(int(ep["reps"])),
                "--truth-cache", cache]
        t0 = time.monotonic()
        p = subprocess.run(args, capture_output=True, text=True, timeout=float(ep["timeout"]))
        row["seconds"] = time.monotonic() - t0
        if p.returncode != 0:
            raise RuntimeError(f"episode exited {p.returncode}: {p.stderr.strip()[-300:]}")
        r = json.loads(p.stdout.strip().splitlines()[-1])
        row["moves"] = int(r["moves"])
        row["us_per_move"] = float(r["us_per_move"])
        row["error_links"] = float(r["error_links"])
        row["truth_s"] = float(r["truth_s"])
        row["ok"] = True
    except Exception as e:  # one episode's failure is its row
        row["error"] = f"{type(e).__name__}: {e}"[:500]
    return row


def _schema():
    import pyarrow as pa

    return pa.schema(
        [
            ("id", pa.string()), ("knobs", pa.string()),
            ("script", pa.string()), ("start", pa.string()), ("links", pa.int64()),
            ("length", pa.float64()), ("thickness", pa.float64()), ("collision", pa.string()), ("method", pa.string()),
            ("substeps", pa.int64()), ("max_step", pa.float64()), ("seed", pa.int64()),
            ("anchors", pa.string()), ("grasp", pa.bool_()), ("driver", pa.bool_()), ("finger", pa.bool_()),
            ("passes", pa.int64()),
            ("ok", pa.bool_()), ("error", pa.string()), ("knot", pa.string()), ("tied", pa.bool_()),
            ("requests", pa.int64()), ("moves_ok", pa.int64()), ("locked", pa.int64()),
            ("refused", pa.int64()), ("seconds", pa.float64()), ("us_per_request", pa.float64()),
            ("rt_p50_us", pa.float64()), ("rt_p99_us", pa.float64()),
            ("length_error", pa.float64()), ("startup_s", pa.float64()), ("worker", pa.string()),
            ("kind", pa.string()), ("scenario", pa.string()), ("precision", pa.string()),
            ("reps", pa.int64()), ("moves", pa.int64()), ("us_per_move", pa.float64()),
            ("error_links", pa.float64()), ("truth_s", pa.float64()),
        ]
    )


def _write(rows: list[dict[str, Any]], out: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pylist(rows, schema=_schema())
    tmp = out.with_name(out.name + ".tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, out)  # a reader never sees half a file


def read(out: str | Path) -> list[dict[str, Any]]:
    """The rows of a sweep's Parquet file (empty if there is none)."""
    import pyarrow.parquet as pq

    out = Path(out)
    return pq.read_table(out).to_pylist() if out.exists() else []


def sweep(
    episodes: Iterable[dict[str, Any]],
    out: str | Path,
    bin_dir: str | None = None,
    address: str | None = None,
    num_cpus: int | None = None,
    progress: bool = True,
) -> list[dict[str, Any]]:
    """Runs the episodes not yet in ``out`` on Ray and returns every row (old and new).

    ``address``: a running cluster (``ray start --head`` prints it); without it a local Ray is started
    with ``num_cpus`` CPUs (all by default). Each episode is a task of one CPU.
    """
    import ray

    out = Path(out)
    rows = read(out)
    done = {r["id"] for r in rows}
    todo = []
    for ep in episodes:
        ep = dict(ep)
        ep["id"] = episode_id(ep)
        if ep["id"] not in done:
            done.add(ep["id"])
            todo.append(ep)
    if not todo:
        return rows
    bin_dir = str(Path(bin_dir or os.environ.get("TRACTRIX_BIN", "target/release")).resolve())
    if not ray.is_initialized():
        if address:
            ray.init(address=address)
        else:
            ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False)
    task = ray.remote(num_cpus=1, max_retries=0)(run_episode)
    pending = [task.remote(ep, bin_dir) for ep in todo]
    bar = None
    if progress:
        try:
            from tqdm import tqdm

            bar = tqdm(total=len(pending), desc="episodes", file=sys.stderr)
        except ImportError:
            bar = None
    last_write = time.monotonic()
    while pending:
        ready, pending = ray.wait(pending, num_returns=1, timeout=60.0)
        for ref in ready:
            try:
                rows.append(ray.get(ref))
            except Exception as e:  # the task itself died (worker lost): still a row
                rows.append({"id": "?", "ok": False, "error": f"ray: {e}"[:500]})
            if bar is not None:
                bar.update(1)
        if ready and (time.monotonic() - last_write > 2.0 or not pending):
            _write(rows, out)
            last_write = time.monotonic()
    if bar is not None:
        bar.close()
    _write(rows, out)
    return rows


def accuracy_summary(rows: list[dict[str, Any]]) -> str:
    """The speed-against-accuracy table of accuracy episodes: per scenario, each configuration's time
    per move and largest joint error against the ground truth (in links), ★ on the Pareto front (no
    other configuration of the scenario is both faster and more accurate)."""
    ok = [r for r in rows if r.get("kind") == "accuracy" and r.get("ok")]
    out = []
    for scen in sorted({r["scenario"] for r in ok}):
        mine = [r for r in ok if r["scenario"] == scen]
        moves = mine[0]["moves"]
        out.append(f"\n### {scen} ({moves} moves)\n")
        out.append("| method | precision | substeps | µs per move (median of the episode's reps) "
                   "| error (links) | Pareto front |")
        out.append("|---|---|---:|---:|---:|:---:|")
        for r in sorted(mine, key=lambda r: (r["method"], r["precision"], r["substeps"])):
            front = not any(
                q is not r and q["us_per_move"] <= r["us_per_move"] and q["error_links"] <= r["error_links"]
                and (q["us_per_move"] < r["us_per_move"] or q["error_links"] < r["error_links"])
                for q in mine
            )
            out.append(f"| {r['method']} | {r['precision']} | {r['substeps']} | {r['us_per_move']:.2f} "
                       f"| {r['error_links']:.2e} | {'★' if front else ''} |")
    failed = [r for r in rows if r.get("kind") == "accuracy" and not r.get("ok")]
    if failed:
        out.append(f"\n{len(failed)} episodes failed; the first: {failed[0]['error']}")
    return "\n".join(out).lstrip("\n")


def summary(rows: list[dict[str, Any]], by: Sequence[str] = ("script", "links", "collision", "method")) -> str:
    """A Markdown table: per combination of ``by``, episodes, knots tied, the knots the identification
    named (with how many episodes each), errors, the round trip of the hands' requests (each episode's
    p50 and p99 over both hands' requests; the medians over the episodes),
    locked and refused moves (a held rope pulled taut refuses what it cannot reach) and the largest
    link-length error (accuracy episodes: :func:`accuracy_summary`)."""
    if rows and all(r.get("kind") == "accuracy" for r in rows):
        return accuracy_summary(rows)
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(tuple(r.get(k) for k in by), []).append(r)
    head = [*by, "episodes", "tied", "knots named", "failed",
            "request round trip p50, ms (median over episodes)",
            "request round trip p99, ms (median over episodes)",
            "locked moves", "refused moves", "max link-length error"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def median(xs):
        xs = sorted(x for x in xs if x is not None and not math.isnan(x))
        return xs[len(xs) // 2] if xs else math.nan

    def order(key):  # numbers as numbers (40 before 160), lists of them likewise ([16] before [128]), then text
        def one(x):
            if isinstance(x, bool) or x is None:
                return (2, 0, str(x))
            if isinstance(x, (int, float)):
                return (0, x, ())
            if isinstance(x, str) and x.startswith("["):  # a list as the Parquet file keeps it
                try:
                    x = json.loads(x)
                except ValueError:
                    return (2, 0, x)
            if isinstance(x, (list, tuple)):
                return (1, 0, tuple(one(v) for v in x))
            return (2, 0, str(x))
        return tuple(one(x) for x in key)

    for key in sorted(groups, key=order):
        g = groups[key]
        ok = [r for r in g if r.get("ok")]
        named = Counter(r["knot"] or "none" for r in ok)
        knots = ", ".join(f"{k} {n}" for k, n in sorted(named.items(), key=lambda kv: (-kv[1], kv[0])))
        lines.append(
            "| " + " | ".join(str(k) for k in key)
            + f" | {len(g)} | {sum(1 for r in ok if r['tied'])}/{len(g)} | {knots} | {len(g) - len(ok)}"
            + f" | {median([r.get('rt_p50_us', math.nan) for r in ok]) / 1e3:.2f}"
            + f" | {median([r.get('rt_p99_us', math.nan) for r in ok]) / 1e3:.2f}"
            + f" | {sum(r['locked'] for r in ok)}"
            + f" | {sum(r['refused'] for r in ok)} of {sum(r['requests'] for r in ok)}"
            + f" | {max([r['length_error'] for r in ok], default=math.nan):.1e} |"
        )
    return "\n".join(lines)


def plot(rows: list[dict[str, Any]], out: str | Path, x: str = "links", series: Sequence[str] = ("script",),
         title: str = "Knot success over rope resolution") -> None:
    """An SVG of the share of episodes that tied their knot (``tied``) over knob ``x`` (or the derived
    ``link_length``), one line per combination of ``series``; each point is labelled tied/episodes.
    Failed episodes count as not tied."""
    import matplotlib

    matplotlib.use("svg")
    import matplotlib.pyplot as plt

    def xval(r):  # `link_length` is derived: length / links
        if x == "link_length":
            return r["length"] / r["links"] if r.get("links") else None
        return r.get(x)

    lines: dict[tuple, dict[Any, list[bool]]] = {}
    for r in rows:
        v = xval(r)
        if v is None:
            continue
        key = tuple(r.get(k) for k in series)
        lines.setdefault(key, {}).setdefault(v, []).append(bool(r.get("ok") and r.get("tied")))
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    keys = sorted(lines, key=lambda k: tuple(str(v) for v in k))
    markers, styles = "osd^v<>", ["-", "--", ":", "-."]
    every_x = sorted({v for k in keys for v in lines[k]})
    for i, key in enumerate(keys):
        xs = sorted(lines[key])
        ys = [sum(lines[key][v]) / len(lines[key][v]) for v in xs]
        # Series side by side (a small shift along the log axis) so that equal results stay visible.
        shift = 2 ** (0.05 * (i - (len(keys) - 1) / 2))
        ax.plot([v * shift for v in xs], ys, marker=markers[i % len(markers)],
                linestyle=styles[i % len(styles)], label=", ".join(str(v) for v in key))
        for v, y in zip(xs, ys):
            ax.annotate(f"{sum(lines[key][v])}/{len(lines[key][v])}", (v * shift, y),
                        textcoords="offset points", xytext=(3, 5 + 8 * (i % 3)), fontsize=7)
    ax.set_xscale("log", base=2)
    ax.set_xticks(every_x, [f"{v:g}" for v in every_x])
    ax.set_xlabel(x)
    ax.set_ylabel("share of episodes tied")
    ax.set_ylim(-0.05, 1.1)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(title=", ".join(series))
    fig.tight_layout()
    # No date in the file: the same rows give the same bytes.
    if str(out).endswith(".png"):
        fig.savefig(out, format="png", dpi=100)
    else:
        fig.savefig(out, format="svg", metadata={"Date": None})
    plt.close(fig)


def scaling(bin_dir: str | None, episodes: int = 32, rounds: int = 3, links: int = 80) -> str:
    """Episodes per second with 1 and 2 Ray workers, rounds interleaved (1, 2, 1, 2, ...), each round a
    fresh local Ray and the same episodes (one-handed overhand, ``links`` links, seeds 1..episodes);
    and what one episode costs: starting its service, and the hand's run. Returns a Markdown table."""
    import ray

    results: dict[int, list[tuple[float, list[dict[str, Any]]]]] = {1: [], 2: []}
    eps = grid({"script": "overhand", "links": links}, seed=range(1, episodes + 1))
    with tempfile.TemporaryDirectory(prefix="tractrix-scaling-") as tmp:
        for r in range(rounds):
            for workers in (1, 2):
                if ray.is_initialized():
                    ray.shutdown()
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
                out = Path(tmp) / f"r{r}-w{workers}.parquet"
                t0 = time.monotonic()
                rows = sweep(eps, out, bin_dir=bin_dir, progress=False)
                wall = time.monotonic() - t0
                ray.shutdown()
                failed = [x for x in rows if not x["ok"]]
                if failed:
                    raise RuntimeError(f"scaling: {len(failed)} episodes failed: {failed[0]['error']}")
                results[workers].append((wall, rows))

    def med(xs):
        xs = sorted(xs)
        return xs[len(xs) // 2]

    lines = [
        f"| Ray workers (CPUs) | rounds | episodes per round | episodes/s, median of rounds (min, max) "
        f"| median episode: service start until it answered, s | median episode: hands' run, s "
        f"| median hand wall time per request, µs |",
        "|---|---|---|---|---|---|---|",
    ]
    for workers in (1, 2):
        rates = [len(rows) / wall for wall, rows in results[workers]]
        rows = [x for _, rs in results[workers] for x in rs]
        lines.append(
            f"| {workers} | {rounds} | {episodes} | {med(rates):.2f} ({min(rates):.2f}, {max(rates):.2f}) "
            f"| {med([x['startup_s'] for x in rows]):.3f} | {med([x['seconds'] for x in rows]):.2f} "
            f"| {med([x['us_per_request'] for x in rows]):.0f} |"
        )
    r1 = med([len(rows) / wall for wall, rows in results[1]])
    r2 = med([len(rows) / wall for wall, rows in results[2]])
    lines.append("")
    lines.append(f"Speed-up of 2 workers over 1 (ratio of the medians): {r2 / r1:.2f}×.")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="tractrix-sweep", description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser(
        "run", help="run a sweep: GRID is JSON, {base, axes} or a list of episodes and {base, axes}"
    )
    r.add_argument("grid")
    r.add_argument("--out", required=True)
    r.add_argument("--bin", help="directory of solver-service and hand (default $TRACTRIX_BIN or target/release)")
    r.add_argument("--address", help="a Ray cluster's address (default: start a local Ray)")
    r.add_argument("--num-cpus", type=int)
    r.add_argument("--no-progress", action="store_true")
    r.add_argument("--by", default="script,links,collision,method", help="the summary's grouping")
    s = sub.add_parser("summary", help="the Markdown summary of a sweep's Parquet file")
    s.add_argument("parquet")
    s.add_argument("--by", default="script,links,collision,method")
    p = sub.add_parser("plot", help="an SVG of knot success over a knob")
    p.add_argument("parquet")
    p.add_argument("--out", required=True)
    p.add_argument("--x", default="links", help="a knob, or link_length (length / links)")
    p.add_argument("--series", default="script")
    c = sub.add_parser("scaling", help="episodes per second with 1 and 2 workers (Markdown)")
    c.add_argument("--bin", help="directory of solver-service and hand")
    c.add_argument("--episodes", type=int, default=32)
    c.add_argument("--rounds", type=int, default=3)
    c.add_argument("--links", type=int, default=80)
    a = ap.parse_args(argv)
    if a.cmd == "plot":
        plot(read(a.parquet), a.out, a.x, tuple(a.series.split(",")))
        return 0
    if a.cmd == "scaling":
        print(scaling(a.bin, a.episodes, a.rounds, a.links))
        return 0
    if a.cmd == "run":
        spec = json.loads(Path(a.grid).read_text())
        parts = spec if isinstance(spec, list) else [spec]
        episodes = []
        for k, part in enumerate(parts):
            if not isinstance(part, dict):
                print(f"{a.grid}: item {k}: expected an episode or {{base, axes}}", file=sys.stderr)
                return 2
            if "axes" in part:
                episodes += grid(part.get("base", {}), **part["axes"])
            else:
                episodes.append(part)
        rows = sweep(episodes, a.out, a.bin, a.address, a.num_cpus, not a.no_progress)
        print(summary(rows, tuple(a.by.split(","))))
        return 0 if all(r.get("ok") for r in rows) else 1
    print(summary(read(a.parquet), tuple(a.by.split(","))))
    return 0


def main_exit() -> None:
    sys.exit(main())


if __name__ == "__main__":
    main_exit()
