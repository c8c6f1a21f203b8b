//! Instruments through the service (issue 16): a scene's instrument moved by pose pushes the rope
//! (never deeper than the collision tolerance, checked by a distance computed here), a push the rope
//! cannot give way to is `locked` and changes nothing, bad poses are refused with a reason, and an
//! instrument's pose survives `kill -9` (journal and snapshot): a restored service pushes on from where
//! the instrument was, bit for bit as a service that never stopped.

use shared::{Command, RequestHeader, Status, Vec3};
use tests::{Service, unique_prefix};

const SCENE: &str = r#"
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
fn an_instrument_pushes_the_rope_locks_when_it_must_and_survives_kill_9() {
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

    // Both ends held: driving the rod far on would stretch the rope around it. Locked, unchanged.
    for j in [0, shared::JOINT_HEAD] {
        let mut h = RequestHeader::new(Command::Grasp, 0);
        h.joint = j;
        assert!(c.call(h, &[]).unwrap().is_ok());
    }
    let held = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    let (h, p) = driver_at(40.0);
    let r = c.call(h, &p).unwrap();
    assert_eq!(
        Status::from_u32(r.header.status),
        Some(Status::Locked),
        "{}",
        r.header.reason_str()
    );
    let q3 = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(q3.header.sequence, held.header.sequence);
    assert_eq!(bits(q3.joints()), bits(held.joints()));
    // And the driver is still where it was: let go, step it on, and compare with the reference.
    for j in [0, shared::JOINT_HEAD] {
        let mut h = RequestHeader::new(Command::Release, 0);
        h.joint = j;
        assert!(c.call(h, &[]).unwrap().is_ok());
    }
    let (h, p) = driver_at(5.5);
    let mine = c.call(h, &p).unwrap();
    let theirs = rc.call(h, &p).unwrap();
    assert!(mine.is_ok() && theirs.is_ok());
    assert_eq!(bits(mine.joints()), bits(theirs.joints()));
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
