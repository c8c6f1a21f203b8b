//! Goals beyond a point for a fixed-base chain (Korein & Badler, "Techniques for generating the
//! goal-directed motion of articulated structures"): an orientation goal and goals in a region.
//!
//! * [`Goal::Pose`]: the head at a point *and* the last link along a direction ("we may add to the goal
//!   a constraint on the orientation of the last link"). The last link is fixed by the orientation, so
//!   its base joint, the wrist, becomes a position goal for the rest: the chain without its last link
//!   reaches the wrist by the options' strategy (the two-link closed form where it applies), then the
//!   last link is laid along the direction. A wrist outside the shorter chain's workspace is refused
//!   with the nearest head that keeps the direction; a pose whose last joint breaks its limit is
//!   refused as such. A chain's links are directions without a roll, so a spatial goal has no roll to
//!   set.
//! * [`Goal::Box`], [`Goal::Ball`]: the head anywhere inside a region ("constrain the fingertip to lie
//!   within a rectangular box"). A head already inside does not move; otherwise the chain reaches for
//!   the region's nearest point to the head, a tolerance inside its boundary (so the solved head lies
//!   in the region, not a tolerance outside it), which moves it only as far as needed. The goal is the
//!   region and the workspace together: when that point is outside the workspace (the shell between
//!   [`workspace_radii`]), the aim moves along the region toward its point nearest to (or, for the
//!   workspace's hole, farthest from) the base until it is inside. A region refused has no point in
//!   common with the workspace; the refusal names the workspace's point nearest to it.
//!
//! [`reach_goal`] with [`Goal::Point`] is [`reach`].

use crate::chain::{Chain, ChainError};
use crate::fixed_base::{
    ReachError, ReachOptions, ReachOutcome, ReachWorkspace, nearest_reachable, reach,
    workspace_radii,
};
use crate::math::{Embed3, Real, Vector, all_finite, positive_finite};

/// What a fixed-base reach asks of the head.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal<T: Real, const D: usize> {
    /// The head at a point ([`reach`]).
    Point(Vector<T, D>),
    /// The head at `at`, the last link pointing along `direction` (any length but zero).
    Pose {
        /// Where the head goes.
        at: Vector<T, D>,
        /// The last link's direction, from its base joint to the head.
        direction: Vector<T, D>,
    },
    /// The head inside the axis-aligned box from `lo` to `hi` (each coordinate `lo ≤ hi`).
    Box {
        /// The corner of the smallest coordinates.
        lo: Vector<T, D>,
        /// The corner of the largest coordinates.
        hi: Vector<T, D>,
    },
    /// The head within `radius` of `centre`.
    Ball {
        /// The ball's centre.
        centre: Vector<T, D>,
        /// Its radius (positive).
        radius: T,
    },
}

impl<T: Real, const D: usize> Goal<T, D> {
    /// Whether `p` meets a region goal (a point or pose goal: whether `p` is its point).
    pub fn contains(&self, p: &Vector<T, D>) -> bool {
        match self {
            Goal::Point(q) | Goal::Pose { at: q, .. } => p == q,
            Goal::Box { lo, hi } => (0..D).all(|i| lo[i] <= p[i] && p[i] <= hi[i]),
            Goal::Ball { centre, radius } => (p - centre).norm() <= *radius,
        }
    }

    /// The goal's nearest point to `p`, `margin` inside a region's boundary where the region is wider
    /// than twice the margin (its middle where it is not).
    fn nearest_inside(&self, p: &Vector<T, D>, margin: T) -> Vector<T, D> {
        match self {
            Goal::Point(q) | Goal::Pose { at: q, .. } => *q,
            Goal::Box { lo, hi } => {
                let mut q = *p;
                for i in 0..D {
                    let m = margin.min((hi[i] - lo[i]) * T::lit(0.5));
                    q[i] = q[i].max(lo[i] + m).min(hi[i] - m);
                }
                q
            }
            Goal::Ball { centre, radius } => {
                let d = p - centre;
                let r = d.norm();
                let inner = (*radius - margin).max(*radius * T::lit(0.5));
                if r <= inner {
                    *p
                } else {
                    centre + d * (inner / r)
                }
            }
        }
    }

