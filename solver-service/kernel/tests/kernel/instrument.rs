//! Instruments (issue 16): an obstacle moved by pose pushes the rope out of its way, never deeper than
//! the collision tolerance (checked by a distance written here), keeps lengths and held joints, and
//! locks (nothing changes) when the rope would have to pass through it.

use crate::support::max_length_error;
use nalgebra::Vector3;
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, Obstacle, push_by_obstacle,
};
use tractrix::{Chain, ChainError};

type V = Vector3<f64>;
const THICKNESS: f64 = 0.2;
const TOLERANCE: f64 = 0.01;

fn model(obstacles: Vec<Obstacle<f64, 3>>) -> CollisionModel<f64, 3> {
    CollisionModel {
        options: CollisionOptions {
            thickness: THICKNESS,
            ..CollisionOptions::default()
        },
        obstacles,
        holding: Vec::new(),
    }
}

/// Distance from `p` to the segment `a`–`b`, written here (not the kernel's).
fn point_segment(p: V, a: V, b: V) -> f64 {
    let ab = b - a;
    let len2 = ab.dot(&ab);
    let t = if len2 > 0.0 {
        ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).norm()
}

/// Smallest gap between the rope's surface and a sphere's (negative: penetration), over all links.
fn sphere_gap(points: &[V], c: V, r: f64) -> f64 {
    points
        .windows(2)
        .map(|w| point_segment(c, w[0], w[1]) - r - THICKNESS / 2.0)
        .fold(f64::INFINITY, f64::min)
}

fn bits(c: &Chain<f64, 3>) -> Vec<[u64; 3]> {
    c.positions()
        .iter()
        .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect()
}

/// Smallest gap between the rope's surface and a capsule's, sampled along each link (written here).
fn capsule_gap(points: &[V], a: V, b: V, r: f64) -> f64 {
    points
        .windows(2)
        .flat_map(|w| {
            (0..=200).map(move |i| point_segment(w[0] + (w[1] - w[0]) * (i as f64 / 200.0), a, b))
        })
        .fold(f64::INFINITY, f64::min)
        - r
        - THICKNESS / 2.0
}

#[test]
fn a_sphere_pushing_off_centre_lets_the_rope_slip_by_without_penetration() {
    // A ball driven across the rope a little above its axis: the rope slides under it, as a real one
    // would, and is never entered.
    let mut rope = Chain::<f64, 3>::straight(40, 1.0, V::zeros(), V::x()).unwrap();
    let r = 0.5;
    let mut m = model(vec![Obstacle::Sphere {
        center: V::new(20.3, -3.0, 0.05),
        radius: r,
    }]);
    let mut ws = CollisionWorkspace::new();
    for k in 1..=12 {
        let c = V::new(20.3, -3.0 + 0.5 * k as f64, 0.05);
        let to = Obstacle::Sphere {
            center: c,
            radius: r,
        };
        push_by_obstacle(&mut rope, &m, 0, &to, 1000, &mut ws).expect("a free rope gives way");
        m.obstacles[0] = to;
        let gap = sphere_gap(&rope.positions(), c, r);
        assert!(gap >= -TOLERANCE * (r + THICKNESS / 2.0), "step {k}: {gap}");
        assert!(max_length_error(&rope) < 1e-12);
    }
}

#[test]
fn a_rod_swept_across_a_free_rope_carries_it_along() {
    let mut rope = Chain::<f64, 3>::straight(40, 1.0, V::zeros(), V::x()).unwrap();
    let r = 0.3;
    let rod = |y: f64| Obstacle::Capsule {
        a: V::new(20.3, y, -3.0),
        b: V::new(20.3, y, 3.0),
        radius: r,
    };
    let mut m = model(vec![rod(-3.0)]);
    let mut ws = CollisionWorkspace::new();
    for k in 1..=12 {
        let y = -3.0 + 0.5 * k as f64;
        push_by_obstacle(&mut rope, &m, 0, &rod(y), 1000, &mut ws).expect("a free rope gives way");
        m.obstacles[0] = rod(y);
        let gap = capsule_gap(
            &rope.positions(),
            V::new(20.3, y, -3.0),
            V::new(20.3, y, 3.0),
            r,
        );
        assert!(gap >= -TOLERANCE * (r + THICKNESS / 2.0), "step {k}: {gap}");
        assert!(max_length_error(&rope) < 1e-12);
    }
    // The rope is hooked on the rod: where it crosses the plane x = 20.3 of the rod's axis, it lies
    // ahead of the rod (y beyond 3 + clearance), not behind it.
    let p = rope.positions();
    let crossings: Vec<f64> = p
        .windows(2)
        .filter(|w| (w[0].x - 20.3) * (w[1].x - 20.3) <= 0.0 && w[0].x != w[1].x)
        .map(|w| {
            let t = (20.3 - w[0].x) / (w[1].x - w[0].x);
            w[0].y + (w[1].y - w[0].y) * t
        })
        .collect();
    assert!(!crossings.is_empty());
    let clearance = r + THICKNESS / 2.0;
    assert!(
        crossings
            .iter()
            .all(|&y| y >= 3.0 + clearance * (1.0 - TOLERANCE)),
        "{crossings:?}"
    );
}

