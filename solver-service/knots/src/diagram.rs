//! The knot diagram behind [`crate::identify`] and [`crate::Namer`]: the cyclic sequence of passages
//! with the crossings' signs, its Reidemeister I/II reduction, and the Jones polynomial by the Kauffman
//! bracket's sweep over the crossings.

use crate::kind::{KnotType, MAX_EVALUATED_CROSSINGS};
use nalgebra::Vector3;
/// One passage of the rope through a crossing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Passage {
    pub(crate) crossing: usize,
    pub(crate) over: bool,
}

/// A knot diagram: the cyclic sequence of passages and, per crossing, its sign (+1 right-handed).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Diagram {
    pub(crate) seq: Vec<Passage>,
    pub(crate) sign: Vec<i8>,
}

impl Diagram {
    /// Projects the closed polygon `p` (the last point joins the first) along `view`. `None` for a
    /// degenerate view.
    pub(crate) fn project(p: &[Vector3<f64>], view: &Vector3<f64>) -> Option<Diagram> {
        let mut d = Diagram::default();
        Sweep::default().project(p, view, &mut d).then_some(d)
    }

    pub(crate) fn crossings(&self) -> usize {
        self.seq.len() / 2
    }

    pub(crate) fn writhe(&self) -> i32 {
        let mut seen = vec![false; self.sign.len()];
        let mut w = 0;
        for p in &self.seq {
            if !seen[p.crossing] {
                seen[p.crossing] = true;
                w += self.sign[p.crossing] as i32;
            }
        }
        w
    }

    /// Applies Reidemeister I and II moves until none applies.
    pub(crate) fn reduced(mut self) -> Diagram {
        self.reduce(&mut Vec::new());
        self
    }

    /// Reduces the diagram in place by Reidemeister moves I and II until neither applies: `at` is a
    /// buffer for where each crossing is passed, so each round is linear in the passages.
    pub(crate) fn reduce(&mut self, at: &mut Vec<[usize; 2]>) {
        loop {
            let n = self.seq.len();
            if n == 0 {
                return;
            }
            // I: a crossing passed twice in a row (a kink).
            if let Some(k) =
                (0..n).find(|&k| self.seq[k].crossing == self.seq[(k + 1) % n].crossing)
            {
                self.remove(&[k, (k + 1) % n]);
                continue;
            }
            // II: crossings X, Y passed in a row over-over, and in a row (either order) under-under.
            // A crossing's other passage is the other way over, so it is enough that the other
            // passages of two passages in a row, both over or both under, are in a row too.
            at.clear();
            at.resize(self.sign.len(), [usize::MAX; 2]);
            for (k, p) in self.seq.iter().enumerate() {
                at[p.crossing][usize::from(p.over)] = k;
            }
            let other = |p: &Passage| at[p.crossing][usize::from(!p.over)];
            let found = (0..n).find_map(|k| {
                let (a, b) = (self.seq[k], self.seq[(k + 1) % n]);
                if a.over != b.over {
                    return None;
                }
                let (oa, ob) = (other(&a), other(&b));
                let next = |x: usize| (x + 1) % n;
                if next(oa) == ob {
                    Some([k, (k + 1) % n, oa, ob])
                } else if next(ob) == oa {
                    Some([k, (k + 1) % n, ob, oa])
                } else {
                    None
                }
            });
            match found {
                Some(idx) => self.remove(&idx),
                None => return,
            }
        }
    }

    pub(crate) fn remove(&mut self, idx: &[usize]) {
        let mut k = 0;
        self.seq.retain(|_| {
            let keep = !idx.contains(&k);
            k += 1;
            keep
        });
    }

