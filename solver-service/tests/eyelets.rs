//! Eyelets on the wire, through the service's answer path: a response about a chain whose scene has
//! eyelets carries them after the pulls (`n_eyelets`, two elements each), and each threaded eyelet's
//! point lies on the link the payload names, as the test computes from the payload's joints.

use shared::{Command, Parts, RequestHeader, Status, Vec3};
use solver_service::serve::respond;
use solver_service::service::Solver;
use std::time::Duration;
use world::World;
use world::owners::LOCAL;
use world::scene::parse_scene;

const SCENE: &str = r#"
[[chain]]
name = "suture"
links = 40
link_length = 1.0
eyelets = [[10.5, 0.0, 0.0], [25.5, 0.0, 0.0]]

[[chain]]
name = "plain"
links = 4
link_length = 1.0
"#;

fn to_segment(a: Vec3, b: Vec3, p: Vec3) -> f64 {
    let (a, b, p) = (a.to_array(), b.to_array(), p.to_array());
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let t = (dot(ap, ab) / dot(ab, ab)).clamp(0.0, 1.0);
    let d = [ap[0] - ab[0] * t, ap[1] - ab[1] * t, ap[2] - ab[2] * t];
    dot(d, d).sqrt()
}

#[test]
fn a_response_carries_the_eyelets_on_their_links() {
    let world = World::new(&parse_scene(SCENE, "suture.toml").unwrap()).unwrap();
    let mut solver = Solver::new(world, None, Duration::from_secs(3600));
    let mut out = Vec::new();
    let mut m = RequestHeader::new(Command::Move, 0);
    m.joint = 40;
    for (k, target) in [[41.0, 5.0, 2.0], [43.0, 3.0, -2.0], [42.0, -4.0, 0.0]]
        .into_iter()
        .enumerate()
    {
        let (h, _) = respond(
            &mut solver,
            LOCAL,
            &m,
            &[Vec3::new(target[0], target[1], target[2])],
            &mut out,
        );
        assert_eq!(h.status, Status::Ok as u32, "{}", h.reason_str());
        assert_eq!(h.n_eyelets, 2);
        assert_eq!(out.len() as u32, h.n_joints + 2 * h.n_eyelets, "move {k}");
        let parts = Parts::of_response(&h, &out);
        let eyelets: Vec<_> = parts.eyelet_states().collect();
        assert_eq!(eyelets.len(), 2);
        for (i, e) in eyelets.iter().enumerate() {
            assert!(e.threaded, "move {k}: eyelet {i}");
            let l = e.link as usize;
            let d = to_segment(parts.joints[l], parts.joints[l + 1], e.at);
            assert!(d < 1e-9, "move {k}: eyelet {i} {d:e} off link {l}");
        }
        assert_eq!(eyelets[0].at, Vec3::new(10.5, 0.0, 0.0));
    }
    // A chain without eyelets answers none.
    let (h, _) = respond(
        &mut solver,
        LOCAL,
        &RequestHeader::new(Command::Query, 1),
        &[],
        &mut out,
    );
    assert_eq!((h.n_eyelets, out.len()), (0, 5));
}

