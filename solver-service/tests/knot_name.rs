//! The knot a scene asks for (`knot = true`), in every answer through the service's answer path: a
//! rope laid through points built here (the (2, 3) torus knot, a trefoil, cut open and its ends run out
//! straight, and the same curl climbing steadily, which is no knot) is named in the response's `knot`
//! field; a chain that does not ask gets `KNOT_NOT_ASKED`; a planar chain cannot ask. The names come
//! from the construction, not from the namer.

use shared::{Command, RequestHeader, ResponseHeader, Status, Vec3};
use solver_service::serve::respond;
use solver_service::service::Solver;
use std::fmt::Write;
use std::time::Duration;
use world::World;
use world::owners::LOCAL;
use world::scene::parse_scene;

/// The (2, 3) torus knot `r = 2 + cos 3t, θ = 2t, z = sin 3t` (or, with `climb`, `z = t`: the same
/// picture from above with the later strand always over), cut open at its left-most point, both ends
/// run 10 units straight out along x (the second over the top, z = 4).
fn rope(climb: bool) -> Vec<[f64; 3]> {
    let n = 120;
    let closed: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            let r = 2.0 + (3.0 * t).cos();
            let z = if climb { t } else { (3.0 * t).sin() };
            [r * (2.0 * t).cos(), r * (2.0 * t).sin(), z]
        })
        .collect();
    let c = (0..n)
        .min_by(|&i, &j| closed[i][0].total_cmp(&closed[j][0]))
        .unwrap();
    let min_x = closed[c][0];
    let first = closed[(c + 1) % n];
    let last = closed[(c + n - 1) % n];
    let mut out = vec![[min_x - 10.0, first[1], first[2]]];
    out.extend((1..n).map(|k| closed[(c + k) % n]));
    out.push([min_x - 1.0, last[1], 4.0]);
    out.push([min_x + 15.0, last[1], 4.0]);
    out
}

fn scene() -> String {
    let mut s = String::new();
    for (name, climb, knot) in [
        ("knotted", false, true),
        ("curl", true, true),
        ("quiet", false, false),
    ] {
        let points: Vec<String> = rope(climb)
            .iter()
            .map(|p| format!("[{}, {}, {}]", p[0], p[1], p[2]))
            .collect();
        write!(
            s,
            "[[chain]]\nname = \"{name}\"\nshape = \"points\"\npoints = [{}]\nknot = {knot}\n\n",
            points.join(", ")
        )
        .unwrap();
    }
    s
}

fn call(solver: &mut Solver, h: &RequestHeader, points: &[Vec3]) -> ResponseHeader {
    let mut out = Vec::new();
    respond(solver, LOCAL, h, points, &mut out).0
}

#[test]
fn the_response_carries_the_knot_of_a_chain_that_asks() {
    let world = World::new(&parse_scene(&scene(), "knots.toml").unwrap()).unwrap();
    let mut solver = Solver::new(world, None, Duration::from_secs(3600));
    let query = |c| RequestHeader::new(Command::Query, c);
    for (chain, want) in [
        (0, shared::KNOT_TREFOIL),
        (1, shared::KNOT_UNKNOT),
        (2, shared::KNOT_NOT_ASKED),
    ] {
        let h = call(&mut solver, &query(chain), &[]);
        assert_eq!(h.status, Status::Ok as u32, "{}", h.reason_str());
        assert_eq!(h.knot, want, "chain {chain}");
    }
    assert_eq!(shared::knot_name(shared::KNOT_TREFOIL), Some("trefoil"));
    assert_eq!(shared::knot_name(shared::KNOT_NOT_ASKED), None);
    // A small move of the knotted rope's far end (no collision here, nothing passes through) keeps
    // the name; the move's own answer carries it.
    let mut m = RequestHeader::new(Command::Move, 0);
    m.joint = rope(false).len() as u32 - 1;
    let end = rope(false).last().copied().unwrap();
    let h = call(
        &mut solver,
        &m,
        &[Vec3::new(end[0] + 0.5, end[1], end[2] + 0.5)],
    );
    assert_eq!(h.status, Status::Ok as u32, "{}", h.reason_str());
    assert_eq!(h.knot, shared::KNOT_TREFOIL);
    // A refused request names nothing and changes nothing.
    let mut bad = RequestHeader::new(Command::Move, 0);
    bad.joint = 10_000;
    let h = call(&mut solver, &bad, &[Vec3::new(0.0, 0.0, 0.0)]);
    assert_ne!(h.status, Status::Ok as u32);
    assert_eq!(h.knot, shared::KNOT_NOT_ASKED);
    assert_eq!(call(&mut solver, &query(0), &[]).knot, shared::KNOT_TREFOIL);
}

#[test]
fn only_a_free_spatial_chain_can_ask_for_its_knot() {
    let planar = "[[chain]]\nname = \"arm\"\nspace = \"planar\"\nlinks = 4\nlink_length = 1.0\nknot = true\n";
    let e = parse_scene(planar, "arm.toml").unwrap_err().to_string();
    assert!(e.contains("arm.toml:6") && e.contains("knot"), "{e}");
    let fixed = "[[chain]]\nname = \"arm\"\nkind = \"fixed-base\"\nlinks = 4\nlink_length = 1.0\nknot = true\n";
    let e = parse_scene(fixed, "arm.toml").unwrap_err().to_string();
    assert!(e.contains("knot"), "{e}");
    let not_bool = "[[chain]]\nname = \"rope\"\nlinks = 4\nlink_length = 1.0\nknot = 1\n";
    assert!(parse_scene(not_bool, "rope.toml").is_err());
}
