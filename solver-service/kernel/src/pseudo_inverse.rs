//! The classical baseline: resolved-motion-rate control (Whitney, in Korein & Badler's "numerical
//! solutions") with damped least squares, on the same fixed-base chain.
//!
//! Each iteration takes the head error `e` (clamped to `max_step` of the chain's length), solves
//! `δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e` and rotates the links. For a chain whose joints rotate about points, the
//! Jacobian column of joint `j` (at joint `j−1`'s position) for a rotation `ω` is `ω × rⱼ`, with `rⱼ` the
//! vector from the joint to the head, so:
//!
//! * `J Jᵀ = Σⱼ (|rⱼ|² I − rⱼ rⱼᵀ)`, a `D × D` matrix: one small solve per iteration, O(n) overall;
//! * `ωⱼ = rⱼ × y` with `y = (J Jᵀ + λ² I)⁻¹ e` (in the plane only the `z` component is non-zero).
//!
//! Rotations are applied from the base outward, each link turned by the product of the rotations of the
//! joints below it. This minimises joint rates in the least-squares sense (remark 5 contrasts it with the
//! tractrix, which moves the joints near the base least).

use crate::chain::{Chain, ChainError};
use crate::fixed_base::{ReachError, ReachOutcome, nearest_reachable};
use crate::math::{Embed3, Real, Vector, all_finite};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// Options of the damped-least-squares baseline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DlsOptions<T> {
    /// Damping λ in length units: larger is more robust near singular poses and slower to converge.
    pub damping: T,
    /// Largest head correction per iteration, as a fraction of the chain's length (the resolved-rate
    /// "velocity" limit; smaller follows the straight line more closely and takes more iterations).
    pub max_step: T,
    /// Accepted head distance, as a fraction of the chain's total length.
    pub tolerance: T,
    /// Iteration limit.
    pub max_iterations: u32,
}

impl<T: Real> Default for DlsOptions<T> {
    fn default() -> Self {
        DlsOptions {
            damping: T::lit(1e-3),
            max_step: T::lit(0.05),
            tolerance: T::lit(1e-9).max(T::EPSILON * T::lit(64.0)),
            max_iterations: 10_000,
        }
    }
}

/// Reaches `target` with the fixed-base `chain` by damped least squares. Unreachable targets and
/// non-convergence are errors that leave the chain unchanged. What it minimises: each step's joint
/// rates, `‖δq‖² + ‖J δq − e‖² / λ²` (the least joint motion that moves the head by the clamped
/// error `e`, in least squares); the tractrix instead moves each link least for the motion of its
/// leading end (remark 5).
pub fn reach_dls<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    opts: &DlsOptions<T>,
) -> Result<ReachOutcome<T>, ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    check_target(chain, target)?;
    let backup: Vec<_> = chain.links().to_vec();
    let backup_datum = chain.datum();
    let total = chain.total_length();
    let tol = opts.tolerance * total;
    let max_step = opts.max_step * total;
    let lambda2 = opts.damping * opts.damping;
    let target3 = target.to_3d();
    for it in 0..opts.max_iterations {
        let head3 = chain.head().to_3d();
        let mut e = target3 - head3;
        let en = e.norm();
        if en <= tol {
            return Ok(ReachOutcome {
                iterations: it,
                residual: en,
            });
        }
        if en > max_step {
            e *= max_step / en;
        }
        // J Jᵀ = Σ (|r|² I − r rᵀ), r from each joint to the head, accumulated from the head down.
        let mut jjt = Matrix3::<T>::zeros();
        let mut r = Vector3::<T>::zeros();
        for l in chain.links().iter().rev() {
            r += l.to_3d();
            jjt += Matrix3::identity() * r.norm_squared() - r * r.transpose();
        }
        // In the plane the z row decouples (r_z = e_z = 0), so y_z = 0 and every ω points along z.
        let a = jjt + Matrix3::identity() * lambda2;
        let Some(y) = a.lu().solve(&e) else {
            break;
        };
        // ωⱼ = rⱼ × y, applied base-outward: link i turns by R(ω₁)…R(ωᵢ).
        let mut r_from_head: Vector3<T> = chain
            .links()
            .iter()
            .fold(Vector3::zeros(), |a, l| a + l.to_3d());
        let mut rot = UnitQuaternion::<T>::identity();
        let (links, lengths, _) = chain.links_lengths_limits_mut();
        for (l, &len) in links.iter_mut().zip(lengths) {
            let omega = r_from_head.cross(&y);
            r_from_head -= l.to_3d();
            rot *= UnitQuaternion::from_scaled_axis(omega);
            let nl = rot * l.to_3d();
            *l = Vector::<T, D>::from_3d(&(nl * (len / nl.norm())));
        }
    }
    give_up(chain, target, &backup, backup_datum, opts.max_iterations)
}

