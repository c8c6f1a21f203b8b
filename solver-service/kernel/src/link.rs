//! One link, three ways: what the tail of a rigid link does when its head moves along a straight segment.
//!
//! Every function here takes the link as `t = tail − head` (before the move), the head's displacement `s`
//! and the link's nominal length `len`, and returns a [`LinkStep`]: the new link vector (tail − new head)
//! and the tail's displacement, which is the next link's head displacement.
//!
//! * [`tractrix_step`]: the singularity-free closed form (the default). Exact for a straight head motion.
//! * [`tractrix_paper_step`]: algorithm TRACTRIX3D exactly as printed (section 3.1, eqs. 13–14), kept as
//!   the reference. It is undefined when the move is zero or the tail lies on the line of motion.
//! * [`follow_the_leader_step`]: the tail is put on the line from the new head to the old tail; the cheap
//!   first-order peer used by knot-tying simulators.
//!
//! # The closed form
//!
//! In the paper's reference frame the head moves along `+x` and the tail sits at
//! `(−L tanh a, L sech a)` relative to the head (eq. 3 with `a = p/L`). So `tanh a = −c` and
//! `sech a = |w|`, where `c` and `w` are the tail's components along and across the motion in units of
//! `L`. Moving the head by `b = |s|/L` gives the tail at `a + b`; the addition formulas
//!
//! ```text
//! tanh(a+b) = (tanh a + tanh b) / (1 + tanh a tanh b)      sech(a+b) = sech a sech b / (1 + tanh a tanh b)
//! ```
//!
//! written with `q = e^{−b}`, `E = q²`, `p = 1 + tanh a`, `m = 1 − tanh a` become
//!
//! ```text
//! t'/L = ((E m − p) û + 2 q w) / D,      D = p + E m,
//! ```
//!
//! one exponential and one division, no `sech⁻¹`, no cross product, no rotation matrix. The output has
//! length `L` whatever rounding the input carries (because `p m = |w|²` by construction), so lengths do
//! not drift over millions of moves. Two cancellations are avoided:
//!
//! * `p = 1 − c` when the tail is *ahead* of the head (`c > 0`, pushing) is written as `|w|² / (1 + c)`
//!   (the `1 − cos = sin² / (1 + cos)` trick), so that `p m = |w|²` and the output keeps its length
//!   however close to the line of motion the push is; with the tail behind (`c ≤ 0`, pulling) `D ≥ 1`
//!   and `m = 1 + c` as it stands loses nothing that shows (the mirror rewrite, `m = |w|²/(1 − c)`,
//!   cost a division per link and no test fails without it);
//! * for a move shorter than a thousandth of the link the tail's displacement is computed in its own
//!   form, `(b − p m (1−E)/D) û + (e₁ (2c − e₁ m)/D) w` with `e₁ = 1 − q = −expm1(−b)`, so a move of
//!   `10⁻¹²·L` gives a displacement accurate to the last digits instead of the difference of two nearly
//!   equal positions (and `2c − e₁ m = q m − p` when the tail is ahead, where it would cancel); a
//!   longer move takes it as that difference (new tail − old tail), which keeps it to about
//!   `1000 ε` of itself;
//! * near the line of motion (`|w| < 1/2`) `w` is tiny and the factor `2q/D` large (up to `1/|w|` for
//!   a long push), so `w` is orthogonalised against `û` twice: one Gram–Schmidt pass leaves an
//!   `ε`-sized component along `û` that would otherwise come out as a length error of `ε/|w|` (seen as
//!   1.7e-11 in a 10⁶-move walk); farther from it that error is at most `2ε` and the pass is skipped.
//!
//! Each guard runs only for the inputs that need it, and each has a test that fails without it
//! (`tests/kernel/link.rs`: `tiny_moves_keep_relative_accuracy` for the short-move form;
//! `tests/kernel/extremes.rs`, `collinear_pushes_of_every_length_stay_finite` and the 10⁶-move walks, for
//! the second pass).
//!
//! The collinear pull (`w = 0`, `c = −1`: `m = 0`) and push (`w = 0`, `c = 1`: `p = 0`) need no branch.
//! The only guard is the zero move and `D = 0`, which happens only for an exactly collinear push so large
//! that `E` underflows (`b ≳ 745` in f64); its limit, the tail staying ahead, is returned.

use crate::math::{Embed3, Real, Vector, positive_finite, robust_norm};
use nalgebra::Vector3;

/// The outcome of moving one link's head.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkStep<T: Real, const D: usize> {
    /// The new link vector, tail − new head. Its length is the nominal length to rounding.
    pub link: Vector<T, D>,
    /// How far the tail moved (new tail − old tail): the head displacement of the next link.
    pub tail_shift: Vector<T, D>,
}

