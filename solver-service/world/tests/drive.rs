//! A needle driven along its own arc (`FLAG_DRIVE`): the head moved step by step round the circle of
//! a needle laid curving down (`needle_bend`), through a block of tissue and out. Checked with code
//! of the test: after every step each end of the needle's capsules lies on the circle the test drew
//! (its centre below the head, the needle's radius, the plane of the drive) and the needle's swage on
//! the head; where the needle's point crossed the tissue's top (the test's own interpolation between
//! consecutive states) the world has a hole there, an eyelet not yet threaded; when the head has
//! gone through, the rope is threaded at both holes (each eyelet on the rope and within the rope's
//! and the needle's thickness of the point's crossing), and no joint lies inside the tissue but those
//! between the two eyelets.

use world::World;
use world::command::{Command, NeedleMove, Point};
use world::scene::parse_scene;

/// 10 units of suture in 80 links, its head at (0, 0, 1.55) along +x; a needle of radius 1 spanning
/// 120°, curving down toward the tissue's top at z = 0: its centre at (0, 0, 0.55), its point at the
/// start 0.05 above the tissue.
const SCENE: &str = r#"
budget = 4000000

[[chain]]
name = "suture"
links = 80
link_length = 0.125
base = [-10.0, 0.0, 1.55]
axis = [1.0, 0.0, 0.0]
thickness = 0.1
collision = "capsules"
tissue = [[-4.0, -3.0, -3.0], [6.0, 3.0, 0.0]]
needle = [1.0, 120.0, 0.1]
needle_bend = [0.0, 0.0, -1.0]
"#;

const N: usize = 80;
const R: f64 = 1.0;

fn joints(w: &World) -> Vec<Point> {
    w.elements_with(0, false, false, false, (false, false))
        .take(N + 1)
        .collect()
}

/// The needle's capsules' ends `(a, b)`, from the instruments after the joints.
fn needle(w: &World) -> Vec<(Point, Point)> {
    let e: Vec<Point> = w
        .elements_with(0, false, false, true, (false, false))
        .skip(N + 1)
        .collect();
    e.chunks(3).map(|c| (c[0], c[1])).collect()
}

/// The chain's eyelets: `(at, link, threaded)`.
fn eyelets(w: &World) -> Vec<(Point, u32, bool)> {
    w.state().chains[0]
        .eyelets
        .iter()
        .map(|e| (Point::new(e.0[0], e.0[1], e.0[2]), e.1, e.2))
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

/// A move of the head to `to`, driven or not.
fn go<'a>(w: &World, to: &'a [Point], drive: bool) -> Command<'a> {
    let needle = if drive {
        NeedleMove::Driven
    } else {
        NeedleMove::Carried
    };
    head_move(w, to, needle)
}

/// A move of the head to `to` that does `needle` to the needle.
fn head_move<'a>(w: &World, to: &'a [Point], needle: NeedleMove) -> Command<'a> {
    Command::Move {
        chain: 0,
        joint: N,
        targets: to,
        options: w.specs()[0].moves,
        take_over: false,
        smooth: false,
        pull: false,
        needle,
    }
}

/// Where the needle's point, from `before` to `now`, crossed the tissue's top (z = 0), interpolated
/// here; the world must have a hole there, an eyelet not yet threaded, to 1e-9.
fn hole_where_the_point_crossed(w: &World, before: Point, now: Point, what: &str) -> Option<Point> {
    if (before.z > 0.0) == (now.z > 0.0) {
        return None;
    }
    let at = before + (now - before) * (before.z / (before.z - now.z));
    let cut = eyelets(w)
        .iter()
        .filter(|e| !e.2)
        .map(|e| (e.0 - at).norm())
        .fold(f64::INFINITY, f64::min);
    assert!(
        cut < 1e-9,
        "{what}: no hole where the point crossed ({cut:e} off)"
    );
    Some(at)
}

fn inside(p: &Point) -> bool {
    (-4.0..=6.0).contains(&p.x) && (-3.0..=3.0).contains(&p.y) && (-3.0..=0.0).contains(&p.z)
}

