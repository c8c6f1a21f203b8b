//! Many free strands at once (hair, fur, a bundle of sutures): every strand's head moved to its own
//! target, every link following its closed-form tractrix, computed across strands with SIMD.
//!
//! # Layout
//!
//! Strands are stored in blocks of [`LANES`] (structure of arrays inside a block, arrays of blocks
//! outside): block `b` holds strands `b·LANES ..` and, for each link `i` from the head, one [`Block`]
//! of the `LANES` link vectors' x, y and z. A sweep steps link `i` of all the block's strands with the
//! same instructions, so the compiler turns the lane loop into vector instructions: 4 f64 or 8 f32 per
//! AVX2 register, 8 or 16 with AVX-512. The instruction set is picked at run time (`pulp`): AVX-512,
//! else AVX2 + FMA, else the baseline (SSE2 on x86-64). Each block holds up to `substeps` steps in
//! flight (the substep wavefront: substep `s` of link `i` beside substep `s − 1` of link `i + 1`), which
//! is the same arithmetic in another order, bit for bit.
//!
//! # The arithmetic, and how it differs from [`crate::link::tractrix_step`]
//!
//! A lane computes exactly what `tractrix_step` computes, operation for operation, except the
//! exponential: `e^{−b}` and `1 − e^{−b}` come from a polynomial written here (branch-free, so it
//! vectorises) instead of the platform's `exp`/`exp_m1`. Both are within about an ulp of the true value,
//! so a strand agrees with a [`crate::Chain`] moved the same way to a few ulps per step (the tests
//! bound it); the link lengths are kept to the same 1e-12. No fused multiply-add is used anywhere, so
//! the SIMD result equals the baseline result bit for bit on every instruction set. Lanes in the rare
//! cases `tractrix_step` treats apart (a denominator below 1e-30: a push exactly along the link) are
//! recomputed by `tractrix_step` itself.
//!
//! The kernel runs no threads: [`Strands::split_at_block`] cuts the state into independent halves a
//! caller may sweep on two cores.

use crate::link::tractrix_step;
use crate::math::Real;
use nalgebra::Vector3;

/// Strands per block: the width of the lane loop (two AVX2 registers of f64, one of f32).
pub const LANES: usize = 8;

/// Most substeps kept in flight at once by the wavefront; more substeps run as several wavefronts.
const MAX_WAVE: usize = 32;

/// `LANES` vectors as three arrays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block<T> {
    /// x of each lane.
    pub x: [T; LANES],
    /// y of each lane.
    pub y: [T; LANES],
    /// z of each lane.
    pub z: [T; LANES],
}

impl<T: Real> Block<T> {
    fn splat(v: Vector3<T>) -> Self {
        Block {
            x: [v.x; LANES],
            y: [v.y; LANES],
            z: [v.z; LANES],
        }
    }
    fn get(&self, l: usize) -> Vector3<T> {
        Vector3::new(self.x[l], self.y[l], self.z[l])
    }
    fn set(&mut self, l: usize, v: Vector3<T>) {
        self.x[l] = v.x;
        self.y[l] = v.y;
        self.z[l] = v.z;
    }
}

/// The scalars a strand sweep runs in, with the branch-free exponential the lanes use.
pub trait StrandReal: Real {
    /// `(e^{−b}, 1 − e^{−b})` for `b ≥ 0` (or `+∞`), each accurate to about an ulp: the second without
    /// cancellation for small `b`. Branch-free: both forms are computed and one is selected.
    fn exp_neg_pair(b: Self) -> (Self, Self);
}

#[inline(always)]
fn sel<T: Copy>(c: bool, a: T, b: T) -> T {
    if c { a } else { b }
}

/// `1/k!` for `k = 0..=15`, each from the last by one division (rounded; the high terms are tiny).
const INV_FACT_64: [f64; 16] = {
    let mut c = [1.0f64; 16];
    let mut k = 1;
    while k < 16 {
        c[k] = c[k - 1] / k as f64;
        k += 1;
    }
    c
};

/// `1/k!` for `k = 0..=9` in f32, rounded from the f64 values.
const INV_FACT_32: [f32; 10] = {
    let mut c = [1.0f32; 10];
    let mut k = 0;
    while k < 10 {
        c[k] = INV_FACT_64[k] as f32;
        k += 1;
    }
    c
};

