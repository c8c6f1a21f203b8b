//! What one command does to one chain in the chain's own form (planar or spatial, f64 or f32): the
//! per-chain body of [`World::apply`](crate::World::apply) and of
//! [`World::estimate`](crate::World::estimate), generic over the form, each reached through one
//! dispatch ([`crate::each_form`]). The [`World`](crate::World) keeps what spans chains: the budgets,
//! the owners of grasps, the undo record and the sequence number; it lends the ones a command needs
//! in a [`Context`].

use crate::command::{Answer, Command, Counts, Point, Residual, Stop};
use crate::form::{Kept, LiveChain};
use crate::moves::{
    Tries, give_way, instrument_travel, move_and_carry, move_eyelet, pull_instrument, pull_move,
    push_instrument, reach_with_holds, stop_of,
};
use crate::point::{point, to_point};
use crate::refusal::Refusal;
use crate::refuse;
use crate::scene::ChainSpec;
use tractrix::ChainError;
use tractrix::math::{Embed3, Real, Vector};

/// What the [`World`](crate::World) lends a command on one of its chains.
#[derive(Debug)]
pub(crate) struct Context<'a> {
    /// The chain's handle.
    pub(crate) chain: u32,
    /// Its scene's declaration.
    pub(crate) spec: &'a ChainSpec,
    /// Most link-steps the request may cost.
    pub(crate) budget: u64,
    /// Most link-steps a pull may cost (never more than `budget`).
    pub(crate) pull_budget: Option<u64>,
    /// The sequence number before the command.
    pub(crate) sequence: u64,
    /// The world's undo record: set (this chain, `sequence`) before a change is made.
    pub(crate) undo: &'a mut Option<(u32, u64)>,
    /// The collision work the kernel's meter charged, in link-steps.
    pub(crate) last_work: &'a mut u64,
}

/// Refused as over the budget when `work` passes it.
pub(crate) fn within_budget(work: u64, budget: u64) -> Result<(), Refusal> {
    if work > budget {
        return Err(refuse!(
            OverBudget,
            "about {work:.2e} link-steps, over the budget of {:.2e} (--budget)",
            budget as f64
        ));
    }
    Ok(())
}

/// A pull's budget: the pull budget when set, never more than the request's.
pub(crate) fn pull_cap(pull_budget: Option<u64>, budget: u64) -> u64 {
    pull_budget.map_or(budget, |p| p.min(budget))
}

/// A move of one point on a chain without collision whose estimate passes the frame, clipped to the
/// frame: the point over the share of the way that fits (halved until the move's estimate does, at
/// most eight times). `None` when it is no such move, or not even a small share fits (refused, as by
/// its size).
fn clip_to_frame<T: Real, const D: usize>(
    h: &LiveChain<T, D>,
    spec: &ChainSpec,
    req: &Command<'_>,
    budget: u64,
) -> Result<Option<Point>, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let Command::Move {
        joint,
        targets: [target],
        pull: false,
        smooth: false,
        ..
    } = *req
    else {
        return Ok(None);
    };
    if spec.collision.is_some() || joint > spec.lengths.len() {
        return Ok(None);
    }
    let from = to_point(&h.chain.joint(joint));
    let mut share = budget as f64 / estimate(h, spec, req)? as f64;
    for _ in 0..8 {
        let to = [from + (target - from) * share];
        if estimate(h, spec, &with_targets(req, &to))? <= budget {
            return Ok(Some(to[0]));
        }
        share *= 0.5;
    }
    Ok(None)
}

/// The move `req` to `targets` instead.
fn with_targets<'a>(req: &Command<'_>, targets: &'a [Point]) -> Command<'a> {
    match *req {
        Command::Move {
            chain,
            joint,
            options,
            take_over,
            smooth,
            pull,
            needle,
            ..
        } => Command::Move {
            chain,
            joint,
            targets,
            options,
            take_over,
            smooth,
            pull,
            needle,
        },
        _ => unreachable!("only a move is clipped"),
    }
}

