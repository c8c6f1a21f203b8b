//! All contacts of a rope between fixed joints solved together with its lengths: the joint
//! projection of a knot under tension.
//!
//! The pass-by-pass resolution ([`super::resolve`]) pushes each contact apart on its own, then
//! restores the lengths: on a knot pulled taut the two fight (a push lengthens the rope, the
//! lengths pull the strands back into contact) and the passes creep toward the tolerance, hundreds of
//! them per substep, until the passes or the work budget run out (issue 38: every tightening pull
//! stopped at `locked`, "links still 2e-3 too close after 64 passes"). Here the length of every link
//! and the clearance of every contact are one linear system, solved at once: each iteration
//! linearises them where the rope is and moves the free joints by the smallest displacement that
//! meets all of them (fast projection, Goldenthal et al. 2007, with the contacts as extra rows: Newton
//! on the constraint manifold), the contact set found again from the new pose (so strands slide
//! along each other: only the normal distance is constrained). A contact that would pull its links
//! together (a negative multiplier) leaves the active set: contacts only push.
//!
//! The system `J W Jᵀ λ = b` has the links' rows (tridiagonal among themselves) and the contacts'
//! (a few joints each). With `A` the links' block, `B` the coupling and `C` the contacts' block, the
//! contacts' multipliers solve the Schur complement `(C − Bᵀ A⁻¹ B) λ_c = b_c − Bᵀ A⁻¹ b_l` (dense,
//! contacts × contacts), and `A` is factored once per iteration (Thomas). Each contact touches at
//! most eight links, so `B` is sparse; the complement is formed only over the rows the active set
//! takes (a column of `A⁻¹ B` each, solved once over the parts between fixed joints it touches,
//! where `A` falls apart), `C` from the joints rows share, and the active set's rounds take its
//! sub-block (`a³`).
//! The hand's joint and the held joints do not move (inverse mass zero).
//!
//! Used on the moves of a rope with held joints whose contacts have not parted after the passes the
//! options set (`together_after`, two by default; pulls always after two; a threaded rope's plain
//! moves never), from the re-straightened pose, whose lengths are exact.

use super::query::{
    away_from, closest_param_point_segment, closest_param_segment_block,
    closest_params_segment_segment, lerp, unit_or_perpendicular,
};
use super::tree::boxes_apart;
use super::{CollisionModel, CollisionWorkspace, Obstacle, Scheme, cost, neighbour_span};
use crate::math::{Embed3, Real, Vector, positive_finite};

/// Most contacts one iteration solves together (the dense block is contacts²): beyond, the
/// projection gives way to the passes.
pub(super) const MAX_CONTACTS: usize = 192;

/// Newton iterations of one projection.
pub(super) const ITERATIONS: usize = 16;

/// Pairs nearer than their target distance plus this share of the clearance are rows of the
/// system, inactive until a step would bring them closer than their target (the active set: without
/// them, a strand sliding over another meets the next pair of links at every step, the step that
/// parts one contact closes its neighbour, and on `square-held` at 160 links a fifth of the
/// projections stalled so; with a tenth of a clearance none did, and with a quarter the pairs of
/// strands lying side by side were more rows than [`MAX_CONTACTS`]; counted with temporary prints).
const NEAR: f64 = 0.1;

/// The projection has converged when every link is within this share of its length (the
/// re-straightening that follows makes them exact, moving joints by about as much) and every contact
/// within half the tolerance of its clearance (the pass that follows pushes nothing then).
const LENGTHS_MET: f64 = 1e-7;

/// A step that leaves the worst error more than this many times the best so far ends the
/// projection at once (stalled): the linearisation is no guide there (strands pressed between
/// others on a taut rope), and the steps after it cost as much and gain nothing.
const BLOWN: f64 = 2.0;

/// Rounds of the active set per step: contacts that would pull (negative multipliers) leave it,
/// rows the step would bring too close join it.
const ACTIVE_ROUNDS: usize = 8;

/// Added to each active contact row's diagonal in the contacts' system (the Schur complement, whose
/// diagonal is the row's squared joint weights, 0.5 to 2): a compliance, as XPBD's (Macklin, Müller
/// & Chentanez 2016), that makes each Newton step a damped least-squares one. On links shorter than
/// the rope is thick one contact between two strands is several nearly dependent rows; undamped,
/// the step's multipliers grew huge (joints asked to move 10⁶ units), the active set did not settle
/// in its rounds, and nearly every projection of the 320-link square knot stalled. With it almost
/// none stall. Outside pulls only: a pull's steps stay undamped, to meet each contact in full
/// (docs/history.md, issue 68, fifth and sixth sessions).
const COMPLIANCE: f64 = 1e-2;

/// One contact's row: the joints it moves with their weights (its gradient is `weight × normal` at
/// each), the normal, and how far it is from its target distance (positive: too close).
#[derive(Clone, Copy, Debug)]
pub(super) struct Row<T: Real, const D: usize> {
    joints: [usize; 4],
    weights: [T; 4],
    count: usize,
    normal: Vector<T, D>,
    gap: T,
}