/// The exponential both ways from one polynomial. `x = −b ≤ 0` is reduced to `x = n ln 2 + r`,
/// `|r| ≤ ln 2 / 2` (`n` = `x / ln 2` rounded by the shift trick, `ln 2` in two parts), and
/// `e^r − 1 = r (1 + r/2! + … )` is summed by Horner through the term `coef` ends with. Then
/// `e^x = 2ⁿ (1 + (e^r − 1))`, and for `b < 0.5` (where `n` is 0 or −1, so `2ⁿ − 1` is exact)
/// `1 − e^x = −(2ⁿ (e^r − 1) + (2ⁿ − 1))` without cancellation; as in `tractrix_step`, the small side
/// takes `q = 1 − e1` and the large side `e1 = 1 − q`. `2ⁿ` is built as two normal factors so that
/// `n` down to −1076 (`x` is clamped to `lo`, where `e^x` rounds to 0) never leaves the normal range.
macro_rules! exp_neg_pair {
    ($t:ty, $bits:ty, $coef:expr, $terms:expr, $shift:expr, $ln2_hi:expr, $ln2_lo:expr, $lo:expr,
     $bias:expr, $mant:expr, $log2e:expr) => {
        #[inline(always)]
        fn exp_neg_pair(b: $t) -> ($t, $t) {
            const SHIFT: $t = $shift;
            let x = -b;
            let xc = sel(x > $lo, x, $lo);
            let n = (xc * $log2e + SHIFT) - SHIFT;
            let r = (xc - n * $ln2_hi) - n * $ln2_lo;
            let c = &$coef;
            let mut p = c[$terms];
            for k in (1..$terms).rev() {
                p = p * r + c[k];
            }
            let em1 = r * p;
            let n1 = (n * 0.5).floor();
            let n2 = n - n1;
            let pow2 = |m: $t| {
                <$t>::from_bits(
                    (m + SHIFT)
                        .to_bits()
                        .wrapping_sub(SHIFT.to_bits())
                        .wrapping_add($bias)
                        << $mant,
                )
            };
            let (s1, s2) = (pow2(n1), pow2(n2));
            let q_large = (1.0 + em1) * s1 * s2;
            // For b < 0.5, n ≥ −1 and s1 s2 = 2ⁿ exactly.
            let p2 = s1 * s2;
            let e1_small = -(p2 * em1 + (p2 - 1.0));
            let small = b < 0.5;
            (
                sel(small, 1.0 - e1_small, q_large),
                sel(small, e1_small, 1.0 - q_large),
            )
        }
    };
}

impl StrandReal for f64 {
    // Through r¹⁴/14!: for |r| ≤ 0.347 the next term is below 2e-17 of e^r − 1.
    exp_neg_pair!(
        f64,
        u64,
        INV_FACT_64,
        14,
        6_755_399_441_055_744.0, // 1.5 · 2⁵²: adding it rounds to an integer
        6.931_471_803_691_238e-1,
        1.908_214_929_270_587_7e-10,
        -746.0,
        1023,
        52,
        std::f64::consts::LOG2_E
    );
}

impl StrandReal for f32 {
    // Through r⁸/8!: the next term is below 2e-8 of e^r − 1.
    exp_neg_pair!(
        f32,
        u32,
        INV_FACT_32,
        8,
        12_582_912.0, // 1.5 · 2²³
        0.693_145_75,
        1.428_606_8e-6,
        -104.0,
        127,
        23,
        std::f32::consts::LOG2_E
    );
}

/// One lane of [`crate::link::tractrix_step`], written out in scalars with selects instead of branches.
/// Returns the new link, the tail's shift, and whether the lane must be recomputed by `tractrix_step`
/// (a denominator at or below 1e-30, or not finite).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn lane<T: StrandReal>(
    tx: T,
    ty: T,
    tz: T,
    sx: T,
    sy: T,
    sz: T,
    len: T,
    inv_len: T,
) -> ([T; 6], bool) {
    let zero = T::zero();
    let one = T::one();
    let two = T::lit(2.0);
    let (ssx, ssy, ssz) = (sx * inv_len, sy * inv_len, sz * inv_len);
    let b = (ssx * ssx + ssy * ssy + ssz * ssz).sqrt();
    let moved = b != zero;
    let (ux, uy, uz) = (ssx / b, ssy / b, ssz / b);
    let (ttx, tty, ttz) = (tx * inv_len, ty * inv_len, tz * inv_len);
    let c = ttx * ux + tty * uy + ttz * uz;
    let (wx, wy, wz) = (ttx - ux * c, tty - uy * c, ttz - uz * c);
    let c2 = wx * ux + wy * uy + wz * uz;
    let (wx, wy, wz) = (wx - ux * c2, wy - uy * c2, wz - uz * c2);
    let y2 = wx * wx + wy * wy + wz * wz;
    let pos = c > zero;
    // One division for the side that cancels (the same quotient tractrix_step takes).
    let (opc, omc) = (one + c, one - c);
    let ratio = y2 / sel(pos, opc, omc);
    let p = sel(pos, ratio, omc);
    let m = sel(pos, opc, ratio);
    let (q, e1) = T::exp_neg_pair(b);
    let e = q * q;
    let d = p + e * m;
    let cw_num = sel(pos, e1 * (q * m - p), e1 * (two * c - e1 * m));
    let cu_num = p * m * e1 * (one + q);
    let regular = d > T::lit(1e-30) && d <= T::MAX;
    let inv_d = one / d;
    let a_link = (e * m - p) * inv_d * len;
    let b_link = two * q * inv_d * len;
    let a_tail = (b - cu_num * inv_d) * len;
    let b_tail = cw_num * inv_d * len;
    let out = [
        sel(moved, ux * a_link + wx * b_link, tx),
        sel(moved, uy * a_link + wy * b_link, ty),
        sel(moved, uz * a_link + wz * b_link, tz),
        sel(moved, ux * a_tail + wx * b_tail, zero),
        sel(moved, uy * a_tail + wy * b_tail, zero),
        sel(moved, uz * a_tail + wz * b_tail, zero),
    ];
    (out, moved && !regular)
}