/// The work checked against the frame before `req` runs: on a chain with collision, whose moves stop
/// short inside their frame ([`tractrix::collision::CollisionWorkspace::stop_short`], the meter
/// charging every sweep and solve), only the request's size (a link-step per link per point of a
/// path: a path too long to start on every point is refused); else [`estimate`], checked in full (the
/// substeps are still refused past the chain's limit, as the kernel would).
pub(crate) fn frame_estimate<T: Real, const D: usize>(
    h: &LiveChain<T, D>,
    spec: &ChainSpec,
    req: &Command<'_>,
) -> Result<u64, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let full = estimate(h, spec, req)?;
    if spec.collision.is_none() {
        return Ok(full);
    }
    let n = spec.lengths.len() as u64;
    Ok(match *req {
        Command::Move { targets, .. } => n.saturating_mul(targets.len() as u64),
        Command::Instrument { .. } | Command::Eyelet { .. } => n,
        _ => full,
    })
}

/// The work `req` on `h` (declared by `spec`) will cost at most, in link-steps, collision work aside
/// (metered while it runs): the substeps of a move are counted from where the joint is now, as the
/// kernel will count them. A move needing more substeps than its chain allows is refused here as the
/// kernel would refuse it (`too-many-substeps`).
pub(crate) fn estimate<T: Real, const D: usize>(
    h: &LiveChain<T, D>,
    spec: &ChainSpec,
    req: &Command<'_>,
) -> Result<u64, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let n = spec.lengths.len() as u64;
    match *req {
        Command::Move {
            joint,
            targets,
            ref options,
            ..
        } => estimate_move(h, spec, req, joint, targets, options),
        // With joint limits each iteration also tries the hierarchy (a second pass).
        Command::Reach { ref options, .. } => Ok(n
            .saturating_mul(u64::from(options.substeps.max(1)))
            .saturating_mul(u64::from(options.max_iterations.max(1)))
            .saturating_mul(if spec.limits.is_some() { 2 } else { 1 })),
        Command::Instrument {
            index,
            centre,
            axis,
            max_substeps,
            ..
        } => estimate_instrument(h, spec, index, centre, axis, max_substeps),
        // Substeps of half the shortest link over the way the eyelet goes.
        Command::Eyelet {
            index,
            at,
            max_substeps,
            ..
        } => estimate_eyelet(h, spec, index, at, max_substeps),
        Command::Query { .. }
        | Command::Describe { .. }
        | Command::Reset { .. }
        | Command::Grasp { .. }
        | Command::Release { .. } => Ok(n),
        Command::Snapshot | Command::Bundle { .. } => Ok(0),
    }
}

