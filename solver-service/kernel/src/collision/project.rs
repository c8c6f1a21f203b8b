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
//! contacts × contacts), and `A` is factored once per iteration (Thomas): `O(n·r + r³)` for `n` links
//! and `r` contacts. The hand's joint and the held joints do not move (inverse mass zero).

use super::query::{
    away_from, closest_param_point_segment, closest_param_segment_block,
    closest_params_segment_segment, lerp, unit_or_perpendicular,
};
use super::{CollisionModel, CollisionWorkspace, Obstacle, Scheme, cost, neighbour_span};
use crate::math::{Embed3, Real, Vector, positive_finite};

/// Most contacts one iteration solves together (the dense block is contacts²): beyond, the
/// projection gives way to the passes.
pub(super) const MAX_CONTACTS: usize = 192;

/// Newton iterations of one projection.
pub(super) const ITERATIONS: usize = 16;

/// Pairs nearer than their target distance plus this share of the clearance are rows of the
/// system, inactive until a step would bring them closer than their target (the active set: without
/// them, a step that parts one contact closes another, and the next step parts that one again).
const NEAR: f64 = 0.0;

/// Rounds of the active set per step: contacts that would pull (negative multipliers) leave it,
/// rows the step would bring too close join it.
const ACTIVE_ROUNDS: usize = 8;

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
    /// `A⁻¹ B`, one column (of `n`) per contact.
    ab: Vec<T>,
    /// The Schur complement (row-major) and its right-hand side, then `λ_c`.
    s: Vec<T>,
    rhs: Vec<T>,
    active: Vec<bool>,
    col: Vec<T>,
}

/// How a projection ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Projected {
    /// Every link within `1e-9` of its length and every contact within the tolerance.
    Converged,
    /// It stopped gaining (the rope cannot give way: the knot is jammed); the best pose is kept.
    Stalled,
    /// Its iterations ran out while it still gained (the pose reached is kept).
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