/// Steps one link of a block: `t` the links, `s` the shifts of their head ends (replaced by the shifts
/// of their tail ends).
#[inline(always)]
fn step_block<T: StrandReal>(t: &mut Block<T>, s: &mut Block<T>, len: T, inv_len: T) {
    step_lanes(t, s, &[len; LANES], &[inv_len; LANES]);
}

/// [`step_block`] with a length per lane (the steps of one chain's wavefront: each lane at a
/// different link).
#[inline(always)]
fn step_lanes<T: StrandReal>(
    t: &mut Block<T>,
    s: &mut Block<T>,
    len: &[T; LANES],
    inv_len: &[T; LANES],
) {
    let mut apart = [false; LANES];
    let (old_t, old_s) = (*t, *s);
    for (l, apart) in apart.iter_mut().enumerate() {
        let (o, a) = lane(
            old_t.x[l], old_t.y[l], old_t.z[l], old_s.x[l], old_s.y[l], old_s.z[l], len[l],
            inv_len[l],
        );
        t.x[l] = o[0];
        t.y[l] = o[1];
        t.z[l] = o[2];
        s.x[l] = o[3];
        s.y[l] = o[4];
        s.z[l] = o[5];
        *apart = a;
    }
    if apart.iter().any(|&a| a) {
        for l in (0..LANES).filter(|&l| apart[l]) {
            let st = tractrix_step::<T, 3>(&old_t.get(l), &old_s.get(l), len[l]);
            t.set(l, st.link);
            s.set(l, st.tail_shift);
        }
    }
}

/// Most substeps [`chain_wave`] keeps in flight: two blocks of lanes.
pub const CHAIN_WAVE: usize = 2 * LANES;

/// One side of one chain moved by `w ≤ CHAIN_WAVE` substeps of `s` as a wavefront, with SIMD across
/// the steps in flight: at diagonal `d`, substep `j` (lane `j`) steps the `(d − j)`-th link from the
/// moved joint. `links` are the side's link vectors as the chain stores them (`Xᵢ − Xᵢ₋₁`, tail
/// first); `tail_side` says the moved joint is at their end (the tail side of a move: links walked
/// last to first, stepped reversed), else at their start. The lanes compute what
/// [`crate::link::tractrix_step`] computes but for the exponential (the module docs), so the result
/// is the scalar wavefront's to a few ulps per step, and the same bits on every instruction set.
pub fn chain_wave<T: StrandReal>(
    links: &mut [Vector3<T>],
    lengths: &[T],
    s: Vector3<T>,
    w: usize,
    tail_side: bool,
    simd: Simd,
) {
    let op = ChainWave {
        links,
        lengths,
        s,
        w: w.clamp(1, CHAIN_WAVE),
        tail_side,
        limits: None,
    };
    match simd {
        Simd::Best => pulp::Arch::new().dispatch(op),
        Simd::Baseline => pulp::WithSimd::with_simd(op, pulp::Scalar::new()),
    }
}

/// The joint limits of one side of a chain for [`chain_wave_limited`].
pub(crate) struct WaveLimits<'a, T: Real> {
    /// The chain's limits (cones).
    pub lim: &'a crate::limits::JointLimits<T>,
    /// The chain index of the side's first link.
    pub offset: usize,
    /// The tail side's link beside the moved joint after each substep of the wave (as the chain
    /// stores it), written by the tail side and read by the head side for its first link; and its
    /// length.
    pub across: &'a mut [Vector3<T>; CHAIN_WAVE],
    pub across_len: T,
    /// Links turned back into their limit.
    pub clamps: &'a mut u32,
}

impl<T: Real> WaveLimits<'_, T> {
    /// The link before the one `along` links from the moved joint (lane `j`) on a side of `links`
    /// (`rev`: the tail side), toward the moved joint: its vector as the side stores it, its length
    /// and the chain index of the joint between; `None` for a link with no joint before it.
    #[inline(always)]
    fn before(
        &self,
        links: &[Vector3<T>],
        lengths: &[T],
        rev: bool,
        along: usize,
        j: usize,
    ) -> Option<(Vector3<T>, T, usize)> {
        let n = links.len();
        if rev {
            let i = n - 1 - along;
            if i + 1 >= n {
                return None;
            }
            Some((-links[i + 1], lengths[i + 1], self.offset + i + 1))
        } else if self.offset + along == 0 {
            None
        } else if along > 0 {
            Some((links[along - 1], lengths[along - 1], self.offset + along))
        } else {
            Some((self.across[j], self.across_len, self.offset + along))
        }
    }
}