/// The single-link method used to propagate a move down a chain.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Method {
    /// Singularity-free closed-form tractrix ([`tractrix_step`]). Second order in the step size.
    #[default]
    Tractrix = 0,
    /// The paper's TRACTRIX3D as printed ([`tractrix_paper_step`]); where it is undefined the closed form
    /// is used and the fallback counted.
    TractrixPaper = 1,
    /// Follow-the-leader ([`follow_the_leader_step`]). First order in the step size.
    FollowTheLeader = 2,
}

impl Method {
    /// All methods, for tables and tests.
    pub const ALL: [Method; 3] = [
        Method::Tractrix,
        Method::TractrixPaper,
        Method::FollowTheLeader,
    ];

    /// Short name used in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Tractrix => "tractrix",
            Method::TractrixPaper => "paper",
            Method::FollowTheLeader => "ftl",
        }
    }
}

/// The closed-form tractrix step (see the module docs). Exact for a straight head motion of any length.
///
/// `len` must be positive and the inputs finite; `t` should have length `len` (rounding drift is
/// corrected, not amplified). Inlined into the sweeps: as a call it showed in the f32 rows of
/// `cargo bench -p tractrix --bench lean`.
#[inline(always)]
pub fn tractrix_step<T: Real, const D: usize>(
    t: &Vector<T, D>,
    s: &Vector<T, D>,
    len: T,
) -> LinkStep<T, D> {
    let one = T::one();
    let two = T::lit(2.0);
    let inv_len = one / len;
    // Work in units of the link length: scale-free, and squares stay in range for f32 too.
    let ss = s * inv_len;
    let b = ss.norm();
    if b == T::zero() {
        return LinkStep {
            link: *t,
            tail_shift: Vector::zeros(),
        };
    }
    // Divided, not multiplied by 1/b: the rounding of a reciprocal leaves |û| an ulp off 1, which a
    // push near the line of motion amplifies (by up to 1/|w|) into a length error.
    let u = ss / b;
    let tt = t * inv_len;
    let c = tt.dot(&u);
    let mut w = tt - u * c;
    let mut y2 = w.norm_squared();
    // Second Gram–Schmidt pass, for a push near the line of motion only: there |w| ≪ 1 keeps an
    // ε-sized component along û, which the factor 2q/D (up to ~1/|w| when the tail is ahead, c > 0)
    // would amplify into a length error of ε/|w|. Beyond |w| = 1/2, or with the tail behind (c ≤ 0:
    // D ≥ 1, the factor at most 2), that error is at most 2ε, and the pass is skipped.
    if c > T::zero() && y2 < T::lit(0.25) {
        w -= u * w.dot(&u);
        y2 = w.norm_squared();
    }
    // p = 1 + tanh a = 1 − c, m = 1 − tanh a = 1 + c; for a push p cancels and is rewritten |w|²/(1 + c).
    let m = one + c;
    let p = if c > T::zero() { y2 / m } else { one - c };
    if b < T::lit(SHORT_MOVE) {
        return short_move_step(t, s, &u, &w, c, p, m, b, len);
    }
    let q = (-b).exp();
    let e = q * q;
    let d = p + e * m;
    if !positive_finite(d) {
        // Exactly collinear push with E underflowed: the tail stays ahead, the link translates.
        return LinkStep {
            link: *t,
            tail_shift: *s,
        };
    }
    if d > T::lit(1e-30) {
        // The length folded into the scalar coefficients: two vector scalings fewer.
        let inv_d = one / d;
        let link = u * ((e * m - p) * inv_d * len) + w * (two * q * inv_d * len);
        // The new tail less the old one (a move of at least SHORT_MOVE links: the difference keeps
        // the displacement's digits to about ε/SHORT_MOVE of itself).
        let tail_shift = s + link - t;
        return LinkStep { link, tail_shift };
    }
    tiny_denominator_step(t, s, &u, &w, q, m, b, one - q, len)
}

/// Moves shorter than this (in link lengths) take [`short_move_step`]: their tail displacement is
/// computed in its own form, accurate relative to itself; longer ones take it as the difference of the
/// new and the old tail, which loses at most a factor `1/SHORT_MOVE` of its relative accuracy.
const SHORT_MOVE: f64 = 1e-3;

