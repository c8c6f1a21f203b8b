//! What a command does to one chain: a move or a path (its held sides solved as fixed-base chains),
//! instruments carried by the joint they follow or pushed to a new pose, a fixed-base reach. A chain
//! may be left moved on a refusal: [`crate::World::apply`] restores it.

use crate::command::{Goal, NeedleMove, Point};
use crate::form::LiveChain;
use crate::point::{point, to_point};
use crate::refusal::{Cause, Refusal};
use crate::refuse;
use crate::tension::Stop;
use nalgebra::Vector3;
use tractrix::collision::Obstacle;
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

/// Whether capsule `at` of the model, carried rigidly to `to`, passes clear of every link it does not
/// hold: each point of it moves at most as far as one of its ends (the motion is affine along it), so
/// a link farther from its old axis than its radius, the rope's radius and that distance cannot meet
/// it on the way.
fn clear_of<T: Real, const D: usize>(
    joints: &[Vector<T, D>],
    model: &tractrix::collision::CollisionModel<T, D>,
    at: usize,
    to: &Obstacle<T, D>,
) -> bool
where
    Vector<T, D>: Embed3<T>,
{
    let (Obstacle::Capsule { a, b, radius }, Obstacle::Capsule { a: a2, b: b2, .. }) =
        (model.obstacles[at], *to)
    else {
        return false;
    };
    let travel = (a2 - a).norm().max((b2 - b).norm());
    let reach = radius + model.options.thickness * T::lit(0.5) + travel;
    let held = |l: usize| {
        model
            .holding
            .iter()
            .any(|h| h.obstacle == at && h.links.contains(&l))
    };
    joints.windows(2).enumerate().all(|(l, w)| {
        let (p, q) = (&w[0], &w[1]);
        let (s, t) = tractrix::collision::closest_params_segment_segment(p, q, &a, &b);
        let d = ((p + (q - p) * s) - (a + (b - a) * t)).norm();
        held(l) || d > reach
    })
}

/// The head joint and the unit direction of the head link (a needle's swage and tangent).
fn head_frame<T: Real, const D: usize>(c: &tractrix::Chain<T, D>) -> (Point, Point)
where
    Vector<T, D>: Embed3<T>,
{
    let n = c.n_links();
    let (a, b) = (to_point(&c.joint(n - 1)), to_point(&c.joint(n)));
    (b, (b - a).normalize())
}

/// The needle's capsules (f64), in order from the swage.
fn needle_capsules<T: Real, const D: usize>(g: &LiveChain<T, D>) -> Vec<Obstacle<f64, 3>>
where
    Vector<T, D>: Embed3<T>,
{
    let (Some(nd), Some((model, _))) = (g.needle, g.collision.as_ref()) else {
        return Vec::new();
    };
    let at = g.instruments_at + nd.first;
    model.obstacles[at..at + nd.segments]
        .iter()
        .map(|o| match *o {
            Obstacle::Capsule { a, b, radius } => Obstacle::Capsule {
                a: to_point(&a),
                b: to_point(&b),
                radius: radius.to_f64(),
            },
            _ => Obstacle::HalfSpace {
                point: Point::zeros(),
                normal: Point::z(),
            },
        })
        .collect()
}

/// A driven needle before a move: its swage, its tangent there and its point (the far end).
fn needle_frame<T: Real, const D: usize>(g: &LiveChain<T, D>) -> Option<(Point, Point, Point)>
where
    Vector<T, D>: Embed3<T>,
{
    let nd = g.needle?;
    let caps = needle_capsules(g);
    let (Some(Obstacle::Capsule { a: swage, .. }), Some(Obstacle::Capsule { b: tip, .. })) =
        (caps.first(), caps.last())
    else {
        return None;
    };
    Some((*swage, crate::needle::tangent(&nd, &caps)?, *tip))
}

