//! A curved needle swaged to a suture's head (`needle = [radius, angle°, thickness]`): a rigid arc
//! carried as capsules, the chain's last instruments. Checked with code of the test: where the arc
//! must lie (its centre a radius from the head, its first chord leaving along the head link), that it
//! stays rigid (every distance between its capsules' ends kept), swaged (its first end on the head)
//! and tangent to the head link (its first chord half a segment's angle off the link) after every
//! move of the head or of the tail, and that the rope keeps its thickness from it (less the
//! collision's 1 % tolerance), the tail drawn across it so that the rope lies against it.

use world::World;
use world::command::{Command, Point};
use world::scene::parse_scene;

/// With the work budget of `stitch.toml` (a needle pushing the rope with each of its capsules costs
/// more than the default allows).
const SUTURE: &str = r#"
budget = 2000000

[[chain]]
name = "suture"
links = 40
link_length = 0.5
base = [0.0, 0.0, 2.0]
axis = [1.0, 0.0, 0.0]
thickness = 0.1
collision = "capsules"
tissue = [[22.0, -6.0, -3.0], [34.0, 6.0, 0.0]]
needle = [1.0, 135.0, 0.1]
"#;

fn joints(w: &World) -> Vec<Point> {
    w.elements_with(0, false, false, false, (false, false))
        .take(41)
        .collect()
}

/// The needle's capsules: `(a, b, radius)` each, from the instruments after the joints.
fn needle(w: &World) -> Vec<(Point, Point, f64)> {
    let e: Vec<Point> = w
        .elements_with(0, false, false, true, (false, false))
        .skip(41)
        .collect();
    e.chunks(3).map(|c| (c[0], c[1], c[2].x)).collect()
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
        needle: world::command::NeedleMove::Carried,
    }
}

/// The distance between segments `p0`–`p1` and `q0`–`q1`, by sampling both finely enough for the
/// bound used here (2001 points on each).
fn gap(p0: Point, p1: Point, q0: Point, q1: Point) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..=2000 {
        let p = p0 + (p1 - p0) * (i as f64 / 2000.0);
        // The nearest point of the other segment to `p`, clamped.
        let d = q1 - q0;
        let t = ((p - q0).dot(&d) / d.dot(&d)).clamp(0.0, 1.0);
        best = best.min((q0 + d * t - p).norm());
    }
    best
}

/// Checks that every link but those the needle holds by the head (the last six) keeps the rope's
/// thickness from every capsule of the needle, less the collision's 1 % tolerance; returns the
/// smallest gap beyond touching.
fn clear(j: &[Point], n: &[(Point, Point, f64)], what: &str) -> f64 {
    let mut nearest = f64::INFINITY;
    for (c, (a, b, r)) in n.iter().enumerate() {
        for l in 0..34 {
            let d = gap(j[l], j[l + 1], *a, *b);
            nearest = nearest.min(d - r - 0.05);
            assert!(
                d >= r + 0.05 - 1e-3 - 1e-9,
                "{what}: link {l} {d} from needle capsule {c}"
            );
        }
    }
    nearest
}