/// [`estimate`] of a move or path of `joint` through `targets`.
fn estimate_move<T: Real, const D: usize>(
    h: &LiveChain<T, D>,
    spec: &ChainSpec,
    req: &Command<'_>,
    joint: usize,
    targets: &[Point],
    options: &tractrix::MoveOptions<f64>,
) -> Result<u64, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let n = spec.lengths.len() as u64;
    // With held joints, each side up to a held joint iterates the fixed-base method: at
    // most `hierarchy_after` tractrix passes, then the hierarchy's one pass.
    let (held, threaded) = (
        h.chain.held().any(|j| j != joint),
        h.eyelets.iter().any(|e| e.threaded),
    );
    // Friction holds the links through the eyelets as held joints.
    let sticks = threaded && spec.eyelet_friction > 0.0;
    // With joint limits the hierarchy's pose is kept only when it lands within them, so
    // the passes may run to `max_iterations`, each with a try of the hierarchy (two);
    // boundary following takes its passes from these (`ReachOptions::passes_bound`).
    // Through eyelets each alternation walks out and back (two passes), and with
    // friction a stuck try that finds the rope taut is tried again sliding (twice).
    let passes = if held || sticks {
        let p = options.held.passes_bound(spec.limits.is_some());
        match (threaded, sticks) {
            (false, _) => p,
            (true, false) => p.saturating_mul(2),
            (true, true) => p.saturating_mul(4),
        }
    } else {
        1
    };
    let n = n.saturating_mul(passes);
    // Collision splits a move so that the hand moves at most half a clearance per substep.
    let half_clearance = spec.collision.as_ref().map(|c| {
        let link = match c.options.scheme {
            tractrix::collision::Scheme::Capsules => c.options.thickness,
            tractrix::collision::Scheme::PaperSpheres => spec.shortest,
        };
        0.5 * if c.obstacles.is_empty() {
            link
        } else {
            0.5 * link
        }
    });
    if let (tractrix::Substeps::Fixed(k), None) = (options.substeps, half_clearance) {
        // Fixed substeps, no collision: the distances do not matter (no walk to the joint).
        let k = substeps_within(f64::from(k), options.max_substeps)?;
        let substeps = k.saturating_mul(targets.len() as u64);
        return Ok(n.saturating_mul(substeps));
    }
    let mut substeps = 0u64;
    // Where the joint is now: one walk along the chain, for the substeps that depend on it.
    let mut from: Point = to_point(&h.chain.joint(joint));
    for t in targets {
        let d = ((t.x - from.x).powi(2) + (t.y - from.y).powi(2) + (t.z - from.z).powi(2)).sqrt();
        let asked = match options.substeps {
            tractrix::Substeps::Fixed(k) => f64::from(k),
            tractrix::Substeps::MaxStep(s) => (d / (s * spec.shortest)).ceil(),
        };
        let needed = half_clearance.map_or(0.0, |h| (d / h).ceil());
        let k = substeps_within(asked.max(needed).max(1.0), options.max_substeps)?;
        substeps = substeps.saturating_add(k);
        from = *t;
    }
    // Instruments riding with the joint are carried after the move: as many substeps again.
    let carried = spec.collision.as_ref().map_or(0, |c| {
        c.follows
            .iter()
            .filter(|f| f.map(|j| j as usize) == Some(joint))
            .count()
    });
    // A pull may try the move several times ([`crate::moves::PULL_TRIES`]), and on tissue
    // that gives move each threaded eyelet by up to the give times the way
    // ([`crate::moves::give_way`]); with collision the kernel's meter bounds every try
    // together.
    let tries = match *req {
        Command::Move { pull: true, .. } if spec.collision.is_none() => {
            let give = spec.wound.map_or(0, |w| {
                let threaded = h.eyelets.iter().filter(|e| e.threaded).count() as u64;
                threaded.saturating_mul(w.give.ceil().clamp(1.0, 1e9) as u64)
            });
            crate::moves::PULL_TRIES.saturating_add(give)
        }
        _ => 1,
    };
    Ok(n.saturating_mul(substeps)
        .saturating_mul(1 + carried as u64)
        .saturating_mul(tries))
}

/// `k` substeps (a whole number ≥ 1, or not finite) as the kernel counts them, refused as the kernel
/// would refuse them (`too-many-substeps`) past the chain's `limit`.
fn substeps_within(k: f64, limit: u32) -> Result<u64, Refusal> {
    if k.is_finite() && k <= f64::from(limit) {
        return Ok(k as u64);
    }
    Err(ChainError::TooManySubsteps {
        required: if k.is_finite() && k < 1e18 {
            k as u64
        } else {
            u64::MAX
        },
        limit,
    }
    .into())
}

/// [`estimate`] of an instrument's pose: substeps of half a clearance (a link against an obstacle has
/// half a link's), over the farthest any point of the instrument travels.
fn estimate_instrument<T: Real, const D: usize>(
    h: &LiveChain<T, D>,
    spec: &ChainSpec,
    index: usize,
    centre: Point,
    axis: Option<Point>,
    max_substeps: u32,
) -> Result<u64, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let n = spec.lengths.len() as u64;
    let travel = instrument_travel(&h.instruments()[index], centre, axis);
    let link = spec
        .collision
        .as_ref()
        .map_or(spec.thickness, |c| match c.options.scheme {
            tractrix::collision::Scheme::Capsules => c.options.thickness,
            tractrix::collision::Scheme::PaperSpheres => spec.shortest,
        });
    let k = substeps_within((travel / (0.25 * link)).ceil().max(1.0), max_substeps)?;
    Ok(n.saturating_mul(k))
}