/// A move of `joint`; the instruments that follow it are then carried by the joint's displacement,
/// pushing the rest of the rope (locked: the whole move is refused). A move of the head carries the
/// needle as `needle_move` says: turned with the head link, driven along its own arc
/// ([`crate::needle::drive`]) or set to a pose; driven or posed, where its point crosses the tissue's
/// surface it makes a hole.
pub(crate) fn move_and_carry<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    joint: usize,
    targets: &[Point],
    opts: &MoveOptions<f64>,
    needle_move: NeedleMove,
) -> Result<MoveOutcome, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    if g.needle.is_none() && !g.follows.contains(&Some(joint)) {
        return move_path(g, joint, targets, opts);
    }
    let needle = g.needle.map_or(0..0, |nd| nd.first..nd.first + nd.segments);
    // Point by point, so that the instruments follow the path, not its chord (a refusal anywhere
    // refuses the whole request: the caller undoes it).
    let mut outcome = MoveOutcome::default();
    for t in targets {
        let from = g.chain.joint(joint);
        let swage = g.needle.map(|_| head_frame(&g.chain));
        // The needle's frame before the step, when its point may cut (driven or posed).
        let driven = if needle_move == NeedleMove::Carried {
            None
        } else {
            needle_frame(g)
        };
        let m = move_path(g, joint, std::slice::from_ref(t), opts)?;
        outcome.short = outcome.short.or(m.short);
        outcome.substeps = outcome.substeps.saturating_add(m.substeps);
        outcome.paper_fallbacks = outcome.paper_fallbacks.saturating_add(m.paper_fallbacks);
        outcome.collision_iterations = outcome
            .collision_iterations
            .saturating_add(m.collision_iterations);
        let delta = g.chain.joint(joint) - from;
        let swaged = g.needle.map(|_| head_frame(&g.chain));
        // A driven needle's motion: from its swage along its arc to where the head landed; a
        // posed one's capsules: its arc from the swage where the head landed, in the pose's frame.
        let head = to_point(&g.chain.joint(g.chain.n_links()));
        let motion = match needle_move {
            NeedleMove::Driven => {
                driven.map(|(s, tangent, _)| (s, crate::needle::drive(s, tangent, head), head))
            }
            _ => None,
        };
        let posed = match (needle_move, g.needle) {
            (NeedleMove::Posed(r), Some(nd)) => crate::needle::posed(&nd, head, r),
            _ => Vec::new(),
        };
        // The joints, for the needle's clearance (again after a push moved the rope).
        let mut joints = std::mem::take(&mut g.needle_joints);
        if g.needle.is_some() {
            joints.resize(g.chain.n_links() + 1, Vector::zeros());
            g.chain.write_positions(&mut joints);
        }
        for k in 0..g.follows.len() {
            if !needle.contains(&k) && g.follows[k] != Some(joint) {
                continue;
            }
            let at = g.instruments_at + k;
            // A follower a carry before left behind (stopped short inside its frame) catches up.
            let lag: Vector<T, D> = point(follower_lag(g, k));
            let Some((model, _)) = g.collision.as_mut() else {
                continue;
            };
            let step = NeedleStep {
                posed: &posed,
                motion,
                swage,
                swaged,
            };
            let to = match model.obstacles[at] {
                Obstacle::Capsule { a, b, radius } if needle.contains(&k) => {
                    match step.carry(a, b, radius, k - needle.start) {
                        Some(to) => to,
                        None => continue,
                    }
                }
                o => follow(o, delta + lag),
            };
            if needle.contains(&k) && clear_of(&joints, model, at, &to) {
                // No link can meet the needle on its way: it is set on its new pose.
                model.obstacles[at] = to;
                continue;
            }
            // The needle pushes the rope with the head held: the head is swaged to it.
            let n = g.chain.n_links();
            let swaged_free = needle.contains(&k) && !g.chain.is_held(n);
            if swaged_free {
                g.chain.hold(n)?;
            }
            let m = push(g, at, &to, opts.max_substeps);
            if swaged_free {
                g.chain.release(n)?;
            }
            let m = match m {
                // A needle that stops short of the head would leave its swage: refused.
                Ok(m) if needle.contains(&k) && m.short.is_some() => {
                    g.needle_joints = joints;
                    return Err(m.short.map_or(ChainError::NonFinite, |s| s.error).into());
                }
                Ok(m) => m,
                Err(e) => {
                    g.needle_joints = joints;
                    return Err(e);
                }
            };
            if needle.contains(&k) {
                g.chain.write_positions(&mut joints);
            } else {
                // Where it was asked to be, when it stopped short of it: its lag.
                let stop = m.short.map(|s| stop_of(&s.error));
                g.tension.instrument_moved(k, centre_of(&to), stop);
            }
            outcome.substeps = outcome.substeps.saturating_add(m.substeps);
            outcome.collision_iterations = outcome
                .collision_iterations
                .saturating_add(m.collision_iterations);
        }
        g.needle_joints = joints;
        if let Some((_, _, tip)) = driven {
            cut(g, tip)?;
        }
        if outcome.short.is_some() {
            // Stopped short inside its frame: the points after it are not tried.
            break;
        }
    }
    Ok(outcome)
}