/// [`chain_wave`] with joint limits: each link, once its lane has stepped it, is turned back into its
/// joint's limit about its neighbour toward the moved joint at the same substep (the neighbour still
/// holds that substep's step: the lane that steps it next writes it back only after the diagonal), as
/// [`crate::chain::Chain::move_joint`] does for a limited chain substep after substep. The lanes'
/// steps are [`chain_wave`]'s (the exponential from a polynomial); the turns are
/// [`crate::limits::JointLimits::clamp`]'s, computed by it for a few lanes at a diagonal and in lanes
/// for more ([`SCALAR_TURNS`]).
pub(crate) fn chain_wave_limited<T: StrandReal>(
    links: &mut [Vector3<T>],
    lengths: &[T],
    s: Vector3<T>,
    w: usize,
    tail_side: bool,
    limits: WaveLimits<'_, T>,
) {
    let op = ChainWave {
        links,
        lengths,
        s,
        w: w.clamp(1, CHAIN_WAVE),
        tail_side,
        limits: Some(limits),
    };
    pulp::Arch::new().dispatch(op);
}

struct ChainWave<'a, 'b, T: Real> {
    links: &'a mut [Vector3<T>],
    lengths: &'a [T],
    s: Vector3<T>,
    w: usize,
    tail_side: bool,
    limits: Option<WaveLimits<'b, T>>,
}

impl<T: StrandReal> pulp::WithSimd for ChainWave<'_, '_, T> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(mut self, _: S) {
        let n = self.links.len();
        if n == 0 || self.lengths.len() != n {
            return;
        }
        let (w, rev) = (self.w, self.tail_side);
        // Lane j of block b is substep b·LANES + j: its shift lives here from its first step to its
        // last; its link and length are gathered per diagonal.
        let mut shift = [Block::splat(self.s); 2];
        let first = if rev {
            -self.links[n - 1]
        } else {
            self.links[0]
        };
        let mut t = [Block::splat(first); 2];
        let mut len = [[self.lengths[0]; LANES]; 2];
        let mut inv = [[T::one() / self.lengths[0]; LANES]; 2];
        let at = |d: usize, j: usize| {
            let along = d - j;
            if rev { n - 1 - along } else { along }
        };
        for d in 0..n + w - 1 {
            let lo = d.saturating_sub(n - 1);
            let hi = d.min(w - 1);
            for j in lo..=hi {
                let i = at(d, j);
                let (b, l) = (j / LANES, j % LANES);
                t[b].set(l, if rev { -self.links[i] } else { self.links[i] });
                len[b][l] = self.lengths[i];
                inv[b][l] = T::one() / self.lengths[i];
            }
            for b in lo / LANES..=hi / LANES {
                // Lanes not in flight (not started, or done) keep their shifts.
                let keep = shift[b];
                step_lanes(&mut t[b], &mut shift[b], &len[b], &inv[b]);
                for l in 0..LANES {
                    let j = b * LANES + l;
                    if j < lo || j > hi {
                        shift[b].set(l, keep.get(l));
                    }
                }
            }
            if let Some(lim) = self.limits.as_mut() {
                let Some((cosines, sines)) = lim.lim.cone_terms() else {
                    return;
                };
                for b in lo / LANES..=hi / LANES {
                    // Each lane's link toward the moved joint at the same substep (the neighbour
                    // still holds it: written back only after the diagonal), its length and its
                    // joint's cone, kept for the lanes whose link lies outside that cone (the
                    // clamp's own test; a lane not in flight, or whose link has no joint before it,
                    // is not).
                    let mut prev = Block::splat(Vector3::zeros());
                    let mut prev_len = [T::one(); LANES];
                    let (mut cos, mut sin) = ([T::one(); LANES], [T::zero(); LANES]);
                    let mut joint = [0; LANES];
                    let mut out = [false; LANES];
                    for l in 0..LANES {
                        let j = b * LANES + l;
                        if j < lo || j > hi {
                            continue;
                        }
                        let Some((p, pl, jt)) = lim.before(self.links, self.lengths, rev, d - j, j)
                        else {
                            continue;
                        };
                        let within = p.dot(&t[b].get(l)) >= cosines[jt] * pl * len[b][l];
                        if !within {
                            out[l] = true;
                            prev.set(l, p);
                            prev_len[l] = pl;
                            cos[l] = cosines[jt];
                            sin[l] = sines[jt];
                            joint[l] = jt;
                        }
                    }
                    let outside = out.iter().filter(|&&o| o).count();
                    // A few turns by the scalar clamp; more (a rope bent to its limit) in lanes.
                    let turns = (outside > SCALAR_TURNS)
                        .then(|| cone_turns(&prev, &prev_len, &t[b], &len[b], &cos, &sin));
                    for l in 0..LANES {
                        let j = b * LANES + l;
                        if out[l] {
                            let v = t[b].get(l);
                            // Folded straight back (no side to turn toward): the scalar clamp
                            // picks its fixed side.
                            let c = match turns {
                                Some((turn, flat)) if !flat[l] => Some(turn.get(l)),
                                _ => lim.lim.clamp(
                                    joint[l],
                                    &prev.get(l),
                                    prev_len[l],
                                    &v,
                                    len[b][l],
                                    false,
                                ),
                            };
                            if let Some(c) = c {
                                shift[b].set(l, shift[b].get(l) + (c - v));
                                t[b].set(l, c);
                                *lim.clamps += 1;
                            }
                        }
                        if rev && j >= lo && j <= hi && d - j == 0 {
                            lim.across[j] = -t[b].get(l);
                        }
                    }
                }
            }
            for j in lo..=hi {
                let v = t[j / LANES].get(j % LANES);
                self.links[at(d, j)] = if rev { -v } else { v };
            }
        }
    }
}