    /// The goal's farthest point from `p`, `margin` inside a region's boundary as in
    /// [`Goal::nearest_inside`] (a box's farthest corner, a ball's point opposite `p`).
    fn farthest_inside(&self, p: &Vector<T, D>, margin: T) -> Vector<T, D> {
        match self {
            Goal::Point(q) | Goal::Pose { at: q, .. } => *q,
            Goal::Box { lo, hi } => {
                let mut q = *p;
                for i in 0..D {
                    let m = margin.min((hi[i] - lo[i]) * T::lit(0.5));
                    let (a, b) = (lo[i] + m, hi[i] - m);
                    q[i] = if (p[i] - a).abs() >= (b - p[i]).abs() {
                        a
                    } else {
                        b
                    };
                }
                q
            }
            Goal::Ball { centre, radius } => {
                let inner = (*radius - margin).max(*radius * T::lit(0.5));
                let d = centre - p;
                let r = d.norm();
                if r > T::zero() {
                    centre + d * (inner / r)
                } else {
                    let mut e = Vector::zeros();
                    e[0] = inner;
                    centre + e
                }
            }
        }
    }

    fn check(&self) -> Result<(), ChainError> {
        let finite = match self {
            Goal::Point(q) => all_finite(q),
            Goal::Pose { at, direction } => all_finite(at) && all_finite(direction),
            Goal::Box { lo, hi } => all_finite(lo) && all_finite(hi),
            Goal::Ball { centre, radius } => all_finite(centre) && radius.is_finite(),
        };
        if !finite {
            return Err(ChainError::NonFinite);
        }
        match self {
            Goal::Pose { direction, .. } if !positive_finite(direction.norm()) => Err(
                ChainError::BadOption("an orientation goal needs a direction of non-zero length"),
            ),
            Goal::Box { lo, hi } if (0..D).any(|i| lo[i] > hi[i]) => Err(ChainError::BadOption(
                "a box goal needs lo ≤ hi in every coordinate",
            )),
            Goal::Ball { radius, .. } if !positive_finite(*radius) => {
                Err(ChainError::BadOption("a ball goal needs a positive radius"))
            }
            _ => Ok(()),
        }
    }
}

/// Reaches for `goal` with the options' strategy (see the module). On success the outcome's residual
/// is the head's distance from the goal's point (zero for a region it lies in); on an error nothing
/// moves. For a region the head already lies in, nothing moves and no iteration runs. A pose goal
/// builds the chain without its last link (it allocates); the other goals allocate nothing.
pub fn reach_goal<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    goal: &Goal<T, D>,
    opts: &ReachOptions<T>,
    ws: &mut ReachWorkspace<T, D>,
) -> Result<ReachOutcome<T>, ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    goal.check()?;
    match goal {
        Goal::Point(p) => reach(chain, p, opts, ws),
        Goal::Pose { at, direction } => reach_pose(chain, at, direction, opts, ws),
        Goal::Box { .. } | Goal::Ball { .. } => {
            let head = chain.head();
            if goal.contains(&head) {
                return Ok(ReachOutcome {
                    iterations: 0,
                    residual: T::zero(),
                });
            }
            let tol = opts.tolerance * chain.total_length();
            // Twice the tolerance inside: the solve lands within the tolerance of its aim.
            let aim = goal.nearest_inside(&head, tol * T::lit(2.0));
            let aim = region_aim(goal, chain, &aim, tol * T::lit(2.0))?;
            let mut o = reach(chain, &aim, opts, ws)?;
            let head = chain.head();
            o.residual = if goal.contains(&head) {
                T::zero()
            } else {
                (goal.nearest_inside(&head, T::zero()) - head).norm()
            };
            Ok(o)
        }
    }
}

