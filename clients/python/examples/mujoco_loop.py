"""A surgical-simulator loop in MuJoCo, with the solver service as the suture (issue 17).

MuJoCo steps at 1 kHz. The suture is a chain of kinematic capsules (mocap bodies, one per link) whose
poses come from the service every step; a needle driver (a mocap body: the hand) moves the suture's
end along a small circle; the rest of the scene (a ball rolling on a table) is MuJoCo's physics. The
loop runs twice, with and without the service, and prints the step time's percentiles of each, so the
service's share of a 1 kHz step is measured, not guessed.

    cargo run --release --bin solver-service &      # a service on the default scene
    target/pyenv/bin/python clients/python/examples/mujoco_loop.py --prefix tractrix_ --steps 2000

`--json` prints one JSON object instead, with the capsule centres MuJoCo holds at the end (for a test
to compare with the service's joints).

`--coupling K` is the haptic hand of issue 38: the suture's tail is grasped, the hand's circle takes the
end beyond the suture's length for part of each turn, and every move is sent with the pull flag. The
service stops the end where the rope is taut and reports the pull p (where the end is less where the
hand asked it to be, docs/tension.md); a virtual coupling of stiffness K (N per unit length) turns it
into the force on the hand, F = K·p, at every 1 kHz step. The loop prints the force's percentiles
(with `--json`, the hand's position and the force of every step); a haptic device would command its
motors with it. `--frames DIR` renders four frames of the run offscreen
(OSMesa, headless) to DIR/mujoco-K.png. Needs `pip install mujoco PyOpenGL` (scripts/python-venv.sh
installs them) and, for frames, OSMesa (scripts/system-packages.sh).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import struct
import sys
import time
import zlib

if "--frames" in sys.argv:
    os.environ.setdefault("MUJOCO_GL", "osmesa")  # offscreen, no display: set before mujoco loads
import mujoco
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from tractrix_client import (FLAG_PULL, JOINT_HEAD, Client, ServiceError, eyelets,  # noqa: E402
                             instruments, pull_stop, pulls, tissue)


def scene_xml(n_links: int, link: float, radius: float, n_eyelets: int = 0,
              block: dict | None = None, tools: list | None = None) -> str:
    """A table, a ball, the hand, a small green mocap sphere per eyelet the suture passes through
    (its entry and exit points in tissue), the suture's block of tissue if it has one (a static box
    that nothing collides with: the service keeps the suture out of it), one grey mocap body per
    instrument of the chain (`tools`: a sphere, or a capsule along its body's x axis: a driver's jaws,
    the pieces of a curved needle) and one mocap capsule per link (along its body's x axis)."""
    slab = ""
    if block is not None:
        lo, hi = np.asarray(block["lo"]), np.asarray(block["hi"])
        c, half = (lo + hi) / 2.0, (hi - lo) / 2.0
        slab = (f'<geom name="tissue" type="box" pos="{c[0]} {c[1]} {c[2]}" '
                f'size="{half[0]} {half[1]} {half[2]}" rgba="0.85 0.6 0.5 0.6" '
                f'contype="0" conaffinity="0"/>')
    rings = "\n".join(
        f'<body name="eyelet{k}" mocap="true"><geom type="sphere" size="{2.5 * radius}" '
        f'rgba="0.1 0.7 0.3 1" contype="0" conaffinity="0"/></body>'
        for k in range(n_eyelets)
    )
    shapes = []
    for k, t in enumerate(tools or []):
        if t["shape"] == "capsule":
            half = float(np.linalg.norm(np.subtract(t["b"], t["a"]))) / 2.0
            geom = f'type="capsule" size="{t["radius"]}" fromto="{-half} 0 0 {half} 0 0"'
        else:
            geom = f'type="sphere" size="{t["radius"]}"'
        shapes.append(f'<body name="tool{k}" mocap="true"><geom {geom} rgba="0.55 0.55 0.6 1" '
                      f'contype="0" conaffinity="0"/></body>')
    tools_xml = "\n".join(shapes)
    links = "\n".join(
        f'<body name="link{i}" mocap="true"><geom type="capsule" size="{radius}" '
        f'fromto="{-link / 2} 0 0 {link / 2} 0 0" rgba="0.8 0.7 0.5 1" contype="0" conaffinity="0"/></body>'
        for i in range(n_links)
    )
    return f"""
<mujoco model="suture">
  <option timestep="0.001"/>
  <worldbody>
    <light pos="20 -10 30" dir="0 0.3 -1"/>
    <camera name="view" pos="33 -10 8" xyaxes="0.914 -0.406 0 0.235 0.529 0.815"/>
    <geom name="table" type="plane" size="60 60 0.1" pos="0 0 -2" rgba="0.3 0.4 0.5 1"/>
    <body name="ball" pos="20 5 2"><freejoint/><geom type="sphere" size="0.8" rgba="0.8 0.2 0.2 1"/></body>
    <body name="driver" mocap="true"><geom type="box" size="0.3 0.15 0.15" rgba="0.6 0.6 0.6 1"
      contype="0" conaffinity="0"/></body>
    {slab}
    {rings}
    {tools_xml}
    {links}
  </worldbody>
</mujoco>"""


def link_quat(d: np.ndarray) -> np.ndarray:
    """The rotation (w, x, y, z) that turns the x axis onto the unit vector d."""
    w = 1.0 + d[0]
    if w < 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    q = np.array([w, 0.0, -d[2], d[1]])
    return q / np.linalg.norm(q)


def place(data: mujoco.MjData, first_link: int, joints) -> None:
    """Puts capsule i between joints i and i + 1."""
    p = np.asarray(joints)
    for i in range(len(p) - 1):
        a, b = p[i], p[i + 1]
        d = b - a
        data.mocap_pos[first_link + i] = (a + b) / 2.0
        data.mocap_quat[first_link + i] = link_quat(d / np.linalg.norm(d))


def place_tools(data: mujoco.MjData, first: int, tools: list) -> None:
    """Puts instrument k's body at its centre, a capsule's x axis along its axis."""
    for k, t in enumerate(tools):
        a, b = np.asarray(t["a"], dtype=float), np.asarray(t["b"], dtype=float)
        data.mocap_pos[first + k] = (a + b) / 2.0
        if t["shape"] == "capsule":
            d = b - a
            data.mocap_quat[first + k] = link_quat(d / np.linalg.norm(d))


def tool_ends(data: mujoco.MjData, model: mujoco.MjModel, first: int, tools: list) -> list:
    """Where the MuJoCo scene has each instrument's axis: its two ends (a sphere's centre twice),
    from the body's pose and its geom's half length."""
    out = []
    for k, t in enumerate(tools):
        pos, quat = data.mocap_pos[first + k], data.mocap_quat[first + k]
        geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"tool{k}")
        half = model.geom_size[model.body_geomadr[geom]][1] if t["shape"] == "capsule" else 0.0
        axis = np.zeros(3)
        mujoco.mju_rotVecQuat(axis, np.array([half, 0.0, 0.0]), quat)
        out.append([(pos - axis).tolist(), (pos + axis).tolist()])
    return out


