//! The relaxation of a part of the rope between two fixed joints toward its link lengths (fast
//! projection), after a contact pushed it: the resolution's re-straightening and the joint
//! projection's fallback both use it.

use super::Meter;
use super::cost;
use crate::math::{Embed3, Real, Vector, positive_finite};

/// The joints the last pass pushed (indexed by joint; empty: none marked) and the inverse mass the
/// relaxation gives them ([`CollisionOptions::pushed_weight`]).
#[derive(Clone, Copy)]
pub(super) struct Pushed<'a, T> {
    pub(super) joints: &'a [bool],
    pub(super) weight: T,
    /// Whether a part with no joint marked is left as it is (its lengths are still exact: nothing
    /// moved it since the move or the last re-straightening).
    pub(super) skip_untouched: bool,
}

#[cfg(test)]
impl Pushed<'static, f64> {
    /// No joint marked: the relaxation moves every free joint alike.
    const NONE: Self = Pushed {
        joints: &[],
        weight: 1.0,
        skip_untouched: false,
    };
}

impl<T: Real> Pushed<'_, T> {
    /// The marks of the part from joint `a` to joint `b` (inclusive), indexed from `a`.
    pub(super) fn part(self, a: usize, b: usize) -> Self {
        Pushed {
            joints: self.joints.get(a..=b).unwrap_or(&[]),
            ..self
        }
    }

    /// Whether the part from joint `a` to joint `b` may be left as it is: nothing in it was pushed.
    pub(super) fn untouched(self, a: usize, b: usize) -> bool {
        self.skip_untouched
            && self
                .joints
                .get(a..=b)
                .is_some_and(|part| !part.iter().any(|&m| m))
    }
}

/// Relaxes the part `p` between two fixed joints (its first and last) toward its link `lengths`,
/// every free joint alike ([`relax_lengths`]); `false` when the meter ran out.
pub(super) fn relax_part<T: Real, const D: usize>(
    p: &mut [Vector<T, D>],
    lengths: &[T],
    meter: &mut Meter,
) -> bool
where
    Vector<T, D>: Embed3<T>,
{
    let alike = Pushed {
        joints: &[],
        weight: T::one(),
        skip_untouched: false,
    };
    relax_lengths(p, lengths, alike, meter)
}

/// Most Newton iterations [`relax_lengths`] takes (near a solution each iteration about squares the
/// error; a part that cannot meet its lengths stops as soon as an iteration gains nothing).
const RELAX_ITERATIONS: usize = 12;

