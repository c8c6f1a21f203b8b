//! What a command does to one chain: a move or a path (its held sides solved as fixed-base chains),
//! instruments carried by the joint they follow or pushed to a new pose, a fixed-base reach. A chain
//! may be left moved on a refusal: [`crate::World::apply`] restores it.

use crate::command::{Goal, Point};
use crate::form::{LiveChain, point};
use crate::refusal::Refusal;
use nalgebra::Vector3;
use tractrix::collision::{Obstacle, move_joint_colliding};
use tractrix::math::{Embed3, Real, Vector};
use tractrix::{ChainError, MoveOptions, MoveOutcome, ReachOptions, reach_goal};

/// The instrument `from` moved to `centre` (and, for a capsule, turned to `axis`), its size kept.
fn instrument_pose<T: Real, const D: usize>(
    from: &Obstacle<T, D>,
    centre: Point,
    axis: Option<Point>,
) -> Obstacle<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let c: Vector<T, D> = point(centre);
    match (*from, axis) {
        (Obstacle::Capsule { a, b, radius }, Some(axis)) => {
            let half = (b - a).norm() * T::lit(0.5);
            let d: Vector<T, D> = point(axis);
            let d = d / d.norm();
            Obstacle::Capsule {
                a: c - d * half,
                b: c + d * half,
                radius,
            }
        }
        (Obstacle::Sphere { radius, .. }, _) => Obstacle::Sphere { center: c, radius },
        (other, _) => other,
    }
}

/// How far any point of the instrument travels from its pose to the new one (the centre's distance
/// plus the arc its axis's end sweeps), in f64.
pub(crate) fn instrument_travel<T: Real, const D: usize>(
    from: &Obstacle<T, D>,
    centre: Point,
    axis: Option<Point>,
) -> f64
where
    Vector<T, D>: Embed3<T>,
{
    let v = |p: &Vector<T, D>| {
        let q = p.to_3d();
        Vector3::new(q.x.to_f64(), q.y.to_f64(), q.z.to_f64())
    };
    let to = Vector3::new(centre.x, centre.y, centre.z);
    match (from, axis) {
        (Obstacle::Capsule { a, b, .. }, Some(ax)) => {
            let (a, b) = (v(a), v(b));
            let h0 = (b - a) * 0.5;
            let d = Vector3::new(ax.x, ax.y, ax.z);
            let angle = h0.angle(&d);
            ((a + b) * 0.5 - to).norm() + h0.norm() * angle
        }
        (Obstacle::Sphere { center, .. }, _) => (v(center) - to).norm(),
        _ => 0.0,
    }
}

/// A move of `joint`; the instruments that follow it are then carried by the joint's displacement,
/// pushing the rest of the rope (locked: the whole move is refused).
pub(crate) fn move_and_carry<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    joint: usize,
    targets: &[Point],
    opts: &MoveOptions<f64>,
) -> Result<MoveOutcome, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    if !g.follows.contains(&Some(joint)) {
        return move_path(g, joint, targets, opts);
    }
    // Point by point, so that the instruments follow the path, not its chord (a refusal anywhere
    // refuses the whole request: the caller undoes it).
    let mut outcome = MoveOutcome::default();
    for t in targets {
        let from = g.chain.joint(joint);
        let m = move_path(g, joint, std::slice::from_ref(t), opts)?;
        outcome.substeps = outcome.substeps.saturating_add(m.substeps);
        outcome.paper_fallbacks = outcome.paper_fallbacks.saturating_add(m.paper_fallbacks);
        outcome.collision_iterations = outcome
            .collision_iterations
            .saturating_add(m.collision_iterations);
        let delta = g.chain.joint(joint) - from;
        for k in 0..g.follows.len() {
            if g.follows[k] != Some(joint) {
                continue;
            }
            let at = g.instruments_at + k;
            let Some((model, ws)) = g.collision.as_mut() else {
                continue;
            };
            let to = match model.obstacles[at] {
                Obstacle::Sphere { center, radius } => Obstacle::Sphere {
                    center: center + delta,
                    radius,
                },
                Obstacle::Capsule { a, b, radius } => Obstacle::Capsule {
                    a: a + delta,
                    b: b + delta,
                    radius,
                },
                other => other,
            };
            let m = tractrix::collision::push_by_obstacle(
                &mut g.chain,
                model,
                at,
                &to,
                opts.max_substeps,
                ws,
            )?;
            model.obstacles[at] = to;
            outcome.substeps = outcome.substeps.saturating_add(m.substeps);
            outcome.collision_iterations = outcome
                .collision_iterations
                .saturating_add(m.collision_iterations);
        }
    }
    Ok(outcome)
}