#[test]
fn a_driven_needle_follows_its_arc_and_its_point_cuts_the_holes_the_rope_threads() {
    let scene = parse_scene(SCENE, "drive.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    let centre = Point::new(0.0, 0.0, 0.55);
    // Clockwise seen from +y... the drive turns the swage from the top of the circle toward +x, then
    // down: the angle from +x in the xz-plane decreases.
    let on_circle = |p: &Point| (((p - centre).norm() - R).abs(), p.y.abs());
    let start = joints(&w)[N];
    assert!((start - Point::new(0.0, 0.0, 1.55)).norm() < 1e-12);
    for (a, b) in needle(&w) {
        for p in [a, b] {
            let (dr, dy) = on_circle(&p);
            assert!(
                dr < 1e-9 && dy < 1e-12,
                "the needle laid off its circle: {p:?}"
            );
        }
    }
    let step = 0.05 / R;
    let turn = 250f64.to_radians();
    let steps = (turn / step).ceil() as usize;
    let mut point_before = needle(&w).last().unwrap().1;
    let mut holes: Vec<Point> = Vec::new();
    for k in 1..=steps {
        let angle = 90f64.to_radians() - turn * k as f64 / steps as f64;
        let to = [centre + Point::new(angle.cos(), 0.0, angle.sin()) * R];
        let cmd = go(&w, &to, true);
        w.apply(&cmd)
            .unwrap_or_else(|e| panic!("step {k} to {:?}: {e:?}", to[0]));
        let j = joints(&w);
        assert!(
            (j[N] - to[0]).norm() < 1e-9,
            "step {k}: the head at {:?}",
            j[N]
        );
        let caps = needle(&w);
        assert!(
            (caps[0].0 - j[N]).norm() < 1e-12,
            "step {k}: the swage left the head"
        );
        for (a, b) in &caps {
            for p in [a, b] {
                let (dr, dy) = on_circle(p);
                assert!(
                    dr < 1e-9 && dy < 1e-9,
                    "step {k}: a needle end {dr:e} off the circle, {dy:e} off its plane"
                );
            }
        }
        let point = caps.last().unwrap().1;
        holes.extend(hole_where_the_point_crossed(
            &w,
            point_before,
            point,
            &format!("step {k}"),
        ));
        point_before = point;
    }
    // The point went in on the right of the centre and came out on the left.
    assert_eq!(holes.len(), 2, "the point crossed the surface at {holes:?}");
    let x = (1.0f64 - 0.55 * 0.55).sqrt();
    assert!(
        (holes[0].x - x).abs() < 1e-3 && (holes[1].x + x).abs() < 1e-3,
        "{holes:?}"
    );
    // The head has come out: the rope through both holes, nowhere else.
    let j = joints(&w);
    let e = eyelets(&w);
    assert_eq!(e.len(), 2, "{e:?}");
    let reach = 0.1 + 0.1;
    for (i, (at, link, threaded)) in e.iter().enumerate() {
        assert!(*threaded, "eyelet {i} not threaded: {e:?}");
        let d = off_rope(&j, *at);
        assert!(d < 1e-9, "eyelet {i} {d:e} off the rope");
        let from_hole = (at - holes[i]).norm();
        println!("eyelet {i} on link {link}, {from_hole:.4} from the point's crossing");
        assert!(from_hole <= reach, "eyelet {i} {from_hole} from its hole");
    }
    let (a, b) = (e[0].1 as usize, e[1].1 as usize);
    for (k, p) in j.iter().enumerate() {
        assert!(
            !inside(p) || (a < k && k <= b),
            "joint {k} inside the tissue at {p:?}, outside the stitch (links {a}..={b})"
        );
    }
}

/// Once the needle's point has cut a hole, the rope goes into the tissue there and nowhere else: the
/// head taken down into the tissue two units from the hole is refused, and nothing changes.
#[test]
fn once_the_needle_has_cut_a_hole_the_rope_goes_in_nowhere_else() {
    let scene = parse_scene(SCENE, "drive.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    let centre = Point::new(0.0, 0.0, 0.55);
    let mut k = 0;
    while !eyelets(&w).iter().any(|e| !e.2) {
        k += 1;
        assert!(k < 40, "no hole after {k} steps");
        let angle = 90f64.to_radians() - 0.05 * k as f64;
        let to = [centre + Point::new(angle.cos(), 0.0, angle.sin()) * R];
        let cmd = go(&w, &to, true);
        w.apply(&cmd).unwrap();
    }
    let before = (joints(&w), needle(&w), eyelets(&w));
    let head = joints(&w)[N];
    let to = [Point::new(head.x - 2.0, 0.0, -0.5)];
    // A frame the whole move fits in (the default would stop it short, out of the tissue).
    w.set_budget(200_000);
    let cmd = go(&w, &to, false);
    let refusal = w
        .apply(&cmd)
        .expect_err("the rope went into the tissue away from the hole");
    assert!(
        refusal.reason().contains("hole"),
        "refused for another reason: {}",
        refusal.reason()
    );
    assert_eq!((joints(&w), needle(&w), eyelets(&w)), before);
}

/// A move of the head to `to` that poses the needle by the rotation vector `r`.
fn pose<'a>(w: &World, to: &'a [Point], r: Point) -> Command<'a> {
    head_move(w, to, NeedleMove::Posed(r))
}

