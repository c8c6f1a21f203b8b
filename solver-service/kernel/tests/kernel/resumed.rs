//! A plain move of a held rope inside a frame (`stop_short`) whose one substep needs more than one
//! request's work (`keep_unfinished`): asked again, it goes on from the passes it kept and lands,
//! even when its held side's re-solve moves a joint more than half a clearance (a plain substep is
//! not guarded against that; a resumed one was, and threw its finished passes away every time: the
//! 320-link device ties' hand left 14 units behind, history.md, issue 68's eighth session). The
//! result is checked by this file's own code: lengths, the held end, the landing, the clearance to
//! the ball, and no crossing between the two states (`knots::check`, not the kernel's).
//!
//! The same substep as a pull (`solve_contacts_together`) is guarded: its resumed passes move a
//! joint farther than half a clearance, so they are thrown away and the piece is done again in
//! halves from the state it started (it locked there, and a device hand's pull ended jammed).

use nalgebra::Vector3;
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, Obstacle, move_joint_colliding,
};
use tractrix::{Chain, MoveOptions};

const N: usize = 40;
const LINK: f64 = 0.25;
const THICKNESS: f64 = 0.2;
/// The ball the rope's middle meets as it straightens: off the rope's plane, so the rope slides
/// over it in a few passes.
const BALL: ([f64; 3], f64) = ([4.95, 0.2, 0.3], 0.3);