/// Up to this many lanes outside their cones at one diagonal are turned by the scalar clamp; more, by
/// the lanes ([`cone_turns`]). (On the limits bench, turning in lanes at every diagonal made the
/// 40-link rope's move of 8 substeps, 7 % of its steps turned, about 1.3× slower than the scalar
/// clamp, and the 1000-link rope bent to its limit, 62 % turned, about 1.4× faster.)
const SCALAR_TURNS: usize = 2;

/// [`crate::limits::JointLimits::clamp`]'s turn for cones, lane by lane without branches: link `v`
/// after `prev` turned onto its joint's cone (`cos`, `sin` of the cone's angle) about `prev`, in the
/// plane of the two. Also returns the lanes with no plane to turn in (`v` within rounding of `prev`'s
/// line), which the caller leaves to the scalar clamp.
#[inline(always)]
fn cone_turns<T: Real>(
    prev: &Block<T>,
    prev_len: &[T; LANES],
    v: &Block<T>,
    len: &[T; LANES],
    cos: &[T; LANES],
    sin: &[T; LANES],
) -> (Block<T>, [bool; LANES]) {
    let mut turn = *v;
    let mut flat = [false; LANES];
    let tiny = T::EPSILON * T::lit(16.0);
    for l in 0..LANES {
        let (ax, ay, az) = (
            prev.x[l] / prev_len[l],
            prev.y[l] / prev_len[l],
            prev.z[l] / prev_len[l],
        );
        let (vx, vy, vz) = (v.x[l], v.y[l], v.z[l]);
        let along = ax * vx + ay * vy + az * vz;
        let (wx, wy, wz) = (vx - ax * along, vy - ay * along, vz - az * along);
        let pn = (wx * wx + wy * wy + wz * wz).sqrt();
        let turnable = pn > len[l] * tiny;
        let (c, s) = (cos[l], sin[l]);
        turn.x[l] = (ax * c + wx / pn * s) * len[l];
        turn.y[l] = (ay * c + wy / pn * s) * len[l];
        turn.z[l] = (az * c + wz / pn * s) * len[l];
        flat[l] = !turnable;
    }
    (turn, flat)
}

/// `substeps` substeps of `sub` for one block's links (head end first), as wavefronts of up to
/// [`MAX_WAVE`] substeps in flight. (Two blocks stepped side by side were tried as well: no gain on
/// the machine the benches ran on, and the baseline build spilled registers.)
#[inline(always)]
fn sweep_block<T: StrandReal>(links: &mut [Block<T>], sub: Block<T>, substeps: usize, len: T) {
    let inv_len = T::one() / len;
    let n = links.len();
    let mut left = substeps;
    while left > 0 {
        let k = left.min(MAX_WAVE);
        let mut wave = [sub; MAX_WAVE];
        for d in 0..n + k - 1 {
            let lo = d.saturating_sub(n - 1);
            let hi = d.min(k - 1);
            for (s, shift) in wave.iter_mut().enumerate().take(hi + 1).skip(lo) {
                step_block(&mut links[d - s], shift, len, inv_len);
            }
        }
        left -= k;
    }
}

/// Which instructions a sweep runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Simd {
    /// The best the CPU offers, detected at run time (AVX-512, AVX2 + FMA, or the baseline).
    Best,
    /// The target's baseline only (SSE2 on x86-64): the reference the SIMD result equals bit for bit.
    Baseline,
}

/// The instruction set [`Simd::Best`] picks on this CPU: `"avx512"`, `"avx2"` or `"baseline"`.
pub fn best_simd() -> &'static str {
    #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
    match pulp::Arch::new() {
        pulp::Arch::V4(_) => return "avx512",
        pulp::Arch::V3(_) => return "avx2",
        _ => {}
    }
    "baseline"
}

struct Sweep<'a, T> {
    heads: &'a mut [Block<T>],
    links: &'a mut [Block<T>],
    targets: &'a [Block<T>],
    n_links: usize,
    substeps: usize,
    len: T,
}

impl<T: StrandReal> pulp::WithSimd for Sweep<'_, T> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let k = self.substeps;
        let kk = T::lit(k as f64);
        for ((head, target), links) in self
            .heads
            .iter_mut()
            .zip(self.targets)
            .zip(self.links.chunks_exact_mut(self.n_links))
        {
            let mut sub = *target;
            for l in 0..LANES {
                sub.x[l] = (target.x[l] - head.x[l]) / kk;
                sub.y[l] = (target.y[l] - head.y[l]) / kk;
                sub.z[l] = (target.z[l] - head.z[l]) / kk;
            }
            sweep_block(links, sub, k, self.len);
            *head = *target;
        }
    }
}

