//! Joint limits (Korein & Badler, "Extensions for inequality constraints"): a cone at each spherical
//! joint, a range at each revolute joint of a planar chain, and a rope's minimum bend radius turned
//! into cones.
//!
//! # Angles
//!
//! The angle at joint `j` (`1 ≤ j ≤ n − 1`) is the turn from link `j` (joints `j − 1 → j`) to link
//! `j + 1` (joints `j → j + 1`): zero where the chain runs straight through the joint. The two ends
//! (joints 0 and `n`) have one link each and no angle; a fixed base's own angle (the first link
//! against the base frame) is not limited here.
//!
//! * [`LimitKind::Cone`]: the unsigned angle between the two links is at most `hi[j]` (`0 ≤ hi ≤ π`),
//!   in space or in the plane (there the cone is the range `[−hi, hi]`).
//! * [`LimitKind::Range`] (planar chains only): the signed angle (counter-clockwise positive, as
//!   [`crate::angles::signed_angle`]) lies in `[lo[j], hi[j]]`.
//!
//! # How they are honoured
//!
//! A tractrix sweep runs outward from the moved joint, one link after the other; with limits each link,
//! once stepped, is turned back into its joint's cone or range about the link before it (the one nearer
//! the moved joint) when it left it: the smallest rotation that puts it on the boundary (FABRIK's clamp,
//! here after a tractrix step instead of a straight pull). The links beyond follow the turned link's end.
//! Lengths are untouched (a rotation), a link already inside its limit is not touched at all, so a move
//! that never meets a limit is bit for bit the move without limits. The check costs one dot product per
//! link (the cosines are kept); the clamp, when it happens, one square root and a division.
//!
//! A bent rope keeps its loops open because it resists bending: it cannot bend tighter than a radius
//! `R_min`, a physical length. A polygon of links of length `L` turning by `θ` at a vertex has the
//! polygonal radius `L / (2 tan(θ/2))` (Rawdon's MinRad, with the shorter of the two links at an
//! uneven joint); so `θ_max = 2 atan(L / (2 R_min))` is the same rope at every resolution
//! ([`JointLimits::bend_radius`]).

use crate::math::{Embed3, Real, Vector};

/// The form of a chain's limits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitKind {
    /// The unsigned angle between consecutive links at most `hi` (spherical joints; symmetric in the plane).
    Cone,
    /// The signed angle in `[lo, hi]` (revolute joints of a planar chain).
    Range,
}

/// Why limits could not be set.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum LimitError {
    /// One value per joint (`n + 1` for `n` links) was expected.
    #[error("{given} joint limits for a chain of {joints} joints")]
    Count {
        /// Values given.
        given: usize,
        /// Joints of the chain.
        joints: usize,
    },
    /// A value is not finite or out of its range (a cone in `[0, π]`, a range with `lo ≤ hi` in
    /// `[−π, π]`, a bend radius positive).
    #[error("joint {joint}: limit {value} out of range ({why})")]
    Value {
        /// The joint.
        joint: usize,
        /// The value given.
        value: f64,
        /// What it must be.
        why: &'static str,
    },
    /// Ranges (signed angles) need a planar chain.
    #[error("revolute ranges need a planar chain (use a cone in space)")]
    RangeInSpace,
}

/// Limits at the joints of one chain (see the module docs). Index `j` is joint `j`; the entries of the
/// two ends are kept (as "no limit") so that indices match the chain's.
#[derive(Clone, Debug, PartialEq)]
pub struct JointLimits<T> {
    kind: LimitKind,
    lo: Vec<T>,
    hi: Vec<T>,
    /// `cos(hi)` and `sin(hi)` (cones: the check is one dot product against `cos`).
    cos_hi: Vec<T>,
    sin_hi: Vec<T>,
    /// `cos(lo)` and `sin(lo)` (ranges: the check is two cross products, no arctangent).
    cos_lo: Vec<T>,
    sin_lo: Vec<T>,
}

impl<T: Real> JointLimits<T> {
    /// The same cone (largest angle between consecutive links, radians, in `[0, π]`) at every joint of a
    /// chain of `n_links` links.
    pub fn cone(n_links: usize, max_angle: T) -> Result<Self, LimitError> {
        Self::cones(&vec![max_angle; n_links + 1])
    }

    /// A cone per joint (`n + 1` values, the ends' ignored; `π` means no limit).
    pub fn cones(max_angle: &[T]) -> Result<Self, LimitError> {
        let pi = T::pi();
        for (j, &a) in max_angle.iter().enumerate() {
            if !(a.is_finite() && a >= T::zero() && a <= pi) {
                return Err(LimitError::Value {
                    joint: j,
                    value: a.to_f64(),
                    why: "a cone is an angle in [0, π] radians",
                });
            }
        }
        let lo = max_angle.iter().map(|&a| -a).collect();
        Ok(Self::build(LimitKind::Cone, lo, max_angle.to_vec()))
    }