/// Buffers of the projection (kept in the collision workspace: no allocation once warm).
#[derive(Clone, Debug, Default)]
pub(super) struct Projection<T: Real, const D: usize> {
    rows: Vec<Row<T, D>>,
    u: Vec<Vector<T, D>>,
    c: Vec<T>,
    /// The Thomas factorisation of the links' block: pivots and upper diagonal.
    pivot: Vec<T>,
    upper: Vec<T>,
    /// `A⁻¹ b_l`, then `λ_l`.
    lam_l: Vec<T>,
    /// `B`, one column (of `n`) per contact, each turned into its column of `A⁻¹ B` once its row
    /// joins the active set (`solved`).
    ab: Vec<T>,
    /// Every row's right-hand side of the Schur complement, whether its column of `A⁻¹ B` is
    /// solved, and the links over which that column can be nonzero (`start..end`).
    full_rhs: Vec<T>,
    solved: Vec<bool>,
    ext: Vec<(usize, usize)>,
    /// `A⁻¹ B λ` over the active rows.
    y: Vec<T>,
    /// The contacts' block `C` (row-major), from each free joint's rows (joint, row, slot).
    cmat: Vec<T>,
    touch: Vec<(usize, usize, usize)>,
    /// Each row's coupling to the links.
    bsparse: Vec<Sparse<T>>,
    /// The sub-diagonal of the links' block; `−C`, then `A⁻¹ b_l`.
    lower: Vec<T>,
    bl: Vec<T>,
    /// The active rows' block, and every row's multiplier `λ_c` (zero off the active set).
    s: Vec<T>,
    rhs: Vec<T>,
    active: Vec<bool>,
    /// The active rows of a round.
    idx: Vec<usize>,
    col: Vec<T>,
}

/// How a projection ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Projected {
    /// Every link within [`LENGTHS_MET`] of its length and every contact within half the tolerance.
    Converged,
    /// It stopped gaining (the rope cannot give way: the knot is jammed), or a step made it much
    /// worse; the pose it started from is kept.
    Stalled,
    /// Its iterations ran out while it still gained (the pose it started from is kept).
    Unfinished,
    /// More contacts than [`MAX_CONTACTS`].
    TooMany,
    /// The meter ran out.
    OutOfWork,
}

/// Inverse mass: fixed joints (the hand's `m` and the `held` ones, ascending) do not move.
fn w<T: Real>(i: usize, m: usize, held: &[usize]) -> T {
    if i == m || held.binary_search(&i).is_ok() {
        T::zero()
    } else {
        T::one()
    }
}

/// Whether only fixed joints (the hand's `m`, the `held` ones) could move the contact `row`: every
/// joint it weighs is fixed (an obstacle met at a held or end joint, `s` = 0 or 1).
fn immovable<T: Real, const D: usize>(row: &Row<T, D>, m: usize, held: &[usize]) -> bool {
    (0..row.count)
        .all(|a| row.weights[a] == T::zero() || w::<T>(row.joints[a], m, held) == T::zero())
}

/// The contacts of the rope at `pos` (capsule pairs on the tree, and the obstacles): those closer
/// than their target distance (the clearance plus half the tolerance) into `rows`, the hand's joint
/// `m` and the `held` ones fixed. A contact only fixed joints could move is left out (no step can
/// meet it; the passes that follow lock the move if it is deeper than the tolerance). `None` when
/// the meter ran out.
fn gather<T: Real, const D: usize>(
    pos: &[Vector<T, D>],
    (m, held): (usize, &[usize]),
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
    rows: &mut Vec<Row<T, D>>,
    worst: &mut T,
) -> Option<()>
where
    Vector<T, D>: Embed3<T>,
{
    let opts = &model.options;
    rows.clear();
    let half = T::lit(0.5);
    let n = pos.len() - 1;
    if !ws
        .meter
        .charge((n as u64).saturating_mul(cost::REFIT_PER_LINK))
    {
        return None;
    }
    let c = opts.thickness;
    let target = c + opts.tolerance * half * c;
    if opts.self_collision {
        ws.tree.refit(pos, c * half);
        let min_len = pos
            .windows(2)
            .map(|w| (w[1] - w[0]).norm())
            .fold(T::max_value().unwrap_or_else(T::one), |a, b| a.min(b));
        let span = neighbour_span(min_len, c);
        let near_c = c * T::lit(NEAR);
        let done = ws.tree.close_pairs(&mut ws.meter, span, |meter, i, j| {
            if !meter.charge(cost::CAPSULE_PAIR) {
                return false;
            }
            let (a0, a1, b0, b1) = (pos[i], pos[i + 1], pos[j], pos[j + 1]);
            // Apart along an axis by the row's reach: no closest points needed.
            if boxes_apart(&a0, &a1, &b0, &b1, target + near_c) {
                return true;
            }
            if !meter.charge(cost::CLOSEST) {
                return false;
            }
            let (s, t) = closest_params_segment_segment(&a0, &a1, &b0, &b1);
            let d = lerp(&a0, &a1, s) - lerp(&b0, &b1, t);
            let dist = d.norm();
            if dist >= target + near_c {
                return true;
            }
            let row = Row {
                joints: [i, i + 1, j, j + 1],
                weights: [T::one() - s, s, -(T::one() - t), -t],
                count: 4,
                normal: unit_or_perpendicular(&d, dist, &(a1 - a0), &(b1 - b0)),
                gap: target - dist,
            };
            if !immovable(&row, m, held) {
                *worst = (*worst).max(c - dist);
                rows.push(row);
            }
            true
        });
        if !done {
            return None;
        }
    }
    if opts.scheme != Scheme::Capsules {
        return Some(());
    }
    for (k, ob) in model.obstacles.iter().enumerate() {
        let skip = super::untested(model, k, &ws.through);
        if !ws
            .meter
            .charge((n as u64).saturating_mul(cost::obstacle_per_link(ob)))
        {
            return None;
        }
        let link_r = c * half;
        for i in 0..n {
            if skip.iter().any(|r| r.contains(&i)) {
                continue;
            }
            let (s, normal, dist, clearance) = link_and_obstacle(ob, &pos[i], &pos[i + 1], link_r);
            // Beside a hole only the axis is kept out of the block (the tolerance still the
            // radius's).
            let reach = if super::presses(model, k, &ws.through, ws.pressed, i) {
                T::zero()
            } else {
                clearance
            };
            let goal = reach + opts.tolerance * half * clearance;
            if dist >= goal + clearance * T::lit(NEAR) {
                continue;
            }
            let row = Row {
                joints: [i, i + 1, 0, 0],
                weights: [T::one() - s, s, T::zero(), T::zero()],
                count: 2,
                normal,
                gap: goal - dist,
            };
            if !immovable(&row, m, held) {
                *worst = (*worst).max(reach - dist);
                rows.push(row);
            }
        }
    }
    Some(())
}