/// Where a region goal's reach aims: `start` (the region's point nearest the head, `margin` inside)
/// if the workspace holds it, else a point of the region and the workspace together, on the segment
/// from `start` to the region's point nearest to the base (`start` beyond the workspace) or farthest
/// from it (`start` in the workspace's hole), `margin` inside both where they overlap by more. When
/// they have no point in common, the refusal with the workspace's point nearest to the region.
fn region_aim<T: Real, const D: usize>(
    goal: &Goal<T, D>,
    chain: &Chain<T, D>,
    start: &Vector<T, D>,
    margin: T,
) -> Result<Vector<T, D>, ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    let base = chain.origin();
    let lengths = chain.lengths();
    let fallback = chain.head() - base;
    let (inner, outer) = workspace_radii(lengths);
    let dist = |q: &Vector<T, D>| (q - base).norm();
    // The region meets the shell iff its nearest point to the base is inside the outer sphere and its
    // farthest outside the inner one (the region is convex: between them lie all distances).
    let near = goal.nearest_inside(&base, T::zero());
    let far = goal.farthest_inside(&base, T::zero());
    for (edge, apart) in [(near, dist(&near) > outer), (far, dist(&far) < inner)] {
        if apart {
            let (nearest, residual) = nearest_reachable(&base, lengths, &edge, &fallback);
            return Err(ReachError::Unreachable { nearest, residual });
        }
    }
    let (lo, hi) = if inner + margin <= outer - margin {
        (inner + margin, outer - margin)
    } else {
        let mid = (inner + outer) * T::lit(0.5);
        (mid, mid)
    };
    let r0 = dist(start);
    if lo <= r0 && r0 <= hi {
        return Ok(*start);
    }
    // Toward the base's nearest point when too far, its farthest when too near; the margin kept
    // inside the region where the shrunk region still reaches the wanted distance.
    let (rho, shrunk, edge) = if r0 > hi {
        (hi, goal.nearest_inside(&base, margin), near)
    } else {
        (lo, goal.farthest_inside(&base, margin), far)
    };
    let past = |q: &Vector<T, D>| {
        if r0 > hi {
            dist(q) <= rho
        } else {
            dist(q) >= rho
        }
    };
    let end = if past(&shrunk) {
        shrunk
    } else if past(&edge) {
        edge
    } else {
        // The overlap is thinner than the margin: the workspace's point nearest to the region's edge
        // (the solve lands within its tolerance of the region).
        return Ok(nearest_reachable(&base, lengths, &edge, &fallback).0);
    };
    // Bisection on the segment: `start` is short of the distance, `end` past it.
    let (mut a, mut b) = (T::zero(), T::one());
    for _ in 0..64 {
        let t = (a + b) * T::lit(0.5);
        if past(&(start + (end - start) * t)) {
            b = t;
        } else {
            a = t;
        }
    }
    Ok(start + (end - start) * b)
}

