//! Fixed-base hyper-redundant manipulators (section 5 of the tractrix paper).
//!
//! Joint 0 of the [`Chain`] is the base and never moves. Two strategies of the paper:
//!
//! * [`Strategy::TranslateBack`]: RESOLUTION-TRACTRIX for the whole chain, then the whole chain is
//!   translated rigidly so that joint 0 is back on the base; repeated until the head is on target. The
//!   base drift shrinks every iteration because motion dies out from head to tail (observation 4).
//! * [`Strategy::TractrixTwoLink`]: RESOLUTION-TRACTRIX down to the tail of the third link, then the
//!   closed-form two-link solution (Korein & Badler's algebraic solution of the perfectly constrained 2R
//!   subchain; in space, two spherical joints, whose elbow circle is resolved toward the current elbow).
//! * [`Strategy::PullBack`] (not the paper's): RESOLUTION-TRACTRIX with the head moving to the target,
//!   then RESOLUTION-TRACTRIX again with joint 0 moving back to the base, the rest following it;
//!   repeated (FABRIK's forward-backward alternation, with tractrix passes). The correction dies out
//!   from the base toward the head instead of moving the whole chain rigidly, so a rope held at one
//!   end gives up its slack near the hold (whether that ties knots: BENCHMARKS.md, knots).
//!
//! The paper notes that the closed form "does not work very well when the links are fully stretched out":
//! the tractrix pulls the distal part toward the target and often leaves joint 2 *outside* the two-link
//! annulus. Here that case is handled by placing joint 2 at the nearest point of the annulus (the
//! stretched or folded pose), carrying the distal part along rigidly, and iterating; the iteration
//! converges for the same reason as strategy (i). Elbow angles are computed from a clamped cosine so the
//! singular pose itself yields no NaN.
//!
//! Near full reach both iterations converge linearly with a rate that tends to 1 (a nearly straight chain
//! passes each correction on almost undamped). After [`ReachOptions::hierarchy_after`] iterations the
//! reach hierarchy of Korein & Badler finishes from the tractrix pose: from the base outward each link
//! turns only as much as needed for the goal to lie in the workspace of the links beyond it, and the last
//! two links are solved in closed form; one O(n) pass, exact for a reachable goal.
//!
//! With joint limits the hierarchy places links without them, so its pose is kept only when it lands
//! within them. A limited solve by translate-back or pull-back is finished, once, by Korein &
//! Badler's boundary following ([`crate::boundary`]: damped least squares over the joints' rotations,
//! a joint at its limit frozen while the error pushes it out), started from the pose the solve began
//! with, when the iteration has stalled twice or the hierarchy's pose breaks a limit; its passes come
//! off the iterations left, and when it does not arrive the tractrix iteration goes on. A long rope
//! bent to its limit needs it: the tractrix piles the bends at their limit near the moved end and
//! stalls. (The two-link strategy's closed form ignores the limits by design: a pose of it that
//! breaks one is refused.)
//!
//! Before iterating, the target is checked against the workspace: an annulus (plane) or spherical shell
//! (space) with outer radius `Σ Lᵢ` and inner radius `max(0, 2 max Lᵢ − Σ Lᵢ)` (Korein & Badler's reach
//! hierarchy: the goal must lie in `W[1]`). An unreachable target is an error that names the nearest
//! reachable point and the residual; nothing moves.

use crate::chain::{Chain, ChainError, MoveOptions, Substeps};
use crate::math::{Embed3, Real, Vector, all_finite, positive_finite, robust_norm};
use nalgebra::Vector3;

pub use crate::options::{ReachOptions, Strategy};

/// What a successful reach did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReachOutcome<T> {
    /// Iterations used (tractrix passes).
    pub iterations: u32,
    /// Final distance between head and target (absolute).
    pub residual: T,
}

