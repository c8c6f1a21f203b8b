//! One resolution pass over the contacts of a chain (capsules on the chain's tree, or the paper's spheres) and
//! its obstacles: each contact found is pushed apart at once (Gauss–Seidel).

use super::project::Projected;
use super::query::{
    any_perpendicular, away_from, closest_param_point_segment, closest_param_segment_block,
    closest_params_segment_segment, lerp, unit_or_perpendicular,
};
use super::relax::{Pushed, relax_lengths};
use super::tree::{ChainTree, NearPairs, boxes_apart};
use super::{
    CollisionModel, CollisionOptions, CollisionWorkspace, Meter, Obstacle, Scheme, Stop, cost,
    neighbour_span, restraighten,
};
use crate::chain::Chain;
use crate::fixed_base::{ReachOptions, ReachWorkspace, reach};
use core::cmp::Ordering;

/// Passes of pushes on a rope with held joints before a pull's contacts and lengths are solved
/// together ([`super::project`]): most contacts of a move part after one or two pushes; a knot
/// under tension does not. Plain moves take [`CollisionOptions::together_after`].
const PULL_PROJECT_AFTER: u32 = 2;
use crate::math::{Embed3, Real, Vector, positive_finite};

/// Resolution passes on `ws.pos` (positions of the chain after the sweep). The hand's joint `m` and the
/// `held` joints (ascending, without `m`) never move; a contact that only they could resolve locks.
/// Returns the passes that pushed something and the contacts pushed, or why it stopped short. Every
/// unit of work is charged to `ws`'s meter before it is done ([`CollisionWorkspace::limit_work`]).
/// `threaded`: the rope passes through eyelets (its links there among the fixed joints); the joint
/// projection is then only for pulls.
pub(super) fn resolve<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    held: &[usize],
    threaded: bool,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<(u32, u32), Stop<T>>
where
    Vector<T, D>: Embed3<T>,
{
    let before = ws.stats.passes;
    let done = resolve_passes(chain, m, held, threaded, model, ws);
    ws.stats.resolutions += 1;
    if ws.stats.passes - before >= super::ResolutionStats::LONG {
        ws.stats.long += 1;
    }
    done
}

/// [`resolve`]'s passes, each one that pushed counted in the workspace's statistics.
fn resolve_passes<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    held: &[usize],
    threaded: bool,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<(u32, u32), Stop<T>>
where
    Vector<T, D>: Embed3<T>,
{
    let opts = &model.options;
    // A resumed resolution goes on with the counts its last recorded pass left ([`super::Unfinished`]).
    let start = ws.unfinished.resume_at.take().unwrap_or_default();
    let mut contacts = start.contacts;
    let mut iterations = start.iterations;
    let mut stalled = start.stalled;
    let use_tree = opts.self_collision && opts.scheme == Scheme::Capsules;
    let span = neighbour_span(chain.min_length(), opts.thickness);
    let n = chain.n_links() as u64;
    let detection = detection_cost(n, model);
    let after = project_after(ws.together, threaded, opts.together_after);
    let can_project = use_tree && !held.is_empty() && after != u32::MAX;
    // Passes in a row that moved no joint farther than [`SETTLED`] of the clearance.
    let mut settled = start.settled;
    let clearance = super::smallest_clearance(chain, model);
    loop {
        if !ws.meter.charge(detection) {
            return Err(Stop::OverWork);
        }
        // A knot under tension: after a few passes, every contact and every length of a rope with
        // held joints solved together ([`super::project`]) from the re-straightened pose (its
        // lengths exact), until a projection stalls; the pass that follows finds what is left. Not
        // on a threaded rope's plain moves: there it locked 17 moves of the 160-link needle pass
        // with two hands and turned the surgeon's knot over a bite into a square knot.
        if use_tree && !held.is_empty() && !stalled && iterations >= after {
            match project_held(chain, m, held, model, ws) {
                Ok(true) => {}
                Ok(false) => stalled = true,
                Err(stop) => {
                    // A recorded resolution resumed goes on without the projection that ran out
                    // of work (as after one that stalled): resumed, it would run out the same way.
                    if matches!(stop, Halt::OverWork) && ws.unfinished.recording {
                        ws.unfinished.state.stalled = true;
                    }
                    return Err(stop.at(iterations));
                }
            }
        }
        let pass = push_pass(
            chain,
            m,
            held,
            model,
            ws,
            span,
            iterations == start.iterations,
        )?;
        if pass.blocked {
            // Only a held joint (or the hand) could give way: locked at once.
            return Err(Stop::Locked(iterations, pass.worst));
        }
        if pass.pushed == 0 {
            return Ok((iterations, contacts));
        }
        if iterations == opts.max_iterations {
            return Err(Stop::Locked(iterations, pass.worst));
        }
        iterations += 1;
        ws.stats.passes += 1;
        contacts = contacts.saturating_add(pass.pushed);
        if held.is_empty() {
            if !ws
                .meter
                .charge(n.saturating_mul(cost::RESTRAIGHTEN_PER_LINK))
            {
                return Err(Stop::OverWork);
            }
            restraighten(chain, m, &mut ws.pos);
        } else {
            resolve_held_whole(chain, m, held, model, ws, iterations, pass.worst)?;
        }
        // Passes that have settled where contacts remain lock now: once no projection can run any
        // more, two passes in a row that moved no joint farther than [`SETTLED`] of the clearance
        // have reached the passes' fixed point, which the passes left would only approach (on
        // `bend-320`'s overhand every locked move converged so, by about 0.4 a pass, to contacts
        // 1e-2 too close, and ran its 64 passes; now 9). The comparison, a subtraction per joint,
        // is within the re-straightening's charge (rounded up).
        if iterations >= 2 && (stalled || !can_project) {
            let moved = ws
                .pos
                .iter()
                .zip(&ws.pos_prev)
                .fold(T::zero(), |a, (x, y)| a.max((x - y).norm()));
            settled = if moved <= clearance * T::lit(SETTLED) {
                settled + 1
            } else {
                0
            };
            if settled >= 2 {
                return Err(Stop::Locked(iterations, pass.worst));
            }
        }
        ws.pos_prev.clone_from(&ws.pos);
        if ws.unfinished.recording {
            ws.unfinished.record(
                chain,
                &ws.pos,
                PassState {
                    iterations,
                    contacts,
                    stalled,
                    settled,
                },
            );
        }
    }
}