def write_png(path: str, rgb: np.ndarray) -> None:
    """An 8-bit RGB PNG (no imaging library needed)."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def run(client: Client | None, chain: int, steps: int, rate: float, start,
        frames: str | None = None, coupling: float | None = None,
        rings: list | None = None, block: dict | None = None,
        tools: list | None = None) -> tuple[list, list, dict]:
    """The loop: `steps` steps at `rate` Hz; returns the step times (µs), the capsule centres at the
    end and, with the service, the times of its parts (µs): the service call alone and the posing
    of the capsules from the joints. With `frames`, four frames are rendered (outside the timed step)
    to that directory. With `coupling` (a stiffness), the moves pull (the tail is held by the caller)
    and the hand's force of every step is in the parts (`hand`, `force`). `rings`: the eyelets the
    suture passes through at the start (`tractrix_client.eyelets`), moved each step to where the
    service has them (`eyelets` in the parts: their last positions). `block`: the suture's tissue
    (`tractrix_client.tissue` of a describe), drawn as a box. `tools`: the chain's instruments at the
    start (`tractrix_client.instruments`), posed each step where the service has them (their ends in
    the parts, `instruments`)."""
    n_links = len(start) - 1
    rings, tools = rings or [], tools or []
    model = mujoco.MjModel.from_xml_string(scene_xml(n_links, float(np.linalg.norm(
        np.subtract(start[1], start[0]))), 0.1, len(rings), block, tools))
    data = mujoco.MjData(model)
    for k, e in enumerate(rings):
        data.mocap_pos[1 + k] = e["at"]
    # Mocap ids: the driver is 0, the eyelets, the instruments, then the links.
    first_tool = 1 + len(rings)
    place_tools(data, first_tool, tools)
    first_link = first_tool + len(tools)
    joints = start
    place(data, first_link, joints)
    head = np.asarray(start[-1], dtype=float)
    times = []
    parts = {"service_call": [], "posing": [], "hand": [], "force": [], "stop": []}
    # With the coupling, the circle's centre is a unit behind the end: for part of each turn the hand
    # is beyond the suture's length from its held tail.
    centre = head + (np.array([1.0, 0.0, 0.0]) if coupling is not None else 0.0)
    renderer = mujoco.Renderer(model, 360, 640) if frames else None
    shots = {steps * k // 4 + steps // 8 for k in range(4)}
    t0 = time.perf_counter()
    for i in range(steps):
        # Paced by sleeping, not spinning: the service's core stays the service's.
        due = t0 + i / rate
        wait = due - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
        s = time.perf_counter_ns()
        a = 2.0 * math.pi * (i % 2000) / 2000.0
        hand = centre + np.array([2.0 * (math.cos(a) - 1.0), 2.0 * math.sin(a), 0.5 * math.sin(2 * a)])
        data.mocap_pos[0] = hand
        if client is not None:
            c = time.perf_counter_ns()
            h, elements = client.call("move", chain, [tuple(hand)], joint=JOINT_HEAD,
                                      flags=FLAG_PULL if coupling is not None else 0)
            p = time.perf_counter_ns()
            joints = elements[:h.n_joints]
            place(data, first_link, joints)
            for k, e in enumerate(eyelets(h, elements)[:len(rings)]):
                data.mocap_pos[1 + k] = e["at"]
            place_tools(data, first_tool, instruments(h, elements)[:len(tools)])
            parts["service_call"].append((p - c) / 1000.0)
            parts["posing"].append((time.perf_counter_ns() - p) / 1000.0)
            if coupling is not None:
                # The virtual coupling: the force on the hand is the stiffness times the pull on the
                # joint it holds (the head, the last held joint).
                pull = pulls(h, elements)["held"][-1]["pull"]
                parts["hand"].append(hand.tolist())
                parts["force"].append([coupling * x for x in pull])
                # Why the rope stopped the hand short ("taut", ...; None: it reached the hand).
                parts["stop"].append(pull_stop(h))
        mujoco.mj_step(model, data)
        times.append((time.perf_counter_ns() - s) / 1000.0)
        if renderer is not None and i in shots:
            renderer.update_scene(data, camera="view")
            write_png(os.path.join(frames, f"mujoco-{sorted(shots).index(i)}.png"), renderer.render())
    if renderer is not None:
        renderer.close()
    centres = data.geom_xpos[model.ngeom - n_links:].tolist()
    parts["eyelets"] = [data.mocap_pos[1 + k].tolist() for k in range(len(rings))]
    parts["instruments"] = tool_ends(data, model, first_tool, tools)
    slab = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "tissue")
    parts["tissue"] = ({"centre": model.geom_pos[slab].tolist(), "half": model.geom_size[slab].tolist()}
                       if slab >= 0 else None)
    return times, centres, parts


def percentiles(times: list, unit: str = "us") -> dict:
    t = sorted(times)
    pick = lambda p: t[int(p * (len(t) - 1))]
    return {f"p50_{unit}": pick(0.5), f"p99_{unit}": pick(0.99), f"max_{unit}": t[-1]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--prefix", default="tractrix_")
    ap.add_argument("--chain", default="rope")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--frames", help="render four frames to this directory")
    ap.add_argument("--coupling", type=float,
                    help="a haptic hand: pull the held suture taut, the force on the hand = this "
                         "stiffness (N per unit) times the service's pull")
    a = ap.parse_args()
    try:
        client = Client(prefix=a.prefix, wait_for_service=5.0)
        chain = client.find_chain(a.chain)
        # From the scene's rope, whatever an earlier run left.
        h, elements = client.call("reset", chain)
        start = elements[:h.n_joints]
        rings = eyelets(h, elements)
        tools = instruments(h, elements)
        block = tissue(*client.call("describe", chain))
        alone, _, _ = run(None, chain, a.steps, a.rate, start, block=block, tools=tools)
        if a.coupling is not None:
            # The tail held and the end held by the hand: the suture between them can go taut.
            client.call("grasp", chain, joint=0)
            client.call("grasp", chain, joint=JOINT_HEAD)
        with_service, centres, parts = run(client, chain, a.steps, a.rate, start, a.frames,
                                           a.coupling, rings, block, tools)
        if a.coupling is not None:
            client.call("release", chain, joint=JOINT_HEAD)
            client.call("release", chain, joint=0)
    except (RuntimeError, ServiceError, KeyError, TimeoutError) as e:
        print(e, file=sys.stderr)
        return 1
    result = {
        "steps": a.steps,
        "rate_hz": a.rate,
        "mujoco_alone": percentiles(alone),
        "mujoco_and_service": percentiles(with_service),
        # Within a step with the service: the call alone (request, solve, response) and the posing of
        # the capsules from the joints (Python).
        "service_call": percentiles(parts["service_call"]),
        "posing": percentiles(parts["posing"]),
        "capsule_centres": centres,
        # Where the MuJoCo scene draws the eyelets at the end (the service's points).
        "eyelets": parts["eyelets"],
        # The suture's tissue as the MuJoCo model holds it (its box's centre and half sizes).
        "tissue": parts["tissue"],
        # Where the MuJoCo scene has each instrument's axis at the end (its two ends).
        "instruments": parts["instruments"],
    }
    if a.coupling is not None:
        norms = [math.sqrt(sum(x * x for x in f)) for f in parts["force"]]
        result["coupling"] = {
            "stiffness": a.coupling,
            "force": percentiles(norms, "n"),
            "taut_steps": sum(1 for n in norms if n > 0.0),
            "hand": parts["hand"],
            "forces": parts["force"],
            "stops": parts["stop"],
        }
    if a.json:
        print(json.dumps(result))
    else:
        for k in ("mujoco_alone", "mujoco_and_service", "service_call", "posing"):
            p = result[k]
            what = "step" if k.startswith("mujoco") else "within a step"
            print(f"{k} ({what}): p50 {p['p50_us']:.1f} us, p99 {p['p99_us']:.1f} us, max {p['max_us']:.1f} us")
        if a.coupling is not None:
            c = result["coupling"]
            f = c["force"]
            print(f"force on the hand (coupling {a.coupling} N/unit): taut in {c['taut_steps']} of "
                  f"{a.steps} steps, p50 {f['p50_n']:.3f} N, p99 {f['p99_n']:.3f} N, "
                  f"max {f['max_n']:.3f} N")
    return 0


if __name__ == "__main__":
    sys.exit(main())