/// Why a strand move was refused (the state is unchanged).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum StrandsError {
    /// The targets' count is not the strands'.
    #[error("{got} targets for {want} strands")]
    TargetCount {
        /// Targets given.
        got: usize,
        /// Strands.
        want: usize,
    },
    /// A target is not finite.
    #[error("target {0} is not finite")]
    NonFinite(usize),
    /// Zero substeps.
    #[error("substeps must be at least 1")]
    NoSubsteps,
    /// Bad construction parameters.
    #[error("{0}")]
    Shape(&'static str),
}

/// Many free strands of equal links, moved head first (see the module docs for the layout). Two are
/// equal when their strands are (the staging scratch is not compared).
#[derive(Debug, Clone)]
pub struct Strands<T> {
    n_strands: usize,
    n_links: usize,
    len: T,
    /// One block per `LANES` strands: the heads (joint `n_links`).
    heads: Vec<Block<T>>,
    /// Block-major: block `b`'s links at `b·n_links ..`, head end first, each tail − head.
    links: Vec<Block<T>>,
    /// Targets staged in blocks (the move's scratch; padding lanes keep their heads).
    staged: Vec<Block<T>>,
}

impl<T: PartialEq> PartialEq for Strands<T> {
    fn eq(&self, o: &Self) -> bool {
        self.n_strands == o.n_strands
            && self.n_links == o.n_links
            && self.len == o.len
            && self.heads == o.heads
            && self.links == o.links
    }
}

impl<T: StrandReal> Strands<T> {
    /// `heads.len()` straight strands of `n_links` links of `link_length`, each hanging from its head
    /// along `direction` (normalised).
    pub fn straight(
        heads: &[Vector3<T>],
        n_links: usize,
        link_length: T,
        direction: Vector3<T>,
    ) -> Result<Self, StrandsError> {
        if heads.is_empty() || n_links == 0 {
            return Err(StrandsError::Shape("at least one strand of one link"));
        }
        if !(link_length > T::zero() && link_length <= T::MAX) {
            return Err(StrandsError::Shape(
                "the link length must be positive and finite",
            ));
        }
        let norm = direction.norm();
        if !(norm > T::zero() && norm <= T::MAX)
            || heads.iter().any(|h| !h.iter().all(|c| c.is_finite()))
        {
            return Err(StrandsError::Shape(
                "heads and direction must be finite, the direction non-zero",
            ));
        }
        let link = direction * (link_length / norm);
        let blocks = heads.len().div_ceil(LANES);
        let mut hb = vec![Block::splat(Vector3::zeros()); blocks];
        for (i, h) in heads.iter().enumerate() {
            hb[i / LANES].set(i % LANES, *h);
        }
        // Padding lanes sit at the last real head, with real links: they are stepped by zero shifts.
        for i in heads.len()..blocks * LANES {
            hb[i / LANES].set(i % LANES, heads[heads.len() - 1]);
        }
        Ok(Strands {
            n_strands: heads.len(),
            n_links,
            len: link_length,
            heads: hb,
            links: vec![Block::splat(link); blocks * n_links],
            staged: Vec::new(),
        })
    }

    /// Strands.
    pub fn n_strands(&self) -> usize {
        self.n_strands
    }
    /// Links per strand.
    pub fn n_links(&self) -> usize {
        self.n_links
    }
    /// The length of every link.
    pub fn link_length(&self) -> T {
        self.len
    }
    /// Blocks of [`LANES`] strands.
    pub fn n_blocks(&self) -> usize {
        self.heads.len()
    }
    /// Strand `i`'s head.
    pub fn head(&self, i: usize) -> Vector3<T> {
        self.heads[i / LANES].get(i % LANES)
    }
    /// Strand `i`'s link `j` from the head (tail − head).
    pub fn link(&self, i: usize, j: usize) -> Vector3<T> {
        self.links[(i / LANES) * self.n_links + j].get(i % LANES)
    }

    /// Calls `f` with strand `i`'s joints, tail (joint 0) first, head (joint `n_links`) last: the head
    /// minus the links' running sum, each joint computed once.
    pub fn for_each_joint(&self, i: usize, mut f: impl FnMut(Vector3<T>)) {
        let (b, l) = (i / LANES, i % LANES);
        let links = &self.links[b * self.n_links..(b + 1) * self.n_links];
        let mut p = self.heads[b].get(l);
        for t in links {
            p += t.get(l);
        }
        // p is now the tail; walk back toward the head.
        for t in links.iter().rev() {
            f(p);
            p -= t.get(l);
        }
        f(self.heads[b].get(l));
    }

    /// The joints of block `b`'s strands (its real strands, not the padding lanes), strand after
    /// strand, each tail first, into `out` (cleared): [`Strands::for_each_joint`]'s sums, bit for bit,
    /// made for the block's eight lanes at once. Nothing for a block past the end.
    pub fn block_joints(&self, b: usize, out: &mut Vec<Vector3<T>>) {
        out.clear();
        out.resize(self.block_len(b), Vector3::zeros());
        self.block_joints_into(b, out, |p| p);
    }

    /// How many joints block `b` has: its real strands × (links + 1); 0 past the end.
    pub fn block_len(&self, b: usize) -> usize {
        if b >= self.heads.len() {
            return 0;
        }
        LANES.min(self.n_strands.saturating_sub(b * LANES)) * (self.n_links + 1)
    }

