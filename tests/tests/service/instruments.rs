//! Instruments through the service (issue 16): a scene's instrument moved by pose pushes the rope
//! (never deeper than the collision tolerance, checked by a distance computed here), a push the rope
//! cannot give way to is `locked` and changes nothing, bad poses are refused with a reason, and an
//! instrument's pose survives `kill -9` (journal and snapshot): a restored service pushes on from where
//! the instrument was, bit for bit as a service that never stopped.

use shared::{Command, RequestHeader, Status, Vec3};
use tests::{Service, unique_prefix};

/// A 40-unit suture pushed by a capsule (a needle driver) and a sphere (also the viewer test's scene).
pub(crate) const SCENE: &str = r#"
[[instrument]]
name = "driver"
shape = "capsule"
a = [20.3, -3.0, -20.0]
b = [20.3, -3.0, 20.0]
radius = 0.3

[[instrument]]
name = "ball"
shape = "sphere"
center = [5.0, 6.0, 0.0]
radius = 0.5

[[chain]]
name = "suture"
links = 40
link_length = 1.0
thickness = 0.2
collision = "capsules"
instruments = ["driver", "ball"]
"#;
const CLEARANCE: f64 = 0.3 + 0.1;
const TOLERANCE: f64 = 0.01;

fn instrument(index: u32, points: &[Vec3]) -> (RequestHeader, Vec<Vec3>) {
    let mut h = RequestHeader::new(Command::Instrument, 0);
    h.joint = index;
    (h, points.to_vec())
}

fn driver_at(y: f64) -> (RequestHeader, Vec<Vec3>) {
    instrument(0, &[Vec3::new(20.3, y, 0.0), Vec3::new(0.0, 0.0, 1.0)])
}

/// Distance from `p` to the segment `a`–`b` (written here, not the kernel's).
fn point_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = |u: [f64; 3], v: [f64; 3]| [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
    let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let (ab, ap) = (d(b, a), d(p, a));
    let t = (dot(ap, ab) / dot(ab, ab)).clamp(0.0, 1.0);
    let q = [a[0] + ab[0] * t, a[1] + ab[1] * t, a[2] + ab[2] * t];
    dot(d(p, q), d(p, q)).sqrt()
}

/// Smallest distance from the rope's axis to the driver's axis at height `y`, sampled along the links.
fn gap_to_driver(joints: &[Vec3], y: f64) -> f64 {
    let (a, b) = ([20.3, y, -20.0], [20.3, y, 20.0]);
    joints
        .windows(2)
        .flat_map(|w| {
            (0..=100).map(move |i| {
                let t = i as f64 / 100.0;
                [
                    w[0].x + (w[1].x - w[0].x) * t,
                    w[0].y + (w[1].y - w[0].y) * t,
                    w[0].z + (w[1].z - w[0].z) * t,
                ]
            })
        })
        .map(|p| point_segment(p, a, b))
        .fold(f64::INFINITY, f64::min)
}

fn bits(joints: &[Vec3]) -> Vec<[u64; 3]> {
    joints
        .iter()
        .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
        .collect()
}

