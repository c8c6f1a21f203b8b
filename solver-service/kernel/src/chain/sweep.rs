//! A move's sweeps: both sides of the moved joint, link by link or as a wavefront of substeps
//! (scalar or SIMD), with or without joint limits.

use super::*;

impl<T: Real, const D: usize> Chain<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    pub(crate) fn apply_move(
        &mut self,
        joint: usize,
        target: Vector<T, D>,
        delta: Vector<T, D>,
        k: u32,
        method: Method,
    ) -> MoveOutcome {
        if delta.iter().all(|c| *c == T::zero()) {
            return MoveOutcome::default();
        }
        let sd = delta / T::lit(k as f64);
        if self.limits.is_some() {
            // Each link turned back into its limit as it is stepped: one substep, or several as
            // wavefronts (a link's clamp needs the link before it at the same substep, which the
            // wavefront has at hand: [`wave_limited`]).
            let mut clamps = 0u32;
            let fallbacks = if k == 1 {
                let n = self.links.len();
                self.tail_side_limited(joint, &sd, method, 0, &mut clamps)
                    .0
                    .saturating_add(self.head_side_limited(joint, &sd, method, n, &mut clamps))
            } else if method == Method::Tractrix
                && self.simd_waves_limited(joint, &sd, k, &mut clamps)
            {
                0
            } else {
                self.waves_limited(joint, &sd, k, method, &mut clamps)
            };
            self.place_origin_from(joint, target);
            return MoveOutcome {
                substeps: k,
                paper_fallbacks: fallbacks,
                limited: clamps,
                ..MoveOutcome::default()
            };
        }
        let fallbacks = if k == 1 {
            let (fb, _) = self.tail_side(joint, &sd, method, 0);
            let n = self.links.len();
            fb + self.head_side(joint, &sd, method, n)
        } else {
            match method {
                Method::Tractrix => {
                    if !self.simd_waves(joint, &sd, k) {
                        self.waves(joint, &sd, k, |t, s, l| (tractrix_step(t, s, l), false));
                    }
                    0
                }
                Method::FollowTheLeader => self.waves(joint, &sd, k, |t, s, l| {
                    (follow_the_leader_step(t, s, l), false)
                }),
                Method::TractrixPaper => self.waves(joint, &sd, k, paper_or_closed_form),
            }
        };
        // The moved joint lands on its target: it becomes the datum.
        self.place_origin_from(joint, target);
        MoveOutcome {
            substeps: k,
            paper_fallbacks: fallbacks,
            ..MoveOutcome::default()
        }
    }

    /// `k` substeps of `s` of joint `m`, both sides, as wavefronts of up to [`MAX_WAVE`] substeps in
    /// flight. The two sides share no link, so each side's substeps can run to the end before the other
    /// side's start; within a side, substep `j` of link `i` needs only link `i` after substep `j − 1` and
    /// the shift of link `i − 1` at substep `j`, so it runs beside substep `j − 1` of link `i + 1`. The
    /// same operations on the same inputs as substep after substep: the result is equal bit for bit
    /// (the kernel's tests check it), only the independent divisions, square roots and exponentials
    /// overlap in the CPU. Returns the paper-form fallbacks.
    #[inline(always)]
    pub(super) fn waves<F>(&mut self, m: usize, s: &Vector<T, D>, k: u32, f: F) -> u32
    where
        F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
    {
        let (tail, head) = self.links.split_at_mut(m);
        let (tail_lengths, head_lengths) = self.lengths.split_at(m);
        let mut fallbacks = 0u32;
        let mut left = k as usize;
        while left > 0 {
            let w = left.min(MAX_WAVE);
            fallbacks = fallbacks
                .saturating_add(wave::<T, D, true, F>(tail, tail_lengths, s, w, &f))
                .saturating_add(wave::<T, D, false, F>(head, head_lengths, s, w, &f));
            left -= w;
        }
        fallbacks
    }

    /// [`Chain::waves`] with the chain's limits ([`wave_limited`]): each side as wavefronts of up to
    /// [`MAX_WAVE`] substeps, the tail side first, which hands the head side its first link (the one
    /// beside the moved joint) after each substep: the head side's first link is turned back into the
    /// moved joint's limit about it, as substep after substep does. Counts the links turned in
    /// `clamps`; returns the paper-form fallbacks.
    pub(super) fn waves_limited(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        k: u32,
        method: Method,
        clamps: &mut u32,
    ) -> u32 {
        let Chain {
            links,
            lengths,
            limits,
            ..
        } = self;
        let Some(lim) = limits.as_deref() else {
            return 0;
        };
        let (tail, head) = links.split_at_mut(m);
        let (tail_lengths, head_lengths) = lengths.split_at(m);
        let f = |t: &Vector<T, D>, s: &Vector<T, D>, l: T| step(method, t, s, l);
        let mut across = Across {
            links: [Vector::zeros(); MAX_WAVE],
            length: tail_lengths.last().copied().unwrap_or_else(T::one),
        };
        let mut fallbacks = 0u32;
        let mut left = k as usize;
        while left > 0 {
            let w = left.min(MAX_WAVE);
            let side = |links, lengths, offset| LimitedSide {
                links,
                lengths,
                offset,
                lim,
            };
            fallbacks = fallbacks
                .saturating_add(wave_limited::<T, D, true, _>(
                    side(&mut *tail, tail_lengths, 0),
                    s,
                    w,
                    &f,
                    &mut across,
                    clamps,
                ))
                .saturating_add(wave_limited::<T, D, false, _>(
                    side(&mut *head, head_lengths, m),
                    s,
                    w,
                    &f,
                    &mut across,
                    clamps,
                ));
            left -= w;
        }
        fallbacks
    }

    /// [`Chain::simd_waves`] for a limited chain (cones: a spatial chain in f64 or f32): the lanes
    /// step as there, each stepped link turned back into its limit
    /// ([`crate::strands::chain_wave_limited`]); `false` (nothing changed) for other chains and for
    /// fewer than [`SIMD_FROM`] substeps.
    pub(super) fn simd_waves_limited(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        k: u32,
        clamps: &mut u32,
    ) -> bool {
        use std::any::Any;
        if (k as usize) < SIMD_FROM {
            return false;
        }
        let Chain {
            links,
            lengths,
            limits,
            ..
        } = self;
        let Some(lim) = limits.as_deref() else {
            return false;
        };
        let links: &mut dyn Any = links;
        let lengths: &dyn Any = lengths;
        let s: &dyn Any = s;
        let lim: &dyn Any = lim;
        if let (Some(l), Some(len), Some(s), Some(lim)) = (
            links.downcast_mut::<Vec<nalgebra::Vector3<f64>>>(),
            lengths.downcast_ref::<Vec<f64>>(),
            s.downcast_ref::<nalgebra::Vector3<f64>>(),
            lim.downcast_ref::<JointLimits<f64>>(),
        ) {
            simd_side_waves_limited(l, len, lim, m, *s, k, clamps);
            return true;
        }
        if let (Some(l), Some(len), Some(s), Some(lim)) = (
            links.downcast_mut::<Vec<nalgebra::Vector3<f32>>>(),
            lengths.downcast_ref::<Vec<f32>>(),
            s.downcast_ref::<nalgebra::Vector3<f32>>(),
            lim.downcast_ref::<JointLimits<f32>>(),
        ) {
            simd_side_waves_limited(l, len, lim, m, *s, k, clamps);
            return true;
        }
        false
    }

    /// The closed-form tractrix's `k` substeps of `s` with SIMD across the steps in flight, for a
    /// spatial chain in f64 or f32 (the types the lanes are written for; found at run time, so a
    /// planar chain or another scalar type answers `false` and changes nothing). Waves of at least
    /// [`SIMD_FROM`] substeps run in [`crate::strands::chain_wave`], shorter ones (a block of lanes
    /// would stand mostly idle) as the scalar wavefront.
    pub(super) fn simd_waves(&mut self, m: usize, s: &Vector<T, D>, k: u32) -> bool {
        use std::any::Any;
        if (k as usize) < SIMD_FROM {
            return false;
        }
        let links: &mut dyn Any = &mut self.links;
        let lengths: &dyn Any = &self.lengths;
        let s: &dyn Any = s;
        if let (Some(l), Some(len), Some(s)) = (
            links.downcast_mut::<Vec<nalgebra::Vector3<f64>>>(),
            lengths.downcast_ref::<Vec<f64>>(),
            s.downcast_ref::<nalgebra::Vector3<f64>>(),
        ) {
            simd_side_waves(l, len, m, *s, k);
            return true;
        }
        if let (Some(l), Some(len), Some(s)) = (
            links.downcast_mut::<Vec<nalgebra::Vector3<f32>>>(),
            lengths.downcast_ref::<Vec<f32>>(),
            s.downcast_ref::<nalgebra::Vector3<f32>>(),
        ) {
            simd_side_waves(l, len, m, *s, k);
            return true;
        }
        false
    }

    /// One substep: joint `m` moves by `s`; links toward the tail and toward the head follow outward.
    /// Returns the number of paper-form fallbacks. The origin is kept where it was (callers place it).
    pub(crate) fn sweep(&mut self, m: usize, s: &Vector<T, D>, method: Method) -> u32 {
        self.settle_origin();
        let (fallbacks, _) = self.tail_side(m, s, method, 0);
        fallbacks + self.head_side(m, s, method, self.links.len())
    }

    /// Joint `m` moves by `s`; links with 0-based index `m..hi` follow toward the head (the moving end of
    /// link index `i` is joint `i`, its trailing end joint `i+1`). Returns the fallbacks.
    pub(crate) fn sweep_head_side(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        hi: usize,
    ) -> u32 {
        if m < self.datum {
            self.settle_origin();
        }
        self.head_side(m, s, method, hi)
    }

    /// [`Chain::sweep_head_side`] leaving the datum alone (the caller places it).
    #[inline]
    pub(super) fn head_side(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        hi: usize,
    ) -> u32 {
        if self.limits.is_some() {
            return self.head_side_limited(m, s, method, hi, &mut 0);
        }
        // One loop per method, the method chosen once per sweep rather than once per link.
        match method {
            Method::Tractrix => {
                self.head_side_with(m, s, hi, |t, s, l| (tractrix_step(t, s, l), false))
            }
            Method::FollowTheLeader => {
                self.head_side_with(m, s, hi, |t, s, l| (follow_the_leader_step(t, s, l), false))
            }
            Method::TractrixPaper => self.head_side_with(m, s, hi, paper_or_closed_form),
        }
    }

    #[inline(always)]
    pub(super) fn head_side_with<F>(&mut self, m: usize, s: &Vector<T, D>, hi: usize, f: F) -> u32
    where
        F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
    {
        let mut fallbacks = 0;
        let mut shift = *s;
        for (l, &len) in self.links[m..hi].iter_mut().zip(&self.lengths[m..hi]) {
            let (st, fb) = f(l, &shift, len);
            *l = st.link;
            shift = st.tail_shift;
            fallbacks += fb as u32;
        }
        fallbacks
    }

    /// Joint `m` moves by `s`; links with 0-based index `lo..m` follow toward the tail (link index `i` has
    /// its head at joint `i+1`). Returns the fallbacks and the displacement of joint `lo`.
    pub(crate) fn sweep_tail_side(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        lo: usize,
    ) -> (u32, Vector<T, D>) {
        if lo < self.datum {
            self.settle_origin();
        }
        self.tail_side(m, s, method, lo)
    }

    /// [`Chain::sweep_tail_side`] leaving the datum alone (the caller places it).
    #[inline]
    pub(super) fn tail_side(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        lo: usize,
    ) -> (u32, Vector<T, D>) {
        if self.limits.is_some() {
            return self.tail_side_limited(m, s, method, lo, &mut 0);
        }
        match method {
            Method::Tractrix => {
                self.tail_side_with(m, s, lo, |t, s, l| (tractrix_step(t, s, l), false))
            }
            Method::FollowTheLeader => {
                self.tail_side_with(m, s, lo, |t, s, l| (follow_the_leader_step(t, s, l), false))
            }
            Method::TractrixPaper => self.tail_side_with(m, s, lo, paper_or_closed_form),
        }
    }

    #[inline(always)]
    pub(super) fn tail_side_with<F>(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        lo: usize,
        f: F,
    ) -> (u32, Vector<T, D>)
    where
        F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
    {
        let mut fallbacks = 0;
        let mut shift = *s;
        for (l, &len) in self.links[lo..m].iter_mut().zip(&self.lengths[lo..m]).rev() {
            let (st, fb) = f(&(-*l), &shift, len);
            *l = -st.link;
            shift = st.tail_shift;
            fallbacks += fb as u32;
        }
        (fallbacks, shift)
    }

    /// [`Chain::head_side`] with the chain's limits: link `i`, once stepped, is turned back into joint
    /// `i`'s limit about link `i − 1` (already moved: the tail side's first link for an interior move).
    /// Counts the links turned in `clamps`.
    pub(super) fn head_side_limited(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        hi: usize,
        clamps: &mut u32,
    ) -> u32 {
        let Chain {
            links,
            lengths,
            limits,
            ..
        } = self;
        let Some(lim) = limits.as_deref() else {
            return 0;
        };
        let mut fallbacks = 0u32;
        let mut shift = *s;
        for i in m..hi {
            let (st, fb) = step(method, &links[i], &shift, lengths[i]);
            let (mut link, mut tail_shift) = (st.link, st.tail_shift);
            if i > 0
                && let Some(c) =
                    lim.clamp(i, &links[i - 1], lengths[i - 1], &link, lengths[i], false)
            {
                tail_shift += c - link;
                link = c;
                *clamps += 1;
            }
            links[i] = link;
            shift = tail_shift;
            fallbacks += fb as u32;
        }
        fallbacks
    }

    /// [`Chain::tail_side`] with the chain's limits: link `j`, once stepped, is turned back into joint
    /// `j + 1`'s limit about link `j + 1` (the moved joint's own angle is left to the head side).
    pub(super) fn tail_side_limited(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        lo: usize,
        clamps: &mut u32,
    ) -> (u32, Vector<T, D>) {
        let Chain {
            links,
            lengths,
            limits,
            ..
        } = self;
        let Some(lim) = limits.as_deref() else {
            return (0, *s);
        };
        let mut fallbacks = 0u32;
        let mut shift = *s;
        for j in (lo..m).rev() {
            let (st, fb) = step(method, &(-links[j]), &shift, lengths[j]);
            let (mut link, mut tail_shift) = (st.link, st.tail_shift);
            if j + 1 < m
                && let Some(c) = lim.clamp(
                    j + 1,
                    &(-links[j + 1]),
                    lengths[j + 1],
                    &link,
                    lengths[j],
                    true,
                )
            {
                tail_shift += c - link;
                link = c;
                *clamps += 1;
            }
            links[j] = -link;
            shift = tail_shift;
            fallbacks += fb as u32;
        }
        (fallbacks, shift)
    }
}