#[test]
fn the_needle_is_an_arc_swaged_to_the_head_and_carried_rigidly_with_it() {
    let scene = parse_scene(SUTURE, "suture.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    w.set_budget(scene.budget.expect("the scene's budget"));
    let n = needle(&w);
    // 135° in pieces of at most 22.5°: 6 capsules, each the needle's radius (half its thickness).
    assert_eq!(n.len(), 6);
    let head = Point::new(20.0, 0.0, 2.0);
    // The arc: centre a radius above the head (it curves up), every end a radius from it, the first
    // end on the head, the last 135° round from it.
    let centre = head + Point::new(0.0, 0.0, 1.0);
    for (k, (a, b, r)) in n.iter().enumerate() {
        assert!((r - 0.05).abs() < 1e-15, "capsule {k}: radius {r}");
        for p in [a, b] {
            assert!(
                ((p - centre).norm() - 1.0).abs() < 1e-12,
                "capsule {k}: {p:?}"
            );
        }
    }
    assert!((n[0].0 - head).norm() < 1e-12);
    let tip = n[5].1;
    let turned = ((head - centre).dot(&(tip - centre))).acos().to_degrees();
    assert!((turned - 135.0).abs() < 1e-9, "{turned}");
    assert!(tip.x > head.x, "the point leads: {tip:?}");
    // Every distance between the needle's ends, to check that it stays rigid.
    let ends = |n: &[(Point, Point, f64)]| -> Vec<Point> {
        n.iter().map(|c| c.0).chain([n[n.len() - 1].1]).collect()
    };
    let shape = |e: &[Point]| -> Vec<f64> {
        e.iter()
            .flat_map(|p| e.iter().map(move |q| (p - q).norm()))
            .collect()
    };
    let rigid = shape(&ends(&n));
    // Moves of the head (down toward the tissue, along, up) and of the tail (the head dragged).
    let moves = [
        (40, Point::new(21.0, 0.5, 1.5)),
        (40, Point::new(22.5, 0.0, 0.8)),
        (40, Point::new(23.0, 1.0, 2.5)),
        (0, Point::new(-3.0, 2.0, 2.0)),
        (40, Point::new(19.0, -2.0, 3.0)),
    ];
    let mut nearest = f64::INFINITY;
    for (k, (joint, to)) in moves.iter().enumerate() {
        let path: Vec<Point> = (1..=10)
            .map(|i| {
                let from = joints(&w)[*joint];
                from + (to - from) * (i as f64 / 10.0)
            })
            .collect();
        for p in path {
            w.apply(&go(&w, *joint, &[p]))
                .unwrap_or_else(|r| panic!("move {k}: {}", r.reason()));
        }
        let (j, n) = (joints(&w), needle(&w));
        let e = ends(&n);
        // Rigid: every distance between its ends kept.
        for (x, y) in shape(&e).iter().zip(&rigid) {
            assert!(
                (x - y).abs() < 1e-9,
                "move {k}: the needle bent ({x} for {y})"
            );
        }
        // Swaged: its first end on the head.
        assert!((e[0] - j[40]).norm() < 1e-9, "move {k}: off the head");
        // Tangent to the head link: the first chord 11.25° (half a segment) off the link.
        let link = (j[40] - j[39]).normalize();
        let chord = (e[1] - e[0]).normalize();
        let off = link.dot(&chord).clamp(-1.0, 1.0).acos().to_degrees();
        assert!(
            (off - 11.25).abs() < 1e-6,
            "move {k}: {off}° off the head link"
        );
        nearest = nearest.min(clear(&j, &n, &format!("move {k}")));
    }
    // The head held (the driver holds the needle) and the tail drawn across the needle's middle, a
    // hair outside it: the rope behind the tail lies against the needle and keeps its thickness from
    // it. The arc's centre is the circumcentre of its two ends and its middle, computed here.
    w.apply(&Command::Grasp {
        chain: 0,
        joint: 40,
        take_over: false,
    })
    .unwrap();
    let e = ends(&needle(&w));
    let (a, b, c) = (e[0], e[3], e[6]);
    let (al, be) = (b - a, c - a);
    let wn = al.cross(&be);
    let centre = a
        + (be.cross(&wn) * al.norm_squared() + wn.cross(&al) * be.norm_squared())
            / (2.0 * wn.norm_squared());
    let pass = b + (b - centre).normalize() * 0.15;
    let side = wn.normalize() * 3.0;
    for (k, to) in [pass + side, pass - side].iter().enumerate() {
        let from = joints(&w)[0];
        for i in 1..=30 {
            let p = from + (to - from) * (i as f64 / 30.0);
            w.apply(&go(&w, 0, &[p]))
                .unwrap_or_else(|r| panic!("tail {k}: {}", r.reason()));
            let (j, n) = (joints(&w), needle(&w));
            nearest = nearest.min(clear(&j, &n, &format!("tail {k}")));
        }
    }
    let turn = joints(&w)[40] + Point::new(0.0, -1.0, -1.0);
    w.apply(&go(&w, 40, &[turn]))
        .unwrap_or_else(|r| panic!("the turn: {}", r.reason()));
    let (j, n) = (joints(&w), needle(&w));
    assert!((n[0].0 - j[40]).norm() < 1e-9, "the turn: off the head");
    clear(&j, &n, "the turn");
    // The needle pushed the rope: some link lay within a thickness of touching it.
    println!("nearest approach of rope and needle: {nearest}");
    assert!(
        nearest < 0.1,
        "the needle never came near the rope: {nearest}"
    );
}

/// Tiny moves of the head (the head link turned by angles near rounding, where an arccosine of the
/// dot product can pass 1): the needle stays finite, swaged and rigid.
#[test]
fn tiny_moves_keep_the_needle_finite_and_swaged() {
    let scene = parse_scene(SUTURE, "suture.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    w.set_budget(scene.budget.expect("the scene's budget"));
    let first = needle(&w);
    for k in 0..2000 {
        let step = 10f64.powi(-(8 + (k % 9))) * if k % 2 == 0 { 1.0 } else { -1.0 };
        let head = joints(&w)[40];
        let to = head + Point::new(step * 0.3, step, step * 0.7);
        w.apply(&go(&w, 40, &[to]))
            .unwrap_or_else(|r| panic!("move {k}: {}", r.reason()));
        let n = needle(&w);
        assert!(
            n.iter()
                .all(|c| c.0.iter().chain(c.1.iter()).all(|x| x.is_finite())),
            "move {k}: {n:?}"
        );
        assert!(
            (n[0].0 - joints(&w)[40]).norm() < 1e-9,
            "move {k}: off the head"
        );
        for (c, f) in n.iter().zip(&first) {
            assert!(
                ((c.1 - c.0).norm() - (f.1 - f.0).norm()).abs() < 1e-9,
                "move {k}"
            );
        }
    }
}

#[test]
fn a_needle_needs_tissue_and_a_sound_arc() {
    let base = "[[chain]]\nname = \"s\"\nlinks = 40\nlink_length = 1.0\nthickness = 0.1\n";
    let tissue = "tissue = [[5.0, -5.0, -3.0], [30.0, 5.0, 0.0]]\n";
    for (extra, says) in [
        (
            "collision = \"capsules\"\nneedle = [1.0, 90.0, 0.1]\n".to_string(),
            "tissue",
        ),
        (format!("{tissue}needle = [1.0, 90.0, 0.1]\n"), "collision"),
        (
            format!("{tissue}collision = \"capsules\"\nneedle = [1.0, 300.0, 0.1]\n"),
            "270",
        ),
        (
            format!("{tissue}collision = \"capsules\"\nneedle = [0.0, 90.0, 0.1]\n"),
            "radius > 0",
        ),
        (
            format!("{tissue}collision = \"capsules\"\nneedle = [1.0, 90.0]\n"),
            "thickness",
        ),
        (
            format!("{tissue}collision = \"capsules\"\nneedle_bend = [0.0, 0.0, -1.0]\n"),
            "needle_bend",
        ),
        (
            format!(
                "{tissue}collision = \"capsules\"\nneedle = [1.0, 90.0, 0.1]\nneedle_bend = [2.0, 0.0, 0.0]\n"
            ),
            "along the head link",
        ),
        (
            format!(
                "{tissue}collision = \"capsules\"\nneedle = [1.0, 90.0, 0.1]\nneedle_bend = [0.0, 1.0]\n"
            ),
            "three finite numbers",
        ),
    ] {
        let text = format!("{base}{extra}");
        let e = parse_scene(&text, "s.toml").unwrap_err().to_string();
        assert!(e.contains("needle") && e.contains(says), "{e}\n{text}");
    }
}