#[test]
fn held_joints_stay_bit_for_bit_while_an_instrument_pushes() {
    // A slack rope: a hairpin of 20 links out and 20 back, ends held.
    let mut pts: Vec<V> = (0..=20).map(|k| V::new(k as f64, 0.0, 0.0)).collect();
    pts.extend((0..20).rev().map(|k| V::new(k as f64 + 0.5, 2.0, 0.0)));
    let mut rope = Chain::<f64, 3>::from_points(&pts).unwrap();
    let n = rope.n_links();
    rope.hold(0).unwrap();
    rope.hold(n).unwrap();
    let held_before = [rope.joint(0), rope.joint(n)];
    let r = 0.3;
    let mut m = model(vec![Obstacle::Sphere {
        center: V::new(8.2, -2.0, 0.0),
        radius: r,
    }]);
    let mut ws = CollisionWorkspace::new();
    // Up to y = 0.4: the lower strand is pushed to y ≈ 0.85, still clear of the upper one at y = 2.
    for k in 1..=6 {
        let c = V::new(8.2, -2.0 + 0.4 * k as f64, 0.0);
        let to = Obstacle::Sphere {
            center: c,
            radius: r,
        };
        push_by_obstacle(&mut rope, &m, 0, &to, 1000, &mut ws).expect("slack rope gives way");
        m.obstacles[0] = to;
        let after = [rope.joint(0), rope.joint(n)];
        for (a, b) in held_before.iter().zip(&after) {
            assert_eq!(
                [a.x.to_bits(), a.y.to_bits(), a.z.to_bits()],
                [b.x.to_bits(), b.y.to_bits(), b.z.to_bits()]
            );
        }
        let gap = sphere_gap(&rope.positions(), c, r);
        assert!(gap >= -TOLERANCE * (r + THICKNESS / 2.0), "step {k}: {gap}");
        assert!(max_length_error(&rope) < 1e-12);
    }
}

#[test]
fn driving_a_taut_held_rope_through_an_instrument_locks_and_changes_nothing() {
    let mut rope = Chain::<f64, 3>::straight(20, 1.0, V::zeros(), V::x()).unwrap();
    rope.hold(0).unwrap();
    rope.hold(20).unwrap();
    let before = bits(&rope);
    let start = Obstacle::Capsule {
        a: V::new(10.0, -1.0, -2.0),
        b: V::new(10.0, -1.0, 2.0),
        radius: 0.2,
    };
    let m = model(vec![start]);
    let mut ws = CollisionWorkspace::new();
    // A post swept across the taut rope: the rope cannot stretch around it.
    let to = Obstacle::Capsule {
        a: V::new(10.0, 3.0, -2.0),
        b: V::new(10.0, 3.0, 2.0),
        radius: 0.2,
    };
    let e = push_by_obstacle(&mut rope, &m, 0, &to, 1000, &mut ws).unwrap_err();
    assert!(matches!(e, ChainError::Locked { .. }), "{e:?}");
    assert_eq!(bits(&rope), before, "a locked push changes nothing");
}