/// Why a reach failed. In every case the chain is unchanged.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ReachError<T: Real, const D: usize> {
    /// The target lies outside the workspace.
    #[error(
        "target unreachable: {residual:?} outside the workspace; nearest reachable point {nearest:?}"
    )]
    Unreachable {
        /// The nearest point of the workspace to the target.
        nearest: Vector<T, D>,
        /// Distance from the target to the workspace.
        residual: T,
    },
    /// The iteration limit was reached first.
    #[error("not converged after {iterations} iterations, residual {residual:?}")]
    NotConverged {
        /// Iterations spent.
        iterations: u32,
        /// Distance from the head to the target when they ran out.
        residual: T,
        /// A point the chain can reach: the head of a pose the solve passed through that keeps every
        /// joint within its limits (translate-back and pull-back: the nearest to the target of their
        /// passes, turned about the base onto the line to the target; the other solvers: the last
        /// pose). For a target outside a limited chain's workspace (inside the unlimited one) this is
        /// the nearest point the solve found (a local nearest), which a hand can ask for instead;
        /// `None` when the last pose broke a limit (the two-link closed form ignores them).
        reached: Option<Vector<T, D>>,
    },
    /// Bad input (non-finite target, bad options).
    #[error(transparent)]
    Chain(#[from] ChainError),
}

/// Workspace radii of a fixed-base chain: `(inner, outer)`.
pub fn workspace_radii<T: Real>(lengths: &[T]) -> (T, T) {
    let total = lengths.iter().fold(T::zero(), |a, &b| a + b);
    let longest = lengths.iter().fold(T::zero(), |a, &b| a.max(b));
    ((longest * T::lit(2.0) - total).max(T::zero()), total)
}

/// The nearest reachable point to `target` for a chain with base `base` and these lengths, and the
/// distance to it (zero when reachable). `fallback_dir` is used when the target sits on the base.
pub fn nearest_reachable<T: Real, const D: usize>(
    base: &Vector<T, D>,
    lengths: &[T],
    target: &Vector<T, D>,
    fallback_dir: &Vector<T, D>,
) -> (Vector<T, D>, T) {
    let (inner, outer) = workspace_radii(lengths);
    // Halved first: target − base and |v| overflow for targets near the largest numbers (1.3e308 on
    // two axes), and the nearest point and residual came out as the base and infinity there. The
    // direction comes from the halved vector scaled by its largest component; the distance saturates
    // at the largest number.
    let half = target * T::lit(0.5) - base * T::lit(0.5);
    let m = half.amax();
    let r = robust_norm(&half) * T::lit(2.0);
    let r = if r.is_finite() { r } else { T::MAX };
    if r > outer {
        let dir = (half / m) / (half / m).norm();
        (base + dir * outer, (r - outer).min(T::MAX))
    } else if r < inner {
        let v = target - base;
        let dir = if r > T::zero() {
            v / r
        } else {
            let f = fallback_dir.norm();
            if f > T::zero() {
                fallback_dir / f
            } else {
                let mut e = Vector::zeros();
                e[0] = T::one();
                e
            }
        };
        (base + dir * inner, inner - r)
    } else {
        (*target, T::zero())
    }
}

/// Scratch space for [`reach`], owned by the caller and reused across calls so a reach allocates nothing
/// once warm.
#[derive(Clone, Debug, Default)]
pub struct ReachWorkspace<T: Real, const D: usize> {
    backup: Vec<Vector<T, D>>,
    /// The tractrix pose kept while a hierarchy's pose is tried against the joint limits.
    trial: Vec<Vector<T, D>>,
    /// Boundary following's storage (limited chains).
    boundary: crate::boundary::Scratch<T, D>,
    /// Whether this solve has tried boundary following (once per solve).
    boundary_tried: bool,
    /// Iterations of the solve's budget that boundary following used and the loop has not yet
    /// skipped.
    boundary_charge: u32,
}