/// The rest of [`tractrix_step`] for a move shorter than [`SHORT_MOVE`] links: `e₁ = 1 − e^{−b}` by
/// `expm1` (no cancellation for small `b`) and the tail's displacement in its own form,
/// `(b − p m (1−E)/D) û + (e₁ (2c − e₁ m)/D) w`, so a move of `10⁻¹²·L` gives a displacement accurate
/// to the last digits instead of the difference of two nearly equal positions.
#[allow(clippy::too_many_arguments)]
#[inline]
fn short_move_step<T: Real, const D: usize>(
    t: &Vector<T, D>,
    s: &Vector<T, D>,
    u: &Vector<T, D>,
    w: &Vector<T, D>,
    c: T,
    p: T,
    m: T,
    b: T,
    len: T,
) -> LinkStep<T, D> {
    let one = T::one();
    let two = T::lit(2.0);
    let e1 = -(-b).exp_m1();
    let q = one - e1;
    let e = q * q;
    let d = p + e * m;
    if !positive_finite(d) {
        return LinkStep {
            link: *t,
            tail_shift: *s,
        };
    }
    // 2c − e1 m, written q m − p when the tail is ahead (c > 0, p = 1 − c accurately), where it would
    // cancel toward c − 1 + q m.
    let cw_num = if c > T::zero() {
        e1 * (q * m - p)
    } else {
        e1 * (two * c - e1 * m)
    };
    // 1 − E = e1 (1 + q)
    let cu_num = p * m * e1 * (one + q);
    if d > T::lit(1e-30) {
        let inv_d = one / d;
        let link = *u * ((e * m - p) * inv_d * len) + *w * (two * q * inv_d * len);
        let tail_shift = *u * ((b - cu_num * inv_d) * len) + *w * (cw_num * inv_d * len);
        return LinkStep { link, tail_shift };
    }
    tiny_denominator_step(t, s, u, w, q, m, b, e1, len)
}

/// The rest of [`tractrix_step`] when `D` is tiny (out of line: rare, and it keeps the common path's
/// registers free).
#[cold]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn tiny_denominator_step<T: Real, const D: usize>(
    t: &Vector<T, D>,
    s: &Vector<T, D>,
    u: &Vector<T, D>,
    w: &Vector<T, D>,
    q: T,
    m: T,
    b: T,
    e1: T,
    len: T,
) -> LinkStep<T, D> {
    let one = T::one();
    let two = T::lit(2.0);
    // D tiny: a push nearly along the link (c > 0, |w|² and E = e^{−2b} near or below the smallest
    // normal number: ~44+ links in one substep in f32, ~350+ in f64). 1/D overflows and E, |w|² lose
    // their digits, so the step is written with |w| and q alone: with τ = |w| / (q m) the link turns
    // from û toward ŵ by φ, tan(φ/2) = τ — unit length by construction — and the tail shift's terms
    // are the same ratios. τ or 1/τ, whichever is at most 1, keeps every quantity in range.
    // |w| scaled first: its square may be subnormal.
    let a = w.amax();
    if a == T::zero() {
        return LinkStep {
            link: *t,
            tail_shift: *s,
        };
    }
    let ws = w / a;
    let wn = ws.norm();
    let r = a * wn;
    let wh = ws / wn;
    let x = q * m;
    // cos φ, sin φ, τ²/(1+τ²) and (τ m − τ² |w|)/(1+τ²), the coefficient of ŵ in the tail shift.
    let (cos, sin, t2, cwc) = if r <= x {
        let tau = r / x;
        let den = one + tau * tau;
        (
            (one - tau * tau) / den,
            two * tau / den,
            tau * tau / den,
            (tau * m - tau * tau * r) / den,
        )
    } else {
        let sigma = x / r;
        let den = sigma * sigma + one;
        (
            (sigma * sigma - one) / den,
            two * sigma / den,
            one / den,
            (sigma * m - r) / den,
        )
    };
    let link = (u * cos + wh * sin) * len;
    let tail_shift = (u * (b - e1 * (one + q) * m * t2) + wh * (e1 * cwc)) * len;
    LinkStep { link, tail_shift }
}

/// Why the paper's TRACTRIX3D is undefined for a given link and move.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PaperFormDegenerate {
    /// `S = 0`: step 3 divides by `|S|`.
    #[error("zero move: the reference frame's X axis S/|S| is undefined")]
    ZeroMove,
    /// `S × T = 0`: the tail lies on the line of motion; step 4 divides by `|S × T|` and step 6 needs
    /// `sech⁻¹(0) = ∞`.
    #[error("tail on the line of motion: S x T = 0, Z axis undefined and sech^-1(0) infinite")]
    Collinear,
    /// The formulas produced a non-finite number (only for inputs far outside the link's scale).
    #[error("non-finite result")]
    NonFinite,
}