/// The centre of an instrument (a sphere's, the middle of a capsule's axis), in f64.
fn centre_of<T: Real, const D: usize>(o: &Obstacle<T, D>) -> Point
where
    Vector<T, D>: Embed3<T>,
{
    match o {
        Obstacle::Sphere { center, .. } => to_point(center),
        Obstacle::Capsule { a, b, .. } => (to_point(a) + to_point(b)) * 0.5,
        Obstacle::HalfSpace { .. } | Obstacle::Block { .. } => Point::zeros(),
    }
}

/// How far follower `k` is behind where its last carry asked it to be (zero when it got there).
fn follower_lag<T: Real, const D: usize>(g: &LiveChain<T, D>, k: usize) -> Point
where
    Vector<T, D>: Embed3<T>,
{
    let Some(asked) = g.tension.instruments.iter().find(|a| a.at == k) else {
        return Point::zeros();
    };
    let Some(o) = g.instruments().get(k) else {
        return Point::zeros();
    };
    Point::from(asked.target) - centre_of(o)
}

/// How a step moved the needle: its posed capsules, or its drive along its arc (from the swage,
/// turned, to where the head landed), or the head's frame before and after it.
struct NeedleStep<'a> {
    posed: &'a [Obstacle<f64, 3>],
    motion: Option<(Point, nalgebra::Rotation3<f64>, Point)>,
    swage: Option<(Point, Point)>,
    swaged: Option<(Point, Point)>,
}

impl NeedleStep<'_> {
    /// Where the step takes the needle's `k`-th capsule (`a` to `b`, of `radius`): posed, driven or
    /// carried rigidly with the head (whichever joint moved); `None` when it does not move.
    fn carry<T: Real, const D: usize>(
        &self,
        a: Vector<T, D>,
        b: Vector<T, D>,
        radius: T,
        k: usize,
    ) -> Option<Obstacle<T, D>>
    where
        Vector<T, D>: Embed3<T>,
    {
        let o = Obstacle::Capsule {
            a: to_point(&a),
            b: to_point(&b),
            radius: radius.to_f64(),
        };
        let carried = if let Some(c) = self.posed.get(k) {
            if *c == o {
                return None;
            }
            *c
        } else if let Some((s, rotation, to)) = self.motion {
            if s == to {
                return None;
            }
            crate::needle::moved(&o, s, &rotation, to)
        } else {
            let (before, after) = (self.swage?, self.swaged?);
            if before == after {
                return None;
            }
            crate::needle::carry(&o, before, after)
        };
        match carried {
            Obstacle::Capsule { a, b, .. } => Some(Obstacle::Capsule {
                a: point(a),
                b: point(b),
                radius,
            }),
            _ => None,
        }
    }
}

/// An instrument that follows a joint, moved by the joint's displacement `delta`.
fn follow<T: Real, const D: usize>(o: Obstacle<T, D>, delta: Vector<T, D>) -> Obstacle<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    match o {
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
    }
}

/// After a driven needle's step: where its point went into or out of the tissue (from `tip_before`),
/// a hole, an eyelet the rope has not threaded yet, at the point's crossing of the surface (the
/// straight step between its two positions). Refused when the chain has the most eyelets.
fn cut<T: Real, const D: usize>(g: &mut LiveChain<T, D>, tip_before: Point) -> Result<(), Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let Some(bx) = g.tissue else {
        return Ok(());
    };
    let Some((_, _, tip)) = needle_frame(g) else {
        return Ok(());
    };
    if inside(&tip, &bx) == inside(&tip_before, &bx) {
        return Ok(());
    }
    let Some(at) = surface_crossing(&tip_before, &tip, &bx) else {
        return Ok(());
    };
    if g.eyelets.len() >= crate::sizes::MAX_EYELETS {
        return Err(refuse!(
            BadOption,
            "the needle would cut a hole, but the chain has {} eyelets, the most there may be",
            g.eyelets.len()
        ));
    }
    g.eyelets.push(tractrix::eyelet::Eyelet {
        at: point(at),
        link: 0,
        threaded: false,
    });
    Ok(())
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
    let Some((model, _)) = g.collision.as_ref() else {
        return Err(ChainError::BadOption("the chain has no instruments").into());
    };
    let to = instrument_pose(&model.obstacles[at], centre, axis);
    push(g, at, &to, max_substeps)
}