/// Moves the head of the fixed-base `chain` to `target`, keeping joint 0 where it is.
pub fn reach<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    opts: &ReachOptions<T>,
    ws: &mut ReachWorkspace<T, D>,
) -> Result<ReachOutcome<T>, ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    if !all_finite(target) {
        return Err(ChainError::NonFinite.into());
    }
    if !positive_finite(opts.tolerance) {
        return Err(ChainError::BadOption("tolerance must be positive and finite").into());
    }
    if opts.substeps == 0 || opts.max_iterations == 0 {
        return Err(ChainError::BadOption("substeps and max_iterations must be at least 1").into());
    }
    let base = chain.origin();
    let head = chain.head();
    let (nearest, residual) = nearest_reachable(&base, chain.lengths(), target, &(head - base));
    if residual > T::zero() {
        return Err(ReachError::Unreachable { nearest, residual });
    }
    let tol = opts.tolerance * chain.total_length();
    // The reach hierarchy and the two-link closed form place links without the joint limits: with
    // limits a hierarchy's pose is kept only when it lands within them ([`hierarchy_if_due`]), and
    // the result is checked below.
    let limited = chain.joint_limits().is_some();
    ws.backup.clear();
    ws.backup.extend_from_slice(chain.links());
    ws.boundary_tried = false;
    ws.boundary_charge = 0;
    let backup_datum = chain.datum();
    let result = match opts.strategy {
        Strategy::TranslateBack => translate_back(chain, target, opts, tol, false, ws),
        Strategy::PullBack => translate_back(chain, target, opts, tol, true, ws),
        Strategy::TractrixTwoLink if chain.n_links() >= 3 => {
            tractrix_two_link(chain, target, opts, tol, ws)
        }
        // With one or two links there is nothing for the tractrix to do: the closed form alone.
        Strategy::TractrixTwoLink => {
            two_link_closed_form(chain, target);
            let residual = (chain.head() - target).norm();
            if residual <= tol {
                Ok(ReachOutcome {
                    iterations: 1,
                    residual,
                })
            } else {
                Err(ReachError::NotConverged {
                    iterations: 1,
                    residual,
                    reached: None,
                })
            }
        }
    };
    let result = match result {
        Ok(o) if limited => chain.check_limits().map(|_| o).map_err(ReachError::Chain),
        // Where the iterations left the head, if that pose is one the chain may take (unless the
        // strategy kept a nearer one).
        Err(ReachError::NotConverged {
            iterations,
            residual,
            reached: None,
        }) => Err(ReachError::NotConverged {
            iterations,
            residual,
            reached: chain.check_limits().is_ok().then(|| chain.head()),
        }),
        r => r,
    };
    if result.is_err() {
        chain.links_mut().copy_from_slice(&ws.backup);
        chain.place_origin_from(backup_datum.0, backup_datum.1);
    }
    result
}

