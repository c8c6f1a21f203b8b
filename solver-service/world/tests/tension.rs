//! The pull a hand feels (`world::tension`), checked against geometry computed here: a rope of ten
//! unit links held at both ends, one end pulled out along a ray. The over-pull is the hand's distance
//! from the other end less the rope's length; the pull must be zero while the rope is slack, equal to
//! the over-pull once it is taut (so it grows monotonically with it), point back toward the rope, be
//! felt with the same magnitude at the other end along the rope, and the stretch be flagged taut. A
//! knot jammed on an instrument stops a pull short too.

use world::World;
use world::command::{Command, Point};
use world::scene::parse_scene;

const ROPE: &str = r#"
[[chain]]
name = "rope"
links = 10
link_length = 1.0
"#;

/// The payload parts of chain 0: joints, held joints, instruments (three elements each), pulls.
struct Parts {
    joints: Vec<Point>,
    held: Vec<Point>,
    pulls: Vec<Point>,
}

fn parts(w: &World, instruments: usize) -> Parts {
    let n = w.specs()[0].lengths.len() + 1;
    let all: Vec<Point> = w
        .elements_with(0, false, true, true, (true, false))
        .collect();
    let n_held = (all.len() - n - 3 * instruments - instruments) / 2;
    Parts {
        joints: all[..n].to_vec(),
        held: all[n..n + n_held].to_vec(),
        pulls: all[n + n_held + 3 * instruments..].to_vec(),
    }
}

fn pull_to<'a>(w: &World, joint: usize, target: &'a [Point], pull: bool) -> Command<'a> {
    Command::Move {
        chain: 0,
        joint,
        targets: target,
        options: w.specs()[0].moves,
        take_over: false,
        smooth: false,
        pull,
        needle: world::command::NeedleMove::Carried,
    }
}

#[test]
fn the_pull_is_zero_while_slack_and_the_over_pull_once_taut() {
    let scene = parse_scene(ROPE, "rope.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    for j in [0, 10] {
        w.apply(&Command::Grasp {
            chain: 0,
            joint: j,
            take_over: false,
        })
        .unwrap();
    }
    // Fold the head back first, so that the pull starts slack.
    let fold = [Point::new(6.0, 1.0, 0.5)];
    w.apply(&pull_to(&w, 10, &fold, false)).unwrap();
    let dir = Point::new(0.6, 0.64, 0.48).normalize();
    let mut last = -1.0;
    let mut taut_seen = false;
    for k in 0..40 {
        let d = 6.0 + 0.25 * f64::from(k);
        let target = [dir * d];
        let a = w.apply(&pull_to(&w, 10, &target, true)).unwrap();
        assert_eq!(a.counts.pulls, 2, "one pull per held joint");
        let p = parts(&w, 0);
        let tail = p.joints[0];
        let over = (target[0] - tail).norm() - 10.0;
        let pull = p.pulls[1];
        // Zero while slack; the over-pull once taut (the pull stops a few tolerances inside the
        // rope's length: 4e-9 of it).
        let want = over.max(0.0);
        assert!(
            (pull.norm() - want).abs() <= 1e-7,
            "hand at {d}: pull {:e}, over-pull {want:e}",
            pull.norm()
        );
        assert!(
            pull.norm() >= last - 1e-9,
            "the pull shrank as the hand went further"
        );
        last = pull.norm();
        if over > 1e-6 {
            taut_seen = true;
            // Back toward the rope: against the ray.
            assert!(
                pull.normalize().dot(&dir) < -0.999,
                "pull {pull:?} is not back along the ray"
            );
            // Taut flag on the tail's stretch; the tail feels the same magnitude toward the head.
            assert_eq!(p.held[0].z, 1.0, "stretch not flagged taut at {d}");
            let tail_pull = p.pulls[0];
            assert!((tail_pull.norm() - pull.norm()).abs() <= 1e-9 * (1.0 + pull.norm()));
            assert!(tail_pull.normalize().dot(&dir) > 0.999);
            // The head stopped on the ray, the rope's length from the tail.
            let head = p.joints[10];
            assert!(((head - tail).norm() - 10.0).abs() <= 1e-6);
        } else if over < -1e-6 {
            assert_eq!(p.held[0].z, 0.0, "slack stretch flagged taut at {d}");
            assert_eq!(p.pulls[0], Point::zeros());
        }
    }
    assert!(taut_seen);
    // Without the flag the same over-pull is refused and changes nothing.
    let before = parts(&w, 0).joints;
    let far = [dir * 30.0];
    assert!(w.apply(&pull_to(&w, 10, &far, false)).is_err());
    assert_eq!(parts(&w, 0).joints, before);
    // A slack move clears the pull; a release forgets it.
    let back = [dir * 5.0];
    w.apply(&pull_to(&w, 10, &back, true)).unwrap();
    assert!(parts(&w, 0).pulls.iter().all(|p| *p == Point::zeros()));
    w.apply(&pull_to(&w, 10, &far, true)).unwrap();
    assert!(parts(&w, 0).pulls[1].norm() > 19.0);
    w.apply(&Command::Release {
        chain: 0,
        joint: 10,
        take_over: false,
    })
    .unwrap();
    assert_eq!(parts(&w, 0).pulls, vec![Point::zeros()]);
}