/// Both sides of a move of joint `m`, `k` substeps of `s`, in waves of up to
/// [`crate::strands::CHAIN_WAVE`]: SIMD for waves of at least [`SIMD_FROM`], the scalar wavefront
/// for a shorter last one.
pub(super) fn simd_side_waves<T: crate::strands::StrandReal>(
    links: &mut [nalgebra::Vector3<T>],
    lengths: &[T],
    m: usize,
    s: nalgebra::Vector3<T>,
    k: u32,
) {
    use crate::strands::{CHAIN_WAVE, Simd, chain_wave};
    let (tail, head) = links.split_at_mut(m);
    let (tail_lengths, head_lengths) = lengths.split_at(m);
    let step =
        |t: &nalgebra::Vector3<T>, s: &nalgebra::Vector3<T>, l: T| (tractrix_step(t, s, l), false);
    let mut left = k as usize;
    while left > 0 {
        let w = left.min(CHAIN_WAVE);
        if w >= SIMD_FROM {
            chain_wave(tail, tail_lengths, s, w, true, Simd::Best);
            chain_wave(head, head_lengths, s, w, false, Simd::Best);
        } else {
            wave::<T, 3, true, _>(tail, tail_lengths, &s, w, &step);
            wave::<T, 3, false, _>(head, head_lengths, &s, w, &step);
        }
        left -= w;
    }
}

