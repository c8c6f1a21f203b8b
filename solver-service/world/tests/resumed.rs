//! A tightening pull whose contact resolution needs more than one request's work: the overhand
//! drawn by the head of a 160-link rope (the built-in `overhand-bend`'s path, through the world in
//! process), then its tail held and its head pulled away from the knot 0.05 per request with the
//! contacts solved together, as the service's pulls are, each request with a small work budget
//! (`tractrix::collision`, `CollisionWorkspace::keep_unfinished`). A pull refused for its work keeps
//! its resolution, and the same pull asked again goes on from it: pulls are made after a refusal.
//! Without the kept resolution the same pulls, from the same states, are refused every time. Every
//! refusal leaves the rope as it was; every pull made keeps the tail where it was held, the head
//! where it was pulled and the lengths, and no state passes a link through another (the
//! swept-volume check of `knots::check`, not the kernel's code).

use knots::script::Script;
use nalgebra::Vector3;
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, move_joint_colliding,
};
use tractrix::{Chain, ChainError, MoveOptions, MoveOutcome};
use world::World;
use world::command::{Command, NeedleMove, Point};
use world::scene::parse_scene;

const THICKNESS: f64 = 0.2;

const ROPE: &str = r#"
[[chain]]
name = "rope-160"
links = 160
link_length = 0.25
axis = [1.0, 0.0, 0.0]
thickness = 0.2
collision = "capsules"
"#;

/// Link-steps per request: the knot's last pulls need more than one (15 of 431 pulls when written).
const BUDGET: u64 = 30_000;

