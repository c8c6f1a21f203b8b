//! Boundary following (Korein & Badler, "Extensions for inequality constraints"): damped least squares
//! over the joints' rotations in which a joint that has run into its limit is frozen for as long as the
//! error would push it further out, so the joints still free take up the motion. The finish of a
//! fixed-base solve of a limited chain (a held side of a rope with a bend radius) when the tractrix
//! iteration has stalled twice or the reach hierarchy's pose breaks a limit; its passes are taken
//! from the solve's own budget ([`crate::fixed_base::ReachOptions::passes_bound`] is unchanged).
//!
//! Why it is needed: a rope bent to its limit cannot take a pull by bending more where the tractrix
//! bends it (near the moved end); the translate-back then carries the whole correction back, and the
//! iteration stalls (the kernel test `a_long_held_straight_rope_with_a_bend_radius_follows_a_hand_walking_in`:
//! without boundary following 4 of its 300 moves were made). Here the whole rope turns a little at every free joint, weighted by the lever arm
//! (pivots far from the head turn most, like a beam loaded at its end), and the shortening a pull asks
//! for is spread over the rope's length instead of piled onto the few joints at the moved end.
//!
//! One iteration is O(n) (the `D × D` system of [`crate::pseudo_inverse`], solved twice when a joint
//! is frozen): from the head the lever arms `rⱼ` and `J Jᵀ = Σ (|rⱼ|² I − rⱼ rⱼᵀ)` over the free joints,
//! `y = (J Jᵀ + λ² I)⁻¹ e`, joint `j` turns by `ωⱼ = rⱼ × y`, links are turned from the base outward
//! by the product of the rotations below them and put back to their nominal lengths, and every joint
//! is turned back into its limit ([`JointLimits::clamp`], the rounding a rotation leaves). The damping
//! adapts (Levenberg–Marquardt): a step that does not bring the head nearer is undone and retried more
//! damped. A chain lying straight along the error (a pure push) has no first-order motion toward it:
//! the step then aims half the error sideways, so the rope bows, as the tractrix iteration's detour.

use crate::chain::Chain;
use crate::limits::JointLimits;
use crate::math::{Embed3, Real, Vector};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// Most iterations of [`follow_boundary`].
pub(crate) const ITERATIONS: u32 = 64;
/// Loops over the chain of one iteration, each charged as a tractrix pass (each is lighter): the head
/// before and after, the lever arms (twice with a joint frozen, three times with a bow), the frozen
/// joints, the predicted motion, the turn with its clamp.
pub(crate) const PASSES_PER_ITERATION: u32 = 8;

/// Reused storage of [`follow_boundary`] (so a warm reach allocates nothing).
#[derive(Clone, Debug, Default)]
pub(crate) struct Scratch<T: Real, const D: usize> {
    links: Vec<Vector<T, D>>,
    frozen: Vec<bool>,
}

/// Moves the head of the fixed-base, limited `chain` to within `tol` of `target` by boundary
/// following, from its current pose, in at most `max_iterations` iterations. With the iterations it
/// ran: `Some(residual)` when it arrived (every joint within its limit); otherwise `None` and the
/// chain is where the last accepted step left it (within its limits); the caller restores it.
pub(crate) fn follow_boundary<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    target: &Vector<T, D>,
    tol: T,
    max_iterations: u32,
    scratch: &mut Scratch<T, D>,
) -> (Option<T>, u32)
where
    Vector<T, D>: Embed3<T>,
{
    let Some(limits) = chain.shared_limits() else {
        return (None, 0);
    };
    let n = chain.n_links();
    let total = chain.total_length();
    let t3 = target.to_3d();
    let mut residual = (chain.head() - target).norm();
    // λ² in units of length²: starts small against J Jᵀ (whose trace is ~ n · total²).
    let mut lambda2 = total * total * T::lit(1e-4);
    let frozen = &mut scratch.frozen;
    frozen.clear();
    frozen.resize(n, false);
    let max_step = total * T::lit(0.05);
    let max_iterations = max_iterations.min(ITERATIONS);
    let mut ran = 0;
    while ran < max_iterations {
        if residual <= tol {
            break;
        }
        ran += 1;
        let head3 = chain.head().to_3d();
        let mut e = t3 - head3;
        let en = e.norm();
        if en > max_step {
            e *= max_step / en;
        }
        // Free joints first; then the joints at their limit that this step would push out are frozen
        // and the step solved again without them.
        frozen.iter_mut().for_each(|f| *f = false);
        let Some(mut y) = solve(chain.links(), frozen, &e, lambda2) else {
            break;
        };
        if freeze_pushed(chain.links(), &limits, &y, frozen) {
            let Some(y2) = solve(chain.links(), frozen, &e, lambda2) else {
                break;
            };
            y = y2;
        }
        // A pure push along a straight chain: nothing moves the head toward the target to first
        // order; aim half the error sideways so the chain bows.
        let predicted = predicted_motion(chain.links(), frozen, &y);
        let bow = predicted.dot(&e) < e.norm_squared() * T::lit(0.1);
        if bow {
            let side = sideways(&e) * (e.norm() * T::lit(0.5));
            let Some(y2) = solve(chain.links(), frozen, &(e + side), lambda2) else {
                break;
            };
            y = y2;
        }
        scratch.links.clear();
        scratch.links.extend_from_slice(chain.links());
        turn(chain, &limits, frozen, &y);
        let after = (chain.head() - target).norm();
        // A bow moves the head sideways first (farther, by at most half the error's length).
        if after < residual || (bow && after < residual * T::lit(1.5)) {
            residual = after;
            lambda2 = (lambda2 * T::lit(0.3)).max(total * total * T::lit(1e-12));
        } else {
            chain.links_mut().copy_from_slice(&scratch.links);
            lambda2 *= T::lit(10.0);
            if lambda2 > total * total * T::lit(1e6) {
                // Steps too small to matter: stuck.
                break;
            }
        }
    }
    ((residual <= tol).then_some(residual), ran)
}