pub(crate) fn push_instrument<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    index: usize,
    centre: Point,
    axis: Option<Point>,
    max_substeps: u32,
) -> Result<MoveOutcome, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let at = g.instruments_at + index;
    let Some((model, ws)) = g.collision.as_mut() else {
        return Err(ChainError::BadOption("the chain has no instruments").into());
    };
    let to = instrument_pose(&model.obstacles[at], centre, axis);
    let m = tractrix::collision::push_by_obstacle(&mut g.chain, model, at, &to, max_substeps, ws)?;
    model.obstacles[at] = to;
    Ok(m)
}

/// A move or a path of `joint` on one chain (held sides solved as fixed-base chains). The chain may
/// be left moved on a refusal: [`crate::World::apply`] restores it.
fn move_path<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    joint: usize,
    targets: &[Point],
    opts: &MoveOptions<f64>,
) -> Result<MoveOutcome, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let opts = MoveOptions {
        method: opts.method,
        substeps: match opts.substeps {
            tractrix::Substeps::Fixed(k) => tractrix::Substeps::Fixed(k),
            tractrix::Substeps::MaxStep(s) => tractrix::Substeps::MaxStep(T::lit(s)),
        },
        max_substeps: opts.max_substeps,
        held: tractrix::ReachOptions {
            strategy: opts.held.strategy,
            method: opts.held.method,
            substeps: opts.held.substeps,
            tolerance: T::lit(opts.held.tolerance).max(T::EPSILON * T::lit(64.0)),
            max_iterations: opts.held.max_iterations,
            hierarchy_after: opts.held.hierarchy_after,
        },
    };
    let converted = |g: &mut LiveChain<T, D>| -> Result<(), Refusal> {
        g.targets.clear();
        for t in targets {
            let p: Vector<T, D> = point(*t);
            if !tractrix::math::all_finite(&p) {
                return Err(ChainError::NonFinite.into());
            }
            g.targets.push(p);
        }
        Ok(())
    };
    if let Some((model, ws)) = &mut g.collision {
        // Each target is a straight move with collision.
        let mut total = MoveOutcome::default();
        for t in targets {
            let p: Vector<T, D> = point(*t);
            let o = move_joint_colliding(&mut g.chain, joint, p, &opts, model, ws)?;
            total.substeps = total.substeps.saturating_add(o.substeps);
            total.paper_fallbacks = total.paper_fallbacks.saturating_add(o.paper_fallbacks);
            total.collision_iterations = total
                .collision_iterations
                .saturating_add(o.collision_iterations);
            total.contacts = total.contacts.saturating_add(o.contacts);
        }
        Ok(total)
    } else if targets.len() == 1 {
        let p: Vector<T, D> = point(targets[0]);
        if !tractrix::math::all_finite(&p) {
            return Err(ChainError::NonFinite.into());
        }
        Ok(g.chain.move_joint(joint, p, &opts)?)
    } else {
        converted(g)?;
        let LiveChain { chain, targets, .. } = g;
        Ok(chain.move_along(joint, targets, &opts)?)
    }
}

/// A reach on one fixed-base chain: iterations and residual.
pub(crate) fn reach_with_holds<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    goal: &Goal,
    opts: &ReachOptions<f64>,
) -> Result<(u32, f64), Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let p = |q: &Point| -> Result<Vector<T, D>, Refusal> {
        let v: Vector<T, D> = point(*q);
        if tractrix::math::all_finite(&v) {
            Ok(v)
        } else {
            Err(ChainError::NonFinite.into())
        }
    };
    let goal: tractrix::Goal<T, D> = match goal {
        Goal::Point(q) => tractrix::Goal::Point(p(q)?),
        Goal::Pose { at, direction } => tractrix::Goal::Pose {
            at: p(at)?,
            direction: p(direction)?,
        },
        Goal::Box { lo, hi } => tractrix::Goal::Box {
            lo: p(lo)?,
            hi: p(hi)?,
        },
        Goal::Ball { centre, radius } => tractrix::Goal::Ball {
            centre: p(centre)?,
            radius: T::lit(*radius),
        },
    };
    let opts = ReachOptions::<T> {
        strategy: opts.strategy,
        method: opts.method,
        substeps: opts.substeps,
        tolerance: T::lit(opts.tolerance),
        max_iterations: opts.max_iterations,
        hierarchy_after: opts.hierarchy_after,
    };
    let o = reach_goal(&mut g.chain, &goal, &opts, &mut g.ws)?;
    Ok((o.iterations, o.residual.to_f64()))
}