#[test]
fn an_instrument_pushes_the_rope_stops_short_when_it_must_and_survives_kill_9() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("suture.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let state = dir.path().join("state");
    let args = [
        "--scene",
        scene.to_str().unwrap(),
        "--state-dir",
        state.to_str().unwrap(),
    ];
    let svc = Service::start(&unique_prefix(), &args);
    let mut c = svc.connect();

    // The driver sweeps across the rope in steps of half a unit: the rope is carried along.
    let mut last = None;
    for k in 1..=12 {
        let y = -3.0 + 0.5 * f64::from(k);
        let (h, p) = driver_at(y);
        let r = c.call(h, &p).unwrap();
        assert!(r.is_ok(), "step {k}: {}", r.header.reason_str());
        let gap = gap_to_driver(r.joints(), y);
        assert!(
            gap >= CLEARANCE * (1.0 - TOLERANCE),
            "step {k}: the rope is {gap} from the driver's axis"
        );
        last = Some(r.header.sequence);
    }
    let q = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(Some(q.header.sequence), last);
    // Hooked: where the rope crosses the driver's plane x = 20.3 it lies beyond it (y > 3).
    let crossing: Vec<f64> = q
        .joints()
        .windows(2)
        .filter(|w| (w[0].x - 20.3) * (w[1].x - 20.3) <= 0.0 && w[0].x != w[1].x)
        .map(|w| w[0].y + (w[1].y - w[0].y) * (20.3 - w[0].x) / (w[1].x - w[0].x))
        .collect();
    assert!(
        !crossing.is_empty() && crossing.iter().all(|&y| y >= 3.0 + CLEARANCE * 0.99),
        "{crossing:?}"
    );

    // Bad poses: refused with a reason, nothing changes.
    let before = bits(q.joints());
    let bad: Vec<((RequestHeader, Vec<Vec3>), Status)> = vec![
        (
            instrument(0, &[Vec3::new(20.3, 3.0, 0.0)]),
            Status::BadPointCount,
        ),
        (
            instrument(1, &[Vec3::new(5.0, 6.0, 0.0), Vec3::new(0.0, 0.0, 1.0)]),
            Status::BadPointCount,
        ),
        (
            instrument(2, &[Vec3::new(5.0, 6.0, 0.0)]),
            Status::BadOption,
        ),
        (
            instrument(0, &[Vec3::new(20.3, 3.0, 0.0), Vec3::new(0.0, 0.0, 0.0)]),
            Status::BadOption,
        ),
        (
            instrument(1, &[Vec3::new(f64::NAN, 6.0, 0.0)]),
            Status::NonFinite,
        ),
        (
            instrument(1, &[Vec3::new(5.0e6, 6.0, 0.0)]),
            Status::TooManySubsteps,
        ),
    ];
    for ((h, p), want) in bad {
        let r = c.call(h, &p).unwrap();
        assert_eq!(
            Status::from_u32(r.header.status),
            Some(want),
            "{}",
            r.header.reason_str()
        );
        assert!(!r.header.reason_str().is_empty());
    }
    let q2 = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(q2.header.sequence, q.header.sequence);
    assert_eq!(bits(q2.joints()), before);

    // A snapshot holds the instruments' poses; then the ball moves (journal only), then kill -9.
    let s = c
        .call(RequestHeader::new(Command::Snapshot, 0), &[])
        .unwrap();
    assert!(s.is_ok(), "{}", s.header.reason_str());
    let (h, p) = instrument(1, &[Vec3::new(5.0, 5.5, 0.0)]);
    assert!(c.call(h, &p).unwrap().is_ok());
    let before_kill = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    drop(c);
    svc.kill9();
    let svc = Service::start(&unique_prefix(), &[&args[..], &["--restore"]].concat());
    let mut c = svc.connect();
    let after = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(after.header.sequence, before_kill.header.sequence);
    assert_eq!(bits(after.joints()), bits(before_kill.joints()));
    // The driver sweeps on from where it was (y = 3): the same rope as a service that never stopped.
    let on = |c: &mut clients::Connection| {
        let mut out = Vec::new();
        for k in 1..=4 {
            let (h, p) = driver_at(3.0 + 0.5 * f64::from(k));
            let r = c.call(h, &p).unwrap();
            assert!(r.is_ok(), "{}", r.header.reason_str());
            out = bits(r.joints());
        }
        let (h, p) = instrument(1, &[Vec3::new(5.0, 4.0, 0.0)]);
        let r = c.call(h, &p).unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        out.extend(bits(r.joints()));
        out
    };
    let restored = on(&mut c);
    let reference = Service::start(
        &unique_prefix(),
        &["--scene", scene.to_str().unwrap(), "--no-persist"],
    );
    let mut rc = reference.connect();
    for k in 1..=12 {
        let (h, p) = driver_at(-3.0 + 0.5 * f64::from(k));
        assert!(rc.call(h, &p).unwrap().is_ok());
    }
    let (h, p) = instrument(1, &[Vec3::new(5.0, 5.5, 0.0)]);
    assert!(rc.call(h, &p).unwrap().is_ok());
    assert_eq!(
        on(&mut rc),
        restored,
        "the restored instruments are not where they were"
    );

    // Both ends held: driving the rod far on would stretch the rope around it. It stops short
    // inside its frame (jammed): the held ends where they were, the rod where the rope stopped it,
    // on its way and clear of the rope.
    for j in [0, shared::JOINT_HEAD] {
        let mut h = RequestHeader::new(Command::Grasp, 0);
        h.joint = j;
        assert!(c.call(h, &[]).unwrap().is_ok());
    }
    let held = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    let (h, p) = driver_at(40.0);
    let r = c.call(h, &p).unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    assert_eq!(
        r.header.pull_stop(),
        Some(shared::PullStop::Jammed),
        "{}",
        r.header.reason_str()
    );
    let (was, now) = (held.joints(), r.joints());
    for k in [0, now.len() - 1] {
        assert_eq!(bits(&now[k..=k]), bits(&was[k..=k]), "held joint {k} moved");
    }
    let parts = shared::Parts::of_response(&r.header, &r.payload);
    let rod = parts.instruments[0];
    assert!(rod.y > 5.0 && rod.y < 40.0, "the rod at {rod:?}");
    let gap = gap_to_driver(now, rod.y);
    assert!(
        gap >= CLEARANCE * (1.0 - TOLERANCE),
        "the rope is {gap} from the jammed driver's axis"
    );
    // Let go, the driver stepped back: the rope follows it as before.
    for j in [0, shared::JOINT_HEAD] {
        let mut h = RequestHeader::new(Command::Release, 0);
        h.joint = j;
        assert!(c.call(h, &[]).unwrap().is_ok());
    }
    let (h, p) = driver_at(5.5);
    let mine = c.call(h, &p).unwrap();
    assert!(mine.is_ok(), "{}", mine.header.reason_str());
    drop(rc);
    drop(reference);
}

