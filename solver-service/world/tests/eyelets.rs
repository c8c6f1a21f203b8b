//! A scene's eyelets (`eyelets = [[x, y, z], ...]`): the rope passes through fixed points and slides
//! through them, through the world's commands. Checked with code of the test: each eyelet's point
//! lies on one of the rope's links (the smallest distance from the point to a link's segment, to 1e-9
//! of a link), every link length is kept, and undo, reset and a snapshot put the threading back.

use world::World;
use world::command::{Command, Point};
use world::scene::parse_scene;

const ROPE: &str = r#"
[[chain]]
name = "suture"
links = 40
link_length = 1.0
eyelets = [[10.5, 0.0, 0.0], [25.5, 0.0, 0.0]]
"#;

const EYELETS: [[f64; 3]; 2] = [[10.5, 0.0, 0.0], [25.5, 0.0, 0.0]];

fn joints(w: &World) -> Vec<Point> {
    w.elements_with(0, false, false, false, (false, false))
        .take(41)
        .collect()
}

/// The smallest distance from `p` to a link of the rope through `j`.
fn off_rope(j: &[Point], p: Point) -> f64 {
    j.windows(2)
        .map(|w| {
            let ab = w[1] - w[0];
            let t = ((p - w[0]).dot(&ab) / ab.dot(&ab)).clamp(0.0, 1.0);
            (w[0] + ab * t - p).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

fn threaded(w: &World) -> Vec<(u32, bool)> {
    w.state().chains[0].eyelets.clone()
}

fn check(w: &World, what: &str) {
    let j = joints(w);
    for (k, l) in j.windows(2).enumerate() {
        let len = (l[1] - l[0]).norm();
        assert!((len - 1.0).abs() < 1e-12, "{what}: link {k} is {len}");
    }
    for (e, (_, on)) in EYELETS.iter().zip(threaded(w)) {
        if on {
            let d = off_rope(&j, Point::from(*e));
            assert!(d < 1e-9, "{what}: eyelet {e:?} is {d:e} off the rope");
        }
    }
}

fn go<'a>(w: &World, joint: usize, to: &'a [Point]) -> Command<'a> {
    Command::Move {
        chain: 0,
        joint,
        targets: to,
        options: w.specs()[0].moves,
        take_over: false,
        smooth: false,
        pull: false,
    }
}

#[test]
fn the_rope_slides_through_its_eyelets_and_undo_reset_and_snapshots_keep_them() {
    let scene = parse_scene(ROPE, "suture.toml").unwrap();
    assert_eq!(
        scene.chains[0]
            .eyelets
            .iter()
            .map(|e| e.1)
            .collect::<Vec<_>>(),
        [10, 25]
    );
    let mut w = World::new(&scene).unwrap();
    // The head drawn up and out, then along: the rope slides through both eyelets.
    let path = [
        Point::new(41.0, 5.0, 2.0),
        Point::new(43.0, 7.0, -1.0),
        Point::new(45.0, 3.0, 0.0),
    ];
    for (k, p) in path.iter().enumerate() {
        w.apply(&go(&w, 40, std::slice::from_ref(p))).unwrap();
        check(&w, &format!("head move {k}"));
        assert!((joints(&w)[40] - p).norm() < 1e-9);
    }
    let slid = threaded(&w);
    assert!(
        slid[0].1 && slid[1].1 && slid[0].0 < 10 && slid[1].0 < 25,
        "slid toward the tail's side: {slid:?}"
    );
    // The tail drawn back: the rope slides the other way.
    let before = (joints(&w), threaded(&w));
    w.apply(&go(&w, 0, &[Point::new(-6.0, -2.0, 1.0)])).unwrap();
    check(&w, "tail move");
    let back = threaded(&w);
    assert!(
        back[0].1 && back[0].0 > slid[0].0,
        "{back:?} after {slid:?}"
    );
    // Undo puts joints and threading back; a snapshot restores both into a new world.
    w.undo();
    assert_eq!((joints(&w), threaded(&w)), before);
    let state = w.state();
    let mut x = World::new(&scene).unwrap();
    x.restore(&state).unwrap();
    assert_eq!((joints(&x), threaded(&x)), before);
    // A state whose eyelet is not on its link is refused, changing nothing.
    let mut bad = state.clone();
    bad.chains[0].eyelets[0].0 += 3;
    let mut y = World::new(&scene).unwrap();
    assert!(y.restore(&bad).is_err());
    assert_eq!(threaded(&y), [(10, true), (25, true)]);
    // Reset: the scene's threading.
    w.apply(&Command::Reset {
        chain: 0,
        take_over: false,
    })
    .unwrap();
    assert_eq!(threaded(&w), [(10, true), (25, true)]);
    check(&w, "reset");
}

#[test]
fn the_tail_slides_out_of_an_eyelet_and_the_rope_cannot_be_grasped() {
    let scene = parse_scene(ROPE, "suture.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    // 12 units along the rope's line: the tail (at 0) passes the first eyelet (at 10.5), not the
    // second (at 25.5).
    w.apply(&go(&w, 40, &[Point::new(52.0, 0.0, 0.0)])).unwrap();
    let t = threaded(&w);
    assert!(!t[0].1 && t[1].1, "{t:?}");
    check(&w, "slid out");
    let r = w
        .apply(&Command::Grasp {
            chain: 0,
            joint: 40,
            take_over: false,
        })
        .unwrap_err();
    assert!(r.reason().contains("eyelets"), "{}", r.reason());
}

#[test]
fn eyelets_off_the_rope_too_close_or_with_collision_are_scene_errors() {
    let with = |extra: &str, eyelets: &str| {
        format!(
            "[[chain]]\nname = \"s\"\nlinks = 40\nlink_length = 1.0\n{extra}eyelets = {eyelets}\n"
        )
    };
    for (text, says) in [
        (with("", "[[10.5, 0.2, 0.0]]"), "not on the chain"),
        (
            with("", "[[10.5, 0.0, 0.0], [11.5, 0.0, 0.0]]"),
            "two links apart",
        ),
        (
            with(
                "thickness = 0.2\ncollision = \"capsules\"\n",
                "[[10.5, 0.0, 0.0]]",
            ),
            "collision",
        ),
        (with("anchors = [0]\n", "[[10.5, 0.0, 0.0]]"), "anchors"),
    ] {
        let e = parse_scene(&text, "s.toml").unwrap_err().to_string();
        assert!(e.contains("eyelets") && e.contains(says), "{e}");
    }
}