/// One pass of pushes over the rope's contacts (its own, then each obstacle's), from the positions in
/// the workspace; the joints it pushed marked in `ws.pushed` when the rope has held joints. `first`:
/// the resolution's first pass (it gathers the pairs the later ones keep). Out of work when the
/// meter ran out during it.
fn push_pass<'a, T: Real, const D: usize>(
    chain: &Chain<T, D>,
    m: usize,
    held: &'a [usize],
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
    span: usize,
    first: bool,
) -> Result<Pass<'a, T>, Stop<T>>
where
    Vector<T, D>: Embed3<T>,
{
    let opts = &model.options;
    // Between held joints the joints this pass pushes are marked: a part between fixed joints
    // that nothing pushed is left as it is, and outside a pull the relaxation moves the pushed
    // joints less ([`CollisionOptions::pushed_weight`]).
    ws.pushed.clear();
    if !held.is_empty() {
        ws.pushed.resize(ws.pos.len(), false);
    }
    let mut pass = Pass {
        m,
        held,
        marks: std::mem::take(&mut ws.pushed),
        pushes: Vec::new(),
        farthest: T::zero(),
        tol: opts.tolerance,
        omega: opts.over_relaxation,
        // Between held joints the rope is re-solved as a whole after the pushes, and a joint that
        // moves farther than a substep may locks the move: the extra push is capped there.
        capped: !held.is_empty(),
        pushed: 0,
        worst: T::zero(),
        blocked: false,
        out_of_work: false,
    };
    if opts.self_collision {
        match opts.scheme {
            Scheme::Capsules => pass.capsules(
                &mut ws.pos,
                &mut ws.tree,
                &mut ws.near,
                opts.thickness,
                span,
                first,
                chain.min_length(),
                &mut ws.meter,
            ),
            Scheme::PaperSpheres => pass.spheres(&mut ws.pos),
        }
    }
    if pass.out_of_work {
        return Err(Stop::OverWork);
    }
    for (k, ob) in model.obstacles.iter().enumerate() {
        let skip = super::untested(model, k, &ws.through);
        let (through, pressed) = (&ws.through, ws.pressed);
        pass.obstacle(&mut ws.pos, ob, opts, skip, |i| {
            super::presses(model, k, through, pressed, i)
        });
    }
    ws.pushed = std::mem::take(&mut pass.marks);
    Ok(pass)
}

/// What a pass costs before its pairs (in the meter's units): refitting the tree or the paper's all
/// pairs, and each obstacle against every one of the `n` links.
fn detection_cost<T: Real, const D: usize>(n: u64, model: &CollisionModel<T, D>) -> u64
where
    Vector<T, D>: Embed3<T>,
{
    let opts = &model.options;
    // What a pass costs before its pairs: refitting the tree or the paper's all pairs, and each
    // obstacle against every link.
    match (opts.self_collision, opts.scheme) {
        (false, _) => 0,
        (true, Scheme::Capsules) => n.saturating_mul(cost::REFIT_PER_LINK),
        (true, Scheme::PaperSpheres) => {
            (n.saturating_mul(n.saturating_sub(1)) / 2).saturating_mul(cost::SPHERE_PAIR)
        }
    }
    .saturating_add(
        model
            .obstacles
            .iter()
            .map(|ob| n.saturating_mul(cost::obstacle_per_link(ob)))
            .fold(0u64, u64::saturating_add),
    )
}

/// The passes after which a rope with held joints has its contacts and lengths projected together:
/// never on a threaded rope's plain moves or with `together_after` 0; pulls (`together`) after two.
fn project_after(together: bool, threaded: bool, together_after: u32) -> u32 {
    if together {
        PULL_PROJECT_AFTER
    } else if threaded || together_after == 0 {
        u32::MAX
    } else {
        together_after
    }
}