/// The closest point of the link `a b` to the obstacle `ob`: its parameter along the link, the unit
/// normal away from the obstacle, the distance along it, and the clearance the link keeps there (its
/// radius `link_r`, plus the obstacle's).
fn link_and_obstacle<T: Real, const D: usize>(
    ob: &Obstacle<T, D>,
    a: &Vector<T, D>,
    b: &Vector<T, D>,
    link_r: T,
) -> (T, Vector<T, D>, T, T)
where
    Vector<T, D>: Embed3<T>,
{
    let (a, b) = (*a, *b);
    match ob {
        Obstacle::Block { lo, hi } => {
            let s = closest_param_segment_block(&a, &b, lo, hi);
            let (nrm, dist, _) = away_from(ob, &lerp(&a, &b, s), &(b - a));
            (s, nrm, dist, link_r)
        }
        Obstacle::HalfSpace { point, normal } => {
            let (da, db) = ((a - point).dot(normal), (b - point).dot(normal));
            let s = if da <= db { T::zero() } else { T::one() };
            (s, *normal, da.min(db), link_r)
        }
        Obstacle::Sphere { center, .. } => {
            let s = closest_param_point_segment(center, &a, &b);
            let (nrm, dist, r) = away_from(ob, &lerp(&a, &b, s), &(b - a));
            (s, nrm, dist, link_r + r)
        }
        Obstacle::Capsule {
            a: oa,
            b: ob_b,
            radius,
        } => {
            let (s, t) = closest_params_segment_segment(&a, &b, oa, ob_b);
            let d = lerp(&a, &b, s) - lerp(oa, ob_b, t);
            let dist = d.norm();
            let nrm = unit_or_perpendicular(&d, dist, &(b - a), &(*ob_b - *oa));
            (s, nrm, dist, link_r + *radius)
        }
    }
}