/// `y = (J Jᵀ + λ² I)⁻¹ e` over the joints not frozen (pivot `j` at joint `j` turns links `j..`).
fn solve<T: Real, const D: usize>(
    links: &[Vector<T, D>],
    frozen: &[bool],
    e: &Vector3<T>,
    lambda2: T,
) -> Option<Vector3<T>>
where
    Vector<T, D>: Embed3<T>,
{
    let mut jjt = Matrix3::<T>::identity() * lambda2;
    let mut r = Vector3::<T>::zeros();
    for (l, &f) in links.iter().zip(frozen).rev() {
        r += l.to_3d();
        if !f {
            jjt += Matrix3::identity() * r.norm_squared() - r * r.transpose();
        }
    }
    // In the plane the z row decouples (r_z = e_z = 0): y_z = 0 and every ω points along z.
    jjt.lu().solve(e)
}

/// The head's first-order motion for the rotations `ωⱼ = rⱼ × y`: `Σ ωⱼ × rⱼ` over the free joints.
fn predicted_motion<T: Real, const D: usize>(
    links: &[Vector<T, D>],
    frozen: &[bool],
    y: &Vector3<T>,
) -> Vector3<T>
where
    Vector<T, D>: Embed3<T>,
{
    let mut r = Vector3::<T>::zeros();
    let mut m = Vector3::<T>::zeros();
    for (l, &f) in links.iter().zip(frozen).rev() {
        r += l.to_3d();
        if !f {
            m += r.cross(y).cross(&r);
        }
    }
    m
}

/// Freezes each joint at its limit (within a thousandth of a radian) whose rotation `rⱼ × y` would
/// open its angle further; whether any was frozen.
fn freeze_pushed<T: Real, const D: usize>(
    links: &[Vector<T, D>],
    limits: &JointLimits<T>,
    y: &Vector3<T>,
    frozen: &mut [bool],
) -> bool
where
    Vector<T, D>: Embed3<T>,
{
    let n = links.len();
    let mut any = false;
    let mut r = Vector3::<T>::zeros();
    // Within a thousandth of a radian of a bound.
    let margin = T::lit(1e-3);
    let near = (margin.cos(), margin.sin());
    for j in (1..n).rev() {
        r += links[j].to_3d();
        if !limits.limits(j) {
            continue;
        }
        let (a, b) = (links[j - 1].to_3d(), links[j].to_3d());
        let pushed = limits.pushed_out(j, &a, &b, &r.cross(y), near);
        if pushed {
            frozen[j] = true;
            any = true;
        }
    }
    any
}

/// Turns the links by `ωⱼ = rⱼ × y` (the free joints'), from the base outward, back to their nominal
/// lengths and into their limits.
fn turn<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    limits: &JointLimits<T>,
    frozen: &[bool],
    y: &Vector3<T>,
) where
    Vector<T, D>: Embed3<T>,
{
    let mut r: Vector3<T> = chain
        .links()
        .iter()
        .fold(Vector3::zeros(), |a, l| a + l.to_3d());
    let mut rot = UnitQuaternion::<T>::identity();
    let (links, lengths, _) = chain.links_lengths_limits_mut();
    for i in 0..links.len() {
        if !frozen[i] {
            rot *= UnitQuaternion::from_scaled_axis(r.cross(y));
        }
        r -= links[i].to_3d();
        let nl = rot * links[i].to_3d();
        links[i] = Vector::<T, D>::from_3d(&(nl * (lengths[i] / nl.norm())));
        if i > 0
            && let Some(c) = limits.clamp(
                i,
                &links[i - 1],
                lengths[i - 1],
                &links[i],
                lengths[i],
                false,
            )
        {
            // The links beyond turn with it, so the joints further out keep their angles.
            let turned = UnitQuaternion::rotation_between(&links[i].to_3d(), &c.to_3d())
                .unwrap_or_else(UnitQuaternion::identity);
            rot = turned * rot;
            links[i] = c;
        }
    }
}

/// A unit vector across `e` (in the plane when `e` is).
fn sideways<T: Real>(e: &Vector3<T>) -> Vector3<T> {
    let mut p = Vector3::z().cross(e);
    if p.norm() <= e.norm() * T::lit(0.1) {
        p = Vector3::x().cross(e);
    }
    let n = p.norm();
    if n > T::zero() { p / n } else { Vector3::y() }
}