/// A pass's pushes on a rope with held joints, followed by the rope re-solved as a whole between
/// them ([`restraighten_held`]); locked when a joint would move farther than half the smallest
/// clearance (a substep's reach), out of work when the meter runs out.
fn resolve_held_whole<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    held: &[usize],
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
    iterations: u32,
    worst: T,
) -> Result<(), Stop<T>>
where
    Vector<T, D>: Embed3<T>,
{
    let opts = &model.options;
    let n = chain.n_links() as u64;
    // Between held joints the rope is re-solved as a whole; where it is nearly taut that can
    // pull a pushed strand back across what pushed it. No joint may move farther than a
    // substep may move the hand (half the smallest clearance): a rope that cannot give way
    // locks instead of tunnelling.
    // The copy of the pushed positions, the outer parts and the check of how far joints moved.
    if !ws
        .meter
        .charge(n.saturating_mul(3 * cost::RESTRAIGHTEN_PER_LINK))
    {
        return Err(Stop::OverWork);
    }
    let pushed = ws.pos.clone();
    let pushed_joints = Pushed {
        joints: &ws.pushed,
        weight: if ws.together {
            T::one()
        } else {
            opts.pushed_weight
        },
        skip_untouched: true,
    };
    match restraighten_held(chain, m, held, &mut ws.pos, pushed_joints, &mut ws.meter) {
        Restraightened::Done => {}
        Restraightened::Failed => return Err(Stop::Locked(iterations, worst)),
        Restraightened::OutOfWork => return Err(Stop::OverWork),
    }
    let limit = super::smallest_clearance(chain, model) * T::lit(0.5);
    let limit2 = limit * limit;
    if pushed
        .iter()
        .zip(ws.pos.iter())
        .any(|(a, b)| (a - b).norm_squared() > limit2)
    {
        return Err(Stop::Locked(iterations, worst.max(limit)));
    }
    Ok(())
}

/// Where a resolution's passes stand after a pass: what a resumed resolution goes on from
/// ([`super::Unfinished`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PassState {
    /// Passes that pushed, and the contacts they pushed.
    pub(super) iterations: u32,
    pub(super) contacts: u32,
    /// Whether a joint projection stalled (the passes go on alone).
    pub(super) stalled: bool,
    /// Passes in a row that moved no joint (the settled passes' lock).
    pub(super) settled: u32,
}

/// Below this share of the clearance, the largest move of a joint in one pass counts as none
/// ([`resolve`]'s settled passes).
const SETTLED: f64 = 1e-6;

/// Why [`project_held`] stopped the resolution.
enum Halt {
    OverWork,
    Locked,
}

impl Halt {
    fn at<T: Real>(self, iterations: u32) -> Stop<T> {
        match self {
            Halt::OverWork => Stop::OverWork,
            Halt::Locked => Stop::Locked(iterations, T::zero()),
        }
    }
}

/// The joint projection of a rope with held joints ([`super::project`]) from `ws.pos`, then every
/// part between fixed joints re-solved to its exact lengths (the projection meets them to 1e-7).
/// `Ok(false)`: it stalled (the pose is left as it was).
fn project_held<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    held: &[usize],
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<bool, Halt>
where
    Vector<T, D>: Embed3<T>,
{
    let step = super::smallest_clearance(chain, model) * T::lit(0.5);
    let mut pos = std::mem::take(&mut ws.pos);
    let projected = super::project::project(&mut pos, chain.lengths(), m, held, model, ws, step);
    ws.pos = pos;
    match projected {
        Projected::OutOfWork => return Err(Halt::OverWork),
        // It found no pose that parts the knot: the pushes go on alone (projecting again would
        // cost as much and find the same).
        Projected::Stalled | Projected::TooMany | Projected::Unfinished => return Ok(false),
        Projected::Converged => {}
    }
    let n = chain.n_links() as u64;
    if !ws
        .meter
        .charge(n.saturating_mul(3 * cost::RESTRAIGHTEN_PER_LINK))
    {
        return Err(Halt::OverWork);
    }
    let every_part = Pushed {
        joints: &[],
        weight: T::one(),
        skip_untouched: false,
    };
    match restraighten_held(chain, m, held, &mut ws.pos, every_part, &mut ws.meter) {
        Restraightened::Done => Ok(true),
        Restraightened::Failed => Err(Halt::Locked),
        Restraightened::OutOfWork => Err(Halt::OverWork),
    }
}