/// [`simd_side_waves`] for a limited chain: both sides of a move of joint `m`, the tail side first,
/// which hands the head side its link beside the moved joint after each substep; SIMD for waves of at
/// least [`SIMD_FROM`], the scalar [`wave_limited`] for a shorter last one.
pub(super) fn simd_side_waves_limited<T: crate::strands::StrandReal>(
    links: &mut [nalgebra::Vector3<T>],
    lengths: &[T],
    lim: &JointLimits<T>,
    m: usize,
    s: nalgebra::Vector3<T>,
    k: u32,
    clamps: &mut u32,
) {
    use crate::strands::{CHAIN_WAVE, WaveLimits, chain_wave_limited};
    let (tail, head) = links.split_at_mut(m);
    let (tail_lengths, head_lengths) = lengths.split_at(m);
    let across_len = tail_lengths.last().copied().unwrap_or_else(T::one);
    let mut across = [nalgebra::Vector3::zeros(); CHAIN_WAVE];
    let step =
        |t: &nalgebra::Vector3<T>, s: &nalgebra::Vector3<T>, l: T| (tractrix_step(t, s, l), false);
    let mut left = k as usize;
    while left > 0 {
        let w = left.min(CHAIN_WAVE);
        if w >= SIMD_FROM {
            for (tail_side, offset) in [(true, 0), (false, m)] {
                let side: &mut [nalgebra::Vector3<T>] = if tail_side { tail } else { head };
                let side_lengths = if tail_side {
                    tail_lengths
                } else {
                    head_lengths
                };
                chain_wave_limited(
                    side,
                    side_lengths,
                    s,
                    w,
                    tail_side,
                    WaveLimits {
                        lim,
                        offset,
                        across: &mut across,
                        across_len,
                        clamps,
                    },
                );
            }
        } else {
            let mut a = Across {
                links: [nalgebra::Vector3::zeros(); MAX_WAVE],
                length: across_len,
            };
            let side = |links, lengths, offset| LimitedSide {
                links,
                lengths,
                offset,
                lim,
            };
            wave_limited::<T, 3, true, _>(
                side(&mut *tail, tail_lengths, 0),
                &s,
                w,
                &step,
                &mut a,
                clamps,
            );
            wave_limited::<T, 3, false, _>(
                side(&mut *head, head_lengths, m),
                &s,
                w,
                &step,
                &mut a,
                clamps,
            );
        }
        left -= w;
    }
}