    /// The knot's name from its Jones polynomial.
    pub(crate) fn name(&self) -> KnotType {
        let Some(v) = self.jones() else {
            return KnotType::Other;
        };
        let t = Laurent::trefoil();
        let m = t.mirror();
        let c = Laurent::cinquefoil();
        if v == Laurent::one() {
            KnotType::Unknot
        } else if v == t || v == m {
            KnotType::Trefoil
        } else if v == t.mul(&t) || v == m.mul(&m) {
            KnotType::Granny
        } else if v == t.mul(&m) {
            KnotType::Square
        } else if v == c || v == c.mirror() {
            KnotType::DoubleOverhand
        } else if v == c.mul(&m) || v == c.mirror().mul(&t) {
            KnotType::Surgeons
        } else {
            KnotType::Other
        }
    }

    /// The crossings as arc labels (arc e runs from passage e to passage e + 1), each counterclockwise
    /// from the incoming under arc.
    pub(crate) fn pd(&self) -> Vec<[usize; 4]> {
        // Arcs: arc e runs from passage e to passage e+1; a passage's incoming arc is e−1.
        let n = self.seq.len();
        let mut ids = vec![usize::MAX; self.sign.len()];
        let mut pd: Vec<[usize; 4]> = Vec::with_capacity(self.crossings());
        let mut under = vec![usize::MAX; self.sign.len()];
        let mut over = vec![usize::MAX; self.sign.len()];
        for (k, p) in self.seq.iter().enumerate() {
            if p.over {
                over[p.crossing] = k;
            } else {
                under[p.crossing] = k;
            }
        }
        for p in &self.seq {
            let x = p.crossing;
            if ids[x] != usize::MAX {
                continue;
            }
            ids[x] = pd.len();
            let (u, o) = (under[x], over[x]);
            let (i, k) = ((u + n - 1) % n, u);
            let (oin, oout) = ((o + n - 1) % n, o);
            // Counterclockwise from the incoming under arc: the incoming over arc comes next at a
            // positive crossing's mirror, the outgoing one at a positive crossing.
            pd.push(if self.sign[x] > 0 {
                [i, oin, k, oout]
            } else {
                [i, oout, k, oin]
            });
        }
        pd
    }

    /// The Jones polynomial in powers of `A` (`t = A⁻⁴`): `(−A³)^(−w) ⟨D⟩` with the Kauffman bracket
    /// `⟨D⟩` ([`bracket`]). `None` past [`MAX_EVALUATED_CROSSINGS`].
    pub(crate) fn jones(&self) -> Option<Laurent> {
        let c = self.crossings();
        if c == 0 {
            return Some(Laurent::one());
        }
        if c > MAX_EVALUATED_CROSSINGS {
            return None;
        }
        let bracket = bracket(&self.pd(), self.seq.len());
        // (−A³)^(−w) = (−1)^w A^(−3w).
        let w = self.writhe();
        let norm = Laurent::monomial(-3 * w, if w % 2 == 0 { 1 } else { -1 });
        Some(bracket.mul(&norm).trimmed())
    }
}

/// No partner: an arc label not (or no longer) an open end of a partial state.
pub(crate) const NO_END: u8 = u8::MAX;