/// Re-straightens a chain with held joints after pushes: the parts beyond the outermost fixed joints
/// (the hand and the held joints) follow the leader outward as without holds; each part between two
/// fixed joints is first relaxed toward its lengths where it was pushed ([`relax_lengths`]), then
/// made exact: a part without joint limits that the relaxation brought within 1e-10 of its lengths
/// is closed on them directly ([`close_relaxed`]); any other is solved as a fixed-base chain from
/// that pose (the reach, finished by the hierarchy), so that it keeps its lengths exactly and meets
/// both fixed joints (on a 320-link device tie the reach took most of a frame's work, history.md);
/// a part no push touched is left as it is (on a long held rope most passes push within one part).
/// The relaxation's sweeps, the closing and the reach's iterations are charged to `meter` (the
/// iterations capped by what is left).
fn restraighten_held<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    held: &[usize],
    pos: &mut [Vector<T, D>],
    pushed: Pushed<'_, T>,
    meter: &mut Meter,
) -> Restraightened
where
    Vector<T, D>: Embed3<T>,
{
    let mut fixed: Vec<usize> = held.to_vec();
    if let Err(at) = fixed.binary_search(&m) {
        fixed.insert(at, m);
    }
    let (first, last) = (fixed[0], fixed[fixed.len() - 1]);
    outside_fixed(chain, pos, first, last);
    // With limits the reach has no hierarchy to land exactly: a looser tolerance, the closing two-link
    // solution below takes up the rest (and the move's final check the limits).
    let limits = chain.joint_limits().cloned();
    let tight = ReachOptions {
        tolerance: if limits.is_some() {
            T::lit(1e-9).max(T::EPSILON * T::lit(64.0))
        } else {
            T::EPSILON * T::lit(64.0)
        },
        ..ReachOptions::default()
    };
    let mut ws = ReachWorkspace::default();
    for w in fixed.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b == a + 1 || pushed.untouched(a, b) {
            // One link between two fixed joints (nothing can move), or nothing pushed the part.
            continue;
        }
        if !relax_lengths(
            &mut pos[a..=b],
            &chain.lengths()[a..b],
            pushed.part(a, b),
            meter,
        ) {
            return Restraightened::OutOfWork;
        }
        if limits.is_none() {
            // Closing is two sweeps over the part, charged as re-straightening it.
            if !meter.charge(((b - a) as u64).saturating_mul(cost::RESTRAIGHTEN_PER_LINK)) {
                return Restraightened::OutOfWork;
            }
            if close_relaxed(chain, pos, a, b) {
                continue;
            }
        }
        let links: Vec<Vector<T, D>> = (a..b).map(|i| pos[i + 1] - pos[i]).collect();
        let lengths = chain.lengths()[a..b].to_vec();
        let Ok(mut part) = Chain::from_parts(pos[a], links, lengths) else {
            return Restraightened::Failed;
        };
        if let Some(l) = &limits {
            if part.set_limits(Some(l.sub(a, b, false))).is_err() {
                return Restraightened::Failed;
            }
            // The pushes bend the rope without its limits: each link turned back into its joint's
            // limit about the one before (as the parts outside the fixed joints are), and the reach
            // brings the part's end back to its fixed joint within them.
            let (links, lengths, lim) = part.links_lengths_limits_mut();
            for i in 1..links.len() {
                crate::limits::turn_back(lim, links, lengths, i, true);
            }
        }
        let goal = pos[b];
        // Each iteration of the reach: up to three tractrix passes over the part and a translation.
        let per_iteration = ((b - a) as u64).saturating_mul(cost::RESOLVE_PER_LINK);
        // With limits, a reach that lands too far for the last two links to close on the fixed
        // joint (the part taut there) is run again from where it ended, to the tolerance without
        // limits; closing short would shift every joint after it, the eyelets' links among them
        // (seen 1.2e-9 off the rope after a tightened stitch with a bend radius).
        let mut tolerance = tight.tolerance;
        let (l1, l2) = loop {
            let affordable = meter.left() / per_iteration;
            let iterations = u64::from(tight.max_iterations).min(affordable) as u32;
            if iterations == 0 {
                return Restraightened::OutOfWork;
            }
            let capped = iterations < tight.max_iterations;
            let charged = per_iteration * u64::from(iterations);
            meter.charge(charged);
            let opts = ReachOptions {
                max_iterations: iterations,
                tolerance,
                ..tight
            };
            match reach(&mut part, &goal, &opts, &mut ws) {
                Ok(o) => meter
                    .refund(per_iteration * u64::from(iterations - o.iterations.min(iterations))),
                Err(crate::fixed_base::ReachError::NotConverged { .. }) if capped => {
                    return Restraightened::OutOfWork;
                }
                Err(_) => return Restraightened::Failed,
            }
            chain.links_mut()[a..b].copy_from_slice(part.links());
            let links = chain.links_mut();
            for i in a..b - 2 {
                pos[i + 1] = pos[i] + links[i];
            }
            // The part closes on the fixed joint exactly (the last two links in closed form).
            let (la, lb) = (chain.lengths()[b - 2], chain.lengths()[b - 1]);
            let (l1, l2) =
                crate::fixed_base::two_link(&pos[b - 2], &goal, la, lb, &chain.links()[b - 2]);
            let exact = T::EPSILON * T::lit(64.0);
            if (pos[b - 2] + l1 + l2 - goal).norm() <= (la + lb) * exact || tolerance <= exact {
                break (l1, l2);
            }
            tolerance = exact;
        };
        let links = chain.links_mut();
        links[b - 2] = l1;
        links[b - 1] = l2;
        pos[b - 1] = pos[b - 2] + l1;
    }
    Restraightened::Done
}