    /// [`Strands::block_joints`] written through `f` straight into `out[..block_len(b)]` (a wire
    /// buffer, a shared-memory response): no intermediate copy. Returns how many were written;
    /// nothing if `out` is shorter than the block.
    pub fn block_joints_into<U>(
        &self,
        b: usize,
        out: &mut [U],
        mut f: impl FnMut(Vector3<T>) -> U,
    ) -> usize {
        let n = self.n_links;
        let len = self.block_len(b);
        if len == 0 || out.len() < len {
            return 0;
        }
        let lanes = len / (n + 1);
        let links = &self.links[b * n..(b + 1) * n];
        let head = self.heads[b];
        let mut p = head;
        for t in links {
            for l in 0..LANES {
                p.x[l] += t.x[l];
                p.y[l] += t.y[l];
                p.z[l] += t.z[l];
            }
        }
        // p is the tails; walk back toward the heads.
        for (k, t) in links.iter().rev().enumerate() {
            for l in 0..lanes {
                out[l * (n + 1) + k] = f(p.get(l));
            }
            for l in 0..LANES {
                p.x[l] -= t.x[l];
                p.y[l] -= t.y[l];
                p.z[l] -= t.z[l];
            }
        }
        for l in 0..lanes {
            out[l * (n + 1) + n] = f(head.get(l));
        }
        len
    }

    /// Largest relative error of any link's length.
    pub fn max_length_error(&self) -> f64 {
        let len = self.len.to_f64();
        let mut worst = 0.0f64;
        for b in 0..self.n_blocks() {
            let lanes = LANES.min(self.n_strands - b * LANES);
            for t in &self.links[b * self.n_links..(b + 1) * self.n_links] {
                for l in 0..lanes {
                    worst = worst.max((t.get(l).norm().to_f64() - len).abs() / len);
                }
            }
        }
        worst
    }

    /// Moves every strand's head to its target (`targets[i]` for strand `i`) in `substeps` equal
    /// substeps; each link follows its tractrix. Checks the targets first: on error nothing changes.
    pub fn move_heads(
        &mut self,
        targets: &[Vector3<T>],
        substeps: usize,
        simd: Simd,
    ) -> Result<(), StrandsError> {
        if substeps == 0 {
            return Err(StrandsError::NoSubsteps);
        }
        self.stage(targets)?;
        self.sweep_staged(substeps, simd)
    }

    /// Moves the heads to the targets staged by [`Strands::stage`] (the second half of
    /// [`Strands::move_heads`]); the staging is used up.
    pub fn sweep_staged(&mut self, substeps: usize, simd: Simd) -> Result<(), StrandsError> {
        if substeps == 0 {
            return Err(StrandsError::NoSubsteps);
        }
        if self.staged.len() != self.heads.len() {
            return Err(StrandsError::Shape("no targets staged"));
        }
        let staged = std::mem::take(&mut self.staged);
        let all = self.heads.len();
        self.halves(all).0.sweep(&staged, substeps, simd);
        self.staged = staged;
        self.staged.clear();
        Ok(())
    }

    /// Cuts the strands from block `at` (clamped to 1 ..= blocks − 1) on into strands of their own,
    /// which may then live and be swept on another thread: this keeps strands `..at·LANES`, the result
    /// holds the rest (its strand 0 is this one's strand `at·LANES`). `None` with a single block.
    pub fn split_off_blocks(&mut self, at: usize) -> Option<Strands<T>> {
        let blocks = self.heads.len();
        if blocks < 2 {
            return None;
        }
        let at = at.clamp(1, blocks - 1);
        let rest = Strands {
            n_strands: self.n_strands - at * LANES,
            n_links: self.n_links,
            len: self.len,
            heads: self.heads.split_off(at),
            links: self.links.split_off(at * self.n_links),
            staged: Vec::new(),
        };
        self.n_strands = at * LANES;
        self.staged.clear();
        Some(rest)
    }

    /// Puts strands cut off by [`Strands::split_off_blocks`] back after these (the inverse of the cut:
    /// `a.split_off_blocks(k)` then `a.append_blocks(rest)` gives `a` back). Refused unless these
    /// fill their blocks and the links agree.
    pub fn append_blocks(&mut self, rest: Strands<T>) -> Result<(), StrandsError> {
        if self.n_strands != self.heads.len() * LANES
            || rest.n_links != self.n_links
            || rest.len != self.len
        {
            return Err(StrandsError::Shape(
                "only strands of the same links after whole blocks can be appended",
            ));
        }
        self.n_strands += rest.n_strands;
        self.heads.extend_from_slice(&rest.heads);
        self.links.extend_from_slice(&rest.links);
        self.staged.clear();
        Ok(())
    }

    /// Checks `targets` and stages them in blocks (padding lanes at their heads): the first half of
    /// [`Strands::move_heads`], for a caller that sweeps [`Strands::split_at_block`]'s halves itself
    /// (then [`Strands::take_staged`] gives the blocks to pass).
    pub fn stage(&mut self, targets: &[Vector3<T>]) -> Result<(), StrandsError> {
        if targets.len() != self.n_strands {
            return Err(StrandsError::TargetCount {
                got: targets.len(),
                want: self.n_strands,
            });
        }
        if let Some(i) = targets
            .iter()
            .position(|t| !t.iter().all(|c| c.is_finite()))
        {
            return Err(StrandsError::NonFinite(i));
        }
        self.staged.clear();
        self.staged.extend_from_slice(&self.heads);
        for (i, t) in targets.iter().enumerate() {
            self.staged[i / LANES].set(i % LANES, *t);
        }
        Ok(())
    }

