//! The spatial hash grid that finds candidate link pairs in O(n).

use crate::math::{Real, Vector};

/// A spatial hash grid over links (counting-sort layout, after Müller's "ten minute physics"): cells
/// one link plus one thickness wide, so a link's inflated box covers at most two cells per axis. The
/// table has twice as many slots as entries; a stamp per link de-duplicates candidates found through
/// several cells.
#[derive(Clone, Debug, Default)]
pub(super) struct HashGrid {
    pub(super) cell: f64,
    pub(super) starts: Vec<u32>,
    pub(super) entries: Vec<u32>,
    pub(super) stamp: Vec<u32>,
    pub(super) lo: Vec<[i64; 3]>,
    pub(super) hi: Vec<[i64; 3]>,
    pub(super) mask: usize,
}

impl HashGrid {
    pub(super) fn build<T: Real, const D: usize>(&mut self, pos: &[Vector<T, D>], radius: T) {
        let n = pos.len() - 1;
        let longest = pos
            .windows(2)
            .map(|w| (w[1] - w[0]).amax().to_f64())
            .fold(0.0, f64::max);
        let r = radius.to_f64();
        self.cell = (longest + 2.0 * r).max(f64::MIN_POSITIVE);
        self.lo.resize(n, [0; 3]);
        self.hi.resize(n, [0; 3]);
        let mut inserts = 0usize;
        for i in 0..n {
            let (mut lo, mut hi) = ([0i64; 3], [0i64; 3]);
            for k in 0..D.min(3) {
                let (a, b) = (pos[i][k].to_f64(), pos[i + 1][k].to_f64());
                lo[k] = floor((a.min(b) - r) / self.cell);
                hi[k] = floor((a.max(b) + r) / self.cell);
            }
            inserts += cells_in(&lo, &hi);
            self.lo[i] = lo;
            self.hi[i] = hi;
        }
        let slots = (2 * inserts).next_power_of_two().max(16);
        self.mask = slots - 1;
        self.starts.clear();
        self.starts.resize(slots + 1, 0);
        for i in 0..n {
            self.for_each_cell(i, |g, h| g.starts[h] += 1);
        }
        let mut acc = 0u32;
        for s in self.starts.iter_mut() {
            acc += *s;
            *s = acc;
        }
        self.entries.clear();
        self.entries.resize(inserts, 0);
        for i in 0..n {
            self.for_each_cell(i, |g, h| {
                g.starts[h] -= 1;
                g.entries[g.starts[h] as usize] = i as u32;
            });
        }
        self.stamp.clear();
        self.stamp.resize(n, u32::MAX);
    }

    fn for_each_cell(&mut self, i: usize, mut f: impl FnMut(&mut Self, usize)) {
        let (lo, hi) = (self.lo[i], self.hi[i]);
        for cx in lo[0]..=hi[0] {
            for cy in lo[1]..=hi[1] {
                for cz in lo[2]..=hi[2] {
                    let h = self.slot([cx, cy, cz]);
                    f(self, h);
                }
            }
        }
    }

    #[inline]
    pub(super) fn slot(&self, c: [i64; 3]) -> usize {
        let h = (c[0].wrapping_mul(92_837_111))
            ^ (c[1].wrapping_mul(689_287_499))
            ^ (c[2].wrapping_mul(283_923_481));
        (h as u64 as usize) & self.mask
    }

    /// How many entries the cells of link `i` hold (what a query of it scans).
    pub(super) fn entries_around(&self, i: usize) -> u64 {
        let (lo, hi) = (self.lo[i], self.hi[i]);
        let mut total = 0u64;
        for cx in lo[0]..=hi[0] {
            for cy in lo[1]..=hi[1] {
                for cz in lo[2]..=hi[2] {
                    let h = self.slot([cx, cy, cz]);
                    total += u64::from(self.starts[h + 1] - self.starts[h]);
                }
            }
        }
        total
    }

    /// `true` the first time link `j` is seen while querying link `i`.
    #[inline]
    pub(super) fn first_visit(&mut self, j: usize, i: usize) -> bool {
        if self.stamp[j] == i as u32 {
            return false;
        }
        self.stamp[j] = i as u32;
        true
    }
}

/// `x.floor() as i64` without the call to libm's `floor` (the baseline x86-64 has no rounding
/// instruction); the same for every `f64`, NaN (0) and the saturated ends included.
#[inline]
fn floor(x: f64) -> i64 {
    let t = x as i64;
    t.saturating_sub(i64::from(x < t as f64))
}

fn cells_in(lo: &[i64; 3], hi: &[i64; 3]) -> usize {
    (0..3).map(|k| (hi[k] - lo[k] + 1) as usize).product()
}

#[cfg(test)]
mod tests {
    use super::floor;

    /// The grid's floor is `f64::floor` followed by the saturating cast, for every kind of value.
    #[test]
    fn floor_is_the_floor_for_every_value() {
        let values = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999,
            -2.000_001,
            1e-300,
            -1e-300,
            4.5e15,
            -4.5e15,
            9.3e18,
            -9.3e18,
            1e300,
            -1e300,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            i64::MIN as f64,
            i64::MAX as f64,
        ];
        for x in values {
            assert_eq!(floor(x), x.floor() as i64, "{x}");
        }
        let mut x = -1000.0;
        while x < 1000.0 {
            assert_eq!(floor(x), x.floor() as i64, "{x}");
            x += 0.037;
        }
    }
}