/// Relaxes the joints `p` of a part between two fixed joints (its first and last, which do not move)
/// toward the link `lengths` by fast projection (Goldenthal et al., "Efficient simulation of
/// inextensible cloth", 2007): each iteration linearises every link's length constraint and moves the
/// joints by the smallest displacement that satisfies all of them at once, one tridiagonal solve
/// (O(n)). It stops when every link is within 1e-10 of its length (relative), when an iteration no
/// longer lowers the worst error (a part pulled taut past its length keeps the best pose found), or
/// after [`RELAX_ITERATIONS`]; each iteration is charged to `meter` first (`false` when it runs out).
/// A push changes the lengths only near the contact, so the relaxation moves the rope mostly there;
/// the reach that follows then starts from a pose that nearly closes and moves it little. Without it
/// the reach re-solves the whole part from the push: on a coil wound round an instrument that moved
/// joints far from the contact by more than the resolution's step limit, and the move locked: in a
/// trial with the relaxation switched off, the built-in `surgeons-tie` tied a trefoil instead of the
/// double overhand (its second turn round the driver locked) and `instrument-tie` no knot. The
/// relaxation was first Gauss–Seidel projections of one link at a time, which carry a correction one
/// link per sweep: on the 320-link instrument tie almost every call ran its 640 sweeps without
/// converging and took nine tenths of the service's time.
///
/// The joints `pushed` marks have inverse mass `pushed.weight` (the others one): the displacement is
/// the smallest in that weighted norm, so the lengths a push changed are restored more by the rope
/// around the contact than by carrying the pushed joints back into it (on a taut rope the plain
/// projection undid most of each push, and the passes crept toward the tolerance).
pub(super) fn relax_lengths<T: Real, const D: usize>(
    p: &mut [Vector<T, D>],
    lengths: &[T],
    pushed: Pushed<'_, T>,
    meter: &mut Meter,
) -> bool
where
    Vector<T, D>: Embed3<T>,
{
    let n = lengths.len();
    if n < 2 || p.len() != n + 1 {
        return true;
    }
    let goal = T::lit(1e-10);
    // Directions and length errors of the links; the tridiagonal system's rows; the multipliers.
    let mut u = vec![Vector::<T, D>::zeros(); n];
    let mut c = vec![T::zero(); n];
    let mut upper = vec![T::zero(); n];
    let mut rhs = vec![T::zero(); n];
    let mut best = p.to_vec();
    let mut best_worst = T::max_value().unwrap_or_else(T::one);
    for _ in 0..RELAX_ITERATIONS {
        if !meter.charge((n as u64).saturating_mul(cost::RELAX_PER_LINK)) {
            return false;
        }
        let mut worst = T::zero();
        let mut finite = true;
        for i in 0..n {
            let d = p[i + 1] - p[i];
            let len = d.norm();
            if positive_finite(len) {
                u[i] = d / len;
                c[i] = len - lengths[i];
                worst = worst.max(c[i].abs() / lengths[i]);
            } else if len.is_finite() {
                // Two joints on one point: no direction to correct along this time.
                u[i] = Vector::zeros();
                c[i] = T::zero();
                worst = worst.max(T::one());
            } else {
                finite = false;
            }
        }
        if !finite || worst >= best_worst {
            p.copy_from_slice(&best);
            return true;
        }
        best.copy_from_slice(p);
        best_worst = worst;
        if worst <= goal {
            return true;
        }
        // J Jᵀ λ = C with unit masses and the two end joints fixed: the diagonal is the number of
        // free joints of each link, the off-diagonal minus the cosine between consecutive links. A
        // part lying straight between its ends makes it singular; the small regularisation picks
        // the least-squares step there (the null direction moves no joint).
        let eps = T::lit(1e-9);
        // Inverse mass of joint j: the ends do not move, the pushed joints less than the others.
        let wj = |j: usize| {
            if j == 0 || j == n {
                T::zero()
            } else if pushed.joints.get(j).copied().unwrap_or(false) {
                pushed.weight
            } else {
                T::one()
            }
        };
        let diag = |i: usize| wj(i) + wj(i + 1) + eps;
        // Thomas algorithm: forward elimination, then back substitution (into `rhs`).
        let mut m = diag(0);
        for i in 0..n {
            if i > 0 {
                let b = -wj(i) * u[i - 1].dot(&u[i]);
                m = diag(i) - b * upper[i - 1];
                rhs[i] = (c[i] - b * rhs[i - 1]) / m;
            } else {
                rhs[0] = c[0] / m;
            }
            if i + 1 < n {
                upper[i] = -wj(i + 1) * u[i].dot(&u[i + 1]) / m;
            }
        }
        for i in (0..n - 1).rev() {
            let next = rhs[i + 1];
            rhs[i] -= upper[i] * next;
        }
        // δp_j = −(λ_{j−1} u_{j−1} − λ_j u_j) for the free joints.
        for j in 1..n {
            p[j] -= (u[j - 1] * rhs[j - 1] - u[j] * rhs[j]) * wj(j);
        }
    }
    // The last iteration's pose is measured against the best one.
    let worst = (0..n).fold(T::zero(), |w, i| {
        let len = (p[i + 1] - p[i]).norm();
        w.max((len - lengths[i]).abs() / lengths[i])
    });
    // (NaN included: a non-finite pose is never kept.)
    if worst.partial_cmp(&best_worst) != Some(std::cmp::Ordering::Less) {
        p.copy_from_slice(&best);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// A part of unit links bent on an arc with one joint pushed outward (the way a contact pushes
    /// it): the relaxation leaves both fixed ends bit for bit, brings the links near their lengths,
    /// and moves the joints next to the fixed ends less than the pushed one.
    #[test]
    fn relaxation_keeps_the_ends_and_restores_the_lengths_near_a_push() {
        let n = 12;
        let r = 5.0_f64;
        let step = 2.0 * (0.5 / r).asin();
        let mut p: Vec<Vector3<f64>> = (0..=n)
            .map(|i| {
                let a = step * i as f64;
                Vector3::new(r * a.cos(), r * a.sin(), 0.0)
            })
            .collect();
        p[6] *= 1.06;
        let lengths = vec![1.0; n];
        let (first, last) = (p[0], p[n]);
        let before = p.clone();
        let worst = |p: &[Vector3<f64>]| {
            (0..n)
                .map(|i| ((p[i + 1] - p[i]).norm() - 1.0).abs())
                .fold(0.0, f64::max)
        };
        let err_before = worst(&p);
        assert!(relax_lengths(
            &mut p,
            &lengths,
            Pushed::NONE,
            &mut Meter::default()
        ));
        assert_eq!((p[0], p[n]), (first, last));
        let err_after = worst(&p);
        // An order of magnitude at least (about 70 times here): the reach that follows closes it.
        assert!(err_after < 0.1 * err_before, "{err_before} -> {err_after}");
        let moved = |i: usize| (p[i] - before[i]).norm();
        assert!(moved(1) < moved(6) && moved(n - 1) < moved(6));
    }

    /// The same push on a nearly taut part: with the pushed joint marked and weighted 0.5 (as
    /// `knots.toml`'s long held ropes weight it), the relaxation keeps more of the push (the joint ends farther
    /// out of the line between the ends) and restores the lengths as well, by moving the rest of the
    /// rope; the pushed joint weighted 1 is the plain relaxation, bit for bit.
    #[test]
    fn pushed_joints_weighted_keep_more_of_their_push() {
        let n = 12;
        // A shallow arc: the part is nearly taut between its ends.
        let r = 30.0_f64;
        let step = 2.0 * (0.5 / r).asin();
        let arc: Vec<Vector3<f64>> = (0..=n)
            .map(|i| {
                let a = step * i as f64;
                Vector3::new(r * a.cos(), r * a.sin(), 0.0)
            })
            .collect();
        let mut pushed = arc.clone();
        pushed[6] += Vector3::new(0.05, 0.0, 0.0) + arc[6].normalize() * 0.05;
        let lengths = vec![1.0; n];
        let mut marks = vec![false; n + 1];
        marks[6] = true;
        let worst = |p: &[Vector3<f64>]| {
            (0..n)
                .map(|i| ((p[i + 1] - p[i]).norm() - 1.0).abs())
                .fold(0.0, f64::max)
        };
        let relax = |weight: f64, marks: &[bool]| {
            let mut p = pushed.clone();
            let w = Pushed {
                joints: marks,
                weight,
                skip_untouched: false,
            };
            assert!(relax_lengths(&mut p, &lengths, w, &mut Meter::default()));
            p
        };
        let plain = relax(1.0, &[]);
        assert_eq!(relax(1.0, &marks), plain);
        let weighted = relax(0.5, &marks);
        // How far the pushed joint stays out along the push, from where the arc had it.
        let out = |p: &[Vector3<f64>]| (p[6] - arc[6]).dot(&arc[6].normalize());
        assert!(
            out(&weighted) > 1.2 * out(&plain),
            "kept {} against {}",
            out(&weighted),
            out(&plain)
        );
        assert!(
            worst(&weighted) < 0.1 * worst(&pushed),
            "{}",
            worst(&weighted)
        );
    }

    /// A part too short to meet its fixed ends (taut past its length) is left with its ends where
    /// they are and finite joints: the sweeps are bounded and the reach that follows refuses it.
    #[test]
    fn relaxation_of_an_overstretched_part_is_bounded_and_finite() {
        let n = 8;
        let mut p: Vec<Vector3<f64>> = (0..=n)
            .map(|i| Vector3::new(1.5 * i as f64, 0.0, 0.0))
            .collect();
        let (first, last) = (p[0], p[n]);
        assert!(relax_lengths(
            &mut p,
            &[1.0; 8],
            Pushed::NONE,
            &mut Meter::default()
        ));
        assert_eq!((p[0], p[n]), (first, last));
        assert!(p.iter().all(|q| q.iter().all(|x| x.is_finite())));
    }
}