#[test]
fn a_pull_survives_a_snapshot_and_an_undo() {
    let scene = parse_scene(ROPE, "rope.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    for j in [0, 10] {
        w.apply(&Command::Grasp {
            chain: 0,
            joint: j,
            take_over: false,
        })
        .unwrap();
    }
    let far = [Point::new(14.0, 0.0, 0.0)];
    w.apply(&pull_to(&w, 10, &far, true)).unwrap();
    let pulled = parts(&w, 0).pulls;
    assert!((pulled[1].norm() - 4.0).abs() < 1e-6);
    let state = w.state();
    let mut x = World::new(&scene).unwrap();
    x.restore(&state).unwrap();
    assert_eq!(parts(&x, 0).pulls, pulled);
    // An undone slack move gives the pull back.
    let near = [Point::new(9.0, 0.0, 0.0)];
    w.apply(&pull_to(&w, 10, &near, true)).unwrap();
    assert_eq!(parts(&w, 0).pulls[1], Point::zeros());
    w.undo();
    assert_eq!(parts(&w, 0).pulls, pulled);
}

const POST: &str = r#"
[[instrument]]
name = "post"
shape = "capsule"
a = [5.0, -0.5, -3.0]
b = [5.0, -0.5, 3.0]
radius = 0.4

[[chain]]
name = "rope"
links = 40
link_length = 0.5
thickness = 0.2
collision = "capsules"
instruments = ["post"]
"#;

#[test]
fn a_rope_round_a_post_stops_a_pulled_instrument_short() {
    // The rope lies along x with both ends held; the post below it is pulled up through it: the
    // rope, held at both ends and 20 long over 20 units, cannot make way, so the post stops short and
    // its pull points back down.
    let scene = parse_scene(POST, "post.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    for j in [0, 40] {
        w.apply(&Command::Grasp {
            chain: 0,
            joint: j,
            take_over: false,
        })
        .unwrap();
    }
    let mut last = 0.0;
    for k in 1..=6 {
        let up = 0.5 * f64::from(k);
        let a = w
            .apply(&Command::Instrument {
                chain: 0,
                index: 0,
                centre: Point::new(5.0, -0.5 + up, 0.0),
                axis: Some(Point::new(0.0, 0.0, 1.0)),
                max_substeps: 65536,
                pull: true,
            })
            .unwrap();
        assert_eq!(a.counts.pulls, 3);
        let p = parts(&w, 1);
        let post = p.pulls[2];
        // Independent: the post's centre can rise at most until its surface meets the rope's
        // surface, and the rope is straight at y = 0.
        let rise_allowed = 0.5 - 0.4 - 0.1;
        let over = (up - rise_allowed).max(0.0);
        assert!(post.norm() >= last - 1e-9, "the post's pull shrank");
        if over > 0.05 {
            assert!(
                post.norm() > 0.0 && post.y < 0.0,
                "post pull {post:?} at {up}"
            );
        }
        last = post.norm();
        // No joint moved: the rope was straight between its holds.
        for (i, q) in p.joints.iter().enumerate() {
            assert!((q.y).abs() < 1e-9, "joint {i} moved to {q:?}");
        }
    }
    assert!(last > 2.0);
}