/// `N` joints `LINK` apart along a circular arc (its chords a hair shorter) from (0, 0, 0) to (`chord`, 0, 0), bulging toward +y.
fn arc(chord: f64) -> Vec<Vector3<f64>> {
    let len = N as f64 * LINK;
    // The half-angle `a` subtended by the arc: sin(a) / a = chord / len, by bisection.
    let (mut lo, mut hi) = (1e-9, std::f64::consts::PI);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid.sin() / mid > chord / len {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = 0.5 * (lo + hi);
    let r = len / (2.0 * a);
    (0..=N)
        .map(|i| {
            let t = -a + 2.0 * a * i as f64 / N as f64;
            Vector3::new(chord / 2.0 + r * t.sin(), r * t.cos() - r * a.cos(), 0.0)
        })
        .collect()
}

/// Distance from `p` to the segment `a`–`b`.
fn to_segment(p: Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>) -> f64 {
    let d = b - a;
    let t = ((p - a).dot(&d) / d.dot(&d)).clamp(0.0, 1.0);
    (a + d * t - p).norm()
}

/// Link-steps per request: the substep's passes need about five requests' worth.
const WORK: u64 = 3000;

/// The rope of both tests, its ends held, and the ball's model.
fn rope_and_ball() -> (Vec<Vector3<f64>>, Chain<f64, 3>, CollisionModel<f64, 3>) {
    let start = arc(9.9);
    let mut rope = Chain::from_points(&start).unwrap();
    rope.hold(0).unwrap();
    rope.hold(N).unwrap();
    let (centre, radius) = (Vector3::from(BALL.0), BALL.1);
    let model = CollisionModel {
        options: CollisionOptions {
            thickness: THICKNESS,
            ..CollisionOptions::default()
        },
        obstacles: vec![Obstacle::Sphere {
            center: centre,
            radius,
        }],
        holding: Vec::new(),
    };
    (start, rope, model)
}

/// Checks `now` against `before` and the ball with this file's own code: every link its length in
/// `start`, none into the ball, none crossing between the two states.
fn check_state(start: &[Vector3<f64>], before: &[Vector3<f64>], now: &[Vector3<f64>], what: &str) {
    let (centre, radius) = (Vector3::from(BALL.0), BALL.1);
    let allowed = CollisionOptions::<f64>::default().tolerance * (radius + THICKNESS / 2.0);
    for (i, w) in now.windows(2).enumerate() {
        let length = (start[i + 1] - start[i]).norm();
        let off = ((w[1] - w[0]).norm() - length).abs();
        assert!(
            off <= 1e-12 * length,
            "{what}: link {i} is {off:e} off its length"
        );
        let gap = to_segment(centre, w[0], w[1]) - radius - THICKNESS / 2.0;
        assert!(gap >= -allowed, "{what}: link {i} is {gap:e} into the ball");
    }
    let crossed = knots::check::crossings_between(before, now, 2, 1e-9 * LINK);
    assert!(crossed.is_empty(), "{what}: links crossed: {crossed:?}");
}

#[test]
fn a_resumed_pull_that_moved_a_joint_too_far_goes_on_in_halves() {
    let (start, mut rope, model) = rope_and_ball();
    let mut ws = CollisionWorkspace::new();
    ws.stop_short(true);
    ws.keep_unfinished(true);
    ws.solve_contacts_together(true);
    let target = start[N] + Vector3::new(0.05, 0.0, 0.0);
    let (mut short, mut moved_short, mut landed) = (0, 0, None);
    let mut before = start.clone();
    for k in 0..256 {
        ws.limit_work(WORK);
        let o = move_joint_colliding(
            &mut rope,
            N,
            target,
            &MoveOptions::default(),
            &model,
            &mut ws,
        )
        .expect("inside a frame the pull stops short or lands");
        let now = rope.positions();
        check_state(&start, &before, &now, &format!("request {k}"));
        if let Some(s) = o.short {
            short += 1;
            if now != before {
                moved_short += 1;
            }
            assert!(
                !matches!(
                    s.error,
                    tractrix::ChainError::Jumped { .. } | tractrix::ChainError::Locked { .. }
                ),
                "request {k}: the pull locked ({:?})",
                s.error
            );
        } else {
            landed = Some(k);
            break;
        }
        before = now;
    }
    let landed = landed.unwrap_or_else(|| panic!("256 requests toward one target never landed"));
    let now = rope.positions();
    assert_eq!(now[0], start[0], "the held end moved");
    assert!(
        (now[N] - target).norm() <= 1e-12,
        "request {landed}: the end is not at its target"
    );
    assert!(
        moved_short >= 1 && short >= 2,
        "{short} stopped short, {moved_short} of them part of the way: not the case tested"
    );
}

#[test]
fn a_resumed_plain_substep_lands_even_when_its_held_side_moves_far() {
    let (start, mut rope, model) = rope_and_ball();
    let (centre, radius) = (Vector3::from(BALL.0), BALL.1);
    let mut ws = CollisionWorkspace::new();
    ws.stop_short(true);
    ws.keep_unfinished(true);
    // The held end pulled 0.05 along the chord: one substep, the rope's middle drops about 0.3.
    let target = start[N] + Vector3::new(0.05, 0.0, 0.0);
    let (mut short, mut landed) = (0, None);
    for k in 0..64 {
        ws.limit_work(WORK);
        let o = move_joint_colliding(
            &mut rope,
            N,
            target,
            &MoveOptions::default(),
            &model,
            &mut ws,
        )
        .expect("inside a frame the move stops short or lands");
        let now = rope.positions();
        if o.short.is_none() {
            landed = Some(k);
            break;
        }
        short += 1;
        assert_eq!(
            now, start,
            "request {k}: stopped short before a whole substep, yet moved"
        );
    }
    let landed = landed.unwrap_or_else(|| panic!("64 requests toward one target never landed"));
    assert!(
        short >= 2,
        "the substep fit one request ({short} stopped short): not the case tested"
    );
    let now = rope.positions();
    assert_eq!(now[0], start[0], "the held end moved");
    assert!(
        (now[N] - target).norm() <= 1e-12,
        "request {landed}: the end is not at its target"
    );
    for (i, w) in now.windows(2).enumerate() {
        let length = (start[i + 1] - start[i]).norm();
        let off = ((w[1] - w[0]).norm() - length).abs();
        assert!(off <= 1e-12 * length, "link {i} is {off:e} off its length");
        let gap = to_segment(centre, w[0], w[1]) - radius - THICKNESS / 2.0;
        let allowed = model.options.tolerance * (radius + THICKNESS / 2.0);
        assert!(gap >= -allowed, "link {i} is {gap:e} into the ball");
    }
    let jump = start
        .iter()
        .zip(&now)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(
        jump > THICKNESS / 2.0,
        "a joint moved {jump}: not the case tested"
    );
    let crossed = knots::check::crossings_between(&start, &now, 2, 1e-9 * LINK);
    assert!(crossed.is_empty(), "links crossed: {crossed:?}");
}