/// A needle driver that rides with the hand: an instrument that `follows = "head"` is carried with
/// every move of the head, and the strand the hand crosses is pushed out of the jaws' way (its distance
/// from the head, computed here, never below the jaws' clearance), while the links the jaws hold near
/// the head do not count.
#[test]
fn an_instrument_that_follows_the_hand_pushes_the_strand_it_crosses() {
    let scene = r#"
[[instrument]]
name = "jaws"
shape = "sphere"
center = [30.0, 0.0, 0.0]
radius = 0.5
follows = "head"

[[chain]]
name = "suture"
links = 30
link_length = 1.0
thickness = 0.2
collision = "capsules"
instruments = ["jaws"]
"#;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("s.toml");
    std::fs::write(&file, scene).unwrap();
    let svc = Service::start(
        &unique_prefix(),
        &["--scene", file.to_str().unwrap(), "--no-persist"],
    );
    let mut c = svc.connect();
    let mut grasp = RequestHeader::new(Command::Grasp, 0);
    grasp.joint = shared::JOINT_HEAD;
    assert!(c.call(grasp, &[]).unwrap().is_ok());
    // The hand loops back and crosses its own strand near x = 15, in steps of 0.1.
    let corners = [
        Vec3::new(30.0, 3.0, 0.0),
        Vec3::new(15.0, 3.0, 0.0),
        Vec3::new(15.0, -3.0, 0.0),
    ];
    let mut from = Vec3::new(30.0, 0.0, 0.0);
    let mut crossed = 0;
    for to in corners {
        let d = ((to.x - from.x).powi(2) + (to.y - from.y).powi(2)).sqrt();
        let k = (d / 0.1).ceil() as usize;
        for i in 1..=k {
            let t = i as f64 / k as f64;
            let target = Vec3::new(
                from.x + (to.x - from.x) * t,
                from.y + (to.y - from.y) * t,
                0.0,
            );
            let mut h = RequestHeader::new(Command::Move, 0);
            h.joint = shared::JOINT_HEAD;
            let r = c.call(h, &[target]).unwrap();
            assert!(r.is_ok(), "{}", r.header.reason_str());
            let p = r.joints();
            let head = [p[30].x, p[30].y, p[30].z];
            // On target to rounding (the moved joint's position is a sum of the links).
            let off = ((head[0] - target.x).powi(2) + (head[1] - target.y).powi(2)).sqrt();
            assert!(off < 1e-12, "the head is {off} off its target");
            // Links far along the rope from the head (the jaws hold the last few).
            let gap = p[..24]
                .windows(2)
                .map(|w| point_segment(head, [w[0].x, w[0].y, w[0].z], [w[1].x, w[1].y, w[1].z]))
                .fold(f64::INFINITY, f64::min);
            assert!(
                gap >= 0.6 * (1.0 - TOLERANCE),
                "the jaws entered the strand: {gap}"
            );
            if (target.x - 15.0).abs() < 1e-9 && target.y.abs() < 1.0 {
                crossed += 1;
            }
        }
        from = to;
    }
    assert!(crossed > 0, "the hand crossed the strand's line");
}