/// [`estimate`] of an eyelet's move to `at`.
fn estimate_eyelet<T: Real, const D: usize>(
    h: &LiveChain<T, D>,
    spec: &ChainSpec,
    index: usize,
    at: Point,
    max_substeps: u32,
) -> Result<u64, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let n = spec.lengths.len() as u64;
    let from = h
        .eyelets
        .get(index)
        .map(|e| to_point(&e.at))
        .ok_or_else(|| {
            refuse!(
                BadOption,
                "chain {:?} has {} eyelets, not {}",
                spec.name,
                spec.eyelets.len(),
                index + 1
            )
        })?;
    let k = substeps_within(
        ((at - from).norm() / (0.5 * spec.shortest)).ceil().max(1.0),
        max_substeps,
    )?;
    Ok(n.saturating_mul(k))
}

/// Applies `req` to `h`, atomically: its estimate within the budget, then the command; on a refusal
/// the chain is as it was. The undo record is set before the kernel runs, so that a panic inside it
/// can be undone too; the caller counts the sequence number on.
pub(crate) fn apply<T: Real, const D: usize>(
    h: &mut LiveChain<T, D>,
    req: &Command<'_>,
    cx: Context<'_>,
) -> Result<Answer, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let estimated = frame_estimate(h, cx.spec, req)?;
    // A move over the frame on a chain without collision goes the share of the way that fits.
    let mut clipped = [Point::zeros()];
    let asked = if estimated > cx.budget {
        let Some(to) = clip_to_frame(h, cx.spec, req, cx.budget)? else {
            // Refused: over the frame by its size.
            return within_budget(estimated, cx.budget).map(|()| Answer::default());
        };
        clipped[0] = to;
        match *req {
            Command::Move { joint, targets, .. } => Some((joint, targets[0])),
            _ => None,
        }
    } else {
        None
    };
    let clipped_req;
    let req = if asked.is_some() {
        clipped_req = with_targets(req, &clipped);
        &clipped_req
    } else {
        req
    };
    let n_links = cx.spec.lengths.len() as u32;
    let mut outcome = Answer {
        chain: Some(cx.chain),
        changed: changes(h, cx.spec, req)?,
        counts: Counts {
            joints: n_links + 1,
            ..Counts::default()
        },
        ..Answer::default()
    };
    if outcome.changed {
        h.arm_undo();
        *cx.undo = Some((cx.chain, cx.sequence));
    }
    // Collision work depends on the contacts met, not known before: the kernel's meter charges
    // every unit (sweeps, held solves, detection, passes, re-solves) before doing it and stops
    // the request at the budget, the chain unchanged.
    // A substep out of work is kept, and the next request from the state it left goes on from it
    // (not through eyelets, whose moves are not resumed).
    let plain = h.eyelets.is_empty() && h.tissue.is_none();
    if let Some((_, ws)) = h.collision.as_mut() {
        ws.limit_work(cx.budget);
        ws.stop_short(true);
        ws.keep_unfinished(plain);
    }
    // A pull's tries share the pull budget (a haptic hand's pulls bounded apart from the tie).
    let pulled = matches!(
        *req,
        Command::Move { pull: true, .. } | Command::Instrument { pull: true, .. }
    );
    let mut tries = Tries::new(if pulled {
        pull_cap(cx.pull_budget, cx.budget)
    } else {
        cx.budget
    });
    let mut result = run(h, req, n_links, &mut outcome, &mut tries);
    if let (Ok(()), Some((joint, target))) = (&result, asked) {
        // Clipped to its frame: the joint stopped short of the target asked, its pull from there.
        if h.chain.is_held(joint) {
            h.tension.joint_moved(joint, target, Some(Stop::Work));
        }
        outcome.stopped = Some(Stop::Work);
        outcome.residual = Residual::Landing { joint, target };
        result = Ok(());
    }
    if let Some((_, ws)) = h.collision.as_mut() {
        ws.keep_unfinished(false);
    }
    let c = &mut outcome.counts;
    c.held = h.chain.held().len() as u32;
    c.instruments = h.instruments().len() as u32;
    c.pulls = c.held + c.instruments;
    c.eyelets = h.eyelets.len() as u32;
    *cx.last_work = h
        .collision
        .as_ref()
        .map_or(0, |(_, ws)| ws.work())
        .max(tries.work);
    match result {
        Ok(()) => {
            if outcome.changed {
                h.refresh_tension();
            }
            Ok(outcome)
        }
        Err(r) => {
            if outcome.changed {
                h.swap_undo();
                *cx.undo = None;
            }
            Err(r)
        }
    }
}