/// Instrument `at` of the model pushed to the pose `to`, the chain giving way (the kernel's door: on
/// a chain with eyelets the links through them stay, the rope does not slide through them under a
/// push), and set where the push left it: at `to`, or on its way there when the push stopped short
/// inside its frame.
fn push<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    at: usize,
    to: &Obstacle<T, D>,
    max_substeps: u32,
) -> Result<MoveOutcome, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let Some(from) = g.collision.as_ref().map(|(model, _)| model.obstacles[at]) else {
        return Err(ChainError::BadOption("the chain has no instruments").into());
    };
    let m = g.rope().push(at, to, max_substeps)?;
    let pose = match m.short {
        Some(s) => tractrix::collision::push_pose(&from, to, s.made, s.of)?,
        None => *to,
    };
    g.set_obstacle(at, pose);
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
    if !g.eyelets.is_empty() || g.tissue.is_some() {
        // Each target is a straight move through the eyelets; a head that goes into or out of the
        // tissue makes an eyelet where the rope crosses its surface.
        let mut total = MoveOutcome::default();
        for t in targets {
            let p: Vector<T, D> = point(*t);
            let before = to_point(&g.chain.joint(g.chain.n_links()));
            total.add(&g.rope().move_to(joint, p, &opts)?);
            if joint == g.chain.n_links() {
                pierce(g, before)?;
            }
        }
        Ok(total)
    } else {
        converted(g)?;
        let targets = std::mem::take(&mut g.targets);
        let moved = g.rope().move_along(joint, &targets, &opts);
        g.targets = targets;
        Ok(moved?)
    }
}

/// Whether `p` lies inside the box `lo`–`hi`.
fn inside(p: &Point, (lo, hi): &(Point, Point)) -> bool {
    (0..3).all(|k| lo[k] <= p[k] && p[k] <= hi[k])
}

/// Where the segment `a`–`b` (one end inside the box, the other outside) crosses the box's surface:
/// the parameter along it (the slab method from the end outside).
fn surface_crossing(a: &Point, b: &Point, bx: &(Point, Point)) -> Option<Point> {
    let (out, into) = if inside(a, bx) { (b, a) } else { (a, b) };
    let d = into - out;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..3 {
        if d[k] == 0.0 {
            if out[k] < bx.0[k] || out[k] > bx.1[k] {
                return None;
            }
            continue;
        }
        let (mut u, mut v) = ((bx.0[k] - out[k]) / d[k], (bx.1[k] - out[k]) / d[k]);
        if u > v {
            std::mem::swap(&mut u, &mut v);
        }
        t0 = t0.max(u);
        t1 = t1.min(v);
    }
    (t0 <= t1).then(|| out + d * t0)
}