    /// The targets staged by [`Strands::stage`], one block per block of strands (moved out: give them
    /// back with [`Strands::restore_staged`] to keep the allocation).
    pub fn take_staged(&mut self) -> Vec<Block<T>> {
        std::mem::take(&mut self.staged)
    }
    /// Returns the staging buffer taken by [`Strands::take_staged`].
    pub fn restore_staged(&mut self, staged: Vec<Block<T>>) {
        self.staged = staged;
    }

    /// The state cut after block `at` (clamped) into two independent parts that may be swept at the
    /// same time (on two threads): blocks `..at` and `at..`.
    pub fn split_at_block(&mut self, at: usize) -> (StrandsMut<'_, T>, StrandsMut<'_, T>) {
        self.halves(at)
    }

    fn halves(&mut self, at: usize) -> (StrandsMut<'_, T>, StrandsMut<'_, T>) {
        let at = at.min(self.heads.len());
        let (h0, h1) = self.heads.split_at_mut(at);
        let (l0, l1) = self.links.split_at_mut(at * self.n_links);
        let (n, len) = (self.n_links, self.len);
        (
            StrandsMut {
                first_block: 0,
                heads: h0,
                links: l0,
                n_links: n,
                len,
            },
            StrandsMut {
                first_block: at,
                heads: h1,
                links: l1,
                n_links: n,
                len,
            },
        )
    }
}

/// A run of whole blocks of a [`Strands`], swept independently of the rest.
#[derive(Debug)]
pub struct StrandsMut<'a, T> {
    first_block: usize,
    heads: &'a mut [Block<T>],
    links: &'a mut [Block<T>],
    n_links: usize,
    len: T,
}

impl<T: StrandReal> StrandsMut<'_, T> {
    /// The part's first block in the whole.
    pub fn first_block(&self) -> usize {
        self.first_block
    }
    /// Blocks in the part.
    pub fn n_blocks(&self) -> usize {
        self.heads.len()
    }
    /// Moves the part's heads to `staged[first_block ..]` (all staged blocks of the whole, as
    /// [`Strands::take_staged`] gives them) in `substeps ≥ 1` substeps.
    pub fn sweep(self, staged: &[Block<T>], substeps: usize, simd: Simd) {
        let n = self.heads.len();
        let targets = &staged[self.first_block..self.first_block + n];
        let op = Sweep {
            heads: self.heads,
            links: self.links,
            targets,
            n_links: self.n_links,
            substeps: substeps.max(1),
            len: self.len,
        };
        match simd {
            Simd::Best => pulp::Arch::new().dispatch(op),
            Simd::Baseline => pulp::WithSimd::with_simd(op, pulp::Scalar::new()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The branch-free exponential against the platform's, over the whole range a step meets.
    #[test]
    fn the_lane_exponential_is_within_two_ulps() {
        let mut worst_q = 0.0f64;
        let mut worst_e1 = 0.0f64;
        let mut b = 1e-300f64;
        while b < 800.0 {
            let (q, e1) = f64::exp_neg_pair(b);
            let (tq, te1) = ((-b).exp(), -(-b).exp_m1());
            if tq > f64::MIN_POSITIVE {
                worst_q = worst_q.max(((q - tq) / tq).abs() / f64::EPSILON);
            } else {
                assert!(
                    (q - tq).abs() <= 4.0 * 4.9e-324,
                    "b = {b}: {q} against {tq}"
                );
            }
            worst_e1 = worst_e1.max(((e1 - te1) / te1).abs() / f64::EPSILON);
            b *= 1.0123;
        }
        assert!(worst_q <= 2.0, "e^-b off by {worst_q} ulp");
        assert!(worst_e1 <= 2.0, "1 - e^-b off by {worst_e1} ulp");
        assert_eq!(f64::exp_neg_pair(f64::INFINITY), (0.0, 1.0));
        assert_eq!(f64::exp_neg_pair(0.0), (1.0, 0.0));

        let (mut wq, mut we) = (0.0f64, 0.0f64);
        let mut b = 1e-40f32;
        while b < 120.0 {
            let (q, e1) = f32::exp_neg_pair(b);
            let (tq, te1) = ((-(b as f64)).exp(), -(-(b as f64)).exp_m1());
            if tq > f32::MIN_POSITIVE as f64 {
                wq = wq.max(((q as f64 - tq) / tq).abs() / f32::EPSILON as f64);
            }
            we = we.max(((e1 as f64 - te1) / te1).abs() / f32::EPSILON as f64);
            b *= 1.0123;
        }
        assert!(wq <= 2.0, "f32 e^-b off by {wq} ulp");
        assert!(we <= 2.0, "f32 1 - e^-b off by {we} ulp");
    }
}