    /// Cones from a rope's minimum bend radius `r_min` (a length) and its link lengths:
    /// `θ_max = 2 atan(L / (2 r_min))` at each joint, `L` the shorter of its two links.
    pub fn bend_radius(lengths: &[T], r_min: T) -> Result<Self, LimitError> {
        if !(r_min.is_finite() && r_min > T::zero()) {
            return Err(LimitError::Value {
                joint: 0,
                value: r_min.to_f64(),
                why: "a bend radius is a positive length",
            });
        }
        let n = lengths.len();
        let two = T::lit(2.0);
        let cones: Vec<T> = (0..=n)
            .map(|j| {
                if j == 0 || j == n {
                    T::pi()
                } else {
                    let l = lengths[j - 1].min(lengths[j]);
                    two * (l / (two * r_min)).atan()
                }
            })
            .collect();
        Self::cones(&cones)
    }

    /// A signed range `[lo, hi]` per joint of a planar chain (`n + 1` pairs, the ends' ignored).
    pub fn ranges(lo: &[T], hi: &[T]) -> Result<Self, LimitError> {
        if lo.len() != hi.len() {
            return Err(LimitError::Count {
                given: lo.len().min(hi.len()),
                joints: lo.len().max(hi.len()),
            });
        }
        let pi = T::pi();
        for (j, (&a, &b)) in lo.iter().zip(hi).enumerate() {
            if !(a.is_finite() && b.is_finite() && a <= b && a >= -pi && b <= pi) {
                return Err(LimitError::Value {
                    joint: j,
                    value: if a.is_finite() && a >= -pi { b } else { a }.to_f64(),
                    why: "a range is lo ≤ hi within [−π, π] radians",
                });
            }
        }
        Ok(Self::build(LimitKind::Range, lo.to_vec(), hi.to_vec()))
    }

    fn build(kind: LimitKind, lo: Vec<T>, hi: Vec<T>) -> Self {
        let cos_hi = hi.iter().map(|a| a.cos()).collect();
        let sin_hi = hi.iter().map(|a| a.sin()).collect();
        let cos_lo = lo.iter().map(|a| a.cos()).collect();
        let sin_lo = lo.iter().map(|a| a.sin()).collect();
        JointLimits {
            kind,
            lo,
            hi,
            cos_hi,
            sin_hi,
            cos_lo,
            sin_lo,
        }
    }

    /// Cone or range.
    pub fn kind(&self) -> LimitKind {
        self.kind
    }

    /// Number of joints the limits are for (`n + 1`).
    pub fn joints(&self) -> usize {
        self.hi.len()
    }

    /// The lower bound at joint `j` (`−hi` for a cone).
    pub fn lo(&self, j: usize) -> T {
        self.lo[j]
    }

    /// The upper bound at joint `j` (a cone's half-angle).
    pub fn hi(&self, j: usize) -> T {
        self.hi[j]
    }

    /// The cosines and sines of the cones (one per joint; `None` for ranges): a link `v` after `prev`
    /// is within joint `j`'s cone when `prev · v ≥ cos[j] · |prev| · |v|`, and [`JointLimits::clamp`]
    /// turns it onto the cone by `cos[j]` and `sin[j]` (for the SIMD lanes of [`crate::strands`],
    /// which compute the same test and turn).
    pub(crate) fn cone_terms(&self) -> Option<(&[T], &[T])> {
        (self.kind == LimitKind::Cone).then_some((&self.cos_hi[..], &self.sin_hi[..]))
    }

    /// These limits with the joints `free` not limited at all (the joints of the links through a
    /// rope's eyelets, where the tissue takes the bend: [`crate::eyelet`]).
    pub fn freed(&self, free: &[usize]) -> Self {
        let mut l = self.clone();
        let pi = T::pi();
        let joints = l.hi.len();
        for &j in free.iter().filter(|&&j| j < joints) {
            (l.lo[j], l.hi[j]) = (-pi, pi);
            (l.cos_hi[j], l.sin_hi[j]) = (pi.cos(), pi.sin());
            (l.cos_lo[j], l.sin_lo[j]) = ((-pi).cos(), (-pi).sin());
        }
        l
    }

    /// Whether joint `j` is limited at all (a cone below `π`, a range narrower than the circle).
    pub fn limits(&self, j: usize) -> bool {
        j > 0 && j + 1 < self.hi.len() && (self.hi[j] < T::pi() || self.lo[j] > -T::pi())
    }