/// The instruments' poses as the test reads them from a payload, by its own count of the layout
/// (`n_joints`, then `n_angles`, then `n_held`, then three elements per instrument: `a`, `b`,
/// `(radius, 1 capsule / 0 sphere, 0)`, then one pull per held joint and per instrument).
fn poses_in(payload: &[Vec3], n_joints: u32, n_angles: u32, n_held: u32, n: u32) -> Vec<[f64; 8]> {
    let from = (n_joints + n_angles + n_held) as usize;
    assert_eq!(
        payload.len(),
        from + 3 * n as usize + (n_held + n) as usize,
        "payload length"
    );
    payload[from..from + 3 * n as usize]
        .chunks(3)
        .map(|e| {
            [
                e[0].x, e[0].y, e[0].z, e[1].x, e[1].y, e[1].z, e[2].x, e[2].y,
            ]
        })
        .collect()
}

/// A capsule of half-length `half` centred at `c` along `dir`, and a sphere at `c`, as the test
/// expects them on the wire.
fn capsule(c: [f64; 3], dir: [f64; 3], half: f64, r: f64) -> [f64; 8] {
    let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let d = [dir[0] / n * half, dir[1] / n * half, dir[2] / n * half];
    [
        c[0] - d[0],
        c[1] - d[1],
        c[2] - d[2],
        c[0] + d[0],
        c[1] + d[1],
        c[2] + d[2],
        r,
        1.0,
    ]
}
fn sphere(c: [f64; 3], r: f64) -> [f64; 8] {
    [c[0], c[1], c[2], c[0], c[1], c[2], r, 0.0]
}

fn assert_poses_near(got: &[[f64; 8]], want: &[[f64; 8]], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (g, w) in got.iter().zip(want) {
        for (x, y) in g.iter().zip(w) {
            assert!((x - y).abs() < 1e-9, "{what}: {g:?} against {w:?}");
        }
    }
}