/// After a move of the head: when it went into or out of the tissue, an eyelet is made where the
/// rope crosses the tissue's surface nearest the head (on the first link back from the head with
/// one end inside and one outside), in order along the rope. Refused (the caller undoes the move)
/// when that eyelet would lie within a link of another or the chain has the most eyelets.
fn pierce<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    head_before: Point,
) -> Result<(), Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let Some(bx) = g.tissue else {
        return Ok(());
    };
    let n = g.chain.n_links();
    let head = to_point(&g.chain.joint(n));
    if inside(&head, &bx) == inside(&head_before, &bx) {
        return Ok(());
    }
    let mut b = head;
    // Once, not `joint(k)` per joint (a pass over the links each): this runs when the head crosses.
    let joints: Vec<Point> = g.chain.joints().map(|p| to_point(&p)).collect();
    for k in (0..n).rev() {
        let a = joints[k];
        if inside(&a, &bx) != inside(&b, &bx) {
            let Some(at) = surface_crossing(&a, &b, &bx) else {
                return Ok(());
            };
            if g.eyelets.len() >= crate::sizes::MAX_EYELETS {
                return Err(refuse!(
                    BadOption,
                    "the chain passes through {} eyelets, the most there may be",
                    g.eyelets.len()
                ));
            }
            // Holes the needle's point cut (eyelets not threaded yet): the rope goes through the
            // nearest, and nowhere else.
            let hole = g
                .eyelets
                .iter()
                .enumerate()
                .filter(|(_, e)| !e.threaded)
                .map(|(i, e)| (i, (to_point(&e.at) - at).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((i, d)) = hole {
                let reach = hole_reach(g);
                if d > reach {
                    return Err(refuse!(
                        Locked,
                        "the rope would cross the tissue's surface {d:.3} from the nearest hole \
                         the needle cut (at most {reach:.3})"
                    ));
                }
                g.eyelets.remove(i);
            }
            if let Some(e) = g
                .eyelets
                .iter()
                .find(|e| e.threaded && e.link.abs_diff(k) < 2)
            {
                return Err(refuse!(
                    Locked,
                    "the rope would cross the tissue's surface on link {k}, within a link of the \
                     eyelet on link {} (a wider bite or a finer suture)",
                    e.link
                ));
            }
            let at: Vector<T, D> = point(at);
            let e = tractrix::eyelet::Eyelet {
                at,
                link: k,
                threaded: true,
            };
            let i = g
                .eyelets
                .iter()
                .position(|x| x.threaded && x.link > k)
                .unwrap_or(g.eyelets.len());
            g.eyelets.insert(i, e);
            return Ok(());
        }
        b = a;
    }
    Ok(())
}

/// How far from a hole the needle cut the rope may cross the tissue's surface to go through it: the
/// rope's thickness plus the needle's.
fn hole_reach<T: Real, const D: usize>(g: &LiveChain<T, D>) -> f64
where
    Vector<T, D>: Embed3<T>,
{
    let rope = g
        .collision
        .as_ref()
        .map_or(0.0, |(m, _)| m.options.thickness.to_f64());
    rope + g.needle.map_or(0.0, |n| n.thickness)
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

/// Halvings of a pulled move that stopped short: the furthest point reached is within 2⁻⁶ of the
/// stretch from the joint to its target (or its nearest reachable point). With the full try and the
/// nearest point, at most eight solves per request.
pub const PULL_HALVINGS: u32 = 6;

/// How much of a pull's budget one try may spend.
#[derive(Clone, Copy)]
enum Share {
    /// `1/n` of it.
    Part(u64),
    /// What the tries before it left.
    Rest,
    /// What the tries before it left, less a sixteenth for each of `n` tries after it.
    RestLeaving(u64),
}

/// Tries a pulled move may take: the full one, the nearest reachable point, the halvings.
pub const PULL_TRIES: u64 = 2 + PULL_HALVINGS as u64;

/// Why a refusal means "the rope could not go that far" (a pull stops short) rather than bad input.
fn stops_short(r: &Refusal) -> Option<Stop> {
    match r.cause {
        Cause::Unreachable | Cause::NotConverged => Some(Stop::Reach),
        Cause::Locked => Some(Stop::Contact),
        Cause::JointLimit => Some(Stop::Limit),
        Cause::OverBudget => Some(Stop::Work),
        _ => None,
    }
}

/// The tries of one pull, each metered against its share of the request's budget and never more
/// than the tries before it left (with collision: the full try half of it, or all of it when it
/// goes on from a resolution the last request kept; the nearest point what the full try left less
/// a sixteenth for each halving; each halving a sixteenth; and the moves of tissue that gives
/// ([`give_way`]) a sixteenth together), their work summed.
pub(crate) struct Tries {
    budget: u64,
    /// Collision work of the tries so far, in link-steps.
    pub(crate) work: u64,
}

impl Tries {
    pub(crate) fn new(budget: u64) -> Tries {
        Tries { budget, work: 0 }
    }

    /// Runs one try with `1/parts` of the budget.
    fn run<T: Real, const D: usize, R>(
        &mut self,
        g: &mut LiveChain<T, D>,
        parts: u64,
        f: impl FnOnce(&mut LiveChain<T, D>) -> Result<R, Refusal>,
    ) -> Result<R, Refusal>
    where
        Vector<T, D>: Embed3<T>,
    {
        self.run_keeping(g, Share::Part(parts), false, f)
    }

    /// [`Tries::run`], with `keep`: a resolution that runs out of work is kept and the same try
    /// in the next request goes on from it (`CollisionWorkspace::keep_unfinished`).
    fn run_keeping<T: Real, const D: usize, R>(
        &mut self,
        g: &mut LiveChain<T, D>,
        share: Share,
        keep: bool,
        f: impl FnOnce(&mut LiveChain<T, D>) -> Result<R, Refusal>,
    ) -> Result<R, Refusal>
    where
        Vector<T, D>: Embed3<T>,
    {
        if let Some((_, ws)) = g.collision.as_mut() {
            // Never more than the tries before it left: the request's work stays within its
            // budget whatever they spent (a resumed try may spend it all).
            let rest = self.budget.saturating_sub(self.work);
            ws.limit_work(match share {
                Share::Part(parts) => (self.budget / parts).min(rest),
                Share::Rest => rest,
                Share::RestLeaving(n) => rest.saturating_sub(self.budget / 16 * n),
            });
            ws.solve_contacts_together(true);
            ws.keep_unfinished(keep);
        }
        let r = f(g);
        if let Some((_, ws)) = g.collision.as_mut() {
            self.work = self.work.saturating_add(ws.work());
            ws.solve_contacts_together(false);
        }
        r
    }
}

/// A move of `joint` toward `target` that goes as far as the rope lets it ([`crate::tension`]): the
/// full move; if the rope cannot make it, the nearest point the held sides reach; if that cannot be
/// made either, [`PULL_HALVINGS`] halvings of the straight line from the joint to it, keeping the
/// furthest pose made. `None` when the whole move was made; else why it stopped short (the joint may
/// not have moved at all). A try over its share of the budget stops short too ([`Stop::Work`]: the
/// rope resists more than the budget can resolve). Bad input is refused as by a plain move.
pub(crate) fn pull_move<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    joint: usize,
    target: Point,
    opts: &MoveOptions<f64>,
    needle_move: NeedleMove,
    tries: &mut Tries,
) -> Result<(MoveOutcome, Option<Stop>), Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    if g.collision.is_some() {
        return pull_in_frame(g, joint, target, opts, needle_move, tries);
    }
    let from = to_point(&g.chain.joint(joint));
    // On the boundary of what the held sides reach, the side solved last can close on its held joint
    // a hair off its last link's length: such a pose is not kept (the pull stops short of it).
    let one = |g: &mut LiveChain<T, D>, p: Point| {
        let m = move_and_carry(g, joint, std::slice::from_ref(&p), opts, needle_move)?;
        if closes_exactly(g, joint) {
            Ok(m)
        } else {
            Err(refuse!(
                NotConverged,
                "the rope closes off its length on a held joint"
            ))
        }
    };
    // The full try, and the nearest point when the full move is out of reach, keep their
    // resolution when it runs out of work (`CollisionWorkspace::keep_unfinished`). The halvings
    // follow as before; when none is made the state is the same, and the next request toward the
    // same point goes on from the resolution kept, with the whole budget (what the tries before
    // it left: the halvings after it then have nothing left unless it ends early). A halving
    // made changes the state, and the next request starts afresh from there.
    let plain = g.eyelets.is_empty() && g.tissue.is_none();
    let resumes = |g: &mut LiveChain<T, D>, p: Point| {
        let p: Vector<T, D> = point(p);
        plain
            && g.collision
                .as_mut()
                .is_some_and(|(_, ws)| ws.can_resume(&g.chain, joint, &p))
    };
    let share = if resumes(g, target) {
        Share::Rest
    } else {
        Share::Part(2)
    };
    let first = match tries.run_keeping(g, share, plain, |g| one(g, target)) {
        Ok(m) => return Ok((m, None)),
        Err(e) => e,
    };
    let Some(mut stop) = stops_short(&first) else {
        return Err(first);
    };
    g.restore_armed();
    let mut goal = target;
    let nearest = if first.cause == Cause::Unreachable {
        g.chain
            .nearest_reachable(joint, point(target))
            .ok()
            .map(|n| to_point(&n))
    } else {
        None
    };
    if let Some(n) = nearest {
        // The nearest point lies on the held sides' shell, which their solves reach only to their
        // tolerance: taken a few tolerances inside (toward where the joint is), so that the last
        // side solved still closes on its held joint.
        let inset = 4.0 * opts.held.tolerance * g.prefix[g.prefix.len() - 1];
        let back = from - n;
        goal = if back.norm() > inset {
            n + back * (inset / back.norm())
        } else {
            from
        };
        let share = if resumes(g, goal) {
            Share::Rest
        } else {
            Share::RestLeaving(PULL_HALVINGS.into())
        };
        match tries.run_keeping(g, share, plain, |g| one(g, goal)) {
            Ok(m) => return Ok((m, Some(stop))),
            Err(e) => {
                stop = stops_short(&e).ok_or(e)?;
                g.restore_armed();
            }
        }
    }
    let best = halve(g, tries, |g, mid| one(g, from + (goal - from) * mid))?;
    Ok((best.unwrap_or_default(), Some(stop)))
}