/// [`Goal::Pose`]: the chain without its last link reaches the wrist, then the last link is laid
/// along the direction.
fn reach_pose<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    at: &Vector<T, D>,
    direction: &Vector<T, D>,
    opts: &ReachOptions<T>,
    ws: &mut ReachWorkspace<T, D>,
) -> Result<ReachOutcome<T>, ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    let n = chain.n_links();
    if n < 2 {
        return Err(ChainError::BadOption("an orientation goal needs two links or more").into());
    }
    let d = direction / direction.norm();
    let last = chain.lengths()[n - 1];
    let wrist = at - d * last;
    let mut arm = Chain::from_raw_parts(
        chain.origin(),
        chain.links()[..n - 1].to_vec(),
        chain.lengths()[..n - 1].to_vec(),
    )?;
    if let Some(l) = chain.joint_limits() {
        arm.set_limits(Some(l.sub(0, n - 1, false)))
            .map_err(|_| ChainError::BadOption("limits of the arm without its last link"))?;
    }
    let outcome = match reach(&mut arm, &wrist, opts, ws) {
        Ok(o) => o,
        Err(ReachError::Unreachable { nearest, residual }) => {
            return Err(ReachError::Unreachable {
                nearest: nearest + d * last,
                residual,
            });
        }
        Err(ReachError::NotConverged {
            iterations,
            residual,
            reached,
        }) => {
            return Err(ReachError::NotConverged {
                iterations,
                residual,
                reached: reached.map(|w| w + d * last),
            });
        }
        Err(e) => return Err(e),
    };
    let backup: Vec<Vector<T, D>> = chain.links().to_vec();
    let links = chain.links_mut();
    links[..n - 1].copy_from_slice(arm.links());
    links[n - 1] = d * last;
    if chain.joint_limits().is_some()
        && let Err(e) = chain.check_limits()
    {
        chain.links_mut().copy_from_slice(&backup);
        return Err(e.into());
    }
    Ok(ReachOutcome {
        iterations: outcome.iterations,
        residual: (chain.head() - at).norm(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Vector2, Vector3};

    /// The paper's planar arm: 10 links of 0.2 along +x from the origin.
    fn arm() -> Chain<f64, 2> {
        Chain::straight(10, 0.2, Vector2::zeros(), Vector2::x()).unwrap()
    }

    /// Joint positions summed here from the links (not the chain's own sum).
    fn joints(c: &Chain<f64, 2>) -> Vec<Vector2<f64>> {
        let mut p = vec![c.origin()];
        for l in c.links() {
            let last = p[p.len() - 1];
            p.push(last + l);
        }
        p
    }

    #[test]
    fn a_pose_goal_puts_the_head_there_and_the_last_link_along_the_direction() {
        let opts = ReachOptions::default();
        let mut ws = ReachWorkspace::default();
        for (at, dir) in [
            (Vector2::new(1.2, 0.9), Vector2::new(0.0, 1.0)),
            (Vector2::new(-0.8, 0.5), Vector2::new(-1.0, -1.0)),
            (Vector2::new(0.3, -1.4), Vector2::new(1.0, 0.2)),
        ] {
            let mut c = arm();
            let o = reach_goal(&mut c, &Goal::Pose { at, direction: dir }, &opts, &mut ws)
                .unwrap_or_else(|e| panic!("{at:?} {dir:?}: {e}"));
            let p = joints(&c);
            let head = p[p.len() - 1];
            let last = head - p[p.len() - 2];
            assert!((head - at).norm() <= 2.0 * 1e-9 * 2.0, "{:?}", head - at);
            // The last link's direction, by the angle between it and the goal's.
            let cos = last.dot(&dir) / (last.norm() * dir.norm());
            assert!(cos > 1.0 - 1e-12, "{cos}");
            assert!((o.residual - (head - at).norm()).abs() < 1e-12);
            assert!(p[0].norm() == 0.0, "the base stays");
        }
    }

    #[test]
    fn a_pose_goal_out_of_reach_is_refused_with_a_head_that_keeps_the_direction() {
        let mut c = arm();
        let before = c.clone();
        let goal = Goal::Pose {
            at: Vector2::new(2.1, 0.0),
            direction: Vector2::new(0.0, 1.0),
        };
        let e = reach_goal(
            &mut c,
            &goal,
            &ReachOptions::default(),
            &mut ReachWorkspace::default(),
        )
        .unwrap_err();
        let ReachError::Unreachable { nearest, .. } = e else {
            panic!("{e:?}")
        };
        // The wrist would be at (2.1, -0.2), beyond the 1.8 of nine links: the nearest wrist is on
        // that circle, the head 0.2 above it.
        let wrist = nearest - Vector2::new(0.0, 0.2);
        assert!((wrist.norm() - 1.8).abs() < 1e-12, "{wrist:?}");
        assert_eq!(c.links(), before.links(), "nothing moved");
    }

    #[test]
    fn a_head_inside_a_region_does_not_move_and_one_outside_moves_into_it() {
        let opts = ReachOptions::default();
        let mut ws = ReachWorkspace::default();
        let mut c = arm();
        let before = c.clone();
        // The head is at (2, 0): inside this box and this ball.
        for goal in [
            Goal::Box {
                lo: Vector2::new(1.5, -0.5),
                hi: Vector2::new(2.5, 0.5),
            },
            Goal::Ball {
                centre: Vector2::new(1.9, 0.1),
                radius: 0.2,
            },
        ] {
            let o = reach_goal(&mut c, &goal, &opts, &mut ws).unwrap();
            assert_eq!((o.iterations, o.residual), (0, 0.0));
            assert_eq!(c.links(), before.links());
        }
        // Outside: the head ends in the region, near the boundary point nearest to where it was.
        let boxed = Goal::Box {
            lo: Vector2::new(0.5, 0.8),
            hi: Vector2::new(1.0, 1.2),
        };
        reach_goal(&mut c, &boxed, &opts, &mut ws).unwrap();
        let h = joints(&c)[10];
        assert!(
            (0.5..=1.0).contains(&h.x) && (0.8..=1.2).contains(&h.y),
            "{h:?}"
        );
        // The box's nearest point to (2, 0) is its corner (1.0, 0.8).
        assert!((h - Vector2::new(1.0, 0.8)).norm() < 1e-6, "{h:?}");
        let ball = Goal::Ball {
            centre: Vector2::new(-1.0, 0.0),
            radius: 0.25,
        };
        reach_goal(&mut c, &ball, &opts, &mut ws).unwrap();
        let h = joints(&c)[10];
        let r = (h - Vector2::new(-1.0, 0.0)).norm();
        assert!(r <= 0.25 && r > 0.25 - 1e-6, "{r}");
    }

    #[test]
    fn a_region_out_of_reach_is_refused_and_one_partly_in_reach_is_met() {
        let opts = ReachOptions::default();
        let mut ws = ReachWorkspace::default();
        let mut c = arm();
        let far = Goal::Ball {
            centre: Vector2::new(3.0, 0.0),
            radius: 0.5,
        };
        let e = reach_goal(&mut c, &far, &opts, &mut ws).unwrap_err();
        assert!(matches!(e, ReachError::Unreachable { .. }), "{e:?}");
        // A ball reaching 0.1 into the workspace from outside: met at its inner edge.
        let edge = Goal::Ball {
            centre: Vector2::new(0.0, 2.2),
            radius: 0.3,
        };
        reach_goal(&mut c, &edge, &opts, &mut ws).unwrap();
        let h = joints(&c)[10];
        assert!((h - Vector2::new(0.0, 2.2)).norm() <= 0.3, "{h:?}");
    }

    /// The default scene's arm (reach 2, head at (2, 0)): a box round the head's corner of the
    /// workspace holds reachable points such as (1.98, 0.05), though its point nearest the head is
    /// out of reach; the head ends in the box and in reach, by the test's own distances. A box beyond
    /// the reach by 1e-6 is refused.
    #[test]
    fn a_region_the_workspace_only_partly_holds_is_met() {
        let opts = ReachOptions::default();
        let mut ws = ReachWorkspace::default();
        let mut c = arm();
        let (lo, hi) = (Vector2::new(1.95, 0.01), Vector2::new(2.1, 0.1));
        assert!(
            (Vector2::new(1.98, 0.05)).norm() < 2.0,
            "the box holds a reachable point"
        );
        reach_goal(&mut c, &Goal::Box { lo, hi }, &opts, &mut ws).unwrap();
        let h = joints(&c)[10];
        assert!(
            h.x >= lo.x && h.x <= hi.x && h.y >= lo.y && h.y <= hi.y,
            "{h:?}"
        );
        assert!(h.norm() <= 2.0 + 1e-12, "{h:?}");
        // The same round the hole of a chain whose first link is longer than the rest together.
        let mut c = Chain::from_raw_parts(
            Vector2::zeros(),
            vec![Vector2::new(3.0, 0.0), Vector2::new(1.0, 0.0)],
            vec![3.0, 1.0],
        )
        .unwrap();
        // The workspace is the ring 2 ≤ r ≤ 4; this box reaches from r 1.5 to just past 2, its
        // point nearest the head (4, 0) in the hole.
        let (lo, hi) = (Vector2::new(-0.1, 1.5), Vector2::new(0.1, 2.05));
        reach_goal(&mut c, &Goal::Box { lo, hi }, &opts, &mut ws).unwrap();
        let h = c.origin() + c.links()[0] + c.links()[1];
        assert!(
            h.x >= lo.x && h.x <= hi.x && h.y >= lo.y && h.y <= hi.y,
            "{h:?}"
        );
        assert!(h.norm() >= 2.0 - 1e-9, "{h:?}");
        let mut c = arm();
        let out = Goal::Box {
            lo: Vector2::new(2.0 + 1e-6, -0.1),
            hi: Vector2::new(2.1, 0.1),
        };
        let e = reach_goal(&mut c, &out, &opts, &mut ws).unwrap_err();
        let ReachError::Unreachable { nearest, residual } = e else {
            panic!("{e:?}")
        };
        assert!(
            (nearest - Vector2::new(2.0, 0.0)).norm() < 1e-12,
            "{nearest:?}"
        );
        assert!((residual - 1e-6).abs() < 1e-12, "{residual}");
    }

    #[test]
    fn a_pose_that_breaks_the_last_joint_s_range_is_refused_and_one_within_is_met() {
        let opts = ReachOptions::default();
        let mut ws = ReachWorkspace::default();
        let mut c = arm();
        let (lo, hi) = (-60f64.to_radians(), 30f64.to_radians());
        c.set_limits(Some(
            crate::JointLimits::ranges(&[lo; 11], &[hi; 11]).unwrap(),
        ))
        .unwrap();
        let before = c.clone();
        // The last link pointing back at the base from near full reach: a turn of about 180°.
        let back = Goal::Pose {
            at: Vector2::new(1.6, 0.0),
            direction: Vector2::new(-1.0, 0.0),
        };
        assert!(reach_goal(&mut c, &back, &opts, &mut ws).is_err());
        assert_eq!(c.links(), before.links(), "nothing moved");
        // Straight on along +x, 0.2 short of full reach: within every range.
        let on = Goal::Pose {
            at: Vector2::new(1.7, 0.3),
            direction: Vector2::new(1.0, 0.0),
        };
        reach_goal(&mut c, &on, &opts, &mut ws).unwrap();
        let p = joints(&c);
        for j in 1..10 {
            let (a, b) = (p[j] - p[j - 1], p[j + 1] - p[j]);
            let t = (a.x * b.y - a.y * b.x).atan2(a.dot(&b));
            assert!(t >= lo - 1e-9 && t <= hi + 1e-9, "joint {j}: {t}");
        }
        assert!((p[10] - Vector2::new(1.7, 0.3)).norm() < 1e-8);
    }

    #[test]
    fn bad_goals_are_refused() {
        let mut c = Chain::<f64, 3>::straight(4, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
        let opts = ReachOptions::default();
        let mut ws = ReachWorkspace::default();
        for goal in [
            Goal::Pose {
                at: Vector3::new(2.0, 1.0, 0.0),
                direction: Vector3::zeros(),
            },
            Goal::Box {
                lo: Vector3::new(1.0, 0.0, 0.0),
                hi: Vector3::new(0.0, 1.0, 1.0),
            },
            Goal::Ball {
                centre: Vector3::zeros(),
                radius: 0.0,
            },
            Goal::Point(Vector3::new(f64::NAN, 0.0, 0.0)),
        ] {
            assert!(
                reach_goal(&mut c, &goal, &opts, &mut ws).is_err(),
                "{goal:?}"
            );
        }
    }
}