/// Algorithm TRACTRIX3D (section 3.1) as printed, in 3D: the reference frame `{r}` with `X_r = S/|S|`,
/// `Z_r = S×T/|S×T|`, `Y_r = Z_r × X_r`; `y = Y_r·T`; `p = L sech⁻¹(y/L) ± |S|`; eq. (13) for
/// `(x_r, y_r)`; eq. (14) back to the global frame.
///
/// The printed `±` is read as follows: `+|S|` when the tail trails the head (`X_r·T ≤ 0`), giving
/// `x_r = |S| − L tanh(p/L)`; when the tail is ahead of the head, the tractrix parameter is negative,
/// `p = L sech⁻¹(y/L) − |S|` and `x_r = |S| + L tanh(p/L)` (the printed `−|S| − L tanh(p/L)` in the
/// frame whose X axis is reversed). `y/L` is clamped to 1 so that rounding in `|T|` cannot take `sech⁻¹`
/// out of its domain; that clamp is the only liberty taken with the text.
pub fn tractrix_paper_step3<T: Real>(
    t: &Vector3<T>,
    s: &Vector3<T>,
    len: T,
) -> Result<LinkStep<T, 3>, PaperFormDegenerate> {
    let one = T::one();
    let sn = s.norm();
    if sn == T::zero() {
        return Err(PaperFormDegenerate::ZeroMove);
    }
    let xr = s / sn; // step 3
    let st = s.cross(t);
    let stn = st.norm();
    if stn == T::zero() {
        return Err(PaperFormDegenerate::Collinear);
    }
    let zr = st / stn; // step 4
    let yr = zr.cross(&xr); // step 5: R = [X_r, Z_r × X_r, Z_r]
    let y = yr.dot(t); // step 6
    let z = (y / len).min(one);
    let asech = ((one + (one - z * z).sqrt()) / z).ln();
    let behind = xr.dot(t) <= T::zero();
    let p = if behind {
        len * asech + sn
    } else {
        len * asech - sn
    };
    let th = (p / len).tanh(); // step 7, eq. (13)
    let x_r = if behind { sn - len * th } else { sn + len * th };
    let y_r = len / (p / len).cosh();
    // eq. (14): tail = X_h + R (x_r, y_r, 0)ᵀ
    let tail_from_old_head = xr * x_r + yr * y_r;
    let link = tail_from_old_head - s;
    let tail_shift = tail_from_old_head - t;
    if !(link.iter().chain(tail_shift.iter()).all(|v| v.is_finite())) {
        return Err(PaperFormDegenerate::NonFinite);
    }
    Ok(LinkStep { link, tail_shift })
}

/// The paper's form for a planar or spatial link: planar links are embedded at `z = 0`.
pub fn tractrix_paper_step<T: Real, const D: usize>(
    t: &Vector<T, D>,
    s: &Vector<T, D>,
    len: T,
) -> Result<LinkStep<T, D>, PaperFormDegenerate>
where
    Vector<T, D>: Embed3<T>,
{
    let r = tractrix_paper_step3(&t.to_3d(), &s.to_3d(), len)?;
    Ok(LinkStep {
        link: Vector::<T, D>::from_3d(&r.link),
        tail_shift: Vector::<T, D>::from_3d(&r.tail_shift),
    })
}

/// Follow-the-leader: the new tail lies on the line from the new head to the old tail, at distance `len`.
///
/// When the head lands exactly on the old tail that line is undefined; the link then keeps its direction
/// (a rigid translation), which is the limit of a head arriving from any direction along the link.
#[inline]
pub fn follow_the_leader_step<T: Real, const D: usize>(
    t: &Vector<T, D>,
    s: &Vector<T, D>,
    len: T,
) -> LinkStep<T, D> {
    let r = t - s; // old tail seen from the new head
    let rn = robust_norm(&r);
    if rn == T::zero() {
        return LinkStep {
            link: *t,
            tail_shift: *s,
        };
    }
    let link = r * (len / rn);
    // tail_shift = link − r = r (len − rn)/rn, with len − rn = (len² − rn²)/(len + rn) and, for a link
    // of exact length, len² − rn² = s·(2t − s): no cancellation for small moves. The stored vector's own
    // rounding (|t|² − len² ~ ε) is left out on purpose: it would fabricate a shift for tiny moves.
    let num = s.dot(&(t * T::lit(2.0) - s));
    let tail_shift = r * (num / (rn * (len + rn)));
    LinkStep { link, tail_shift }
}

/// One step of `method`, with the paper's form falling back to the closed form where it is undefined.
/// Returns the step and whether a fallback happened (never for a zero move, whose answer is no motion).
#[inline]
pub fn step<T: Real, const D: usize>(
    method: Method,
    t: &Vector<T, D>,
    s: &Vector<T, D>,
    len: T,
) -> (LinkStep<T, D>, bool)
where
    Vector<T, D>: Embed3<T>,
{
    match method {
        Method::Tractrix => (tractrix_step(t, s, len), false),
        Method::FollowTheLeader => (follow_the_leader_step(t, s, len), false),
        Method::TractrixPaper => match tractrix_paper_step(t, s, len) {
            Ok(r) => (r, false),
            Err(PaperFormDegenerate::ZeroMove) => (
                LinkStep {
                    link: *t,
                    tail_shift: Vector::zeros(),
                },
                false,
            ),
            Err(_) => (tractrix_step(t, s, len), true),
        },
    }
}