/// Why a move that stopped short inside its frame stopped, as its answer says.
pub(crate) fn stop_of(e: &ChainError) -> Stop {
    match e {
        ChainError::OverWork { .. } => Stop::Work,
        ChainError::JointLimit { .. } => Stop::Limit,
        ChainError::HeldUnreachable { .. } | ChainError::HeldNotConverged { .. } => Stop::Reach,
        _ => Stop::Contact,
    }
}

/// [`pull_move`] on a rope with collision, inside its frame: the move goes as far as the rope lets
/// it in the pull's work (the kernel stops it at its last whole substep,
/// [`tractrix::collision::CollisionWorkspace::stop_short`]); when a held side went out of reach, the
/// nearest point the held sides reach is tried from there with the work left, a few tolerances
/// inside their shell. A pose that closes off its length on a held joint is not kept.
fn pull_in_frame<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    joint: usize,
    target: Point,
    opts: &MoveOptions<f64>,
    needle_move: NeedleMove,
    tries: &mut Tries,
) -> Result<(MoveOutcome, Option<Stop>), Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    // Tissue that gives moves its eyelets after a pull that stopped short ([`give_way`]): a
    // sixteenth of the pull's work is left for them.
    let share = if g.wound.is_some() {
        Share::RestLeaving(1)
    } else {
        Share::Rest
    };
    // On a rope without eyelets a pull's resolution that runs out of work is kept, and the next
    // pull toward a target near it goes on from it (`CollisionWorkspace::keep_unfinished`).
    let plain = g.eyelets.is_empty() && g.tissue.is_none();
    let one = |g: &mut LiveChain<T, D>, p: Point, tries: &mut Tries| -> Result<_, Refusal> {
        g.keep_best();
        let m = tries.run_keeping(g, share, plain, |g| {
            move_and_carry(g, joint, std::slice::from_ref(&p), opts, needle_move)
        })?;
        if closes_exactly(g, joint) {
            Ok(Some(m))
        } else {
            g.take_best();
            Ok(None)
        }
    };
    let Some(mut m) = one(g, target, tries)? else {
        return Ok((MoveOutcome::default(), Some(Stop::Reach)));
    };
    let Some(short) = m.short else {
        return Ok((m, None));
    };
    let stop = stop_of(&short.error);
    if matches!(short.error, ChainError::HeldUnreachable { .. })
        && let Ok(n) = g.chain.nearest_reachable(joint, point(target))
    {
        let (from, n) = (to_point(&g.chain.joint(joint)), to_point(&n));
        let inset = 4.0 * opts.held.tolerance * g.prefix[g.prefix.len() - 1];
        let back = from - n;
        if back.norm() > inset {
            let goal = n + back * (inset / back.norm());
            if let Some(more) = one(g, goal, tries)? {
                m.add(&more);
            }
        }
    }
    Ok((m, Some(stop)))
}

