"""A Python client of the tractrix solver service, on the PyPI wheel iceoryx2==0.10.0.

The wire types are ctypes mirrors of shared/src/lib.rs (the byte layout table there, and the C header
shared/include/tractrix.h); their iceoryx2 type names must be the Rust ones ("tractrix.v2.*") or the
service refuses the connection. Install it (`pip install clients/python`, which brings
iceoryx2==0.10.0; `scripts/python-venv.sh` does it in target/pyenv), then:

    tractrix-client --prefix tractrix_ move rope 35 8 2      # or: python -m tractrix_client ...

The commands are chainctl's (move, path, reach, query, reset, describe, snapshot, grasp, release,
instrument) and bench; each prints one JSON object.

Known bug of the 0.10.0 wheel (iceoryx2 issue #1533): a received slice of structs reports its length in
bytes, so the number of Vec3 in a response is read from the response's own header (`n_joints +
n_angles`), never from the slice.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import math
import os
import pwd
import sys
import time
from typing import Iterable, Sequence

Point = Sequence[float]

import iceoryx2 as iox2

PROTOCOL_VERSION = 1
SERVICE_COMMAND = "tractrix/command"
SERVICE_WAKE_SERVER = "tractrix/wake-server"
DEFAULT_PREFIX = "tractrix_"
JOINT_HEAD = 0xFFFFFFFF
MAX_PATH_POINTS = 4096
FLAG_ANGLES = 1
FLAG_POSE = 2  # a bundle's rigid motion, or a needle's pose: move of its swage, then its rotation vector
FLAG_TAKE_OVER = 4
FLAG_ORIENT = 8  # reach: (head target, direction of the last link)
FLAG_IN_BOX = 16  # reach: (corner lo, corner hi); no motion inside
FLAG_IN_BALL = 32  # reach: (centre, (radius, 0, 0)); no motion inside
FLAG_SMOOTH = 64  # path: the natural cubic spline through the joint and the points (C2)
FLAG_PULL = 128  # move, instrument: as far as the rope lets; the rest is the pull (see `pulls`)
FLAG_DRIVE = 256  # move of a needle's swage (the head): the needle driven along its arc, cutting holes

# The `knot` field of a response: the chain's knot when its scene asks for it (`knot = true`).
KNOTS = {1: "unknot", 2: "trefoil", 3: "square", 4: "granny", 5: "double-overhand",
         6: "surgeons", 7: "other"}


def knot(h) -> str | None:
    """The knot the response names (`None` when the chain's scene does not ask for it)."""
    return KNOTS.get(h.knot)
KIND = ["free", "fixed-base", "bundle"]

CMD = {"move": 1, "path": 2, "reach": 3, "query": 4, "reset": 5, "describe": 6, "snapshot": 7,
       "grasp": 8, "release": 9, "instrument": 10, "eyelet": 11}
STATUS = [
    "ok", "unknown-command", "unknown-chain", "joint-out-of-range", "non-finite", "bad-option",
    "bad-point-count", "unreachable", "not-converged", "too-many-substeps", "wrong-chain-kind",
    "off-plane", "persistence-failed", "internal", "locked", "too-far",
    "over-budget", "joint-limit", "held",
]


class Vec3(ctypes.Structure):
    _fields_ = [("x", ctypes.c_double), ("y", ctypes.c_double), ("z", ctypes.c_double)]

    @staticmethod
    def type_name():
        return "tractrix.v2.Vec3"


class RequestHeader(ctypes.Structure):
    _fields_ = [
        ("command", ctypes.c_uint32),
        ("chain", ctypes.c_uint32),
        ("joint", ctypes.c_uint32),
        ("method", ctypes.c_uint32),
        ("precision", ctypes.c_uint32),
        ("substep_mode", ctypes.c_uint32),
        ("substeps", ctypes.c_uint32),
        ("strategy", ctypes.c_uint32),
        ("max_iterations", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("client_listener", ctypes.c_uint64 * 2),
        ("request_id", ctypes.c_uint64),
        ("max_step", ctypes.c_double),
        ("tolerance", ctypes.c_double),
        ("reserved", ctypes.c_uint64 * 2),
    ]

    @staticmethod
    def type_name():
        return "tractrix.v2.RequestHeader"


class ResponseHeader(ctypes.Structure):
    _fields_ = [
        ("status", ctypes.c_uint32),
        ("command", ctypes.c_uint32),
        ("chain", ctypes.c_uint32),
        ("n_joints", ctypes.c_uint32),
        ("n_angles", ctypes.c_uint32),
        ("iterations", ctypes.c_uint32),
        ("substeps", ctypes.c_uint32),
        ("paper_fallbacks", ctypes.c_uint32),
        ("sequence", ctypes.c_uint64),
        ("request_id", ctypes.c_uint64),
        ("solve_ns", ctypes.c_uint64),
        ("residual", ctypes.c_double),
        ("n_chains", ctypes.c_uint32),
        ("kind", ctypes.c_uint32),
        ("dims", ctypes.c_uint32),
        ("n_links", ctypes.c_uint32),
        ("precision", ctypes.c_uint32),
        ("method", ctypes.c_uint32),
        ("collision", ctypes.c_uint32),
        ("substep_mode", ctypes.c_uint32),
        ("substeps_default", ctypes.c_uint32),
        ("n_held", ctypes.c_uint32),
        ("max_step", ctypes.c_double),
        ("total_length", ctypes.c_double),
        ("thickness", ctypes.c_double),
        ("name", ctypes.c_uint8 * 32),
        ("reason", ctypes.c_uint8 * 96),
        ("n_instruments", ctypes.c_uint32),
        ("limits", ctypes.c_uint32),
        ("limit_value", ctypes.c_double),
        ("n_pulls", ctypes.c_uint32),
        ("knot", ctypes.c_uint32),
        ("n_eyelets", ctypes.c_uint32),
        ("n_tissue", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name():
        return "tractrix.v2.ResponseHeader"


# The layout table of shared/src/lib.rs, checked when the module loads.
_LAYOUT = {
    Vec3: (24, {"x": 0, "y": 8, "z": 16}),
    RequestHeader: (96, {"command": 0, "joint": 8, "flags": 36, "client_listener": 40,
                         "request_id": 56, "max_step": 64, "tolerance": 72, "reserved": 80}),
    ResponseHeader: (288, {"status": 0, "n_joints": 12, "sequence": 32, "residual": 56,
                           "n_chains": 64, "n_links": 76, "n_held": 100, "max_step": 104, "name": 128,
                           "reason": 160, "n_instruments": 256, "limits": 260,
                           "limit_value": 264, "n_pulls": 272, "knot": 276,
                           "n_eyelets": 280, "n_tissue": 284}),
}
for _t, (_size, _offsets) in _LAYOUT.items():
    assert ctypes.sizeof(_t) == _size, (_t, ctypes.sizeof(_t))
    for _f, _o in _offsets.items():
        assert getattr(_t, _f).offset == _o, (_t, _f)


INSTRUMENT_ELEMENTS = 3
EYELET_ELEMENTS = 2  # an eyelet: its point, then (link, 1 threaded / 0 left, 0)
TISSUE_ELEMENTS = 2  # a describe's block of tissue: its corners lo and hi


LIMITS = {1: "bend-radius", 2: "cone", 3: "cones", 4: "ranges"}


def limits(h: ResponseHeader) -> dict:
    """A describe's joint limits: the kind and its value (a bend radius in length units; a cone's angle,
    the widest cone or the widest range's width in radians)."""
    return {"kind": LIMITS.get(h.limits, f"limits-{h.limits}"), "value": h.limit_value}


def instruments(h: ResponseHeader, elements: list) -> list[dict]:
    """The chain's instruments in a response: each {"shape": "sphere" | "capsule", "a", "b", "radius"}
    (a sphere has a == b, its centre)."""
    at = h.n_joints + h.n_angles + h.n_held
    out = []
    for k in range(h.n_instruments):
        a, b, (radius, shape, _) = elements[at + 3 * k: at + 3 * k + 3]
        out.append({"shape": "capsule" if shape else "sphere", "a": list(a), "b": list(b),
                    "radius": radius})
    return out


def pulls(h: ResponseHeader, elements: list) -> dict:
    """What the hands feel (docs/tension.md): {"held": [{"joint", "taut", "pull"}], "instruments":
    [pull, ...]}. A pull is the vector from where the joint's (instrument's) owner last asked it to be
    to where the rope let it be: zero while the rope is slack; times a coupling stiffness k it is the
    force on the hand. `taut`: the stretch from the joint to the next held joint is straight."""
    held_from = h.n_joints + h.n_angles
    at = held_from + h.n_held + INSTRUMENT_ELEMENTS * h.n_instruments
    ps = elements[at:at + h.n_pulls]
    held = [{"joint": int(x), "taut": z != 0.0, "pull": list(ps[k]) if k < len(ps) else [0.0] * 3}
            for k, (x, _, z) in enumerate(elements[held_from:held_from + h.n_held])]
    return {"held": held, "instruments": [list(p) for p in ps[h.n_held:]]}


PULL_STOPS = {"stopped short: taut": "taut", "stopped short: jammed": "jammed",
              "stopped short: joint limit": "joint limit",
              "stopped short: work budget": "work budget"}


def pull_stop(h: ResponseHeader) -> str | None:
    """Why an ok pull (FLAG_PULL) stopped short of its target, from its reason (docs/tension.md):
    "taut", "jammed", "joint limit" or "work budget"; None when it made the whole move."""
    if h.status != 0:
        return None
    return PULL_STOPS.get(_text(h.reason))


def eyelets(h: ResponseHeader, elements: list) -> list[dict]:
    """The eyelets the chain passes through (the scene's `eyelets`, in order along the rope):
    [{"at", "link", "threaded"}]; `link` is the link through the point while `threaded`."""
    at = (h.n_joints + h.n_angles + h.n_held + INSTRUMENT_ELEMENTS * h.n_instruments
          + h.n_pulls)
    es = elements[at:at + EYELET_ELEMENTS * h.n_eyelets]
    return [{"at": list(es[k]), "link": int(es[k + 1][0]), "threaded": es[k + 1][1] != 0.0}
            for k in range(0, len(es) - 1, EYELET_ELEMENTS)]


def tissue(h: ResponseHeader, elements: list) -> dict | None:
    """A describe's block of tissue (scene `tissue`): {"lo", "hi"}, its corners; None without."""
    if not h.n_tissue:
        return None
    at = (h.n_joints + h.n_angles + h.n_held + INSTRUMENT_ELEMENTS * h.n_instruments
          + h.n_pulls + EYELET_ELEMENTS * h.n_eyelets)
    lo, hi = elements[at:at + TISSUE_ELEMENTS]
    return {"lo": list(lo), "hi": list(hi)}


def _text(buf):
    return bytes(buf).split(b"\0", 1)[0].decode("utf-8", "replace")


class ServiceError(Exception):
    """The service answered with an error status; the chain is unchanged."""

    def __init__(self, status, reason):
        super().__init__(f"{status}: {reason}")
        self.status = status
        self.reason = reason


IOX_ROOT_BASE = "/tmp/iceoryx2."
"""The start of the per-user iceoryx2 root directory, followed by the user's numeric id and `/`."""


def iceoryx_config_file() -> str | None:
    """The configuration file iceoryx2 itself loads (the first of its three places that exists)."""
    home = pwd.getpwuid(os.getuid()).pw_dir  # iceoryx2 reads the password database, not $HOME
    for place in ("config/iceoryx2.toml", os.path.join(home, ".config/iceoryx2/iceoryx2.toml"),
                  "/etc/iceoryx2/iceoryx2.toml"):
        if os.path.isfile(place):
            return place
    return None


def _outside_uid(uid: int) -> int:
    """`uid` as the machine sees it (mapped out of a user namespace by /proc/self/uid_map)."""
    try:
        with open("/proc/self/uid_map") as f:
            for line in f:
                inside, outside, count = (int(w) for w in line.split())
                if inside <= uid < inside + count:
                    return outside + uid - inside
    except (OSError, ValueError):
        pass
    return uid


def iceoryx_config(prefix: str = DEFAULT_PREFIX):
    """The iceoryx2 configuration every process of this protocol uses (the Rust crate `shared`'s
    `iceoryx_config`): iceoryx2's configuration file when there is one, else its defaults with the
    per-user root directory `/tmp/iceoryx2.<uid>/`, so two users of one machine never collide; then
    `prefix`."""
    # iceoryx2 warns on stderr that no config file exists; the defaults are what we want.
    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)
    cfg = iox2.config.global_config()
    if iceoryx_config_file() is None:
        cfg.global_cfg.root_path = iox2.Path.new(f"{IOX_ROOT_BASE}{_outside_uid(os.geteuid())}/")
    cfg.global_cfg.prefix = iox2.FileName.new(prefix)
    return cfg


class Client:
    """One client port on the command service. Waits by polling (spin, then short sleeps)."""

    def __init__(self, prefix: str = DEFAULT_PREFIX, wait_for_service: float = 0.0,
                 timeout: float = 5.0, max_request_points: int = MAX_PATH_POINTS) -> None:
        """`max_request_points` sizes the request port: raise it to the strands of a bundle to move
        each strand's head to its own target (a pose move, `flags=FLAG_POSE`, takes two points)."""
        cfg = iceoryx_config(prefix)
        self.node = iox2.NodeBuilder.new().config(cfg).create(iox2.ServiceType.Ipc)
        deadline = time.monotonic() + wait_for_service
        name = iox2.ServiceName.new(SERVICE_COMMAND)
        while True:
            try:
                service = (
                    self.node.service_builder(name)
                    .request_response(iox2.Slice[Vec3], iox2.Slice[Vec3])
                    .request_header(RequestHeader)
                    .response_header(ResponseHeader)
                    .open()
                )
                break
            except iox2.RequestResponseOpenError as e:
                text = str(e)
                if "Incompatible" in text or "incompatible" in text:
                    raise RuntimeError(
                        f"the service with prefix {prefix!r} speaks another protocol version "
                        f"(this client: v{PROTOCOL_VERSION})"
                    ) from e
                if time.monotonic() >= deadline:
                    raise RuntimeError(
                        f"no solver-service runs with prefix {prefix!r} "
                        f"(waited {wait_for_service} s)"
                    ) from e
                time.sleep(0.02)
        # The service exists a moment before its server port does (a service starting up): wait for
        # the server within the same deadline, or a first request would find nobody to answer it and
        # time out (a sweep on a loaded machine caught it), as the Rust client does.
        while service.dynamic_config.number_of_servers == 0:
            if time.monotonic() >= deadline:
                raise RuntimeError(
                    f"the solver-service with prefix {prefix!r} has no server port "
                    f"(waited {wait_for_service} s)"
                )
            time.sleep(0.005)
        self.client = (
            service.client_builder()
            .initial_max_slice_len(max(1, max_request_points))
            .create()
        )
        # Wakes a service that sleeps between requests (--wait event or hybrid). A service that is
        # starting creates this a moment after the command service: wait for it too.
        while True:
            try:
                wake = self.node.service_builder(iox2.ServiceName.new(SERVICE_WAKE_SERVER)).event().open()
                break
            except iox2.EventOpenError:
                if time.monotonic() >= deadline + 1.0:
                    raise
                time.sleep(0.005)
        self.wake_server = wake.notifier_builder().create()
        self.timeout = timeout
        self.next_id = 1

    def call(self, command: str, chain: int = 0, points: Iterable[Point] = (),
             **fields) -> tuple[ResponseHeader, list[tuple[float, float, float]]]:
        """Sends one request; returns (header, list of (x, y, z): n_joints joints, n_angles rotations,
        n_held held joints as (index, 1 for an anchor else 0, 1 if taut else 0), then n_instruments
        instruments, three elements each: see `instruments`, then n_pulls pulls: see `pulls`) or raises
        ServiceError."""
        points = list(points)
        request = self.client.loan_slice_uninit(len(points))
        for i, p in enumerate(points):
            request.payload()[i] = Vec3(*p)
        header = request.user_header().contents
        ctypes.memset(ctypes.addressof(header), 0, ctypes.sizeof(RequestHeader))
        header.command = CMD[command]
        header.chain = chain
        header.joint = fields.pop("joint", JOINT_HEAD)
        header.request_id = self.next_id
        for k, v in fields.items():
            setattr(header, k, v)
        self.next_id += 1
        pending = request.assume_init().send()
        if pending.number_of_server_connections == 0:
            raise RuntimeError("no solver-service answers (its server port is gone)")
        self.wake_server.notify()
        deadline = time.monotonic() + self.timeout
        spins = 0
        while True:
            response = pending.receive()
            if response is not None:
                break
            if time.monotonic() > deadline:
                raise TimeoutError(f"no response within {self.timeout} s")
            spins += 1
            if spins > 1000:
                time.sleep(0.0001)
        h = response.user_header().contents
        # The wheel's Slice.len() is in bytes (issue #1533): count from our own header.
        n = (h.n_joints + h.n_angles + h.n_held + INSTRUMENT_ELEMENTS * h.n_instruments + h.n_pulls
             + EYELET_ELEMENTS * h.n_eyelets + TISSUE_ELEMENTS * h.n_tissue)
        elements = (Vec3 * n).from_address(response.payload().as_ptr()) if n else []
        out = [(v.x, v.y, v.z) for v in elements]
        copy = ResponseHeader.from_buffer_copy(h)
        response.delete()
        if copy.request_id != header.request_id:
            raise RuntimeError(f"response {copy.request_id} to request {header.request_id}")
        if copy.status != 0:
            raise ServiceError(STATUS[copy.status] if copy.status < len(STATUS) else copy.status,
                               _text(copy.reason))
        return copy, out

    def find_chain(self, name: str) -> int:
        h, _ = self.call("describe", 0)
        for c in range(h.n_chains):
            d, _ = self.call("describe", c)
            if _text(d.name) == name:
                return c
        raise KeyError(f"no chain named {name!r}")


def _bench(client: Client, chain: int, n: int) -> int:
    """N head moves around a circle of radius 0.5 (200 per turn), after n / 10 uncounted ones."""
    h, elements = client.call("query", chain)
    x, y, z = elements[h.n_joints - 1]
    warmup, times = n // 10, []
    for i in range(warmup + n):
        a = 2.0 * math.pi * (i % 200) / 200.0
        target = (x + 0.5 * (math.cos(a) - 1.0), y + 0.5 * math.sin(a), z)
        t0 = time.perf_counter_ns()
        client.call("move", chain, [target])
        if i >= warmup:
            times.append(time.perf_counter_ns() - t0)
    times.sort()
    pct = lambda p: times[int(p * (len(times) - 1))] / 1000.0
    print(f"{n} moves at 0 Hz: round trip p50 {pct(0.5):.1f} us, p99 {pct(0.99):.1f} us, "
          f"max {times[-1] / 1000.0:.1f} us")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="tractrix-client", description=__doc__.splitlines()[0])
    ap.add_argument("--prefix", default=DEFAULT_PREFIX)
    ap.add_argument("--wait-for-service", type=float, default=0.0)
    sub = ap.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("move", help="move a chain's head (or --joint) to x y z")
    m.add_argument("chain")
    m.add_argument("xyz", type=float, nargs=3)
    m.add_argument("--joint", type=int, default=JOINT_HEAD)
    m.add_argument("--pull", action="store_true",
                   help="as far as the rope lets; print the rest as the pull instead of refusing")
    p = sub.add_parser("path", help="move a chain's head (or --joint) through points x,y,z ...")
    p.add_argument("chain")
    p.add_argument("points", nargs="+", help="x,y,z")
    p.add_argument("--joint", type=int, default=JOINT_HEAD)
    p.add_argument("--smooth", action="store_true",
                   help="follow the natural cubic spline through the points (C2), not straight segments")
    r = sub.add_parser("reach", help="bring a fixed-base chain's head to x y z (with a goal: the last "
                                     "link along --direction, or anywhere within --within of x y z)")
    r.add_argument("chain")
    r.add_argument("xyz", type=float, nargs=3)
    goal = r.add_mutually_exclusive_group()
    goal.add_argument("--direction", type=float, nargs=3, help="the last link's direction")
    goal.add_argument("--within", type=float, help="a ball goal: the head within this of x y z")
    goal.add_argument("--box", type=float, nargs=3, metavar="HI",
                      help="a box goal from x y z (its smallest corner) to HI")
    for name, what in (("query", "print a chain's joints"), ("reset", "back to the scene's state"),
                       ("describe", "the chain's description and joints")):
        q = sub.add_parser(name, help=what)
        q.add_argument("chain")
    sub.add_parser("snapshot", help="write a snapshot now")
    for name, what in (("grasp", "hold a joint where it is"), ("release", "let a grasped joint go")):
        g = sub.add_parser(name, help=what)
        g.add_argument("chain")
        g.add_argument("--joint", type=int, default=JOINT_HEAD)
    i = sub.add_parser("instrument", help="move an instrument of a chain to centre x y z (capsules: "
                                          "--axis x y z), pushing the chain")
    i.add_argument("chain")
    i.add_argument("xyz", type=float, nargs=3)
    i.add_argument("--axis", type=float, nargs=3)
    i.add_argument("--index", type=int, default=0, help="the instrument's index in the chain's list")
    i.add_argument("--pull", action="store_true",
                   help="as far as the rope makes way; print the rest as the pull instead of refusing")
    b = sub.add_parser("bench", help="N moves of a chain's head around a small circle, back to back: "
                                     "round-trip percentiles (the motion of `latency client`)")
    b.add_argument("chain")
    b.add_argument("n", type=int)
    a = ap.parse_args(argv)
    try:
        client = Client(a.prefix, a.wait_for_service)
        if a.cmd == "snapshot":
            h, elements = client.call("snapshot")
            print(json.dumps({"status": STATUS[h.status], "sequence": h.sequence}))
            return 0
        chain = client.find_chain(a.chain)
        if a.cmd == "move":
            h, elements = client.call("move", chain, [tuple(a.xyz)], joint=a.joint,
                                      flags=FLAG_PULL if a.pull else 0)
        elif a.cmd == "path":
            pts = [tuple(float(x) for x in s.split(",")) for s in a.points]
            h, elements = client.call("path", chain, pts, joint=a.joint,
                                      flags=FLAG_SMOOTH if a.smooth else 0)
        elif a.cmd == "reach":
            if a.direction:
                h, elements = client.call("reach", chain, [tuple(a.xyz), tuple(a.direction)],
                                          flags=FLAG_ORIENT)
            elif a.within is not None:
                h, elements = client.call("reach", chain, [tuple(a.xyz), (a.within, 0.0, 0.0)],
                                          flags=FLAG_IN_BALL)
            elif a.box:
                h, elements = client.call("reach", chain, [tuple(a.xyz), tuple(a.box)],
                                          flags=FLAG_IN_BOX)
            else:
                h, elements = client.call("reach", chain, [tuple(a.xyz)])
        elif a.cmd in ("grasp", "release"):
            h, elements = client.call(a.cmd, chain, joint=a.joint)
        elif a.cmd == "bench":
            return _bench(client, chain, a.n)
        elif a.cmd == "instrument":
            points = [tuple(a.xyz)] + ([tuple(a.axis)] if a.axis else [])
            h, elements = client.call("instrument", chain, points, joint=a.index,
                                      flags=FLAG_PULL if a.pull else 0)
        else:
            h, elements = client.call(a.cmd, chain)
    except (RuntimeError, ServiceError, KeyError, TimeoutError, ValueError) as e:
        print(f"tractrix-client: {e}", file=sys.stderr)
        return 1
    # The description fields (n_links, name, ...) come with `describe` only; a chain of n links answers
    # n + 1 joints.
    joints = elements[:h.n_joints]
    held_from = h.n_joints + h.n_angles
    held = [{"joint": int(x), "anchor": y != 0.0}
            for x, y, _ in elements[held_from:held_from + h.n_held]]
    out = {"status": STATUS[h.status], "sequence": h.sequence, "n_links": h.n_joints - 1,
           "joints": joints, "held": held}
    if h.n_instruments:
        out["instruments"] = instruments(h, elements)
    if h.n_pulls:
        out["pulls"] = pulls(h, elements)
    if knot(h):
        out["knot"] = knot(h)
    if h.n_eyelets:
        out["eyelets"] = eyelets(h, elements)
    if a.cmd == "describe":
        out["name"] = _text(h.name)
        out["total_length"] = h.total_length
        if h.limits:
            out["limits"] = limits(h)
        if h.n_tissue:
            out["tissue"] = tissue(h, elements)
    if a.cmd == "reach":
        out["residual"] = h.residual
    print(json.dumps(out))
    return 0


def main_exit() -> None:
    """The `tractrix-client` console script."""
    sys.exit(main())


if __name__ == "__main__":
    sys.exit(main())