/// [`reach_dls`] with an orientation goal for a planar chain (Korein & Badler: "add to the goal a
/// constraint on the orientation of the last link"): the task is the head's position and the last
/// link's angle, one Jacobian of three rows (the angle's row is 1 for every joint), the angle's error
/// weighted by the last link's length so that both rows are lengths. What it minimises: the joint
/// rates, in the least-squares sense, of the three-row task (the tractrix's orientation goal instead
/// fixes the last link and resolves the rest, [`crate::goals`]). Converged when the head is within
/// the tolerance and the last link's tip moved by the angle's error would be too. Refused, changing
/// nothing, when the wrist (the last link's base joint the goal implies) is outside the workspace of
/// the links before it, with the nearest head that keeps the direction.
pub fn reach_dls_pose<T: Real>(
    chain: &mut Chain<T, 2>,
    target: &nalgebra::Vector2<T>,
    direction: &nalgebra::Vector2<T>,
    opts: &DlsOptions<T>,
) -> Result<ReachOutcome<T>, ReachError<T, 2>> {
    let n = chain.n_links();
    if !all_finite(target) || !all_finite(direction) {
        return Err(ChainError::NonFinite.into());
    }
    let dn = direction.norm();
    if n < 2 || dn <= T::zero() {
        return Err(ChainError::BadOption(
            "an orientation goal needs two links or more and a direction of non-zero length",
        )
        .into());
    }
    let d = direction / dn;
    let w = chain.lengths()[n - 1];
    let base = chain.origin();
    let wrist = target - d * w;
    let inner = &chain.lengths()[..n - 1];
    let (nearest, outside) = nearest_reachable(&base, inner, &wrist, &(chain.head() - base));
    if outside > T::zero() {
        return Err(ReachError::Unreachable {
            nearest: nearest + d * w,
            residual: outside,
        });
    }
    let backup: Vec<_> = chain.links().to_vec();
    let backup_datum = chain.datum();
    let total = chain.total_length();
    let tol = opts.tolerance * total;
    let max_step = opts.max_step * total;
    let lambda2 = opts.damping * opts.damping;
    let goal_angle = d.y.atan2(d.x);
    let mut p = vec![nalgebra::Vector2::<T>::zeros(); n + 1];
    for it in 0..opts.max_iterations {
        chain.write_positions(&mut p);
        let head = p[n];
        let last = chain.links()[n - 1];
        let mut turn = goal_angle - last.y.atan2(last.x);
        while turn > T::pi() {
            turn -= T::two_pi();
        }
        while turn < -T::pi() {
            turn += T::two_pi();
        }
        let mut e = Vector3::new(target.x - head.x, target.y - head.y, w * turn);
        let en = e.norm();
        let pos = (e.x * e.x + e.y * e.y).sqrt();
        if pos <= tol && e.z.abs() <= tol {
            return Ok(ReachOutcome {
                iterations: it,
                residual: pos,
            });
        }
        if en > max_step {
            e *= max_step / en;
        }
        // Column j: the head's motion for a unit turn of joint j (about p[j]), and the angle's (w).
        let column = |j: usize| Vector3::new(-(head.y - p[j].y), head.x - p[j].x, w);
        let mut jjt = Matrix3::<T>::identity() * lambda2;
        for j in 0..n {
            let c = column(j);
            jjt += c * c.transpose();
        }
        let Some(y) = jjt.lu().solve(&e) else {
            break;
        };
        let mut angle = T::zero();
        let (links, lengths, _) = chain.links_lengths_limits_mut();
        for (j, (l, &len)) in links.iter_mut().zip(lengths).enumerate() {
            angle += column(j).dot(&y);
            let (sn, cs) = angle.sin_cos();
            let r = nalgebra::Vector2::new(cs * l.x - sn * l.y, sn * l.x + cs * l.y);
            *l = r * (len / r.norm());
        }
    }
    give_up(chain, target, &backup, backup_datum, opts.max_iterations)
}