/// Tissue that gives ([`crate::scene::Wound`]): after a pull that stopped `pulled` short, each
/// threaded eyelet is moved toward the incision's plane along its normal by the tissue's give times
/// `pulled`, no nearer the plane than the wound's margin, carrying the rope's point at it (an eyelet
/// move, the held joints kept). An eyelet the rope cannot follow (out of reach, the contacts, the
/// request's work budget) stays where it is: the tissue does not give there.
pub(crate) fn give_way<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    pulled: f64,
    max_substeps: u32,
    tries: &mut Tries,
) where
    Vector<T, D>: Embed3<T>,
{
    let Some(w) = g.wound else {
        return;
    };
    // With collision the eyelets' moves share a sixteenth of the request's budget.
    let shares = 16 * g.eyelets.iter().filter(|e| e.threaded).count().max(1) as u64;
    for i in 0..g.eyelets.len() {
        let e = g.eyelets[i];
        if !e.threaded {
            continue;
        }
        let at = to_point(&e.at);
        let off = (at - w.point).dot(&w.normal);
        let step = (w.give * pulled).min(off.abs() - w.margin);
        if step.is_nan() || step <= 0.0 {
            continue;
        }
        let to: Vector<T, D> = point(at - w.normal * (step * off.signum()));
        // A refused eyelet move changes nothing: the tissue does not give there. Metered as a try of
        // the pull (no joint jumping more than half a clearance in a substep: the knot kept).
        let _ = tries.run(g, shares, |g| {
            move_eyelet(g, i, to, max_substeps).map_err(Refusal::from)
        });
    }
}

