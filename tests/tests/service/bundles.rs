//! Bundles through the serving loop: a scene of a rope and 3001 strands of 20 links (enough for the
//! second core), every head to its own target, the whole bundle by one rigid motion, the bundle stream,
//! refusals that change nothing, reset; the rope beside it keeps its own sequence. Distances, rotations
//! and the expected heads are computed here.

use clients::Connection;
use shared::{ChainKind, Command, FLAG_POSE, RequestHeader, Status, SubstepMode, Vec3, WireMethod};
use std::time::{Duration, Instant};
use tests::InProcess;
use world::scene::parse_scene;

const STRANDS: usize = 3001;
const LINKS: usize = 20;
const LEN: f64 = 0.05;
const COLUMNS: usize = 60;
const SPACING: f64 = 0.1;

const SCENE: &str = "
[[chain]]
name = \"rope\"
links = 40
link_length = 1.0

[[bundle]]
name = \"hair\"
strands = 3001
links = 20
link_length = 0.05
columns = 60
spacing = 0.1
origin = [0.0, 0.0, 5.0]
";

/// Strand `i`'s head in the scene, from the table above.
fn head0(i: usize) -> [f64; 3] {
    [
        (i % COLUMNS) as f64 * SPACING,
        (i / COLUMNS) as f64 * SPACING,
        5.0,
    ]
}

fn dist(a: Vec3, b: [f64; 3]) -> f64 {
    ((a.x - b[0]).powi(2) + (a.y - b[1]).powi(2) + (a.z - b[2]).powi(2)).sqrt()
}

fn query<S: iceoryx2::service::Service>(c: &mut Connection<S>, handle: u32) -> Vec<Vec3> {
    let r = c
        .call(RequestHeader::new(Command::Query, handle), &[])
        .unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    r.joints().to_vec()
}

/// Every link of every strand has its length (to `tol`, relative), and strand `i`'s head is `want(i)`
/// to `head_tol`.
fn check(joints: &[Vec3], want: impl Fn(usize) -> [f64; 3], head_tol: f64, tol: f64) {
    assert_eq!(joints.len(), STRANDS * (LINKS + 1));
    for (i, s) in joints.chunks(LINKS + 1).enumerate() {
        let d = dist(s[LINKS], want(i));
        assert!(d <= head_tol, "strand {i}: head {d:e} from its target");
        for (j, w) in s.windows(2).enumerate() {
            let l = dist(w[1], [w[0].x, w[0].y, w[0].z]);
            assert!(
                (l - LEN).abs() <= tol * LEN,
                "strand {i} link {j}: length {l} (want {LEN})"
            );
        }
    }
}