/// The Kauffman bracket `⟨D⟩ = Σ A^(a − b) d^(loops − 1)`, `d = −A² − A⁻²`, over every smoothing of
/// the diagram whose crossings are `pd` (each crossing's four arc labels counterclockwise from the
/// incoming under arc; each of the `n` labels at two slots), summed by a sweep over the crossings
/// rather than over the `2^c` smoothings one by one: the crossings are taken one at a time (next the
/// one with the most arcs already reached), and the partial smoothings of those taken so far are kept
/// by how they pair the open arcs (labels reached once), each with the polynomial of the smoothings
/// that pair them so; a loop closed on the way multiplies by `d`. Smoothings that pair the open arcs
/// alike never need to be told apart again, so the work grows with the number of such pairings (the
/// diagram's width), not with `2^c`: a rope's knots in series are narrow. The states' loops all close
/// at the end, and the sum so far is `d ⟨D⟩`.
pub(crate) fn bracket(pd: &[[usize; 4]], n: usize) -> Laurent {
    let c = pd.len();
    if n > MAX_LABELS {
        // Past the keys' size (never asked: `jones` stops at MAX_EVALUATED_CROSSINGS).
        return Laurent::zero();
    }
    // Exponents of A: each crossing ±1, each of at most c + 1 loops ±2.
    let half = 3 * c + 4;
    let width = 2 * half + 1;
    // The order: each next crossing the one with the most labels already open (the narrowest sweep).
    let mut taken = vec![false; c];
    let mut reached = vec![0u8; n];
    let mut order = Vec::with_capacity(c);
    for _ in 0..c {
        let Some(x) = (0..c).filter(|&x| !taken[x]).max_by_key(|&x| {
            let open = pd[x].iter().filter(|&&l| reached[l] == 1).count();
            (open, std::cmp::Reverse(x))
        }) else {
            break;
        };
        taken[x] = true;
        order.push(x);
        for &l in &pd[x] {
            reached[l] += 1;
        }
    }
    // The partial states: for each label its partner (the other end of the strand it ends), and the
    // polynomial (dense, exponent e at e + half, in one buffer of `width` per state) with the range
    // of its nonzero coefficients.
    let mut keys: Vec<[u8; MAX_LABELS]> = vec![[NO_END; MAX_LABELS]];
    let mut polys: Vec<i64> = vec![0; width];
    polys[half] = 1;
    let mut ranges: Vec<(usize, usize)> = vec![(half, half + 1)];
    let (mut next_keys, mut next_polys, mut next_ranges) = (Vec::new(), Vec::new(), Vec::new());
    let mut index: std::collections::HashMap<[u8; MAX_LABELS], usize> =
        std::collections::HashMap::new();
    for &x in &order {
        let q = pd[x];
        next_keys.clear();
        next_polys.clear();
        next_ranges.clear();
        index.clear();
        for (s, key) in keys.iter().enumerate() {
            let (lo, hi) = ranges[s];
            let poly = &polys[s * width..(s + 1) * width];
            // The A-smoothing joins q0–q3 and q1–q2 (a factor A), the B-smoothing q0–q1 and q2–q3 (A⁻¹).
            for (shift, pairs) in [
                (1isize, [(q[0], q[3]), (q[1], q[2])]),
                (-1, [(q[0], q[1]), (q[2], q[3])]),
            ] {
                let mut k = *key;
                let mut loops = 0;
                for (u, v) in pairs {
                    loops += join(&mut k, u, v);
                }
                let i = *index.entry(k).or_insert_with(|| {
                    next_keys.push(k);
                    next_polys.resize(next_polys.len() + width, 0);
                    next_ranges.push((width, 0));
                    next_keys.len() - 1
                });
                // Added times A^shift d^loops (d = −A² − A⁻², d² = A⁴ + 2 + A⁻⁴).
                let times: &[(isize, i64)] = match loops {
                    0 => &[(0, 1)],
                    1 => &[(-2, -1), (2, -1)],
                    _ => &[(-4, 1), (0, 2), (4, 1)],
                };
                let target = &mut next_polys[i * width..(i + 1) * width];
                let reach = 2 * loops.min(2) as isize;
                for (e, &a) in poly.iter().enumerate().take(hi).skip(lo) {
                    if a != 0 {
                        for &(de, f) in times {
                            target[(e as isize + shift + de) as usize] += a * f;
                        }
                    }
                }
                let r = &mut next_ranges[i];
                r.0 = r.0.min((lo as isize + shift - reach) as usize);
                r.1 = r.1.max((hi as isize + shift + reach) as usize);
            }
        }
        std::mem::swap(&mut keys, &mut next_keys);
        std::mem::swap(&mut polys, &mut next_polys);
        std::mem::swap(&mut ranges, &mut next_ranges);
    }
    // Every label is closed: one state, `d ⟨D⟩`. Divided by d from the lowest power up:
    // P_e = −Q_(e−2) − Q_(e+2), so Q_e = −P_(e−2) − Q_(e−4).
    let p = &polys[..width.min(polys.len())];
    let mut q = vec![0i64; width];
    for e in 2..p.len() {
        q[e] = -p[e - 2] - if e >= 4 { q[e - 4] } else { 0 };
    }
    Laurent {
        lo: -(half as i32),
        coef: q,
    }
    .trimmed()
}