/// Strategy (i), or with `pull` the pull-back: the base is put back by a tractrix pass from joint 0
/// (then the rounding translated away, so it lands exactly) instead of a rigid translation.
fn translate_back<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    opts: &ReachOptions<T>,
    tol: T,
    pull: bool,
    ws: &mut ReachWorkspace<T, D>,
) -> Result<ReachOutcome<T>, ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    let base = chain.origin();
    let n = chain.n_links();
    let mopts = MoveOptions {
        method: opts.method,
        substeps: Substeps::Fixed(opts.substeps),
        max_substeps: opts.substeps,
        held: *opts,
    };
    let mut residual = (chain.head() - target).norm();
    let mut last = residual;
    // The nearest the head came to the target in a pose within the limits (each pass clamps, the
    // translation turns nothing): what a refusal reports as reached.
    let limited = chain.joint_limits().is_some();
    let mut best = (residual, chain.head());
    let mut stalls = 0u32;
    // Iterations so far, and how many the budget allows (boundary following takes its share).
    let (mut it, mut limit) = (0, opts.max_iterations);
    while it < limit {
        it += 1;
        if residual <= tol {
            return Ok(ReachOutcome {
                iterations: it - 1,
                residual,
            });
        }
        if let Some(done) = hierarchy_if_due(chain, target, opts, tol, it, &mut residual, ws) {
            return Ok(done);
        }
        limit = limit.saturating_sub(std::mem::take(&mut ws.boundary_charge));
        if it >= limit {
            break;
        }
        // A chain lying straight along the line of the correction is pushed (or pulled) rigidly: an
        // exact collinear push moves the base as far as the head and the iteration stalls. When the
        // residual stops shrinking, the head takes a detour sideways (half the correction) so the
        // chain buckles; the motion is still a tractrix, only along a bent head path.
        let stalled = it > 1 && residual > last * T::lit(0.9);
        // A limited chain whose iteration has stalled twice is finished by boundary following:
        // the tractrix has piled bends at their limit and passes each correction on.
        stalls += u32::from(stalled);
        if limited
            && stalls >= 2
            && let Some(done) = boundary_once(chain, target, tol, it, opts.max_iterations, ws)
        {
            return Ok(done);
        }
        // What boundary following spent comes off the iterations left.
        limit = limit.saturating_sub(std::mem::take(&mut ws.boundary_charge));
        if it >= limit {
            break;
        }
        if stalled {
            let err = target - chain.head();
            let side = perpendicular(&err) * (err.norm() * T::lit(0.5));
            let mid = chain.head() + err * T::lit(0.5) + side;
            chain.move_joint(n, mid, &mopts)?;
        }
        chain.move_joint(n, *target, &mopts)?;
        if pull {
            chain.move_joint(0, base, &mopts)?;
        }
        chain.translate_to(base);
        last = residual;
        let head = chain.head();
        residual = (head - target).norm();
        if residual < best.0 {
            best = (residual, head);
        }
    }
    match verdict(residual, tol, opts.max_iterations) {
        Err(ReachError::NotConverged {
            iterations,
            residual,
            ..
        }) => {
            // The nearest pose found, turned about the base (whose own angle no limit constrains, so
            // every joint stays within its limit) until its head lies on the line to the target: no
            // farther from it, often nearer.
            let (from, to) = (best.1 - base, target - base);
            let (r, d) = (from.norm(), to.norm());
            let reached = if d > T::zero() && r > T::zero() {
                base + to * (r / d)
            } else {
                best.1
            };
            Err(ReachError::NotConverged {
                iterations,
                residual,
                reached: Some(reached),
            })
        }
        r => r,
    }
}

fn tractrix_two_link<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    opts: &ReachOptions<T>,
    tol: T,
    ws: &mut ReachWorkspace<T, D>,
) -> Result<ReachOutcome<T>, ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    let n = chain.n_links();
    let k = T::lit(opts.substeps as f64);
    let mut residual = (chain.head() - target).norm();
    // (Boundary following is not tried here: nothing is taken off the iterations.)
    for it in 1..=opts.max_iterations {
        if residual <= tol {
            return Ok(ReachOutcome {
                iterations: it - 1,
                residual,
            });
        }
        if let Some(done) = hierarchy_if_due(chain, target, opts, tol, it, &mut residual, ws) {
            return Ok(done);
        }
        // Tractrix of links 3..n with the head moving straight to the target; joint 2 follows.
        let s = (target - chain.head()) / k;
        for _ in 0..opts.substeps {
            chain.sweep_tail_side(n, &s, opts.method, 2);
        }
        // Where joint 2 must be for the head to be on target, then the two-link solution for it.
        let distal: Vector<T, D> = chain.links()[2..]
            .iter()
            .fold(Vector::zeros(), |a, l| a + l);
        two_link_closed_form(chain, &(target - distal));
        residual = (chain.head() - target).norm();
    }
    verdict(residual, tol, opts.max_iterations)
}