#[test]
fn a_capsule_turned_about_its_centre_sweeps_the_rope_and_bad_poses_are_refused() {
    let mut rope = Chain::<f64, 3>::straight(30, 1.0, V::zeros(), V::x()).unwrap();
    let start = Obstacle::Capsule {
        a: V::new(15.0, 1.0, 0.0),
        b: V::new(15.0, 5.0, 0.0),
        radius: 0.25,
    };
    let m = model(vec![start]);
    let mut ws = CollisionWorkspace::new();
    // A quarter turn about its centre (15, 3, 0), clear of the rope, then down across it.
    let turned = Obstacle::Capsule {
        a: V::new(13.0, 3.0, 0.0),
        b: V::new(17.0, 3.0, 0.0),
        radius: 0.25,
    };
    let mut m2 = m.clone();
    push_by_obstacle(&mut rope, &m, 0, &turned, 10_000, &mut ws).unwrap();
    m2.obstacles[0] = turned;
    let down = Obstacle::Capsule {
        a: V::new(13.0, -2.0, 0.0),
        b: V::new(17.0, -2.0, 0.0),
        radius: 0.25,
    };
    push_by_obstacle(&mut rope, &m2, 0, &down, 10_000, &mut ws).unwrap();
    let p = rope.positions();
    let gap = capsule_gap(&p, V::new(13.0, -2.0, 0.0), V::new(17.0, -2.0, 0.0), 0.25);
    assert!(gap >= -TOLERANCE * (0.25 + THICKNESS / 2.0), "{gap}");
    assert!(p[15].y < -2.0, "the rope was swept down: {:?}", p[15]);

    // Bad poses: another radius, another length, a plane, an instrument that is not there.
    let before = bits(&rope);
    let grown = Obstacle::Capsule {
        a: V::new(13.0, -2.0, 0.0),
        b: V::new(17.0, -2.0, 0.0),
        radius: 0.3,
    };
    let longer = Obstacle::Capsule {
        a: V::new(12.0, -2.0, 0.0),
        b: V::new(17.0, -2.0, 0.0),
        radius: 0.25,
    };
    let mut m3 = m2.clone();
    m3.obstacles[0] = down;
    for bad in [grown, longer] {
        let e = push_by_obstacle(&mut rope, &m3, 0, &bad, 10_000, &mut ws).unwrap_err();
        assert!(matches!(e, ChainError::BadOption(_)), "{e:?}");
    }
    assert!(push_by_obstacle(&mut rope, &m3, 1, &down, 10_000, &mut ws).is_err());
    let far = Obstacle::Capsule {
        a: V::new(1013.0, -2.0, 0.0),
        b: V::new(1017.0, -2.0, 0.0),
        radius: 0.25,
    };
    let e = push_by_obstacle(&mut rope, &m3, 0, &far, 100, &mut ws).unwrap_err();
    assert!(matches!(e, ChainError::TooManySubsteps { .. }), "{e:?}");
    assert_eq!(bits(&rope), before);
}

#[test]
fn an_instrument_holding_the_end_moves_with_it_and_pushes_only_the_rest() {
    use tractrix::MoveOptions;
    use tractrix::collision::{Holding, move_joint_colliding};
    let run = |holding: Vec<Holding>| -> Result<Chain<f64, 3>, ChainError> {
        let mut rope = Chain::<f64, 3>::straight(20, 1.0, V::zeros(), V::x()).unwrap();
        rope.hold(20).unwrap();
        let r = 0.3;
        // Jaws around the end: a ball on the grasped joint, holding the last two links.
        let mut m = model(vec![Obstacle::Sphere {
            center: V::new(20.0, 0.0, 0.0),
            radius: r,
        }]);
        m.holding = holding;
        let mut ws = CollisionWorkspace::new();
        for k in 1..=10 {
            let step = V::new(-0.3, 0.25, 0.0);
            let head = rope.joint(20) + step;
            move_joint_colliding(&mut rope, 20, head, &MoveOptions::default(), &m, &mut ws)?;
            let Obstacle::Sphere { center, .. } = m.obstacles[0] else {
                unreachable!()
            };
            let to = Obstacle::Sphere {
                center: center + step,
                radius: r,
            };
            push_by_obstacle(&mut rope, &m, 0, &to, 1000, &mut ws)?;
            m.obstacles[0] = to;
            let p = rope.positions();
            assert_eq!(p[20], head, "step {k}: the hand's joint stays on its path");
            // Every link but the two held ones clear of the jaws (distance computed here).
            let c = head;
            let gap = p[..19]
                .windows(2)
                .map(|w| point_segment(c, w[0], w[1]) - r - THICKNESS / 2.0)
                .fold(f64::INFINITY, f64::min);
            assert!(gap >= -TOLERANCE * (r + THICKNESS / 2.0), "step {k}: {gap}");
            assert!(max_length_error(&rope) < 1e-12);
        }
        Ok(rope)
    };
    run(vec![Holding {
        obstacle: 0,
        links: 18..20,
    }])
    .expect("the held links do not count against the jaws");
    // Without it, the jaws sit on links the held joint cannot let go of: the first move locks.
    let e = run(vec![]).unwrap_err();
    assert!(matches!(e, ChainError::Locked { .. }), "{e:?}");
}