/// `w ≤ MAX_WAVE` substeps of `s` along one side's links, as a wavefront: at diagonal `d`, substep `j`
/// steps the `(d − j)`-th link from the moved joint. `REV` is the tail side: its links are walked from
/// the last to the first and stepped reversed (`−l`), exactly as [`Chain::sweep_tail_side`] does.
#[inline(always)]
pub(super) fn wave<T: Real, const D: usize, const REV: bool, F>(
    links: &mut [Vector<T, D>],
    lengths: &[T],
    s: &Vector<T, D>,
    w: usize,
    f: &F,
) -> u32
where
    F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
{
    let n = links.len();
    if n == 0 {
        return 0;
    }
    let mut lanes = [*s; MAX_WAVE];
    let mut fallbacks = 0u32;
    for d in 0..n + w - 1 {
        // Substeps lo..=hi are in flight; substep j is at the (d − j)-th link from the moved joint, so
        // the links stepped form one contiguous run (zipped, not indexed: no bounds check per step).
        let lo = d.saturating_sub(n - 1);
        let hi = d.min(w - 1);
        let lanes = &mut lanes[lo..=hi];
        if REV {
            // The (d − j)-th from the moved joint is index n − 1 + j − d: rising with j.
            let run = n - 1 + lo - d..=n - 1 + hi - d;
            for ((l, &len), lane) in links[run.clone()].iter_mut().zip(&lengths[run]).zip(lanes) {
                let (st, fb) = f(&(-*l), lane, len);
                *l = -st.link;
                *lane = st.tail_shift;
                fallbacks += fb as u32;
            }
        } else {
            // Index d − j: falling with j.
            let run = d - hi..=d - lo;
            let steps = links[run.clone()].iter_mut().zip(&lengths[run]).rev();
            for ((l, &len), lane) in steps.zip(lanes) {
                let (st, fb) = f(l, lane, len);
                *l = st.link;
                *lane = st.tail_shift;
                fallbacks += fb as u32;
            }
        }
    }
    fallbacks
}

