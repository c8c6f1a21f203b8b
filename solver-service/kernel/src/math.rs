//! The one math module every kernel file imports: the scalar trait, vector aliases, named tolerances.
//!
//! The kernel is generic over the scalar (`f64` or `f32`) and over the dimension `D` (2 for planar
//! chains with rotary joints, 3 for spatial chains with spherical joints). Planar chains are stored and
//! solved in two coordinates: a planar scene pays for no third coordinate.

use nalgebra::{RealField, SVector, Vector2, Vector3};

/// A floating-point scalar the kernel can run in: `f64` (reference) or `f32` (speed, half the memory).
pub trait Real: RealField + Copy + Default + std::fmt::Debug + 'static {
    /// Machine epsilon of the type.
    const EPSILON: Self;
    /// The smallest positive normal number.
    const MIN_POSITIVE: Self;
    /// The largest finite number.
    const MAX: Self;
    /// Converts an `f64` constant or measurement into this type (rounding to nearest for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both implementors).
    fn to_f64(self) -> f64;
}

impl Real for f64 {
    const EPSILON: Self = f64::EPSILON;
    const MIN_POSITIVE: Self = f64::MIN_POSITIVE;
    const MAX: Self = f64::MAX;
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}

impl Real for f32 {
    const EPSILON: Self = f32::EPSILON;
    const MIN_POSITIVE: Self = f32::MIN_POSITIVE;
    const MAX: Self = f32::MAX;
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}

/// A point or displacement in `D` dimensions.
pub type Vector<T, const D: usize> = SVector<T, D>;

/// Conversions between a chain's own dimension and 3D, for the few algorithms that need a cross product
/// (the paper's TRACTRIX3D reference, rotations of the pseudo-inverse baseline). A planar vector embeds
/// at `z = 0` and comes back without its `z`.
pub trait Embed3<T: Real>: Copy {
    /// The vector in 3D (`z = 0` for a planar vector).
    fn to_3d(&self) -> Vector3<T>;
    /// The vector back in its own dimension (a planar vector drops `z`).
    fn from_3d(v: &Vector3<T>) -> Self;
}

impl<T: Real> Embed3<T> for Vector2<T> {
    #[inline(always)]
    fn to_3d(&self) -> Vector3<T> {
        Vector3::new(self.x, self.y, T::zero())
    }
    #[inline(always)]
    fn from_3d(v: &Vector3<T>) -> Self {
        Vector2::new(v.x, v.y)
    }
}

impl<T: Real> Embed3<T> for Vector3<T> {
    #[inline(always)]
    fn to_3d(&self) -> Vector3<T> {
        *self
    }
    #[inline(always)]
    fn from_3d(v: &Vector3<T>) -> Self {
        *v
    }
}

/// Named tolerances, in one place so that every test and algorithm says which one it relies on.
pub mod tol {
    /// Relative length error (f64) that a single tractrix step may introduce: a few ulps.
    pub const LENGTH_REL_F64: f64 = 1e-12;
    /// Relative difference allowed between the closed form and the paper's form, where the latter is defined.
    pub const PAPER_AGREEMENT_REL: f64 = 1e-12;
}

/// `|v|` computed without overflow or underflow for any finite `v`. The plain `√(v·v)` when `v·v` is a
/// normal finite number (then no square lost more than an ulp of the total); otherwise scaled by the
/// largest component.
#[inline]
pub fn robust_norm<T: Real, const D: usize>(v: &Vector<T, D>) -> T {
    let n2 = v.norm_squared();
    if n2 >= T::MIN_POSITIVE && n2 <= T::MAX {
        return n2.sqrt();
    }
    let m = v.amax();
    if m == T::zero() || !m.is_finite() {
        return m;
    }
    (v / m).norm() * m
}

/// `x > 0` and finite; `false` for NaN (which every plain comparison also fails, so a NaN never slips
/// through as "not negative").
#[inline]
pub fn positive_finite<T: Real>(x: T) -> bool {
    x > T::zero() && x.is_finite()
}

/// `true` when every component is finite.
#[inline]
pub fn all_finite<T: Real, const D: usize>(v: &Vector<T, D>) -> bool {
    v.iter().all(|c| c.is_finite())
}

/// Compensated (Kahan–Babuška–Neumaier) summation of vectors: the sum of `n` terms is accurate to a few ulps of the
/// result instead of `n` ulps. Turning a million link vectors into positions needs it; for 40 links it
/// costs a few flops per joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompensatedSum<T: Real, const D: usize> {
    sum: Vector<T, D>,
    carry: Vector<T, D>,
}

impl<T: Real, const D: usize> CompensatedSum<T, D> {
    /// Starts at `start`.
    #[inline]
    pub fn new(start: Vector<T, D>) -> Self {
        CompensatedSum {
            sum: start,
            carry: Vector::zeros(),
        }
    }
    /// Adds `v`. The rounding error of each component's sum is recovered exactly by Knuth's TwoSum
    /// (six operations, no branch) rather than by comparing magnitudes first (Neumaier's form): the
    /// same exact error, so the same bits, without a data-dependent branch per component, which a
    /// sum of link vectors pointing every way mispredicted about half the time.
    #[inline]
    pub fn add(&mut self, v: &Vector<T, D>) {
        for k in 0..D {
            let s = self.sum[k];
            let x = v[k];
            let t = s + x;
            let xv = t - s;
            let sv = t - xv;
            self.carry[k] += (s - sv) + (x - xv);
            self.sum[k] = t;
        }
    }
    /// The compensated total so far.
    #[inline]
    pub fn value(&self) -> Vector<T, D> {
        self.sum + self.carry
    }
    /// The running sum and its carry (what a snapshot stores to resume the sum bit for bit).
    pub fn parts(&self) -> (Vector<T, D>, Vector<T, D>) {
        (self.sum, self.carry)
    }
    /// Resumes a sum from its [`CompensatedSum::parts`].
    pub fn from_parts(sum: Vector<T, D>, carry: Vector<T, D>) -> Self {
        CompensatedSum { sum, carry }
    }
}