/// Projects the joints `pos` of a chain (its `lengths`) onto its lengths and its contacts' clearances
/// together (see the module docs), the hand's joint `m` and the `held` joints fixed. No joint moves
/// more than `step` in one iteration (a longer Newton step is scaled down to it: the projection
/// carries no link through another). Every iteration is charged to the meter first.
pub(super) fn project<T: Real, const D: usize>(
    pos: &mut [Vector<T, D>],
    lengths: &[T],
    m: usize,
    held: &[usize],
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
    step: T,
) -> Projected
where
    Vector<T, D>: Embed3<T>,
{
    let n = lengths.len();
    let opts = &model.options;
    let mut pr = std::mem::take(&mut ws.projection);
    let start = pos.to_vec();
    let mut best: Option<T> = None;
    let mut outcome = Projected::Unfinished;
    let mut idle = 0;
    for _ in 0..ITERATIONS {
        let mut worst_contact = T::zero();
        if gather(pos, (m, held), model, ws, &mut pr.rows, &mut worst_contact).is_none() {
            outcome = Projected::OutOfWork;
            break;
        }
        let r = pr.rows.len();
        if r > MAX_CONTACTS {
            outcome = Projected::TooMany;
            break;
        }
        // The lengths' errors.
        pr.u.resize(n, Vector::zeros());
        pr.c.resize(n, T::zero());
        let mut worst_length = T::zero();
        for k in 0..n {
            let d = pos[k + 1] - pos[k];
            let len = d.norm();
            if positive_finite(len) {
                pr.u[k] = d / len;
                pr.c[k] = len - lengths[k];
            } else {
                pr.u[k] = Vector::zeros();
                pr.c[k] = T::zero();
            }
            worst_length = worst_length.max(pr.c[k].abs() / lengths[k]);
        }
        // How far from the goal: the worse of the lengths' and the contacts' errors, each relative
        // (to its link, to the clearance). A Newton step that parts a contact stretches the links
        // next to it to second order, which the next step takes back: the projection gives up
        // after three steps that did not improve on the best, and keeps only a pose that converged.
        let clearance = opts.thickness.max(T::EPSILON);
        let merit = worst_length.max(worst_contact / clearance);
        if !merit.is_finite() {
            outcome = Projected::Stalled;
            break;
        }
        if worst_length <= T::lit(LENGTHS_MET)
            && worst_contact <= opts.tolerance * T::lit(0.5) * clearance
        {
            outcome = Projected::Converged;
            break;
        }
        match best {
            Some(b) if merit >= b => {
                idle += 1;
                if idle >= 3 || merit > b * T::lit(BLOWN) {
                    outcome = Projected::Stalled;
                    break;
                }
            }
            _ => {
                idle = 0;
                best = Some(merit);
            }
        }
        // Charged: the links' factorisation and solve, the displacement and the contacts' block
        // (about 24 flops a pair of rows); each column of `A⁻¹ B` is charged when its row becomes
        // active and it is solved, and each round of the active set below charges its own.
        let r64 = r as u64;
        let units = (n as u64)
            .saturating_mul(cost::RELAX_PER_LINK)
            .saturating_add(r64.saturating_mul(r64).saturating_mul(4));
        if !ws.meter.charge(units) {
            outcome = Projected::OutOfWork;
            break;
        }
        ws.stats.newton_steps += 1;
        // Damped outside pulls only: a pull's steps are left undamped (see [`COMPLIANCE`]).
        let compliance = if ws.together() {
            T::zero()
        } else {
            T::lit(COMPLIANCE)
        };
        let Some(delta) = solve_step(&mut pr, (m, held), n, compliance, &mut ws.meter) else {
            outcome = Projected::OutOfWork;
            break;
        };
        // Apply δp = W Jᵀ λ, scaled so that no joint moves more than `step`.
        let longest = delta.iter().fold(T::zero(), |a, d| a.max(d.norm()));
        let scale = if longest > step {
            step / longest
        } else {
            T::one()
        };
        for (p, d) in pos.iter_mut().zip(&delta) {
            *p += *d * scale;
        }
        // Back onto the lengths: the step keeps them only to first order, and on a nearly taut
        // rope its second order is most of the step. Not in pulls: there the tightening pulls
        // jammed sooner with it (the tighten bench's 160-link square, granny and surgeon's knots
        // ended three to four times looser, one run each).
        if !ws.together() && !retract(pos, lengths, m, held, &mut ws.meter) {
            outcome = Projected::OutOfWork;
            break;
        }
    }
    // All or nothing: a pose far from the lengths would be re-solved by the reach that follows,
    // which can move joints far (on the instrument tie at 160 links, more than half a clearance:
    // the move locked); the pose it started from is kept instead.
    if outcome != Projected::Converged {
        pos.copy_from_slice(&start);
    }
    ws.stats.projections += 1;
    match outcome {
        Projected::Converged => ws.stats.converged += 1,
        Projected::Stalled | Projected::Unfinished | Projected::TooMany => ws.stats.stalled += 1,
        Projected::OutOfWork => {}
    }
    ws.projection = pr;
    outcome
}

/// Puts the joints `pos` back on the link `lengths`: each part between two fixed joints (the hand's
/// `m` and the `held` ones) relaxed by fast projection, the parts beyond the outermost fixed joints
/// rescaled outward along their links. `false` when the meter ran out.
fn retract<T: Real, const D: usize>(
    pos: &mut [Vector<T, D>],
    lengths: &[T],
    m: usize,
    held: &[usize],
    meter: &mut super::Meter,
) -> bool
where
    Vector<T, D>: Embed3<T>,
{
    let n = lengths.len();
    let (mut first, mut last) = (m, m);
    let mut prev = None;
    for f in held.iter().copied().chain(core::iter::once(m)) {
        first = first.min(f);
        last = last.max(f);
    }
    // The fixed joints in order: `held` is ascending, `m` goes where it belongs.
    for f in (0..=n).filter(|&j| j == m || held.binary_search(&j).is_ok()) {
        if let Some(a) = prev
            && f > a + 1
            && !super::relax::relax_part(&mut pos[a..=f], &lengths[a..f], meter)
        {
            return false;
        }
        prev = Some(f);
    }
    for i in last..n {
        let d = pos[i + 1] - pos[i];
        let len = d.norm();
        if positive_finite(len) {
            pos[i + 1] = pos[i] + d * (lengths[i] / len);
        }
    }
    for i in (0..first).rev() {
        let d = pos[i] - pos[i + 1];
        let len = d.norm();
        if positive_finite(len) {
            pos[i] = pos[i + 1] + d * (lengths[i] / len);
        }
    }
    true
}

/// The displacement `W Jᵀ λ` of the multipliers in `pr` (links' `lam_l`, the active contacts' `rhs`).
fn displacement<T: Real, const D: usize>(
    pr: &Projection<T, D>,
    m: usize,
    held: &[usize],
    n: usize,
) -> Vec<Vector<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    let mut delta = vec![Vector::<T, D>::zeros(); n + 1];
    for k in 0..n {
        let l = pr.lam_l[k];
        delta[k] -= pr.u[k] * l;
        delta[k + 1] += pr.u[k] * l;
    }
    for (q, row) in pr.rows.iter().enumerate() {
        if !pr.active[q] {
            continue;
        }
        let l = pr.rhs[q];
        for e in 0..row.count {
            delta[row.joints[e]] += row.normal * (row.weights[e] * l);
        }
    }
    for (j, d) in delta.iter_mut().enumerate() {
        *d *= w::<T>(j, m, held);
    }
    delta
}