/// A pull's tries share the scene's `pull_budget`, not the request's budget: with the pull budget
/// too small for one pass of collision work, a pull of a held rope with capsule collision stops short
/// at once (`Stop::Work`) and leaves the rope where it was, while the same move without the pull flag
/// has the whole budget and is made.
#[test]
fn a_pull_stops_short_at_the_pull_budget_and_a_plain_move_keeps_the_whole_budget() {
    let text = format!("pull_budget = 1\n{ROPE}collision = \"capsules\"\nthickness = 0.2\n");
    let scene = parse_scene(&text, "rope.toml").unwrap();
    assert_eq!(scene.pull_budget, Some(1));
    let mut w = World::new(&scene).unwrap();
    w.set_budget(2_000_000);
    assert_eq!(w.pull_budget(), 1);
    w.apply(&Command::Grasp {
        chain: 0,
        joint: 0,
        take_over: false,
    })
    .unwrap();
    let before = parts(&w, 0).joints;
    let head = before[10];
    let target = [Point::new(head.x - 0.5, head.y + 0.5, head.z)];
    let a = w.apply(&pull_to(&w, 10, &target, true)).unwrap();
    assert_eq!(a.stopped, Some(world::tension::Stop::Work));
    assert!(w.last_work() <= 1, "{} link-steps", w.last_work());
    assert_eq!(
        parts(&w, 0).joints,
        before,
        "a pull out of work moves nothing"
    );
    w.apply(&pull_to(&w, 10, &target, false)).unwrap();
    let now = parts(&w, 0).joints[10];
    // Within the held side's solve tolerance (1e-9 of the rope's length).
    assert!((now - target[0]).norm() < 1e-7, "{now:?}");
    // Without a pull budget a pull has the request's.
    w.set_pull_budget(None);
    assert_eq!(w.pull_budget(), 2_000_000);
}

/// The world counts each chain's contact resolutions (`World::resolution_stats`): only for chains
/// with collision handling, and at least the passes its answers reported. The rope held at its tail
/// is pushed up by the post, which it wraps.
#[test]
fn the_world_counts_each_chain_s_contact_resolutions() {
    let text = format!("{POST}\n[[chain]]\nname = \"plain\"\nlinks = 4\nlink_length = 1.0\n");
    let scene = parse_scene(&text, "post.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    assert_eq!(
        w.resolution_stats().len(),
        1,
        "only the chain with collision"
    );
    w.apply(&Command::Grasp {
        chain: 0,
        joint: 0,
        take_over: false,
    })
    .unwrap();
    let (mut ok, mut reported) = (0u64, 0u64);
    for k in 1..=30 {
        let a = w.apply(&Command::Instrument {
            chain: 0,
            index: 0,
            centre: Point::new(5.0, -0.5 + 0.05 * f64::from(k), 0.0),
            axis: Some(Point::new(0.0, 0.0, 1.0)),
            max_substeps: 65536,
            pull: false,
        });
        if let Ok(a) = a {
            ok += 1;
            reported += u64::from(a.iterations);
        }
    }
    let stats = w.resolution_stats();
    let (chain, st) = stats[0];
    assert_eq!(chain, 0);
    assert!(ok > 0 && reported > 0, "the post never pushed the rope");
    assert!(st.resolutions >= ok, "{st:?} for {ok} pushes");
    assert!(
        st.passes >= reported,
        "{st:?} against {reported} passes reported"
    );
}