/// The rope with the overhand drawn by its head (the path of `overhand-bend`), through the world.
fn tied() -> Vec<Vector3<f64>> {
    let scene = parse_scene(ROPE, "rope.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    let script = Script::builtin("overhand-bend").unwrap();
    for t in script.turn[0].targets([40.0, 0.0, 0.0], script.max_step) {
        let target = [Point::new(t[0], t[1], t[2])];
        // A move that locks leaves the rope as it was; the path goes on.
        let _ = w.apply(&Command::Move {
            chain: 0,
            joint: 160,
            targets: &target,
            options: w.specs()[0].moves,
            take_over: false,
            smooth: false,
            pull: false,
            needle: NeedleMove::Carried,
        });
    }
    w.elements_of(0, false).take(161).collect()
}

fn model() -> CollisionModel<f64, 3> {
    CollisionModel {
        options: CollisionOptions {
            thickness: THICKNESS,
            // As `knots.toml` gives its 160-link ropes.
            max_iterations: 512,
            ..CollisionOptions::default()
        },
        obstacles: vec![],
        holding: Vec::new(),
    }
}

/// A pull of the head to `target` with [`BUDGET`] link-steps (the contacts solved together, the
/// resolution kept if `ws` keeps it).
fn pull(
    rope: &mut Chain<f64, 3>,
    target: Vector3<f64>,
    model: &CollisionModel<f64, 3>,
    ws: &mut CollisionWorkspace<f64, 3>,
) -> Result<MoveOutcome, ChainError> {
    ws.limit_work(BUDGET);
    move_joint_colliding(rope, 160, target, &MoveOptions::default(), model, ws)
}

/// The head pulled away from the knot until it has moved less than a tenth of a pull for eight
/// requests in a row with none refused for its work: the pulls made after a refusal, as the state
/// before and the target.
fn tighten(rope: &mut Chain<f64, 3>) -> Vec<(Chain<f64, 3>, Vector3<f64>)> {
    let model = model();
    let mut ws = CollisionWorkspace::new();
    ws.solve_contacts_together(true);
    ws.keep_unfinished(true);
    let tail = rope.joint(0);
    let mut prev = rope.positions();
    let array =
        |p: &[Vector3<f64>]| -> Vec<[f64; 3]> { p.iter().map(|q| [q.x, q.y, q.z]).collect() };
    let mut resumed = Vec::new();
    let (mut refused, mut still, mut made) = (0, 0, 0);
    for k in 0..5000 {
        let at = prev[160];
        let away = knots::contact::away_from_knot(&array(&prev), 160, THICKNESS).unwrap();
        let target = at + Vector3::from(away) * 0.05;
        let before = rope.clone();
        match pull(rope, target, &model, &mut ws) {
            Ok(_) => {
                made += 1;
                if refused > 0 {
                    resumed.push((before.clone(), target));
                }
                refused = 0;
                let now = rope.positions();
                assert_eq!(now[0], tail, "pull {k}: the held tail moved");
                assert!(
                    (now[160] - target).norm() < 1e-9 * 40.0,
                    "pull {k}: the head is not where it was pulled"
                );
                let worst = now
                    .windows(2)
                    .map(|p| ((p[1] - p[0]).norm() - 0.25).abs())
                    .fold(0.0, f64::max);
                assert!(worst < 1e-9, "pull {k}: a link is {worst:e} off its length");
                let shortest = 0.25;
                let crossed = knots::check::crossings_between(&prev, &now, 2, 1e-9 * shortest);
                assert!(crossed.is_empty(), "pull {k}: links crossed: {crossed:?}");
                still = if (now[160] - at).norm() < 0.005 {
                    still + 1
                } else {
                    0
                };
                prev = now;
            }
            Err(e) => {
                assert!(
                    *rope == before,
                    "pull {k}: a refusal ({e}) changed the rope"
                );
                if matches!(e, ChainError::OverWork { .. }) {
                    refused += 1;
                    assert!(
                        refused < 64,
                        "pull {k}: refused 64 times in a row for its work"
                    );
                } else {
                    refused = 0;
                    still += 1;
                }
            }
        }
        if still >= 8 && refused == 0 {
            break;
        }
    }
    eprintln!(
        "{made} pulls made, {} of them after a refusal for their work",
        resumed.len()
    );
    resumed
}

#[test]
fn a_pull_refused_for_its_work_goes_on_from_where_it_stopped_when_asked_again() {
    let points = tied();
    assert_eq!(
        knots::identify(&points).kind,
        knots::KnotType::Trefoil,
        "the path did not tie the overhand"
    );
    let mut rope = Chain::from_points(&points).unwrap();
    rope.hold(0).unwrap();
    let resumed = tighten(&mut rope);
    assert!(
        resumed.len() >= 3,
        "{} pulls needed a second request",
        resumed.len()
    );
    // The same pulls from the same states, with nothing kept: refused every time.
    let model = model();
    for (state, target) in &resumed {
        let mut ws = CollisionWorkspace::new();
        ws.solve_contacts_together(true);
        let mut c = state.clone();
        for _ in 0..8 {
            let r = pull(&mut c, *target, &model, &mut ws);
            assert!(matches!(r, Err(ChainError::OverWork { .. })), "{r:?}");
            assert!(c == *state);
        }
    }
}

/// A kept resolution belongs to its own pull: after a pull toward another point from the same state
/// that also runs out of work (and keeps its own passes), the first pull asked again does not go on
/// from the other's passes, and when it is made it lands where it was asked.
#[test]
fn a_kept_resolution_is_not_resumed_after_another_pull_recorded_its_own() {
    let points = tied();
    let mut rope = Chain::from_points(&points).unwrap();
    rope.hold(0).unwrap();
    let resumed = tighten(&mut rope);
    let (state, target) = resumed
        .first()
        .expect("a pull that needed a second request")
        .clone();
    let model = model();
    let mut ws = CollisionWorkspace::new();
    ws.solve_contacts_together(true);
    ws.keep_unfinished(true);
    let mut c = state.clone();
    let first = pull(&mut c, target, &model, &mut ws);
    assert!(
        matches!(first, Err(ChainError::OverWork { .. })),
        "{first:?}"
    );
    // Another pull from the same state, a little farther the same way, that also runs out of work
    // and records passes of its own.
    let way = (target - state.joint(160)).normalize();
    let aside = [0.002, 0.005, 0.01, 0.02]
        .into_iter()
        .map(|d| target + way * d)
        .find(|p| {
            let r = pull(&mut c, *p, &model, &mut ws);
            if r.is_ok() {
                c = state.clone();
            }
            matches!(r, Err(ChainError::OverWork { .. }))
        })
        .expect("no other pull from this state ran out of work");
    assert!(c == state);
    for _ in 0..64 {
        match pull(&mut c, target, &model, &mut ws) {
            Ok(_) => {
                let head = c.joint(160);
                assert!(
                    (head - target).norm() < 1e-9 * 40.0,
                    "the head landed {:e} from where it was pulled ({:e} from the other pull's point)",
                    (head - target).norm(),
                    (head - aside).norm()
                );
                return;
            }
            Err(ChainError::OverWork { .. }) => assert!(c == state),
            Err(e) => panic!("the first pull, asked again: {e}"),
        }
    }
    panic!("the first pull was refused for its work 64 times in a row");
}
