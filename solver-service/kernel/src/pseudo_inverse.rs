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
/// non-convergence are errors that leave the chain unchanged.
pub fn reach_dls<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    opts: &DlsOptions<T>,
) -> Result<ReachOutcome<T>, ReachError<T, D>>
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
    let residual = (chain.head() - target).norm();
    chain.links_mut().copy_from_slice(&backup);
    chain.place_origin_from(backup_datum.0, backup_datum.1);
    Err(ReachError::NotConverged {
        iterations: opts.max_iterations,
        residual,
    })
}