/// Once `it` is past `opts.hierarchy_after`, finishes with the reach hierarchy and updates `residual`;
/// returns the outcome when that converged.
fn hierarchy_if_due<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    opts: &ReachOptions<T>,
    tol: T,
    it: u32,
    residual: &mut T,
    ws: &mut ReachWorkspace<T, D>,
) -> Option<ReachOutcome<T>>
where
    Vector<T, D>: Embed3<T>,
{
    if opts.hierarchy_after == 0 || it <= opts.hierarchy_after {
        return None;
    }
    if chain.joint_limits().is_some() {
        // The hierarchy places links without the limits: its pose is taken only when it lands within
        // them; otherwise, once, boundary following ([`crate::boundary`]); otherwise the tractrix
        // pose stays and the iteration goes on.
        let trial = &mut ws.trial;
        trial.clear();
        trial.extend_from_slice(chain.links());
        reach_hierarchy(chain, target);
        let landed = (chain.head() - target).norm();
        // Within the limits to rounding, as a clamped link is (not merely within the tolerance a
        // refusal allows): the hierarchy's pose must not sit a hair outside where the tractrix's sat on.
        let strict = T::lit(1e-12).max(T::EPSILON * T::lit(64.0));
        if landed <= tol && chain.limit_excess(strict).is_none() {
            *residual = landed;
            return Some(ReachOutcome {
                iterations: it,
                residual: landed,
            });
        }
        chain.links_mut().copy_from_slice(trial);
        // Not for the two-link strategy: its closed form ignores the limits by design, and a pose
        // that breaks one is refused as such.
        if opts.strategy == Strategy::TractrixTwoLink {
            return None;
        }
        let done = boundary_once(chain, target, tol, it, opts.max_iterations, ws);
        if let Some(o) = done {
            *residual = o.residual;
        }
        return done;
    }
    reach_hierarchy(chain, target);
    *residual = (chain.head() - target).norm();
    (*residual <= tol).then_some(ReachOutcome {
        iterations: it,
        residual: *residual,
    })
}

/// Boundary following ([`crate::boundary`]) for a limited chain, once per solve: from the pose the
/// solve started from (the tractrix iterations have piled bends at their limits near the moved end,
/// where boundary following finds them frozen: from there a 1000-link rope bent to its limit refused
/// 1 to 4 moves of 300, from the start none). It may use the passes of the iterations left after
/// iteration `it` of `max_iterations` (two per iteration, as [`ReachOptions::passes_bound`] counts
/// them); what it used is left in `ws.boundary_charge`, in iterations, for the loop to take off its
/// limit. When it does not arrive, the chain is put back where the iteration had it.
fn boundary_once<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    tol: T,
    it: u32,
    max_iterations: u32,
    ws: &mut ReachWorkspace<T, D>,
) -> Option<ReachOutcome<T>>
where
    Vector<T, D>: Embed3<T>,
{
    let per = crate::boundary::PASSES_PER_ITERATION;
    let cap = max_iterations.saturating_sub(it).saturating_mul(2) / per;
    if ws.boundary_tried || cap == 0 {
        return None;
    }
    ws.boundary_tried = true;
    ws.trial.clear();
    ws.trial.extend_from_slice(chain.links());
    chain.links_mut().copy_from_slice(&ws.backup);
    let (done, ran) = crate::boundary::follow_boundary(chain, target, tol, cap, &mut ws.boundary);
    ws.boundary_charge = (ran.saturating_mul(per)).div_ceil(2);
    match done {
        Some(residual) => Some(ReachOutcome {
            iterations: it,
            residual,
        }),
        None => {
            chain.links_mut().copy_from_slice(&ws.trial);
            None
        }
    }
}

/// The result after the last allowed iteration.
fn verdict<T: Real, const D: usize>(
    residual: T,
    tol: T,
    iterations: u32,
) -> Result<ReachOutcome<T>, ReachError<T, D>> {
    if residual <= tol {
        Ok(ReachOutcome {
            iterations,
            residual,
        })
    } else {
        Err(ReachError::NotConverged {
            iterations,
            residual,
            reached: None,
        })
    }
}