/// The rotation vector (axis × angle) of the rotation whose columns are `x`, `y` and `x × y`.
fn rotation_vector(x: Point, y: Point) -> Point {
    let m = nalgebra::Matrix3::from_columns(&[x, y, x.cross(&y)]);
    nalgebra::Rotation3::from_matrix(&m).scaled_axis()
}

/// Rodrigues' formula, written here: `v` turned by the rotation vector `r`.
fn rodrigues(r: Point, v: Point) -> Point {
    let angle = r.norm();
    if angle == 0.0 {
        return v;
    }
    let k = r / angle;
    v * angle.cos() + k.cross(&v) * angle.sin() + k * k.dot(&v) * (1.0 - angle.cos())
}

/// A needle posed (`FLAG_POSE`) lies where the pose puts it, by the test's own arc formula: its swage
/// at the head, leaving it along `R·x` and curving toward `R·y`, every capsule end at
/// `c + r (R·x sin φ − R·y cos φ)`, `c = swage + r R·y`, for φ at the capsules' equal steps. Then,
/// posed step by step round its circle (as a stylus would turn it), its point cuts the holes where
/// it crosses the tissue's top (the test's own interpolation), and the rope threads both.
#[test]
fn a_posed_needle_lies_where_the_pose_puts_it_and_its_point_cuts_the_holes() {
    let scene = parse_scene(SCENE, "drive.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    // In the air first: a small move of the swage, and the needle turned a little from its scene pose
    // (along +x, curving down: a quarter turn about −x) about an oblique axis.
    let r = Point::new(-1.45, 0.1, 0.1);
    let to = [Point::new(0.05, 0.02, 1.6)];
    let cmd = pose(&w, &to, r);
    w.apply(&cmd).unwrap();
    let (t, b) = (rodrigues(r, Point::x()), rodrigues(r, Point::y()));
    let c = to[0] + b * R;
    let caps = needle(&w);
    let segments = caps.len();
    assert_eq!(segments, 6, "120° in capsules of 22.5° or less");
    for (k, (a, e)) in caps.iter().enumerate() {
        for (i, p) in [(k, a), (k + 1, e)] {
            let phi = 120f64.to_radians() * i as f64 / segments as f64;
            let want = c + (t * phi.sin() - b * phi.cos()) * R;
            assert!(
                (p - want).norm() < 1e-12,
                "capsule {k}: an end at {p:?}, the pose puts it at {want:?}"
            );
        }
    }
    assert!((joints(&w)[N] - to[0]).norm() < 1e-9);
    // Round a circle in the xz-plane about (0, 0, 0.55), clockwise seen from -y, from its top: the
    // swage at angle θ, leaving along (sin θ, 0, −cos θ) and curving toward the centre.
    let centre = Point::new(0.0, 0.0, 0.55);
    let frame = |theta: f64| {
        let s = centre + Point::new(theta.cos(), 0.0, theta.sin()) * R;
        let t = Point::new(theta.sin(), 0.0, -theta.cos());
        (s, rotation_vector(t, (centre - s) / R))
    };
    let turn = 250f64.to_radians();
    let steps = (turn / 0.05).ceil() as usize;
    let mut point_before = needle(&w).last().unwrap().1;
    let mut holes = Vec::new();
    for k in 0..=steps {
        let (s, r) = frame(90f64.to_radians() - turn * k as f64 / steps as f64);
        let to = [s];
        let cmd = pose(&w, &to, r);
        w.apply(&cmd)
            .unwrap_or_else(|e| panic!("pose {k} at {s:?}: {e:?}"));
        let caps = needle(&w);
        for (a, e) in &caps {
            for p in [a, e] {
                let off = ((p - centre).norm() - R).abs().max(p.y.abs());
                assert!(off < 1e-9, "pose {k}: a needle end {off:e} off the circle");
            }
        }
        let point = caps.last().unwrap().1;
        holes.extend(hole_where_the_point_crossed(
            &w,
            point_before,
            point,
            &format!("pose {k}"),
        ));
        point_before = point;
    }
    assert_eq!(holes.len(), 2, "the point crossed the surface at {holes:?}");
    let j = joints(&w);
    let e = eyelets(&w);
    assert_eq!(e.len(), 2, "{e:?}");
    for (i, (at, _, threaded)) in e.iter().enumerate() {
        assert!(*threaded, "eyelet {i} not threaded: {e:?}");
        assert!(off_rope(&j, *at) < 1e-9, "eyelet {i} off the rope");
    }
}