/// One Newton step: the multipliers (`pr.lam_l`, the active contacts' `pr.rhs`) and the joints'
/// displacement, from the rows and errors in `pr`. `C` is formed once from the joints the rows
/// share, and a row's column of `A⁻¹ B` the first time a round takes it into the active set (each
/// contact's coupling to the links is sparse: at most eight links); the active set is found by [`ACTIVE_ROUNDS`]
/// rounds on its sub-block (`r³`), each charged to `meter` before it runs (about six flops a
/// sixteenth of a link-step). `None` when the meter ran out.
fn solve_step<T: Real, const D: usize>(
    pr: &mut Projection<T, D>,
    (m, held): (usize, &[usize]),
    n: usize,
    compliance: T,
    meter: &mut super::Meter,
) -> Option<Vec<Vector<T, D>>>
where
    Vector<T, D>: Embed3<T>,
{
    let r = pr.rows.len();
    let eps = T::lit(1e-9);
    factor_links(pr, m, held, n, eps);
    // b_l = −C (each link's length change wanted), and A⁻¹ b_l.
    pr.bl.clear();
    pr.bl.extend(pr.c.iter().map(|c| -*c));
    let mut bl = std::mem::take(&mut pr.bl);
    solve_span(&pr.lower, &pr.pivot, &pr.upper, &mut bl, 0, n - 1);
    couple_contacts(pr, m, held, n);
    contact_block(pr, m, held);
    // Each row's right-hand side `b_c − Bᵀ A⁻¹ b_l`.
    pr.full_rhs.clear();
    for q in 0..r {
        let gap = pr.rows[q].gap;
        pr.full_rhs.push(gap - pr.bsparse[q].dot(&bl));
    }
    if !active_set(pr, n, eps + compliance, meter) {
        return None;
    }
    // λ_l = A⁻¹ (b_l − B λ_c) = A⁻¹ b_l − (A⁻¹ B) λ_c.
    pr.lam_l.clear();
    pr.lam_l.extend_from_slice(&bl);
    for q in 0..r {
        let l = pr.rhs[q];
        if l == T::zero() {
            continue;
        }
        let (start, end) = pr.ext[q];
        let abq = &pr.ab[q * n + start..q * n + end];
        for (x, y) in pr.lam_l[start..end].iter_mut().zip(abq) {
            *x -= *y * l;
        }
    }
    pr.bl = bl;
    Some(displacement(pr, m, held, n))
}

/// The links' block `A` factored (Thomas: `pr.lower`, `pr.pivot`, `pr.upper`), `eps` on its diagonal.
fn factor_links<T: Real, const D: usize>(
    pr: &mut Projection<T, D>,
    m: usize,
    held: &[usize],
    n: usize,
    eps: T,
) where
    Vector<T, D>: Embed3<T>,
{
    // The links' block A (tridiagonal): A_kk = w_k + w_{k+1}, A_{k,k+1} = −w_{k+1} u_k·u_{k+1}.
    pr.pivot.resize(n, T::zero());
    pr.upper.resize(n, T::zero());
    pr.lower.resize(n, T::zero());
    for k in 0..n {
        let diag = w::<T>(k, m, held) + w::<T>(k + 1, m, held) + eps;
        let sub = if k > 0 {
            -w::<T>(k, m, held) * pr.u[k - 1].dot(&pr.u[k])
        } else {
            T::zero()
        };
        let piv = if k > 0 {
            diag - sub * pr.upper[k - 1]
        } else {
            diag
        };
        pr.lower[k] = sub;
        pr.pivot[k] = piv;
        pr.upper[k] = if k + 1 < n {
            -w::<T>(k + 1, m, held) * pr.u[k].dot(&pr.u[k + 1]) / piv
        } else {
            T::zero()
        };
    }
}

/// Each contact row's sparse coupling to the links (`pr.bsparse`) and its column of `B` in `pr.ab`
/// (solved by `A⁻¹` when the row first becomes active).
fn couple_contacts<T: Real, const D: usize>(
    pr: &mut Projection<T, D>,
    m: usize,
    held: &[usize],
    n: usize,
) where
    Vector<T, D>: Embed3<T>,
{
    let r = pr.rows.len();
    // Row q of Bᵀ (J_c W J_lᵀ): for each of the contact's joints j, link j−1 (+u at j) and link j
    // (−u at j), at most eight entries; then A⁻¹ B column by column.
    pr.bsparse.clear();
    // The columns of `A⁻¹ B` are written over their extents only, when their rows become active.
    if pr.ab.len() < n * r {
        pr.ab.resize(n * r, T::zero());
    }
    pr.ext.clear();
    pr.ext.resize(r, (0, 0));
    for q in 0..r {
        let row = pr.rows[q];
        let mut entries = Sparse::default();
        for e in 0..row.count {
            let j = row.joints[e];
            let wj = w::<T>(j, m, held);
            if wj == T::zero() {
                continue;
            }
            let g = row.normal * row.weights[e];
            if j > 0 {
                entries.push(j - 1, wj * pr.u[j - 1].dot(&g));
            }
            if j < n {
                entries.push(j, -(wj * pr.u[j].dot(&g)));
            }
        }
        pr.bsparse.push(entries);
    }
}