#[test]
fn a_bundle_moves_its_heads_by_target_and_by_pose_and_refusals_change_nothing() {
    let scene = parse_scene(SCENE, "bundle.toml").unwrap();
    let service = InProcess::start_scene(scene);
    let mut c = service.connect();
    let stream = c.subscribe_bundles().unwrap();

    // Describe: the handle after the rope.
    let d = c
        .call(RequestHeader::new(Command::Describe, 1), &[])
        .unwrap();
    assert!(d.is_ok(), "{}", d.header.reason_str());
    assert_eq!(d.header.kind, ChainKind::Bundle as u32);
    assert_eq!(d.header.n_chains, 2);
    assert_eq!(d.header.n_links as usize, LINKS);
    assert_eq!(d.header.n_joints as usize, STRANDS * (LINKS + 1));
    assert_eq!(d.header.name_str(), "hair");
    assert_eq!(c.find_chain("hair").unwrap(), Some(1));
    // The scene: straight strands hanging down (-z) from the grid.
    let scene_joints = d.joints().to_vec();
    check(&scene_joints, head0, 0.0, 1e-12);
    for (i, s) in scene_joints.chunks(LINKS + 1).enumerate() {
        let tail = head0(i);
        assert!(dist(s[0], [tail[0], tail[1], tail[2] - LINKS as f64 * LEN]) < 1e-12);
    }

    // Every head to its own target (a wave), two substeps.
    let target = |i: usize| {
        let h = head0(i);
        let a = 0.37 * i as f64;
        [h[0] + 0.3 * a.cos(), h[1] + 0.2, h[2] + 0.3 * a.sin()]
    };
    let targets: Vec<Vec3> = (0..STRANDS)
        .map(|i| {
            let t = target(i);
            Vec3::new(t[0], t[1], t[2])
        })
        .collect();
    let mut mv = RequestHeader::new(Command::Move, 1);
    mv.substep_mode = SubstepMode::Fixed as u32;
    mv.substeps = 2;
    let r = c.call(mv, &targets).unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    assert_eq!((r.header.sequence, r.header.substeps), (1, 2));
    check(r.joints(), target, 0.0, 1e-12);
    // Every non-head joint moved by at most the head's displacement (a tractrix lags its leader).
    for (i, (a, b)) in r
        .joints()
        .chunks(LINKS + 1)
        .zip(scene_joints.chunks(LINKS + 1))
        .enumerate()
    {
        let lead = dist(a[LINKS], [b[LINKS].x, b[LINKS].y, b[LINKS].z]);
        for j in 0..LINKS {
            assert!(
                dist(a[j], [b[j].x, b[j].y, b[j].z]) <= lead + 1e-12,
                "strand {i} joint {j}"
            );
        }
    }
    let after_heads = r.joints().to_vec();
    assert_eq!(query(&mut c, 1), after_heads);

    // The bundle stream has the change, whole.
    let deadline = Instant::now() + Duration::from_secs(10);
    let sample = loop {
        if let Some(s) = stream.try_next(|h, p| (*h, p.to_vec())).unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "no bundle sample");
        std::thread::sleep(Duration::from_millis(1));
    };
    assert_eq!((sample.0.sequence, sample.0.chain), (1, 1));
    assert_eq!(sample.0.n_joints as usize, STRANDS * (LINKS + 1));
    assert_eq!(sample.1, after_heads);

    // Refusals change nothing.
    let refused = |c: &mut Connection<_>, h: RequestHeader, p: &[Vec3], want: Status| {
        let r = c.call(h, p).unwrap();
        assert_eq!(r.header.status(), Some(want), "{}", r.header.reason_str());
        assert!(r.joints().is_empty());
    };
    refused(
        &mut c,
        RequestHeader::new(Command::Move, 1),
        &targets[1..],
        Status::BadPointCount,
    );
    let mut nan = targets.clone();
    nan[2999].y = f64::NAN;
    refused(
        &mut c,
        RequestHeader::new(Command::Move, 1),
        &nan,
        Status::NonFinite,
    );
    let mut far = targets.clone();
    far[7].x = 1e12;
    refused(
        &mut c,
        RequestHeader::new(Command::Move, 1),
        &far,
        Status::TooFar,
    );
    refused(
        &mut c,
        RequestHeader::new(Command::Grasp, 1),
        &[],
        Status::WrongChainKind,
    );
    refused(
        &mut c,
        RequestHeader::new(Command::Path, 1),
        &targets[..1],
        Status::WrongChainKind,
    );
    let mut ftl = RequestHeader::new(Command::Move, 1);
    ftl.method = WireMethod::FollowTheLeader as u32;
    refused(&mut c, ftl, &targets, Status::BadOption);
    let mut max_step = RequestHeader::new(Command::Move, 1);
    max_step.substep_mode = SubstepMode::MaxStep as u32;
    max_step.max_step = 0.5;
    refused(&mut c, max_step, &targets, Status::BadOption);
    let mut tail = RequestHeader::new(Command::Move, 1);
    tail.joint = 0;
    refused(&mut c, tail, &targets, Status::JointOutOfRange);
    // 376 blocks × 20 links × 16 substeps is over the default frame of 16,000 block-steps.
    let mut heavy = RequestHeader::new(Command::Move, 1);
    heavy.substep_mode = SubstepMode::Fixed as u32;
    heavy.substeps = 16;
    refused(&mut c, heavy, &targets, Status::OverBudget);
    let mut pose_query = RequestHeader::new(Command::Query, 1);
    pose_query.flags = FLAG_POSE;
    refused(&mut c, pose_query, &[], Status::BadOption);
    assert_eq!(query(&mut c, 1), after_heads);

    // One rigid motion of the heads: a quarter turn about z (the axis through the origin), then a
    // translation. The heads land on R·h0 + t, computed here.
    let (angle, t) = (0.25f64, [0.5, -0.25, 0.125]);
    let mut pose = RequestHeader::new(Command::Move, 1);
    pose.flags = FLAG_POSE;
    let r = c
        .call(
            pose,
            &[Vec3::new(t[0], t[1], t[2]), Vec3::new(0.0, 0.0, angle)],
        )
        .unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    assert_eq!(r.header.sequence, 2);
    let posed = |i: usize| {
        let h = head0(i);
        let (s, c) = angle.sin_cos();
        [
            c * h[0] - s * h[1] + t[0],
            s * h[0] + c * h[1] + t[1],
            h[2] + t[2],
        ]
    };
    check(r.joints(), posed, 1e-12, 1e-12);

    // The rope beside the bundle keeps its own sequence (bundles are not persisted).
    let rope = c
        .call(
            RequestHeader::new(Command::Move, 0),
            &[Vec3::new(41.0, 0.0, 0.0)],
        )
        .unwrap();
    assert!(rope.is_ok(), "{}", rope.header.reason_str());
    assert_eq!(rope.header.sequence, 1);

    // Reset: the scene's strands, bit for bit.
    let r = c.call(RequestHeader::new(Command::Reset, 1), &[]).unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    assert_eq!(r.header.sequence, 3);
    assert_eq!(r.joints(), &scene_joints[..]);
    // Handles past the bundles are unknown.
    refused(
        &mut c,
        RequestHeader::new(Command::Query, 2),
        &[],
        Status::UnknownChain,
    );
}