    /// The limits of the joints `from..=to` as a chain of their own (a held side); `reversed` walks them
    /// from `to` down to `from` (the links turned round, so a range's signs swap).
    pub fn sub(&self, from: usize, to: usize, reversed: bool) -> Self {
        let pi = T::pi();
        let mut lo: Vec<T> = self.lo[from..=to].to_vec();
        let mut hi: Vec<T> = self.hi[from..=to].to_vec();
        if reversed {
            lo.reverse();
            hi.reverse();
            if self.kind == LimitKind::Range {
                std::mem::swap(&mut lo, &mut hi);
                lo.iter_mut().for_each(|a| *a = -*a);
                hi.iter_mut().for_each(|a| *a = -*a);
            }
        }
        // The sub-chain's ends are not joints of it.
        let last = lo.len() - 1;
        for j in [0, last] {
            lo[j] = -pi;
            hi[j] = pi;
        }
        Self::build(self.kind, lo, hi)
    }

    /// Turns `v` (a link of length `len`, just stepped) back into joint `j`'s limit about `prev` (the
    /// link before it, length `prev_len`, both pointing away from the moved joint); `flip` for a sweep
    /// toward the tail, where the links are walked reversed and a range's signs swap. `None` when `v` is
    /// inside (nothing to do).
    #[inline]
    pub fn clamp<const D: usize>(
        &self,
        j: usize,
        prev: &Vector<T, D>,
        prev_len: T,
        v: &Vector<T, D>,
        len: T,
        flip: bool,
    ) -> Option<Vector<T, D>>
    where
        Vector<T, D>: Embed3<T>,
    {
        match self.kind {
            LimitKind::Cone => {
                let d = prev.dot(v);
                if d >= self.cos_hi[j] * prev_len * len {
                    return None;
                }
                let a = prev / prev_len;
                let along = a.dot(v);
                let mut perp = v - a * along;
                let pn = perp.norm();
                perp = if pn > len * T::EPSILON * T::lit(16.0) {
                    perp / pn
                } else {
                    // Folded straight back: any side will do; the same one every time.
                    perpendicular(&a)
                };
                Some((a * self.cos_hi[j] + perp * self.sin_hi[j]) * len)
            }
            LimitKind::Range => {
                let (lo, hi) = if flip {
                    (-self.hi[j], -self.lo[j])
                } else {
                    (self.lo[j], self.hi[j])
                };
                let p3 = prev.to_3d();
                let v3 = v.to_3d();
                let (c, s) = (p3.dot(&v3), p3.cross(&v3).z);
                // Inside without an arctangent: the turn's direction (c, s) lies on the arc from lo
                // to hi, tested against the bounds' directions by cross products (an arc of at most
                // π is the meet of two half-planes, a longer one the complement of the arc beyond).
                let ((lc, ls), (hc, hs)) = if flip {
                    (
                        (self.cos_hi[j], -self.sin_hi[j]),
                        (self.cos_lo[j], -self.sin_lo[j]),
                    )
                } else {
                    (
                        (self.cos_lo[j], self.sin_lo[j]),
                        (self.cos_hi[j], self.sin_hi[j]),
                    )
                };
                let after_lo = lc * s - ls * c;
                let before_hi = c * hs - s * hc;
                let inside = if hi - lo <= T::pi() {
                    after_lo >= T::zero() && before_hi >= T::zero()
                } else {
                    !(after_lo < T::zero() && before_hi < T::zero())
                };
                if inside {
                    return None;
                }
                // Outside: onto the nearer bound (the larger cosine to the turn's direction), the
                // link before turned by it.
                let (bc, bs) = if c * hc + s * hs >= c * lc + s * ls {
                    (hc, hs)
                } else {
                    (lc, ls)
                };
                let a = p3 / prev_len;
                let r = nalgebra::Vector3::new(bc * a.x - bs * a.y, bs * a.x + bc * a.y, T::zero());
                Some(Vector::<T, D>::from_3d(&(r * len)))
            }
        }
    }