/// Protocol v2: every response that carries the chain's joints carries its instruments' poses too
/// (describe, query, moves, instrument commands), and so does every state sample; a refused push
/// leaves them where they were, `reset` puts them back. Expected poses are computed here from the
/// scene and the requests.
#[test]
fn instrument_poses_are_in_describe_query_and_every_state() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("suture.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let svc = Service::start(
        &unique_prefix(),
        &["--scene", scene.to_str().unwrap(), "--no-persist"],
    );
    let mut c = svc.connect();
    let stream = c.subscribe().unwrap();
    let poses = |r: &clients::Reply| {
        let h = &r.header;
        poses_in(
            &r.payload,
            h.n_joints,
            h.n_angles,
            h.n_held,
            h.n_instruments,
        )
    };
    let scene_poses = vec![
        capsule([20.3, -3.0, 0.0], [0.0, 0.0, 1.0], 20.0, 0.3),
        sphere([5.0, 6.0, 0.0], 0.5),
    ];
    let d = c
        .call(RequestHeader::new(Command::Describe, 0), &[])
        .unwrap();
    assert_eq!(d.header.n_instruments, 2);
    assert_poses_near(&poses(&d), &scene_poses, "describe");

    // The driver moved and turned, the ball moved, the head moved: each response and each state
    // sample carries the poses so far.
    let mut want = scene_poses.clone();
    let mut expected_states = Vec::new();
    let steps: Vec<(RequestHeader, Vec<Vec3>, usize, [f64; 8])> = vec![
        {
            let (h, p) = instrument(0, &[Vec3::new(20.3, -2.5, 1.0), Vec3::new(0.0, 1.0, 4.0)]);
            (
                h,
                p,
                0,
                capsule([20.3, -2.5, 1.0], [0.0, 1.0, 4.0], 20.0, 0.3),
            )
        },
        {
            let (h, p) = instrument(1, &[Vec3::new(4.0, 7.0, 0.5)]);
            (h, p, 1, sphere([4.0, 7.0, 0.5], 0.5))
        },
    ];
    for (h, p, k, pose) in steps {
        let r = c.call(h, &p).unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        want[k] = pose;
        assert_poses_near(&poses(&r), &want, "instrument response");
        expected_states.push((r.header.sequence, want.clone()));
    }
    let mut mv = RequestHeader::new(Command::Move, 0);
    mv.joint = shared::JOINT_HEAD;
    let r = c.call(mv, &[Vec3::new(38.0, -8.0, 0.0)]).unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    assert_poses_near(&poses(&r), &want, "move response");
    expected_states.push((r.header.sequence, want.clone()));
    let mut q = RequestHeader::new(Command::Query, 0);
    q.flags = shared::FLAG_ANGLES;
    let r = c.call(q, &[]).unwrap();
    assert_eq!(r.header.n_angles, 40);
    assert_poses_near(&poses(&r), &want, "query with rotations");

    // A refused pose changes nothing; reset puts the scene's poses back.
    let (h, p) = instrument(1, &[Vec3::new(f64::NAN, 0.0, 0.0)]);
    let bad = c.call(h, &p).unwrap();
    assert_eq!(bad.header.n_instruments, 0, "an error carries no elements");
    let r = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_poses_near(&poses(&r), &want, "after a refusal");
    let r = c.call(RequestHeader::new(Command::Reset, 0), &[]).unwrap();
    assert_poses_near(&poses(&r), &scene_poses, "reset");
    expected_states.push((r.header.sequence, scene_poses.clone()));

    // The state stream: the same poses at the same sequence numbers.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    let mut seen = std::collections::HashMap::new();
    let last = expected_states.last().unwrap().0;
    while std::time::Instant::now() < deadline && !seen.contains_key(&last) {
        match stream
            .try_next(|h, p| {
                (
                    h.sequence,
                    poses_in(p, h.n_joints, 0, h.n_held, h.n_instruments),
                )
            })
            .unwrap()
        {
            Some((s, ps)) => {
                seen.insert(s, ps);
            }
            None => std::thread::sleep(std::time::Duration::from_millis(1)),
        }
    }
    for (seq, want) in &expected_states {
        let got = seen
            .get(seq)
            .unwrap_or_else(|| panic!("no state {seq} on the stream"));
        assert_poses_near(got, want, &format!("state {seq}"));
    }
}