/// How the damped-least-squares baseline honours a planar chain's joint ranges (Korein & Badler,
/// "Extensions for inequality constraints": a penalty function in the objective, or following the
/// boundary once the solve runs into it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RangeHandling<T> {
    /// The redundancy (the null space of the head's Jacobian) descends a penalty that grows without
    /// bound at each range's ends, `Σ (hi − lo)² / (4 (hi − q)(q − lo))` (1 at the middle of a range),
    /// scaled by `gain` (radians per iteration per unit of gradient). Nothing stops a step from
    /// crossing a range: the penalty only steers away from the ends.
    Penalty {
        /// Step along the penalty's gradient, projected into the null space.
        gain: T,
    },
    /// A joint that a step would carry beyond its range is put on the boundary and taken out of the
    /// Jacobian (frozen) for as long as the head's error would push it further out; the others solve
    /// the rest.
    Boundary,
}

/// [`reach_dls`] for a planar chain with joint ranges (its [`crate::JointLimits`] of kind
/// [`crate::LimitKind::Range`]; without limits this is the plain baseline with an explicit Jacobian).
/// Joint `j`'s angle is the turn from link `j` to link `j + 1`, as [`crate::limits`] has it; the base's
/// own angle is free. Unreachable targets (outside the unlimited workspace) and non-convergence are
/// errors that leave the chain unchanged; a converged pose may lie beyond a range with
/// [`RangeHandling::Penalty`] (the baseline is measured, not corrected).
pub fn reach_dls_ranges<T: Real>(
    chain: &mut Chain<T, 2>,
    target: &Vector<T, 2>,
    opts: &DlsOptions<T>,
    handling: RangeHandling<T>,
) -> Result<ReachOutcome<T>, ReachError<T, 2>> {
    use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
    check_target(chain, target)?;
    let n = chain.n_links();
    let (lo, hi): (Vec<T>, Vec<T>) = match chain.joint_limits() {
        Some(l) if l.kind() == crate::LimitKind::Range => {
            (0..=n).map(|j| (l.lo(j), l.hi(j))).unzip()
        }
        _ => (vec![-T::pi(); n + 1], vec![T::pi(); n + 1]),
    };
    let backup: Vec<_> = chain.links().to_vec();
    let backup_datum = chain.datum();
    let total = chain.total_length();
    let tol = opts.tolerance * total;
    let max_step = opts.max_step * total;
    let lambda2 = opts.damping * opts.damping;
    let lengths = chain.lengths().to_vec();
    // Absolute link angles; joint j's angle is a[j] − a[j − 1].
    let mut a: Vec<T> = chain.links().iter().map(|l| l.y.atan2(l.x)).collect();
    let mut frozen = vec![false; n];
    let put = |chain: &mut Chain<T, 2>, a: &[T]| {
        let (links, _, _) = chain.links_lengths_limits_mut();
        for ((l, &ai), &len) in links.iter_mut().zip(a).zip(&lengths) {
            *l = Vector2::new(ai.cos(), ai.sin()) * len;
        }
    };
    for it in 0..opts.max_iterations {
        let head = chain.head();
        let mut e = target - head;
        let en = e.norm();
        if en <= tol {
            return Ok(ReachOutcome {
                iterations: it,
                residual: en,
            });
        }
        if en > max_step {
            e *= max_step / en;
        }
        // Columns: pivot j (at joint j) turns links j.. : ẑ × (head − X_j).
        let p = chain.positions();
        let mut jac = DMatrix::<T>::zeros(2, n);
        for j in 0..n {
            if frozen[j] {
                continue;
            }
            let r = head - p[j];
            jac[(0, j)] = -r.y;
            jac[(1, j)] = r.x;
        }
        let jjt: Matrix2<T> = {
            let m = &jac * jac.transpose();
            Matrix2::new(m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)])
        } + Matrix2::identity() * lambda2;
        let Some(inv) = jjt.try_inverse() else {
            break;
        };
        let y = inv * e;
        let mut dq: DVector<T> = jac.transpose() * DVector::from_column_slice(y.as_slice());
        if let RangeHandling::Penalty { gain } = handling {
            // Turning pivot j turns links j.. together: joint j's angle changes, no other joint's, so
            // ∂H/∂(pivot j) = ∂H/∂q_j.
            let mut grad = DVector::<T>::zeros(n);
            for j in 1..n {
                let q = crate::angles::wrap_angle(a[j] - a[j - 1]);
                let (l, h) = (lo[j], hi[j]);
                if h - l >= T::two_pi() - T::lit(1e-12) {
                    continue;
                }
                let w = (h - l) * (h - l);
                let d = T::lit(4.0) * (h - q) * (q - l);
                // dH/dq of w / d, d = 4(h − q)(q − l): −w·d'/d², d' = 4(h + l − 2q).
                let dd = T::lit(4.0) * (h + l - T::lit(2.0) * q);
                let g = if d > T::zero() {
                    -w * dd / (d * d)
                } else {
                    // Beyond the range: push back toward the middle.
                    (q - (h + l) * T::lit(0.5)).signum() * T::lit(1e6)
                };
                grad[j] += g;
            }
            let z = grad * (-gain);
            // Null-space projection: z − Jᵀ (JJᵀ + λ²)⁻¹ J z.
            let jz = &jac * &z;
            let y2 = inv * Vector2::new(jz[0], jz[1]);
            let back = jac.transpose() * DVector::from_column_slice(y2.as_slice());
            dq += z - back;
        }
        for j in 0..n {
            // Pivot j turns every link from j on.
            for ak in a.iter_mut().skip(j) {
                *ak += dq[j];
            }
        }
        if handling == RangeHandling::Boundary {
            // Joints carried beyond their ranges go back onto the boundary (turning the links beyond
            // with them) and are frozen while the error pushes them out; a frozen joint whose pivot
            // the unfrozen solve would turn back inside is released.
            for j in 1..n {
                let q = crate::angles::wrap_angle(a[j] - a[j - 1]);
                let clamped = q.max(lo[j]).min(hi[j]);
                if clamped != q {
                    let fix = clamped - q;
                    for ak in a.iter_mut().skip(j) {
                        *ak += fix;
                    }
                    frozen[j] = true;
                } else if frozen[j] {
                    let r = head - p[j];
                    let push = -r.y * y.x + r.x * y.y;
                    let inward =
                        (q >= hi[j] && push < T::zero()) || (q <= lo[j] && push > T::zero());
                    let strictly_inside = q < hi[j] && q > lo[j];
                    if inward || strictly_inside {
                        frozen[j] = false;
                    }
                }
            }
        }
        put(chain, &a);
    }
    give_up(chain, target, &backup, backup_datum, opts.max_iterations)
}

/// The checks both solvers start with: a finite target inside the (unlimited) workspace.
fn check_target<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    target: &Vector<T, D>,
) -> Result<(), ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    if !all_finite(target) {
        return Err(ChainError::NonFinite.into());
    }
    let base = chain.origin();
    let (nearest, residual) =
        nearest_reachable(&base, chain.lengths(), target, &(chain.head() - base));
    if residual > T::zero() {
        return Err(ReachError::Unreachable { nearest, residual });
    }
    Ok(())
}

/// Puts the chain back as it was and reports how far off the last iteration left the head.
fn give_up<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    backup: &[Vector<T, D>],
    datum: (usize, Vector<T, D>),
    iterations: u32,
) -> Result<ReachOutcome<T>, ReachError<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    let residual = (chain.head() - target).norm();
    let reached = chain.check_limits().is_ok().then(|| chain.head());
    chain.links_mut().copy_from_slice(backup);
    chain.place_origin_from(datum.0, datum.1);
    Err(ReachError::NotConverged {
        iterations,
        residual,
        reached,
    })
}