/// The contacts' block `C` (`pr.cmat`, `r × r`).
fn contact_block<T: Real, const D: usize>(pr: &mut Projection<T, D>, m: usize, held: &[usize])
where
    Vector<T, D>: Embed3<T>,
{
    let r = pr.rows.len();
    // C: rows that share a joint move each other (few: a contact touches four joints), found by
    // sorting the rows' joints.
    pr.touch.clear();
    for (q, row) in pr.rows.iter().enumerate() {
        for e in 0..row.count {
            if w::<T>(row.joints[e], m, held) != T::zero() {
                pr.touch.push((row.joints[e], q, e));
            }
        }
    }
    pr.touch.sort_unstable();
    pr.cmat.clear();
    pr.cmat.resize(r * r, T::zero());
    let mut g0 = 0;
    while g0 < pr.touch.len() {
        let j = pr.touch[g0].0;
        let mut g1 = g0;
        while g1 < pr.touch.len() && pr.touch[g1].0 == j {
            g1 += 1;
        }
        for x in g0..g1 {
            let (_, q, a) = pr.touch[x];
            for y in g0..g1 {
                let (_, p, b) = pr.touch[y];
                let (rq, rp) = (&pr.rows[q], &pr.rows[p]);
                pr.cmat[q * r + p] += rq.weights[a] * rp.weights[b] * rq.normal.dot(&rp.normal);
            }
        }
        g0 = g1;
    }
}