/// Closes the relaxed part between fixed joints `a` and `b` on its lengths exactly without the
/// reach: when every link of the part is within [`CLOSE_RELAXED`] of its length (relative), each
/// link but the last two is scaled to its length from `a` on, and the last two meet `b` in closed
/// form. `false` (nothing changed) when the part is further off or the last two cannot meet `b`.
fn close_relaxed<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    pos: &mut [Vector<T, D>],
    a: usize,
    b: usize,
) -> bool
where
    Vector<T, D>: Embed3<T>,
{
    if b < a + 2 {
        return false;
    }
    let lengths = chain.lengths();
    let close = T::lit(CLOSE_RELAXED);
    for i in a..b {
        let len = (pos[i + 1] - pos[i]).norm();
        if !positive_finite(len) || (len - lengths[i]).abs() > close * lengths[i] {
            return false;
        }
    }
    let mut p = pos[a];
    let mut links: Vec<Vector<T, D>> = Vec::with_capacity(b - a);
    for i in a..b - 2 {
        let d = pos[i + 1] - pos[i];
        let l = d * (lengths[i] / d.norm());
        p += l;
        links.push(l);
    }
    let goal = pos[b];
    let (la, lb) = (lengths[b - 2], lengths[b - 1]);
    let hint = pos[b - 1] - pos[b - 2];
    let (l1, l2) = crate::fixed_base::two_link(&p, &goal, la, lb, &hint);
    let exact = T::EPSILON * T::lit(64.0);
    if (p + l1 + l2 - goal).norm() > (la + lb) * exact {
        return false;
    }
    links.push(l1);
    links.push(l2);
    let out = chain.links_mut();
    out[a..b].copy_from_slice(&links);
    for i in a..b - 1 {
        pos[i + 1] = pos[i] + out[i];
    }
    true
}

/// How near its length (relative) every link of a relaxed part must be for [`close_relaxed`].
const CLOSE_RELAXED: f64 = 1e-10;

/// The parts of a rope beyond its outermost fixed joints (`first`, `last`) follow the leader outward
/// from them, each link turned back into its joint's limit: its links and its joints `pos`.
fn outside_fixed<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    pos: &mut [Vector<T, D>],
    first: usize,
    last: usize,
) where
    Vector<T, D>: Embed3<T>,
{
    let n = chain.n_links();
    let (links, lengths, limits) = chain.links_lengths_limits_mut();
    for i in last..n {
        let d = pos[i + 1] - pos[i];
        let len = d.norm();
        if positive_finite(len) {
            links[i] = d * (lengths[i] / len);
        }
        crate::limits::turn_back(limits, links, lengths, i, true);
        pos[i + 1] = pos[i] + links[i];
    }
    for i in (0..first).rev() {
        let d = pos[i + 1] - pos[i];
        let len = d.norm();
        if positive_finite(len) {
            links[i] = d * (lengths[i] / len);
        }
        crate::limits::turn_back(limits, links, lengths, i, false);
        pos[i] = pos[i + 1] - links[i];
    }
}

/// How [`restraighten_held`] ended.
enum Restraightened {
    Done,
    /// A part could not be solved (the move locks).
    Failed,
    /// The meter ran out first.
    OutOfWork,
}

/// One resolution pass: contacts are pushed as they are found (Gauss–Seidel), each to its clearance
/// plus half the tolerance so that re-straightening does not bring it straight back.
struct Pass<'a, T> {
    m: usize,
    /// Held joints (ascending): they do not move either.
    held: &'a [usize],
    /// Joints pushed in this pass (marked when not empty).
    marks: Vec<bool>,
    /// How far this pass's capsule pushes moved each joint (counted when not empty: a pass over
    /// the kept pairs), and the farthest a joint was moved (by one push, or in all when counted).
    pushes: Vec<T>,
    farthest: T,
    tol: T,
    /// The over-relaxation of each push.
    omega: T,
    /// Whether the over-relaxation's extra push is capped at the tolerance (held ropes).
    capped: bool,
    pushed: u32,
    worst: T,
    /// A contact only fixed joints could resolve.
    blocked: bool,
    /// The meter ran out during the pass (the pass stopped there).
    out_of_work: bool,
}