/// Arc labels a diagram may have for [`bracket`]: two per crossing evaluated.
pub(crate) const MAX_LABELS: usize = 2 * MAX_EVALUATED_CROSSINGS;

/// Joins the strand ends at labels `u` and `v` of a partial state `k` (a label reached for the first
/// time starts an open end; reached the second time, the strand through it continues): 1 when the
/// join closes a loop, else 0.
pub(crate) fn join(k: &mut [u8], u: usize, v: usize) -> u32 {
    if u == v {
        // An arc from this crossing back to it, both its ends joined here.
        return 1;
    }
    let (open_u, open_v) = (k[u] != NO_END, k[v] != NO_END);
    if open_u && usize::from(k[u]) == v {
        k[u] = NO_END;
        k[v] = NO_END;
        return 1;
    }
    let a = if open_u {
        let a = usize::from(k[u]);
        k[u] = NO_END;
        a
    } else {
        u
    };
    let b = if open_v {
        let b = usize::from(k[v]);
        k[v] = NO_END;
        b
    } else {
        v
    };
    k[a] = b as u8;
    k[b] = a as u8;
    0
}

/// A Laurent polynomial in `A` with integer coefficients: `Σ coef[k] A^(lo + k)`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Laurent {
    pub(crate) lo: i32,
    pub(crate) coef: Vec<i64>,
}