#[test]
fn the_eyelet_command_moves_an_eyelet_and_the_rope_with_it() {
    let world = World::new(&parse_scene(SCENE, "suture.toml").unwrap()).unwrap();
    let mut solver = Solver::new(world, None, Duration::from_secs(3600));
    let mut out = Vec::new();
    // Eyelet 0 (at 10.5 on the straight rope, on link 10) moved sideways by 2: the link through it is
    // carried, so joints 10 and 11 move by exactly that.
    let mut h = RequestHeader::new(Command::Eyelet, 0);
    h.joint = 0;
    let (r, _) = respond(
        &mut solver,
        LOCAL,
        &h,
        &[Vec3::new(10.5, 2.0, 0.0)],
        &mut out,
    );
    assert_eq!(r.status, Status::Ok as u32, "{}", r.reason_str());
    let parts = Parts::of_response(&r, &out);
    assert_eq!(parts.joints[10], Vec3::new(10.0, 2.0, 0.0));
    assert_eq!(parts.joints[11], Vec3::new(11.0, 2.0, 0.0));
    let e: Vec<_> = parts.eyelet_states().collect();
    assert_eq!(e[0].at, Vec3::new(10.5, 2.0, 0.0));
    for (i, e) in e.iter().enumerate() {
        let l = e.link as usize;
        let d = to_segment(parts.joints[l], parts.joints[l + 1], e.at);
        assert!(d < 1e-9, "eyelet {i} {d:e} off link {l}");
    }
    // An eyelet that does not exist, and a chain without eyelets: refused, nothing changed.
    let before = out.clone();
    h.joint = 2;
    let (r, _) = respond(
        &mut solver,
        LOCAL,
        &h,
        &[Vec3::new(1.0, 1.0, 0.0)],
        &mut out,
    );
    assert_ne!(r.status, Status::Ok as u32);
    assert!(r.reason_str().contains("eyelets"), "{}", r.reason_str());
    let (q, _) = respond(
        &mut solver,
        LOCAL,
        &RequestHeader::new(Command::Query, 0),
        &[],
        &mut out,
    );
    assert_eq!(q.status, Status::Ok as u32);
    assert_eq!(out, before);
    let mut h = RequestHeader::new(Command::Eyelet, 1);
    h.joint = 0;
    let (r, _) = respond(
        &mut solver,
        LOCAL,
        &h,
        &[Vec3::new(1.0, 1.0, 0.0)],
        &mut out,
    );
    assert_ne!(r.status, Status::Ok as u32);
}

/// A describe of a chain with tissue carries the block's corners after the eyelets (`n_tissue` 1, two
/// elements), exactly as the scene gives them; other commands on it, and a describe of a chain
/// without tissue, carry none.
#[test]
fn a_describe_carries_the_chain_s_tissue() {
    let text = r#"
[[chain]]
name = "stitched"
links = 20
link_length = 0.5
base = [0.0, 0.0, 2.0]
tissue = [[12.0, -4.0, -3.0], [20.0, 4.0, 0.0]]
"#;
    let scene = format!("{text}{SCENE}");
    let world = World::new(&parse_scene(&scene, "tissue.toml").unwrap()).unwrap();
    let mut solver = Solver::new(world, None, Duration::from_secs(3600));
    let mut out = Vec::new();
    let (h, _) = respond(
        &mut solver,
        LOCAL,
        &RequestHeader::new(Command::Describe, 0),
        &[],
        &mut out,
    );
    assert_eq!(h.status, Status::Ok as u32, "{}", h.reason_str());
    assert_eq!((h.n_eyelets, h.n_tissue), (0, 1));
    assert_eq!(out.len() as u32, h.n_joints + 2);
    assert_eq!(
        &out[out.len() - 2..],
        &[Vec3::new(12.0, -4.0, -3.0), Vec3::new(20.0, 4.0, 0.0)]
    );
    let parts = Parts::of_response(&h, &out);
    assert_eq!(
        parts.tissue_box(),
        Some((Vec3::new(12.0, -4.0, -3.0), Vec3::new(20.0, 4.0, 0.0)))
    );
    assert_eq!(parts.joints.len() as u32, h.n_joints);
    // The text form (`chainctl --json`, the batch mode) carries it too.
    let text = shared::text::TextResponse::from_wire(&h, &out);
    assert_eq!(text.tissue, Some([[12.0, -4.0, -3.0], [20.0, 4.0, 0.0]]));
    // A query of the same chain, and a describe of a chain without tissue: none.
    for (command, chain) in [(Command::Query, 0), (Command::Describe, 1)] {
        let (h, _) = respond(
            &mut solver,
            LOCAL,
            &RequestHeader::new(command, chain),
            &[],
            &mut out,
        );
        assert_eq!(h.status, Status::Ok as u32, "{}", h.reason_str());
        assert_eq!(h.n_tissue, 0, "{command:?} of chain {chain}");
        assert_eq!(
            out.len() as u32,
            h.n_joints + h.n_angles + 2 * h.n_eyelets,
            "{command:?} of chain {chain}"
        );
        assert_eq!(Parts::of_response(&h, &out).tissue_box(), None);
    }
}