/// One side of a limited chain for [`wave_limited`]: its links and lengths, the chain index of its
/// first link, the chain's limits.
pub(super) struct LimitedSide<'a, T: Real, const D: usize> {
    links: &'a mut [Vector<T, D>],
    lengths: &'a [T],
    offset: usize,
    lim: &'a JointLimits<T>,
}

/// The tail side's link beside the moved joint after each substep of a wave, and its length: the head
/// side's first link is turned back into the moved joint's limit about it.
pub(super) struct Across<T: Real, const D: usize> {
    links: [Vector<T, D>; MAX_WAVE],
    length: T,
}

/// [`wave`] with joint limits: each link, once stepped, is turned back into its limit about its
/// neighbour toward the moved joint at the same substep (as [`Chain::head_side_limited`] and
/// [`Chain::tail_side_limited`] do substep after substep). The substeps in flight run in ascending
/// order along a diagonal, so when substep `j` steps a link its neighbour still holds substep `j`'s
/// step (substep `j + 1` reaches it later in the same diagonal): the same operations on the same
/// inputs, equal bit for bit. The tail side (`REV`) writes `across` (its link beside the moved joint
/// after each substep); the head side reads it for its first link. Returns the fallbacks.
#[inline(always)]
pub(super) fn wave_limited<T: Real, const D: usize, const REV: bool, F>(
    side: LimitedSide<'_, T, D>,
    s: &Vector<T, D>,
    w: usize,
    f: &F,
    across: &mut Across<T, D>,
    clamps: &mut u32,
) -> u32
where
    F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
    Vector<T, D>: Embed3<T>,
{
    let LimitedSide {
        links,
        lengths,
        offset,
        lim,
    } = side;
    let n = links.len();
    if n == 0 {
        return 0;
    }
    let mut lanes = [*s; MAX_WAVE];
    let mut fallbacks = 0u32;
    for d in 0..n + w - 1 {
        let lo = d.saturating_sub(n - 1);
        let hi = d.min(w - 1);
        for (j, lane) in lanes.iter_mut().enumerate().take(hi + 1).skip(lo) {
            let along = d - j;
            if REV {
                let i = n - 1 - along;
                let (st, fb) = f(&(-links[i]), lane, lengths[i]);
                let (mut link, mut shift) = (st.link, st.tail_shift);
                if i + 1 < n
                    && let Some(c) = lim.clamp(
                        offset + i + 1,
                        &(-links[i + 1]),
                        lengths[i + 1],
                        &link,
                        lengths[i],
                        true,
                    )
                {
                    shift += c - link;
                    link = c;
                    *clamps += 1;
                }
                links[i] = -link;
                if along == 0 {
                    across.links[j] = links[i];
                }
                *lane = shift;
                fallbacks += fb as u32;
            } else {
                let i = along;
                let (st, fb) = f(&links[i], lane, lengths[i]);
                let (mut link, mut shift) = (st.link, st.tail_shift);
                if offset + i > 0 {
                    let (prev, prev_len) = if i > 0 {
                        (links[i - 1], lengths[i - 1])
                    } else {
                        (across.links[j], across.length)
                    };
                    if let Some(c) =
                        lim.clamp(offset + i, &prev, prev_len, &link, lengths[i], false)
                    {
                        shift += c - link;
                        link = c;
                        *clamps += 1;
                    }
                }
                links[i] = link;
                *lane = shift;
                fallbacks += fb as u32;
            }
        }
    }
    fallbacks
}

/// The paper's form where it is defined, the closed form (counted as a fallback) where it is not.
#[inline(always)]
pub(super) fn paper_or_closed_form<T: Real, const D: usize>(
    t: &Vector<T, D>,
    s: &Vector<T, D>,
    len: T,
) -> (LinkStep<T, D>, bool)
where
    Vector<T, D>: Embed3<T>,
{
    step(Method::TractrixPaper, t, s, len)
}