impl<T: Real> Pass<'_, T> {
    /// Inverse mass of joint `i`: the hand's joint and held joints do not move.
    #[inline]
    fn w(&self, i: usize) -> T {
        if i == self.m || self.held.binary_search(&i).is_ok() {
            T::zero()
        } else {
            T::one()
        }
    }

    /// Records a contact of depth `depth` against clearance `clearance`; `true` when it must be pushed.
    #[inline]
    fn violates(&mut self, depth: T, clearance: T) -> bool {
        if depth <= T::zero() {
            return false;
        }
        if depth > self.worst {
            self.worst = depth;
        }
        depth > self.tol * clearance
    }

    /// The push that brings a contact of depth `depth` to its clearance plus half the tolerance,
    /// over-relaxed: the depth is pushed [`CollisionOptions::over_relaxation`] times.
    #[inline]
    fn push_depth(&self, depth: T, clearance: T) -> T {
        let extra = depth * (self.omega - T::one());
        let extra = if self.capped {
            extra.min(self.tol * clearance)
        } else {
            extra
        };
        depth + extra + self.tol * T::lit(0.5) * clearance
    }

    /// The capsule pairs of one pass: the kept candidate pairs ([`NearPairs`]) while the joints have
    /// not moved too far since they were found. A resolution's first pass with no usable list
    /// descends the tree as it is (most resolutions end there: nothing touches, or one pass parts
    /// it), and so does a pass after one that pushed a joint more than an eighth of the skin (the
    /// list would not outlive the pass); a later pass makes the list first. A pass whose own
    /// pushes could have carried a pair not in the list into contact (a joint pushed farther than
    /// the skin left) leaves the list to be made again for the next pass; the pass that ends the
    /// resolution pushes nothing, so its list was exact.
    #[allow(clippy::too_many_arguments)]
    fn capsules<const D: usize>(
        &mut self,
        pos: &mut [Vector<T, D>],
        tree: &mut ChainTree<T, D>,
        near: &mut NearPairs<T, D>,
        thickness: T,
        span: usize,
        first: bool,
        min_len: T,
        meter: &mut Meter,
    ) where
        Vector<T, D>: Embed3<T>,
    {
        let skin = NearPairs::<T, D>::skin(thickness, min_len);
        let moved = match near.moved(pos, span, thickness, skin) {
            Some(d) => d,
            // No list worth making: the first pass, or passes whose pushes would spend its skin at
            // once (a rope pushed hard every pass, as a locked one is).
            None if first
                || near.last_push().partial_cmp(&(skin * T::lit(0.125)))
                    != Some(Ordering::Less) =>
            {
                tree.refit(pos, thickness * T::lit(0.5));
                self.farthest = T::zero();
                let done = tree.close_pairs(meter, span, |meter, i, j| {
                    self.capsule_pair(pos, i, j, thickness, meter)
                });
                near.set_last_push(self.farthest);
                if !done {
                    self.out_of_work = true;
                }
                return;
            }
            None => {
                if !near.make(pos, tree, span, thickness, skin, meter) {
                    self.out_of_work = true;
                    return;
                }
                T::zero()
            }
        };
        // How far each joint has been pushed in this pass (counted by the pushes), and the farthest.
        let (pairs, acc) = near.pairs_and_pushes(pos.len());
        self.pushes = core::mem::take(acc);
        self.farthest = T::zero();
        for &(i, j) in pairs.iter() {
            if !self.capsule_pair(pos, i as usize, j as usize, thickness, meter) {
                self.out_of_work = true;
                break;
            }
        }
        *acc = core::mem::take(&mut self.pushes);
        let farthest = self.farthest;
        near.set_last_push(farthest);
        let spent = (moved + farthest).partial_cmp(&(skin * T::lit(0.5)));
        // (NaN included: a list is never trusted past a non-finite push.)
        if !matches!(spent, Some(Ordering::Less | Ordering::Equal)) {
            near.invalidate();
        }
    }

    /// Pushes the pair of links `i` and `j` apart if they are closer than `c`, counting how far it
    /// moves each joint (into `pushes` when the pass keeps them, and the farthest), charging `meter`
    /// for the box test and, when the boxes meet, for the closest points: `false` (the pair not
    /// tested) if either charge would pass its limit.
    fn capsule_pair<const D: usize>(
        &mut self,
        pos: &mut [Vector<T, D>],
        i: usize,
        j: usize,
        c: T,
        meter: &mut Meter,
    ) -> bool
    where
        Vector<T, D>: Embed3<T>,
    {
        if !meter.charge(cost::CAPSULE_PAIR) {
            return false;
        }
        let (a0, a1, b0, b1) = (pos[i], pos[i + 1], pos[j], pos[j + 1]);
        // Most candidates from overlapping leaves are farther apart than the clearance along some
        // axis: no closest points needed (the pair could not violate it).
        if boxes_apart(&a0, &a1, &b0, &b1, c) {
            return true;
        }
        if !meter.charge(cost::CLOSEST) {
            return false;
        }
        let (s, t) = closest_params_segment_segment(&a0, &a1, &b0, &b1);
        let d = lerp(&a0, &a1, s) - lerp(&b0, &b1, t);
        let dist = d.norm();
        if !self.violates(c - dist, c) {
            return true;
        }
        let n = unit_or_perpendicular(&d, dist, &(a1 - a0), &(b1 - b0));
        let (w0, w1, w2, w3) = (self.w(i), self.w(i + 1), self.w(j), self.w(j + 1));
        let (s1, t1) = (T::one() - s, T::one() - t);
        let den = w0 * s1 * s1 + w1 * s * s + w2 * t1 * t1 + w3 * t * t;
        if den <= T::zero() {
            self.blocked = true;
            return true;
        }
        let lambda = self.push_depth(c - dist, c) / den;
        pos[i] += n * (w0 * s1 * lambda);
        pos[i + 1] += n * (w1 * s * lambda);
        pos[j] -= n * (w2 * t1 * lambda);
        pos[j + 1] -= n * (w3 * t * lambda);
        self.pushed += 1;
        if !self.marks.is_empty() {
            for k in [i, i + 1, j, j + 1] {
                self.marks[k] = true;
            }
        }
        let l = lambda.abs();
        let by = [w0 * s1 * l, w1 * s * l, w2 * t1 * l, w3 * t * l];
        if self.pushes.is_empty() {
            self.farthest = by.into_iter().fold(self.farthest, T::max);
        } else {
            for (k, d) in [i, i + 1, j, j + 1].into_iter().zip(by) {
                self.pushes[k] += d;
                self.farthest = self.farthest.max(self.pushes[k]);
            }
        }
        true
    }

    fn spheres<const D: usize>(&mut self, pos: &mut [Vector<T, D>])
    where
        Vector<T, D>: Embed3<T>,
    {
        let n = pos.len() - 1;
        let half = T::lit(0.5);
        for i in 0..n {
            for j in i + 2..n {
                let ci = (pos[i] + pos[i + 1]) * half;
                let cj = (pos[j] + pos[j + 1]) * half;
                let (ri, rj) = (
                    (pos[i + 1] - pos[i]).norm() * half,
                    (pos[j + 1] - pos[j]).norm() * half,
                );
                let clearance = ri + rj;
                let d = ci - cj;
                let dist = d.norm();
                if !self.violates(clearance - dist, clearance) {
                    continue;
                }
                let dir = if positive_finite(dist) {
                    d / dist
                } else {
                    any_perpendicular(&(pos[i + 1] - pos[i]))
                };
                // The colliding link is the one farther from the hand; it is moved, not the other.
                let far_i = self.distance_from_hand(i) >= self.distance_from_hand(j);
                let (k, sign) = if far_i { (i, T::one()) } else { (j, -T::one()) };
                self.translate_link(
                    pos,
                    k,
                    dir * (sign * self.push_depth(clearance - dist, clearance)),
                );
            }
        }
    }

    /// How many links lie between link `i` and the hand's joint.
    fn distance_from_hand(&self, i: usize) -> usize {
        if i >= self.m {
            i - self.m
        } else {
            self.m - 1 - i
        }
    }

    /// Moves link `k`'s centre by `delta`: both joints, or the free one twice as far when the other is
    /// the hand's.
    fn translate_link<const D: usize>(
        &mut self,
        pos: &mut [Vector<T, D>],
        k: usize,
        delta: Vector<T, D>,
    ) {
        let two = T::lit(2.0);
        let (fixed_k, fixed_next) = (self.w(k) == T::zero(), self.w(k + 1) == T::zero());
        match (fixed_k, fixed_next) {
            (true, true) => {
                self.blocked = true;
                return;
            }
            (true, false) => pos[k + 1] += delta * two,
            (false, true) => pos[k] += delta * two,
            (false, false) => {
                pos[k] += delta;
                pos[k + 1] += delta;
            }
        }
        self.pushed += 1;
        if !self.marks.is_empty() {
            self.marks[k] = true;
            self.marks[k + 1] = true;
        }
    }

    fn obstacle<const D: usize>(
        &mut self,
        pos: &mut [Vector<T, D>],
        ob: &Obstacle<T, D>,
        opts: &CollisionOptions<T>,
        skip: [core::ops::Range<usize>; 2],
        presses: impl Fn(usize) -> bool,
    ) where
        Vector<T, D>: Embed3<T>,
    {
        let half = T::lit(0.5);
        for i in 0..pos.len() - 1 {
            if skip.iter().any(|r| r.contains(&i)) {
                continue;
            }
            let (a, b) = (pos[i], pos[i + 1]);
            let link_r = match opts.scheme {
                Scheme::Capsules => opts.thickness * half,
                Scheme::PaperSpheres => (b - a).norm() * half,
            };
            // The point of the link that meets the obstacle: its centre for a sphere, the closest
            // point of its axis for a capsule.
            let (s, normal, depth, clearance) = match (opts.scheme, ob) {
                (Scheme::PaperSpheres, _) => {
                    let c = (a + b) * half;
                    let (n, dist, r) = away_from(ob, &c, &(b - a));
                    (half, n, link_r + r - dist, link_r + r)
                }
                (Scheme::Capsules, Obstacle::Block { lo, hi }) => {
                    if boxes_apart(&a, &b, lo, hi, link_r) {
                        continue;
                    }
                    let s = closest_param_segment_block(&a, &b, lo, hi);
                    let (n, dist, _) = away_from(ob, &lerp(&a, &b, s), &(b - a));
                    // Beside a hole only the axis is kept out (the tolerance still the radius's).
                    let reach = if presses(i) { T::zero() } else { link_r };
                    (s, n, reach - dist, link_r)
                }
                (Scheme::Capsules, Obstacle::HalfSpace { point, normal }) => {
                    let (da, db) = ((a - point).dot(normal), (b - point).dot(normal));
                    let s = if da <= db { T::zero() } else { T::one() };
                    (s, *normal, link_r - da.min(db), link_r)
                }
                (Scheme::Capsules, Obstacle::Sphere { center, radius }) => {
                    if boxes_apart(&a, &b, center, center, link_r + *radius) {
                        continue;
                    }
                    let s = closest_param_point_segment(center, &a, &b);
                    let p = lerp(&a, &b, s);
                    let (n, dist, r) = away_from(ob, &p, &(b - a));
                    debug_assert_eq!(r, *radius);
                    (s, n, link_r + r - dist, link_r + r)
                }
                (
                    Scheme::Capsules,
                    Obstacle::Capsule {
                        a: oa,
                        b: ob_b,
                        radius,
                    },
                ) => {
                    if boxes_apart(&a, &b, oa, ob_b, link_r + *radius) {
                        continue;
                    }
                    let (s, t) = closest_params_segment_segment(&a, &b, oa, ob_b);
                    let d = lerp(&a, &b, s) - lerp(oa, ob_b, t);
                    let dist = d.norm();
                    let n = unit_or_perpendicular(&d, dist, &(b - a), &(*ob_b - *oa));
                    (s, n, link_r + *radius - dist, link_r + *radius)
                }
            };
            if !self.violates(depth, clearance) {
                continue;
            }
            let push = self.push_depth(depth, clearance);
            if opts.scheme == Scheme::PaperSpheres {
                self.translate_link(pos, i, normal * push);
                continue;
            }
            let (w0, w1) = (self.w(i), self.w(i + 1));
            let s1 = T::one() - s;
            let den = w0 * s1 * s1 + w1 * s * s;
            if den <= T::zero() {
                self.blocked = true;
                continue;
            }
            let lambda = push / den;
            pos[i] += normal * (w0 * s1 * lambda);
            pos[i + 1] += normal * (w1 * s * lambda);
            self.pushed += 1;
            if !self.marks.is_empty() {
                self.marks[i] = true;
                self.marks[i + 1] = true;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// A capsule pair is charged its box test, and its closest points only when the boxes meet
    /// within the clearance: two links far apart cost the one, two links a clearance's tenth apart
    /// (their boxes meeting) both and are pushed; with the closest points' charge not left, the pair
    /// is not tested and nothing moves.
    #[test]
    fn a_pair_whose_boxes_meet_is_charged_its_closest_points() {
        let held: [usize; 0] = [];
        let mut pass = Pass {
            m: 0,
            held: &held,
            marks: Vec::new(),
            pushes: Vec::new(),
            farthest: 0.0,
            tol: 0.01,
            omega: 1.0,
            capped: false,
            pushed: 0,
            worst: 0.0,
            blocked: false,
            out_of_work: false,
        };
        let c = 0.2;
        let link = |x: f64, y: f64| [Vector3::new(x, y, 0.0), Vector3::new(x + 1.0, y, 0.0)];
        let mut pos: Vec<Vector3<f64>> = [link(0.0, 0.0), link(0.0, 5.0)].concat();
        let mut meter = Meter::default();
        assert!(pass.capsule_pair(&mut pos, 0, 2, c, &mut meter));
        assert_eq!(meter.done, cost::CAPSULE_PAIR);
        assert_eq!(pass.pushed, 0);

        let mut pos: Vec<Vector3<f64>> = [link(0.0, 0.0), link(0.0, 0.1 * c)].concat();
        let mut meter = Meter::default();
        assert!(pass.capsule_pair(&mut pos, 0, 2, c, &mut meter));
        assert_eq!(meter.done, cost::CAPSULE_PAIR + cost::CLOSEST);
        assert_eq!(pass.pushed, 1);
        assert!((pos[2].y - pos[0].y) > 0.1 * c);

        let before: Vec<Vector3<f64>> = [link(0.0, 0.0), link(0.0, 0.1 * c)].concat();
        let mut pos = before.clone();
        let mut meter = Meter {
            limit: cost::CAPSULE_PAIR + cost::CLOSEST - 1,
            done: 0,
        };
        assert!(!pass.capsule_pair(&mut pos, 0, 2, c, &mut meter));
        assert_eq!(meter.done, cost::CAPSULE_PAIR);
        assert_eq!(pos, before);
        assert_eq!(pass.pushed, 1);
    }

    /// A part of 24 links of about 0.15 on a helix, its joints off their lengths by up to 5e-11
    /// (relative), as the relaxation leaves them: closed, every link is its length to rounding, the
    /// fixed ends are kept bit for bit, and no joint moves further than the errors add up to. A part
    /// further off is left as it is.
    #[test]
    fn a_relaxed_part_closes_on_its_lengths_and_keeps_its_ends() {
        let n = 24;
        let mut pos: Vec<Vector3<f64>> = (0..=n)
            .map(|i| {
                let a = 0.3 * i as f64;
                Vector3::new(0.5 * a.cos(), 0.5 * a.sin(), 0.02 * i as f64)
            })
            .collect();
        // Lengths from the helix itself, then every free joint nudged by about 1e-12.
        let lengths: Vec<f64> = (0..n).map(|i| (pos[i + 1] - pos[i]).norm()).collect();
        for (i, p) in pos.iter_mut().enumerate().take(n).skip(1) {
            let s = if i % 2 == 0 { 1.0 } else { -1.0 };
            *p += Vector3::new(s * 1.5e-12, 0.7e-12, -s * 0.4e-12);
        }
        let links: Vec<Vector3<f64>> = (0..n).map(|i| pos[i + 1] - pos[i]).collect();
        let mut chain = Chain::from_parts(pos[0], links, lengths.clone()).unwrap();
        let before = pos.clone();
        assert!(close_relaxed(&mut chain, &mut pos, 0, n));
        assert_eq!((pos[0], pos[n]), (before[0], before[n]));
        for i in 0..n {
            let l = (pos[i + 1] - pos[i]).norm();
            assert!(
                (l - lengths[i]).abs() <= 1e-14,
                "link {i}: {l} against {}",
                lengths[i]
            );
            assert!((pos[i] - before[i]).norm() <= 1e-10, "joint {i} moved");
            let from_links = pos[i] + chain.links()[i];
            assert!(
                (from_links - pos[i + 1]).norm() <= 1e-14,
                "link {i} against the joints"
            );
        }
        // The closing two links meet the fixed end.
        let end = pos[n - 1] + chain.links()[n - 1];
        assert!((end - pos[n]).norm() <= 1e-14);

        // Off by 1e-6: not the relaxation's pose; nothing changes.
        let mut far = before.clone();
        far[7] += Vector3::new(1e-6, 0.0, 0.0);
        let snapshot = far.clone();
        let links_before = chain.links().to_vec();
        assert!(!close_relaxed(&mut chain, &mut far, 0, n));
        assert_eq!(far, snapshot);
        assert_eq!(chain.links(), &links_before[..]);
    }
}