    /// Whether turning link `b` (after link `a`, at joint `j`) by the small rotation `omega` would
    /// take the joint's angle further out at a bound it lies within `margin` radians of (boundary
    /// following's test, [`crate::boundary`]), the margin given by its cosine and sine. No
    /// arctangent: the bounds' cosines and sines, turned by the margin.
    pub(crate) fn pushed_out(
        &self,
        j: usize,
        a: &nalgebra::Vector3<T>,
        b: &nalgebra::Vector3<T>,
        omega: &nalgebra::Vector3<T>,
        (cm, sm): (T, T),
    ) -> bool {
        let cross = a.cross(b);
        let (c, s) = (a.dot(b), cross.z);
        match self.kind {
            LimitKind::Cone => {
                // Opening (ω · (a × b) > 0) at an angle θ ≥ hi − margin: sin(θ − φ) ≥ 0 with
                // φ = hi − margin, both in [0, π].
                let cn = cross.norm();
                if cn <= T::zero() || omega.dot(&cross) <= T::zero() {
                    return false;
                }
                let (ch, sh) = (self.cos_hi[j], self.sin_hi[j]);
                let (cf, sf) = (ch * cm + sh * sm, sh * cm - ch * sm);
                cn * cf - c * sf >= T::zero()
            }
            LimitKind::Range => {
                // The signed turn (c, s) within margin of a bound, on the arc from bound − margin
                // to bound + margin (two half-planes), and ω turning it outward.
                let near = |bc: T, bs: T| {
                    let (c0, s0) = (bc * cm + bs * sm, bs * cm - bc * sm);
                    let (c1, s1) = (bc * cm - bs * sm, bs * cm + bc * sm);
                    c0 * s - s0 * c >= T::zero() && c * s1 - s * c1 >= T::zero()
                };
                (omega.z > T::zero() && near(self.cos_hi[j], self.sin_hi[j]))
                    || (omega.z < T::zero() && near(self.cos_lo[j], self.sin_lo[j]))
            }
        }
    }

    /// The worst excess over the limits of a chain's links (tail first): the joint, its angle (unsigned
    /// for a cone, signed for a range) and the excess in radians; `None` when every joint is within its
    /// limit plus `tol` radians.
    pub fn worst<const D: usize>(&self, links: &[Vector<T, D>], tol: T) -> Option<(usize, T, T)>
    where
        Vector<T, D>: Embed3<T>,
    {
        self.worst_except(links, tol, &[])
    }

    /// [`JointLimits::worst`] with the joints `free` (ascending) not limited: the joints of the links
    /// through a rope's eyelets, where the tissue takes the bend ([`crate::eyelet`]).
    pub fn worst_except<const D: usize>(
        &self,
        links: &[Vector<T, D>],
        tol: T,
        free: &[usize],
    ) -> Option<(usize, T, T)>
    where
        Vector<T, D>: Embed3<T>,
    {
        let mut worst: Option<(usize, T, T)> = None;
        for j in 1..links.len() {
            if !self.limits(j) || free.binary_search(&j).is_ok() {
                continue;
            }
            let (a, b) = (links[j - 1].to_3d(), links[j].to_3d());
            let (angle, excess) = match self.kind {
                LimitKind::Cone => {
                    let angle = a.cross(&b).norm().atan2(a.dot(&b));
                    (angle, angle - self.hi[j])
                }
                LimitKind::Range => {
                    let angle = a.cross(&b).z.atan2(a.dot(&b));
                    (angle, (angle - self.hi[j]).max(self.lo[j] - angle))
                }
            };
            if excess > tol && worst.is_none_or(|w| excess > w.2) {
                worst = Some((j, angle, excess));
            }
        }
        worst
    }
}

/// Turns link `i` of `links` back into its joint's limit, as a sweep outward from a fixed joint places
/// it: toward the head (`head_side`) about link `i − 1` (joint `i`), toward the tail about link `i + 1`
/// (joint `i + 1`). Nothing without limits or at an end. For solvers that place links one after the
/// other (collision passes).
pub(crate) fn turn_back<T: Real, const D: usize>(
    limits: Option<&JointLimits<T>>,
    links: &mut [Vector<T, D>],
    lengths: &[T],
    i: usize,
    head_side: bool,
) where
    Vector<T, D>: Embed3<T>,
{
    let Some(lim) = limits else {
        return;
    };
    if head_side {
        if i > 0
            && let Some(c) = lim.clamp(
                i,
                &links[i - 1],
                lengths[i - 1],
                &links[i],
                lengths[i],
                false,
            )
        {
            links[i] = c;
        }
    } else if i + 1 < links.len()
        && let Some(c) = lim.clamp(
            i + 1,
            &(-links[i + 1]),
            lengths[i + 1],
            &(-links[i]),
            lengths[i],
            true,
        )
    {
        links[i] = -c;
    }
}

/// A unit vector perpendicular to the unit `a` (in the plane for a planar chain), the same for the same `a`.
fn perpendicular<T: Real, const D: usize>(a: &Vector<T, D>) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let a3 = a.to_3d();
    let mut p = nalgebra::Vector3::z().cross(&a3);
    if p.norm() <= T::lit(0.1) {
        p = nalgebra::Vector3::x().cross(&a3);
    }
    Vector::<T, D>::from_3d(&p.normalize())
}