/// The closed-form two-link solution about `base`: new vectors of the first and second link so that the
/// second link's end is as close as possible to `goal` (exactly on it inside the annulus
/// `[|a1 − a2|, a1 + a2]`, else on the annulus's nearest point). The elbow stays on the side of the
/// current first link `cur` (continuity; in space, the nearest point of the elbow circle). The cosine is
/// clamped so the stretched-out and folded singular poses give a straight or folded pair, never NaN.
pub(crate) fn two_link<T: Real, const D: usize>(
    base: &Vector<T, D>,
    goal: &Vector<T, D>,
    a1: T,
    a2: T,
    cur: &Vector<T, D>,
) -> (Vector<T, D>, Vector<T, D>)
where
    Vector<T, D>: Embed3<T>,
{
    let v = goal - base;
    let r = v.norm();
    let axis = if r > T::zero() {
        v / r
    } else {
        cur / cur.norm()
    };
    let d = r.max((a1 - a2).abs()).min(a1 + a2);
    let x = if d > T::zero() {
        ((d * d + a1 * a1 - a2 * a2) / (T::lit(2.0) * d))
            .max(-a1)
            .min(a1)
    } else {
        T::zero()
    };
    let h = (a1 * a1 - x * x).max(T::zero()).sqrt();
    let mut side = cur - axis * cur.dot(&axis);
    let sn = side.norm();
    if sn > a1 * T::EPSILON * T::lit(16.0) {
        side /= sn;
    } else {
        side = perpendicular(&axis);
    }
    let elbow = axis * x + side * h;
    let l1 = elbow * (a1 / elbow.norm());
    let l2 = axis * d - l1;
    let l2n = l2.norm();
    (
        l1,
        if l2n > T::zero() {
            l2 * (a2 / l2n)
        } else {
            axis * a2
        },
    )
}

/// Places joints 1 and 2 by the closed-form two-link solution so that joint 2 is as close as possible to
/// `goal`. With a one-link chain, the link points at the goal.
fn two_link_closed_form<T: Real, const D: usize>(chain: &mut Chain<T, D>, goal: &Vector<T, D>)
where
    Vector<T, D>: Embed3<T>,
{
    let base = chain.origin();
    let lens = chain.lengths();
    let a1 = lens[0];
    if lens.len() == 1 {
        let v = goal - base;
        let r = v.norm();
        if r > T::zero() {
            chain.links_mut()[0] = v * (a1 / r);
        }
        return;
    }
    let a2 = lens[1];
    let cur = chain.links()[0];
    let (l1, l2) = two_link(&base, goal, a1, a2, &cur);
    let links = chain.links_mut();
    links[0] = l1;
    links[1] = l2;
}

/// Korein & Badler's reach hierarchy from the current pose: going from the base outward, each link turns
/// only as much as needed for the goal to lie in the workspace annulus (shell) of the links beyond it;
/// the last two links are solved in closed form. Links beyond the one being turned are carried along
/// rigidly. For a reachable goal the head lands on it in one pass.
fn reach_hierarchy<T: Real, const D: usize>(chain: &mut Chain<T, D>, goal: &Vector<T, D>)
where
    Vector<T, D>: Embed3<T>,
{
    let n = chain.n_links();
    if n <= 2 {
        two_link_closed_form(chain, goal);
        return;
    }
    let mut pos = chain.origin();
    for i in 0..n - 2 {
        let (inner, outer) = workspace_radii(&chain.lengths()[i + 1..]);
        let li = chain.lengths()[i];
        let cur = chain.links()[i];
        let d = (goal - (pos + cur)).norm();
        if d > outer || d < inner {
            // Turn link i minimally: its end goes to the nearest point at the clamped distance from the goal.
            let want = d.max(inner).min(outer);
            let (l, _) = two_link(&pos, goal, li, want, &cur);
            chain.links_mut()[i] = l;
        }
        pos += chain.links()[i];
    }
    let (a1, a2) = (chain.lengths()[n - 2], chain.lengths()[n - 1]);
    let cur = chain.links()[n - 2];
    let (l1, l2) = two_link(&pos, goal, a1, a2, &cur);
    let links = chain.links_mut();
    links[n - 2] = l1;
    links[n - 1] = l2;
}

/// A unit vector perpendicular to `v` in the chain's own space (in the plane for planar chains).
fn perpendicular<T: Real, const D: usize>(v: &Vector<T, D>) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let v3 = v.to_3d();
    let mut p = Vector3::z().cross(&v3);
    if D == 3 && p.norm() <= v3.norm() * T::lit(0.1) {
        p = Vector3::x().cross(&v3);
    }
    let out = Vector::<T, D>::from_3d(&p);
    let n = out.norm();
    if n > T::zero() {
        out / n
    } else {
        let mut e = Vector::zeros();
        e[D - 1] = T::one();
        e
    }
}