/// Whether `req` changes the chain's state: a grasp of a held joint and a release of a free one are
/// accepted and change nothing; a grasp past the most held joints is refused.
fn changes<T: Real, const D: usize>(
    h: &LiveChain<T, D>,
    spec: &ChainSpec,
    req: &Command<'_>,
) -> Result<bool, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    Ok(match *req {
        Command::Grasp { joint, .. } => {
            let held = h.chain.is_held(joint);
            let held_now = h.chain.held().len();
            if !held && held_now >= crate::sizes::MAX_HELD {
                return Err(refuse!(
                    BadOption,
                    "chain {:?} already holds {held_now} joints, the most there may be",
                    spec.name
                ));
            }
            !held
        }
        Command::Release { joint, .. } => h.chain.is_held(joint),
        _ => req.changes_state(),
    })
}

/// Runs `req` on `h` (which may be left moved on a refusal: [`apply`] restores it), filling in what
/// `outcome` reports of it.
fn run<T: Real, const D: usize>(
    h: &mut LiveChain<T, D>,
    req: &Command<'_>,
    n_links: u32,
    outcome: &mut Answer,
    tries: &mut Tries,
) -> Result<(), Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    match *req {
        Command::Move {
            joint,
            targets,
            ref options,
            pull,
            needle,
            ..
        } => {
            let target = targets[targets.len() - 1];
            let done = if pull {
                pull_move(h, joint, target, options, needle, tries).map(|(m, stop)| {
                    if stop.is_some() {
                        let pulled = (to_point(&h.chain.joint(joint)) - target).norm();
                        give_way(h, pulled, options.max_substeps, tries);
                    }
                    (m, stop)
                })
            } else {
                move_and_carry(h, joint, targets, options, needle)
                    .map(|m| (m, m.short.map(|s| stop_of(&s.error))))
            };
            let (m, stop) = done?;
            if h.chain.is_held(joint) {
                h.tension.joint_moved(joint, target, stop);
            }
            outcome.stopped = stop;
            outcome.short = m.short;
            outcome.substeps = m.substeps;
            outcome.paper_fallbacks = m.paper_fallbacks;
            outcome.iterations = m.collision_iterations;
            outcome.residual = Residual::Landing { joint, target };
            Ok(())
        }
        Command::Reach {
            ref goal,
            ref options,
            angles,
            ..
        } => {
            let (it, res) = reach_with_holds(h, goal, options)?;
            outcome.iterations = it;
            outcome.residual = Residual::Known(res);
            outcome.counts.angles = if angles { n_links } else { 0 };
            Ok(())
        }
        Command::Query { angles, .. } => {
            outcome.counts.angles = if angles { n_links } else { 0 };
            Ok(())
        }
        Command::Describe { .. } => {
            outcome.describe = true;
            outcome.counts.tissue = u32::from(h.tissue.is_some());
            Ok(())
        }
        Command::Reset { .. } => {
            h.load(Kept::Initial);
            Ok(())
        }
        Command::Instrument {
            index,
            centre,
            axis,
            max_substeps,
            pull,
            ..
        } => {
            let (m, stop) = if pull {
                pull_instrument(h, index, centre, axis, max_substeps, tries)?
            } else {
                let m = push_instrument(h, index, centre, axis, max_substeps)?;
                (m, m.short.map(|s| stop_of(&s.error)))
            };
            h.tension.instrument_moved(index, centre, stop);
            outcome.stopped = stop;
            outcome.short = m.short;
            outcome.substeps = m.substeps;
            outcome.iterations = m.collision_iterations;
            Ok(())
        }
        Command::Grasp { joint, .. } => Ok(h.chain.hold(joint)?),
        Command::Eyelet {
            index,
            at,
            max_substeps,
            ..
        } => {
            let m = move_eyelet(h, index, point(at), max_substeps)?;
            outcome.substeps = m.substeps;
            outcome.stopped = m.short.map(|s| stop_of(&s.error));
            outcome.short = m.short;
            Ok(())
        }
        Command::Release { joint, .. } => {
            h.tension.released(joint);
            h.chain.release(joint)?;
            Ok(())
        }
        Command::Snapshot | Command::Bundle { .. } => Ok(()),
    }
}