/// The active set and its multipliers (`pr.active`, `pr.rhs`), by [`ACTIVE_ROUNDS`] rounds on the
/// complement's sub-block over the active rows, each charged to `meter` before it runs; `false`
/// when the meter ran out.
fn active_set<T: Real, const D: usize>(
    pr: &mut Projection<T, D>,
    n: usize,
    eps: T,
    meter: &mut super::Meter,
) -> bool
where
    Vector<T, D>: Embed3<T>,
{
    let r = pr.rows.len();
    // The active set: rows too close to begin with; contacts that pull leave, rows the step brings
    // too close join (Δgap_q = (S λ)_q over the active λ). `A⁻¹ B` is solved only for the rows
    // that are active in some round (a column each, once): the complement's sub-block over the
    // active rows is formed from them, and an inactive row's change takes one solve of `A⁻¹ B λ`
    // for all of them.
    pr.active.clear();
    pr.active
        .extend(pr.rows.iter().map(|row| row.gap > T::zero()));
    pr.solved.clear();
    pr.solved.resize(r, false);
    pr.rhs.clear();
    pr.rhs.resize(r, T::zero());
    let mut idx = std::mem::take(&mut pr.idx);
    for _round in 0..ACTIVE_ROUNDS {
        idx.clear();
        idx.extend((0..r).filter(|&q| pr.active[q]));
        let a = idx.len();
        let a64 = a as u64;
        if !meter.charge(a64.saturating_mul(a64).saturating_mul(a64) / 18 + (r as u64) * a64 / 6) {
            pr.idx = idx;
            return false;
        }
        for &q in &idx {
            if pr.solved[q] {
                continue;
            }
            pr.solved[q] = true;
            let e = pr.bsparse[q];
            let links = &e.links[..e.count];
            if let (Some(&lo), Some(&hi)) = (links.iter().min(), links.iter().max()) {
                // The column is nonzero only over the parts its links lie in: zeroed there, its
                // entries of `B` put in, solved there. Charged as a relaxation of the whole rope,
                // an upper bound of its two substitutions (see docs/history.md, issue 68, sixth
                // session, for the charge over its extent alone).
                let (start, end) = extent(&pr.lower, &pr.upper, lo, hi);
                if !meter.charge((n as u64).saturating_mul(cost::RELAX_PER_LINK)) {
                    pr.idx = idx;
                    return false;
                }
                let col = &mut pr.ab[q * n..(q + 1) * n];
                col[start..end].iter_mut().for_each(|x| *x = T::zero());
                for k in 0..e.count {
                    col[e.links[k]] += e.values[k];
                }
                solve_span(&pr.lower, &pr.pivot, &pr.upper, col, lo, hi);
                pr.ext[q] = (start, end);
            }
        }
        pr.s.clear();
        pr.s.resize(a * a, T::zero());
        pr.col.clear();
        for (x, &q) in idx.iter().enumerate() {
            for (y, &p) in idx.iter().enumerate() {
                let abp = &pr.ab[p * n..(p + 1) * n];
                pr.s[x * a + y] = pr.cmat[q * r + p] - pr.bsparse[q].dot_within(abp, pr.ext[p]);
            }
            pr.s[x * a + x] += eps;
            pr.col.push(pr.full_rhs[q]);
        }
        let mut sol = std::mem::take(&mut pr.col);
        gauss(&mut pr.s, &mut sol, a);
        pr.rhs.iter_mut().for_each(|x| *x = T::zero());
        for (x, &q) in idx.iter().enumerate() {
            pr.rhs[q] = sol[x];
        }
        pr.col = sol;
        // A⁻¹ B λ over the active rows.
        pr.y.clear();
        pr.y.resize(n, T::zero());
        let (mut lo, mut hi) = (n, 0);
        for &p in &idx {
            let e = pr.bsparse[p];
            for k in 0..e.count {
                pr.y[e.links[k]] += e.values[k] * pr.rhs[p];
                lo = lo.min(e.links[k]);
                hi = hi.max(e.links[k]);
            }
        }
        if lo <= hi {
            solve_span(&pr.lower, &pr.pivot, &pr.upper, &mut pr.y, lo, hi);
        }
        let mut changed = false;
        for q in 0..r {
            if pr.active[q] {
                if pr.rhs[q] < T::zero() {
                    pr.active[q] = false;
                    changed = true;
                }
            } else {
                // How far the step moves row q: (S λ)_q less its right-hand side is how much more
                // than its gap it parts.
                let moved = idx
                    .iter()
                    .fold(T::zero(), |acc, &p| acc + pr.cmat[q * r + p] * pr.rhs[p])
                    - pr.bsparse[q].dot(&pr.y);
                if moved < pr.full_rhs[q] {
                    pr.active[q] = true;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    pr.idx = idx;
    for q in 0..r {
        if !pr.active[q] || pr.rhs[q] < T::zero() {
            pr.rhs[q] = T::zero();
        }
    }
    true
}

/// The links `start..end` over which [`solve_span`] of a right-hand side nonzero only in `lo..=hi`
/// can be nonzero: out to where the factored block falls apart (a zero off-diagonal) either side.
fn extent<T: Real>(lower: &[T], upper: &[T], lo: usize, hi: usize) -> (usize, usize) {
    let n = lower.len();
    let end = (hi + 1..n).find(|&k| lower[k] == T::zero()).unwrap_or(n);
    let start = (0..lo)
        .rev()
        .find(|&k| upper[k] == T::zero())
        .map_or(0, |k| k + 1);
    (start, end)
}

/// Solves the factored links' block (Thomas: `lower`, `pivot`, `upper`) for `x`, whose entries are
/// zero outside `lo..=hi`. The block falls apart at fixed joints (a zero off-diagonal), so the
/// substitutions stop where the rest of `x` stays zero: a contact's column costs the links of the
/// parts it touches, not the whole rope: the entries it skips are the exact zeros the whole solve
/// would compute (tested against a solve written in the test).
fn solve_span<T: Real>(lower: &[T], pivot: &[T], upper: &[T], x: &mut [T], lo: usize, hi: usize) {
    let n = x.len();
    x[lo] /= pivot[lo];
    let mut end = n;
    for k in lo + 1..n {
        if k > hi && lower[k] == T::zero() {
            end = k;
            break;
        }
        x[k] = (x[k] - lower[k] * x[k - 1]) / pivot[k];
    }
    for k in (0..end.saturating_sub(1)).rev() {
        if k < lo && upper[k] == T::zero() {
            break;
        }
        let next = x[k + 1];
        x[k] -= upper[k] * next;
    }
}

/// A contact row's coupling to the links: at most eight (link, value) entries.
#[derive(Clone, Copy, Debug)]
pub(super) struct Sparse<T: Real> {
    links: [usize; 8],
    values: [T; 8],
    count: usize,
}

impl<T: Real> Default for Sparse<T> {
    fn default() -> Self {
        Sparse {
            links: [0; 8],
            values: [T::zero(); 8],
            count: 0,
        }
    }
}

impl<T: Real> Sparse<T> {
    fn push(&mut self, link: usize, value: T) {
        if self.count < 8 {
            self.links[self.count] = link;
            self.values[self.count] = value;
            self.count += 1;
        }
    }

    /// The row's coupling against a vector over the links: `Σ value · x[link]`.
    fn dot(&self, x: &[T]) -> T {
        (0..self.count).fold(T::zero(), |acc, e| acc + self.values[e] * x[self.links[e]])
    }

    /// [`Sparse::dot`] against a column that is zero outside the links `start..end`.
    fn dot_within(&self, x: &[T], (start, end): (usize, usize)) -> T {
        (0..self.count)
            .filter(|&e| (start..end).contains(&self.links[e]))
            .fold(T::zero(), |acc, e| acc + self.values[e] * x[self.links[e]])
    }
}

/// Solves the dense `r × r` system `a x = b` in place (`b` becomes `x`) by Gaussian elimination with
/// partial pivoting; a zero pivot leaves that unknown zero.
fn gauss<T: Real>(a: &mut [T], b: &mut [T], r: usize) {
    for col in 0..r {
        let mut piv = col;
        for row in col + 1..r {
            if a[row * r + col].abs() > a[piv * r + col].abs() {
                piv = row;
            }
        }
        if a[piv * r + col] == T::zero() {
            continue;
        }
        if piv != col {
            for k in 0..r {
                a.swap(col * r + k, piv * r + k);
            }
            b.swap(col, piv);
        }
        let d = a[col * r + col];
        for row in col + 1..r {
            let f = a[row * r + col] / d;
            if f == T::zero() {
                continue;
            }
            for k in col..r {
                let v = a[col * r + k];
                a[row * r + k] -= f * v;
            }
            let v = b[col];
            b[row] -= f * v;
        }
    }
    for col in (0..r).rev() {
        let d = a[col * r + col];
        if d == T::zero() {
            b[col] = T::zero();
            continue;
        }
        let mut x = b[col];
        for k in col + 1..r {
            x -= a[col * r + k] * b[k];
        }
        b[col] = x / d;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::{CollisionOptions, Scheme};
    use nalgebra::Vector3;

    /// A tridiagonal system that falls apart into three blocks (zero off-diagonals at 3 and 7), a
    /// right-hand side nonzero only in 4..=5: the span solve gives the dense solve's answer
    /// (Gaussian elimination written here), exactly zero outside the middle block.
    #[test]
    fn a_span_solve_stays_in_its_block_and_matches_a_dense_solve() {
        let n = 10;
        let diag: Vec<f64> = (0..n).map(|k| 2.5 + 0.1 * k as f64).collect();
        // off[k] couples k and k + 1.
        let mut off: Vec<f64> = (0..n - 1).map(|k| -0.4 - 0.05 * k as f64).collect();
        off[3] = 0.0;
        off[7] = 0.0;
        // The Thomas factors as `solve_step` keeps them.
        let (mut lower, mut pivot, mut upper) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for k in 0..n {
            lower[k] = if k > 0 { off[k - 1] } else { 0.0 };
            pivot[k] = if k > 0 {
                diag[k] - lower[k] * upper[k - 1]
            } else {
                diag[k]
            };
            upper[k] = if k + 1 < n { off[k] / pivot[k] } else { 0.0 };
        }
        let mut b = vec![0.0; n];
        b[4] = 1.0;
        b[5] = -0.5;
        let mut x = b.clone();
        solve_span(&lower, &pivot, &upper, &mut x, 4, 5);
        // Dense Gaussian elimination, no pivoting (diagonally dominant).
        let mut a = vec![vec![0.0; n]; n];
        for k in 0..n {
            a[k][k] = diag[k];
            if k + 1 < n {
                a[k][k + 1] = off[k];
                a[k + 1][k] = off[k];
            }
        }
        let mut y = b.clone();
        for c in 0..n {
            for r in c + 1..n {
                let f = a[r][c] / a[c][c];
                let pivot_row = a[c].clone();
                for (v, p) in a[r][c..].iter_mut().zip(&pivot_row[c..]) {
                    *v -= f * p;
                }
                y[r] -= f * y[c];
            }
        }
        for c in (0..n).rev() {
            let mut v = y[c];
            for k in c + 1..n {
                v -= a[c][k] * y[k];
            }
            y[c] = v / a[c][c];
        }
        for k in 0..n {
            if !(4..=7).contains(&k) {
                assert_eq!(x[k], 0.0, "entry {k} outside the block");
            }
            assert!(
                (x[k] - y[k]).abs() < 1e-14,
                "entry {k}: {} against {}",
                x[k],
                y[k]
            );
        }
        assert!(x[4] != 0.0 && x[7] != 0.0);
    }

    /// A rope crossing over itself 0.1 apart (thickness 0.2), its ends fixed: the projection parts
    /// the crossing to the clearance and keeps every length (computed here).
    #[test]
    fn a_crossing_pressed_together_is_parted_with_its_lengths_kept() {
        // Along x at z = 0 from (−2, 0, 0) to (2, 0, 0), up and round, back along y at z = 0.1.
        let mut pts: Vec<Vector3<f64>> = Vec::new();
        for k in 0..=16 {
            pts.push(Vector3::new(-2.0 + 0.25 * f64::from(k), 0.0, 0.0));
        }
        // A square arc from (2, 0, 0) to (0, −2, 0.1) out of the way, then along +y through x = 0.
        let corners = [
            Vector3::new(2.0, 0.0, 0.0),
            Vector3::new(2.0, -2.0, 0.05),
            Vector3::new(0.0, -2.0, 0.1),
            Vector3::new(0.0, 2.0, 0.1),
        ];
        for w in corners.windows(2) {
            let len: f64 = (w[1] - w[0]).norm();
            let steps = (len / 0.25).round() as usize;
            for k in 1..=steps {
                pts.push(w[0] + (w[1] - w[0]) * (k as f64 / steps as f64));
            }
        }
        let lengths: Vec<f64> = pts.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
        let n = lengths.len();
        let model = CollisionModel {
            options: CollisionOptions {
                scheme: Scheme::Capsules,
                self_collision: true,
                thickness: 0.2,
                max_iterations: 64,
                tolerance: 0.01,
                over_relaxation: 1.5,
                pushed_weight: 1.0,
                together_after: 2,
            },
            obstacles: vec![],
            holding: vec![],
        };
        let mut ws = CollisionWorkspace::new();
        let mut pos = pts.clone();
        let out = project(&mut pos, &lengths, n, &[0], &model, &mut ws, 0.1);
        assert_eq!(out, Projected::Converged);
        assert_eq!(pos[0], pts[0]);
        assert_eq!(pos[n], pts[n]);
        for k in 0..n {
            let l = (pos[k + 1] - pos[k]).norm();
            assert!(
                (l - lengths[k]).abs() <= 1e-9,
                "link {k}: {l} not {}",
                lengths[k]
            );
        }
        // The two strands: every pair of links three or more apart at least the clearance less
        // the tolerance.
        let mut closest = f64::INFINITY;
        for i in 0..n {
            for j in i + 3..n {
                let (s, t) =
                    closest_params_segment_segment(&pos[i], &pos[i + 1], &pos[j], &pos[j + 1]);
                let d = (lerp(&pos[i], &pos[i + 1], s) - lerp(&pos[j], &pos[j + 1], t)).norm();
                closest = closest.min(d);
            }
        }
        assert!(closest >= 0.2 * 0.99, "closest {closest}");
    }
}