impl Laurent {
    pub(crate) fn zero() -> Self {
        Laurent {
            lo: 0,
            coef: vec![],
        }
    }
    pub(crate) fn one() -> Self {
        Laurent::monomial(0, 1)
    }
    pub(crate) fn monomial(e: i32, c: i64) -> Self {
        Laurent {
            lo: e,
            coef: vec![c],
        }
    }
    /// A polynomial in `t` (lowest power `lo`, coefficients) written in `A` with `t = A⁻⁴`.
    pub(crate) fn from_t(lo: i32, coef: &[i64]) -> Self {
        let mut p = Laurent::zero();
        for (k, &c) in coef.iter().enumerate() {
            p = p.add(&Laurent::monomial(-4 * (lo + k as i32), c));
        }
        p.trimmed()
    }
    /// The left- or right-handed trefoil (whichever `t + t³ − t⁴` is); its mirror is [`Laurent::mirror`].
    pub(crate) fn trefoil() -> Self {
        Laurent::from_t(1, &[1, 0, 1, -1])
    }
    /// The knot 5₁, the (2, 5) torus knot (one chirality; Wikipedia gives the other, `t → 1/t`): the
    /// same hand as [`Laurent::trefoil`] (both the positive torus knots, all powers of `t` positive).
    pub(crate) fn cinquefoil() -> Self {
        Laurent::from_t(2, &[1, 0, 1, -1, 1, -1])
    }
    pub(crate) fn mirror(&self) -> Self {
        let mut coef = self.coef.clone();
        coef.reverse();
        Laurent {
            lo: -(self.lo + self.coef.len() as i32 - 1),
            coef,
        }
        .trimmed()
    }
    pub(crate) fn add(&self, o: &Laurent) -> Laurent {
        if self.coef.is_empty() {
            return o.clone();
        }
        if o.coef.is_empty() {
            return self.clone();
        }
        let lo = self.lo.min(o.lo);
        let hi = (self.lo + self.coef.len() as i32).max(o.lo + o.coef.len() as i32);
        let mut coef = vec![0; (hi - lo) as usize];
        for (k, c) in self.coef.iter().enumerate() {
            coef[(self.lo - lo) as usize + k] += c;
        }
        for (k, c) in o.coef.iter().enumerate() {
            coef[(o.lo - lo) as usize + k] += c;
        }
        Laurent { lo, coef }.trimmed()
    }
    pub(crate) fn mul(&self, o: &Laurent) -> Laurent {
        if self.coef.is_empty() || o.coef.is_empty() {
            return Laurent::zero();
        }
        let mut coef = vec![0; self.coef.len() + o.coef.len() - 1];
        for (i, a) in self.coef.iter().enumerate() {
            for (j, b) in o.coef.iter().enumerate() {
                coef[i + j] += a * b;
            }
        }
        Laurent {
            lo: self.lo + o.lo,
            coef,
        }
        .trimmed()
    }
    pub(crate) fn trimmed(mut self) -> Laurent {
        while self.coef.last() == Some(&0) {
            self.coef.pop();
        }
        let lead = self.coef.iter().take_while(|c| **c == 0).count();
        self.coef.drain(..lead);
        self.lo += lead as i32;
        if self.coef.is_empty() {
            self.lo = 0;
        }
        self
    }
    /// `|V(−1)|`: `t = −1` is `A⁴ = −1`, i.e. `A^e` is `(−1)^(e/4)` for the multiples of 4 a knot has.
    pub(crate) fn determinant(&self) -> u64 {
        let mut s: i64 = 0;
        for (k, c) in self.coef.iter().enumerate() {
            let e = self.lo + k as i32;
            if e.rem_euclid(4) != 0 {
                continue;
            }
            s += if (e / 4).rem_euclid(2) == 0 { *c } else { -*c };
        }
        s.unsigned_abs()
    }
    /// Coefficients in powers of `t`, lowest power first (only powers `A^(4k)` occur for a knot).
    pub(crate) fn to_t(&self) -> Vec<i64> {
        let mut out: Vec<i64> = self.coef.iter().rev().step_by(4).copied().collect();
        if out.is_empty() {
            out.push(0);
        }
        out
    }
}

/// The buffers of a projection: the projected points, the segments sorted by their lowest x, the
/// segments whose x range the sweep is in, and the passages found.
#[derive(Clone, Debug, Default)]
pub(crate) struct Sweep {
    /// At most this many segment pairs tested and crossings found per projection, when set (a
    /// namer's bound on the work of one state); beyond it the view counts as not generic.
    pub(crate) budget: Option<(usize, usize)>,
    q: Vec<[f64; 3]>,
    order: Vec<u32>,
    active: Vec<u32>,
    passages: Vec<(f64, Passage)>,
}