/// The contacts of the rope at `pos` (capsule pairs on the tree, and the obstacles): those closer
/// than their target distance (the clearance plus half the tolerance) into `rows`. `None` when the
/// meter ran out.
fn gather<T: Real, const D: usize>(
    pos: &[Vector<T, D>],
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
        let done = ws.tree.close_pairs(&mut ws.meter, span, |meter, i, j| {
            if !meter.charge(cost::CAPSULE_PAIR) {
                return false;
            }
            let (a0, a1, b0, b1) = (pos[i], pos[i + 1], pos[j], pos[j + 1]);
            let (s, t) = closest_params_segment_segment(&a0, &a1, &b0, &b1);
            let d = lerp(&a0, &a1, s) - lerp(&b0, &b1, t);
            let dist = d.norm();
            if dist >= target + c * T::lit(NEAR) {
                return true;
            }
            *worst = (*worst).max(c - dist);
            rows.push(Row {
                joints: [i, i + 1, j, j + 1],
                weights: [T::one() - s, s, -(T::one() - t), -t],
                count: 4,
                normal: unit_or_perpendicular(&d, dist, &(a1 - a0), &(b1 - b0)),
                gap: target - dist,
            });
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
            let (a, b) = (pos[i], pos[i + 1]);
            let (s, normal, dist, clearance) = match ob {
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
            };
            let goal = clearance + opts.tolerance * half * clearance;
            if dist >= goal + clearance * T::lit(NEAR) {
                continue;
            }
            *worst = (*worst).max(clearance - dist);
            rows.push(Row {
                joints: [i, i + 1, 0, 0],
                weights: [T::one() - s, s, T::zero(), T::zero()],
                count: 2,
                normal,
                gap: goal - dist,
            });
        }
    }
    Some(())
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
        if gather(pos, model, ws, &mut pr.rows, &mut worst_contact).is_none() {
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
        if worst_length <= T::lit(1e-9) && worst_contact <= opts.tolerance * clearance {
            outcome = Projected::Converged;
            break;
        }
        match best {
            Some(b) if merit >= b => {
                idle += 1;
                if idle >= 3 {
                    outcome = Projected::Stalled;
                    break;
                }
            }
            _ => {
                idle = 0;
                best = Some(merit);
            }
        }
        // Charged: the links' factorisation and a solve per contact; each round of the active set
        // below charges its own.
        let units = (n as u64)
            .saturating_mul(cost::RELAX_PER_LINK)
            .saturating_mul(1 + r as u64);
        if !ws.meter.charge(units) {
            outcome = Projected::OutOfWork;
            break;
        }
        let Some(delta) = solve_step(&mut pr, m, held, n, &mut ws.meter) else {
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
    }
    // All or nothing: a pose that does not meet the lengths would be re-solved by the reach that
    // follows, which can move joints far (on the instrument tie at 160 links, more than half a
    // clearance: the move locked); the pushes' pose is kept instead.
    if outcome != Projected::Converged {
        pos.copy_from_slice(&start);
    }
    ws.projection = pr;
    outcome
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
/// displacement, from the rows and errors in `pr`; the active set found by [`ACTIVE_ROUNDS`] rounds,
/// each charged to `meter` before it runs (the Schur complement, `r² n`, and its elimination, `r³`,
/// at about six flops a sixteenth of a link-step). `None` when the meter ran out.
fn solve_step<T: Real, const D: usize>(
    pr: &mut Projection<T, D>,
    m: usize,
    held: &[usize],
    n: usize,
    meter: &mut super::Meter,
) -> Option<Vec<Vector<T, D>>>
where
    Vector<T, D>: Embed3<T>,
{
    let r = pr.rows.len();
    let eps = T::lit(1e-9);
    // The links' block A (tridiagonal): A_kk = w_k + w_{k+1}, A_{k,k+1} = −w_{k+1} u_k·u_{k+1}.
    pr.pivot.resize(n, T::zero());
    pr.upper.resize(n, T::zero());
    for k in 0..n {
        let diag = w::<T>(k, m, held) + w::<T>(k + 1, m, held) + eps;
        let (piv, _) = if k > 0 {
            let b = -w::<T>(k, m, held) * pr.u[k - 1].dot(&pr.u[k]);
            (diag - b * pr.upper[k - 1], b)
        } else {
            (diag, T::zero())
        };
        pr.pivot[k] = piv;
        pr.upper[k] = if k + 1 < n {
            -w::<T>(k + 1, m, held) * pr.u[k].dot(&pr.u[k + 1]) / piv
        } else {
            T::zero()
        };
    }
    // The sub-diagonal entry of row k (k ≥ 1): −w_k u_{k−1}·u_k.
    let sub = |pr: &Projection<T, D>, k: usize| -w::<T>(k, m, held) * pr.u[k - 1].dot(&pr.u[k]);
    let solve = |pr: &Projection<T, D>, x: &mut [T]| {
        for k in 0..n {
            x[k] = if k > 0 {
                (x[k] - sub(pr, k) * x[k - 1]) / pr.pivot[k]
            } else {
                x[0] / pr.pivot[0]
            };
        }
        for k in (0..n.saturating_sub(1)).rev() {
            let next = x[k + 1];
            x[k] -= pr.upper[k] * next;
        }
    };
    // b_l = −C (each link's length change wanted).
    pr.lam_l.resize(n, T::zero());
    for k in 0..n {
        pr.lam_l[k] = -pr.c[k];
    }
    let mut bl = pr.lam_l.clone();
    solve(pr, &mut bl);
    // Column q of B: (J_l W J_cᵀ)_{k,q} = Σ_joints w_j J_l[k][j]·J_c[q][j], for the links next to
    // the contact's joints; then A⁻¹ B column by column.
    pr.ab.resize(n * r, T::zero());
    pr.col.resize(n, T::zero());
    let mut bcols = vec![T::zero(); n * r];
    for q in 0..r {
        let row = pr.rows[q];
        let col = &mut bcols[q * n..(q + 1) * n];
        for e in 0..row.count {
            let j = row.joints[e];
            let wj = w::<T>(j, m, held);
            if wj == T::zero() {
                continue;
            }
            let g = row.normal * row.weights[e];
            // Link j−1 has +u at joint j; link j has −u at joint j.
            if j > 0 {
                col[j - 1] += wj * pr.u[j - 1].dot(&g);
            }
            if j < n {
                col[j] -= wj * pr.u[j].dot(&g);
            }
        }
        let mut x = col.to_vec();
        solve(pr, &mut x);
        pr.ab[q * n..(q + 1) * n].copy_from_slice(&x);
    }
    // C_{qp} = Σ_joints w_j J_c[q][j]·J_c[p][j]; S = C − Bᵀ A⁻¹ B; rhs = b_c − Bᵀ A⁻¹ b_l.
    pr.active.clear();
    pr.active
        .extend(pr.rows.iter().map(|row| row.gap > T::zero()));
    let mut delta = Vec::new();
    let (r64, n64) = (r as u64, n as u64);
    let round = r64
        .saturating_mul(r64)
        .saturating_mul(n64.saturating_add(r64))
        / 6;
    for _round in 0..ACTIVE_ROUNDS {
        if !meter.charge(round) {
            return None;
        }
        pr.s.clear();
        pr.s.resize(r * r, T::zero());
        pr.rhs.clear();
        pr.rhs.resize(r, T::zero());
        for q in 0..r {
            if !pr.active[q] {
                pr.s[q * r + q] = T::one();
                continue;
            }
            let rq = pr.rows[q];
            for p in 0..r {
                if !pr.active[p] {
                    continue;
                }
                let rp = pr.rows[p];
                let mut cqp = T::zero();
                for a in 0..rq.count {
                    for b in 0..rp.count {
                        if rq.joints[a] == rp.joints[b] {
                            let wj = w::<T>(rq.joints[a], m, held);
                            cqp += wj * rq.weights[a] * rp.weights[b] * rq.normal.dot(&rp.normal);
                        }
                    }
                }
                let bq = &bcols[q * n..(q + 1) * n];
                let abp = &pr.ab[p * n..(p + 1) * n];
                let btab: T = bq
                    .iter()
                    .zip(abp)
                    .fold(T::zero(), |acc, (x, y)| acc + *x * *y);
                pr.s[q * r + p] = cqp - btab;
            }
            pr.s[q * r + q] += eps;
            let bq = &bcols[q * n..(q + 1) * n];
            let btbl = bq
                .iter()
                .zip(&bl)
                .fold(T::zero(), |acc, (x, y)| acc + *x * *y);
            pr.rhs[q] = rq.gap - btbl;
        }
        gauss(&mut pr.s, &mut pr.rhs, r);
        for q in 0..r {
            if !pr.active[q] {
                pr.rhs[q] = T::zero();
            }
        }
        // λ_l = A⁻¹ (b_l − B λ_c) = A⁻¹ b_l − (A⁻¹ B) λ_c.
        for (k, b) in bl.iter().enumerate() {
            let mut x = *b;
            for q in 0..r {
                x -= pr.ab[q * n + k] * pr.rhs[q];
            }
            pr.lam_l[k] = x;
        }
        delta = displacement(pr, m, held, n);
        // Contacts that pull leave; rows the step brings too close join.
        let mut changed = false;
        for q in 0..r {
            if pr.active[q] && pr.rhs[q] < T::zero() {
                pr.active[q] = false;
                changed = true;
            } else if !pr.active[q] {
                let row = pr.rows[q];
                let moved = (0..row.count).fold(T::zero(), |acc, e| {
                    acc + row.normal.dot(&delta[row.joints[e]]) * row.weights[e]
                });
                if moved < row.gap {
                    pr.active[q] = true;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    Some(delta)
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