/// Eyelet `index` moved to `to` (the tissue moving it), carrying the rope's point at it, with
/// collision when the chain has it (the kernel's door, [`tractrix::Rope::move_eyelet`]).
pub(crate) fn move_eyelet<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    index: usize,
    to: Vector<T, D>,
    max_substeps: u32,
) -> Result<MoveOutcome, tractrix::RopeError>
where
    Vector<T, D>: Embed3<T>,
{
    g.rope_with(true).move_eyelet(index, to, max_substeps)
}

/// Whether the two links below the first held joint above `joint` (those the move closes on it) have
/// their lengths to rounding (64 ε of the length).
fn closes_exactly<T: Real, const D: usize>(g: &LiveChain<T, D>, joint: usize) -> bool
where
    Vector<T, D>: Embed3<T>,
{
    let c = &g.chain;
    let Some(top) = c.held().find(|&h| h > joint) else {
        return true;
    };
    (top.saturating_sub(2).max(joint)..top).all(|k| {
        let len = (c.joint(k + 1) - c.joint(k)).norm();
        let want = c.lengths()[k];
        (len - want).abs() <= T::EPSILON * T::lit(64.0) * want.max(T::one())
    })
}

/// [`PULL_HALVINGS`] halvings of the way from the armed state to a pose (`at(fraction)` makes the
/// pose at that fraction of the way), keeping the furthest made: its outcome, `None` if none was.
fn halve<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    tries: &mut Tries,
    mut at: impl FnMut(&mut LiveChain<T, D>, f64) -> Result<MoveOutcome, Refusal>,
) -> Result<Option<MoveOutcome>, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let (mut lo, mut hi) = (0.0, 1.0);
    let mut best = None;
    for _ in 0..PULL_HALVINGS {
        let mid = 0.5 * (lo + hi);
        match tries.run(g, 16, |g| at(g, mid)) {
            Ok(m) => {
                lo = mid;
                g.keep_best();
                best = Some(m);
            }
            Err(e) => {
                if stops_short(&e).is_none() {
                    g.restore_armed();
                    return Err(e);
                }
                hi = mid;
            }
        }
        g.restore_armed();
    }
    if best.is_some() {
        g.take_best();
    }
    Ok(best)
}

/// An instrument's pose taken as far as the rope makes way ([`pull_move`] for a pose): the full pose,
/// then [`PULL_HALVINGS`] halvings of the way to it (the centre along its straight line, the axis
/// turned in proportion), keeping the furthest pose made.
pub(crate) fn pull_instrument<T: Real, const D: usize>(
    g: &mut LiveChain<T, D>,
    index: usize,
    centre: Point,
    axis: Option<Point>,
    max_substeps: u32,
    tries: &mut Tries,
) -> Result<(MoveOutcome, Option<Stop>), Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let Some(from) = g.instruments().get(index).copied() else {
        return Err(ChainError::BadOption("the chain has no such instrument").into());
    };
    let v = |p: &Vector<T, D>| to_point(p);
    let (c0, a0) = match from {
        Obstacle::Sphere { center, .. } => (v(&center), None),
        Obstacle::Capsule { a, b, .. } => ((v(&a) + v(&b)) * 0.5, Some(v(&b) - v(&a))),
        Obstacle::HalfSpace { .. } | Obstacle::Block { .. } => (Point::zeros(), None),
    };
    if g.collision.is_some() {
        // Inside its frame: the push stops short where the rope does not make way.
        let m = tries.run_keeping(g, Share::Rest, false, |g| {
            push_instrument(g, index, centre, axis, max_substeps)
        })?;
        return Ok((m, m.short.map(|s| stop_of(&s.error))));
    }
    let first = match tries.run(g, 2, |g| {
        push_instrument(g, index, centre, axis, max_substeps)
    }) {
        Ok(m) => return Ok((m, None)),
        Err(e) => e,
    };
    let Some(stop) = stops_short(&first) else {
        return Err(first);
    };
    g.restore_armed();
    let best = halve(g, tries, |g, mid| {
        let c = c0 + (centre - c0) * mid;
        // The axis turned by `mid` of the angle between the two (normalised lerp is enough: the
        // halvings only need a pose between the two for every fraction).
        let ax = match (a0, axis) {
            (Some(a0), Some(a1)) => {
                let (a0, a1) = (a0.normalize(), a1.normalize());
                let w = a0 * (1.0 - mid) + a1 * mid;
                Some(if w.norm() > 1e-12 { w } else { a0 })
            }
            _ => axis,
        };
        push_instrument(g, index, c, ax, max_substeps)
    })?;
    Ok((best.unwrap_or_default(), Some(stop)))
}