impl Sweep {
    /// Projects the closed polygon `p` (the last point joins the first) along `view` into `d`: its
    /// crossings found by a sweep along the picture's x axis (only segments whose x and y ranges
    /// overlap are tested), each with its over/under order and its sign. `false` for a degenerate
    /// view: a crossing on a joint, two crossings at one point of the rope, strands that meet in
    /// space, or overlapping parallel segments.
    pub(crate) fn project(
        &mut self,
        p: &[Vector3<f64>],
        view: &Vector3<f64>,
        d: &mut Diagram,
    ) -> bool {
        d.seq.clear();
        d.sign.clear();
        self.passages.clear();
        let e1 = view.cross(&Vector3::new(0.577, -0.211, 0.789)).normalize();
        let e2 = view.cross(&e1);
        let m = p.len();
        self.q.clear();
        self.q
            .extend(p.iter().map(|x| [x.dot(&e1), x.dot(&e2), x.dot(view)]));
        let q = &self.q;
        let scale = q
            .iter()
            .map(|x| x[0].abs().max(x[1].abs()))
            .fold(0.0, f64::max);
        let eps = 1e-9;
        let margin = 1e-9 * scale.max(1.0);
        let x_range = |i: usize| {
            let (a, b) = (q[i][0], q[(i + 1) % m][0]);
            (a.min(b), a.max(b))
        };
        let y_range = |i: usize| {
            let (a, b) = (q[i][1], q[(i + 1) % m][1]);
            (a.min(b), a.max(b))
        };
        self.order.clear();
        self.order.extend(0..m as u32);
        self.order
            .sort_unstable_by(|&a, &b| x_range(a as usize).0.total_cmp(&x_range(b as usize).0));
        self.active.clear();
        let (max_pairs, max_crossings) = self.budget.unwrap_or((usize::MAX, usize::MAX));
        let mut pairs = 0usize;
        for &s in &self.order {
            let s = s as usize;
            let (xs, _) = x_range(s);
            self.active
                .retain(|&a| x_range(a as usize).1 >= xs - margin);
            let (ylo, yhi) = y_range(s);
            pairs += self.active.len();
            if pairs > max_pairs || d.sign.len() > max_crossings {
                return false;
            }
            for &a in &self.active {
                let a = a as usize;
                let (i, j) = (a.min(s), a.max(s));
                if j == i + 1 || (i == 0 && j == m - 1) {
                    continue;
                }
                let (alo, ahi) = y_range(a);
                if ahi < ylo - margin || alo > yhi + margin {
                    continue;
                }
                let (a0, a1) = (q[i], q[(i + 1) % m]);
                let (b0, b1) = (q[j], q[(j + 1) % m]);
                let da = (a1[0] - a0[0], a1[1] - a0[1]);
                let db = (b1[0] - b0[0], b1[1] - b0[1]);
                let den = da.0 * db.1 - da.1 * db.0;
                let r = (b0[0] - a0[0], b0[1] - a0[1]);
                let la = da.0.hypot(da.1);
                let lb = db.0.hypot(db.1);
                if den.abs() <= 1e-12 * la * lb {
                    let off = (r.0 * da.1 - r.1 * da.0).abs();
                    if off <= margin * la {
                        let t0 = (r.0 * da.0 + r.1 * da.1) / (la * la);
                        let t1 = ((b1[0] - a0[0]) * da.0 + (b1[1] - a0[1]) * da.1) / (la * la);
                        if t0.max(t1) >= 0.0 && t0.min(t1) <= 1.0 {
                            return false;
                        }
                    }
                    continue;
                }
                let s_ = (r.0 * db.1 - r.1 * db.0) / den;
                let t = (r.0 * da.1 - r.1 * da.0) / den;
                if !(-eps..=1.0 + eps).contains(&s_) || !(-eps..=1.0 + eps).contains(&t) {
                    continue;
                }
                if s_ < eps || s_ > 1.0 - eps || t < eps || t > 1.0 - eps {
                    return false; // a crossing on a joint
                }
                let ha = a0[2] + (a1[2] - a0[2]) * s_;
                let hb = b0[2] + (b1[2] - b0[2]) * t;
                if (ha - hb).abs() <= margin {
                    return false; // the strands meet in space
                }
                let a_over = ha > hb;
                let x = d.sign.len();
                let (dover, dunder) = if a_over { (da, db) } else { (db, da) };
                let c = dover.0 * dunder.1 - dover.1 * dunder.0;
                d.sign.push(if c > 0.0 { 1 } else { -1 });
                self.passages.push((
                    i as f64 + s_,
                    Passage {
                        crossing: x,
                        over: a_over,
                    },
                ));
                self.passages.push((
                    j as f64 + t,
                    Passage {
                        crossing: x,
                        over: !a_over,
                    },
                ));
            }
            self.active.push(s as u32);
        }
        self.passages.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        if self.passages.windows(2).any(|w| w[1].0 - w[0].0 < eps) {
            return false; // two crossings at one point of the rope
        }
        d.seq.extend(self.passages.iter().map(|p| p.1));
        true
    }
}
