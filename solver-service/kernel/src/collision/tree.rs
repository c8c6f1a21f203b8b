//! The broad phase of capsule self-collision: a bounding-volume tree over the chain whose shape never
//! changes. A chain's neighbours stay its neighbours, so the tree is not built by splitting space: leaf
//! `l` holds links `l·B .. (l+1)·B` (B = [`LEAF`]), and the tree over the leaves is the complete binary
//! tree of an implicit heap (node 1 the root, node `k`'s children `2k` and `2k + 1`). Each pass only
//! refits the boxes, bottom up, in O(n); the self-test descends pairs of nodes at the same depth whose
//! boxes overlap, and hands each overlapping pair of leaves to the narrow phase. A rope that does not
//! touch itself costs about one box test per leaf per level it shares with its neighbours, plus the
//! link pairs of neighbouring leaves; a rope piled into a ball costs up to all leaf pairs, each charged to
//! the work meter before it is tested.

use super::{Meter, cost};
use crate::math::{Real, Vector};
use core::ops::Range;

/// Links per leaf.
pub(super) const LEAF: usize = 4;

/// The tree's boxes, reused from pass to pass (after the first pass of a chain nothing is allocated).
#[derive(Clone, Debug, Default)]
pub(super) struct ChainTree<T: Real, const D: usize> {
    /// Lower and upper corners of each node's box (index 0 unused), inflated by the margin.
    lo: Vec<Vector<T, D>>,
    hi: Vec<Vector<T, D>>,
    /// Leaves of the complete tree (a power of two, at least one).
    leaves: usize,
    /// Links of the chain.
    links: usize,
    /// Pairs of nodes waiting to be tested.
    stack: Vec<(u32, u32)>,
    /// Pairs of leaves (node indices) whose boxes overlap.
    pairs: Vec<(u32, u32)>,
}

impl<T: Real, const D: usize> ChainTree<T, D> {
    /// Refits every box to the joints `pos` (link `i` joins joints `i` and `i + 1`), each inflated by
    /// `margin` on every side: two links closer than twice the margin have overlapping leaf boxes.
    pub(super) fn refit(&mut self, pos: &[Vector<T, D>], margin: T) {
        let n = pos.len().saturating_sub(1);
        let leaves = n.div_ceil(LEAF).max(1).next_power_of_two();
        self.links = n;
        self.leaves = leaves;
        let big = T::max_value().unwrap_or_else(T::one);
        self.lo.resize(2 * leaves, Vector::from_element(big));
        self.hi.resize(2 * leaves, Vector::from_element(-big));
        for l in 0..leaves {
            let (first, last) = (l * LEAF, ((l + 1) * LEAF).min(n));
            let (mut lo, mut hi): (Vector<T, D>, Vector<T, D>) =
                (Vector::from_element(big), Vector::from_element(-big));
            if first < last {
                for p in &pos[first..=last] {
                    for k in 0..D {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
                lo.add_scalar_mut(-margin);
                hi.add_scalar_mut(margin);
            }
            self.lo[leaves + l] = lo;
            self.hi[leaves + l] = hi;
        }
        for k in (1..leaves).rev() {
            let (a, b) = (2 * k, 2 * k + 1);
            self.lo[k] = self.lo[a].inf(&self.lo[b]);
            self.hi[k] = self.hi[a].sup(&self.hi[b]);
        }
    }

    /// The links of leaf node `node` (an index among the tree's nodes, `leaves..2·leaves`).
    #[inline]
    fn leaf_links(&self, node: usize) -> Range<usize> {
        let l = node - self.leaves;
        (l * LEAF).min(self.links)..((l + 1) * LEAF).min(self.links)
    }

    #[inline]
    fn overlap(&self, a: usize, b: usize) -> bool {
        (0..D).all(|k| self.lo[a][k] <= self.hi[b][k] && self.lo[b][k] <= self.hi[a][k])
    }

    /// The links of node `node`: the leaves below it, as link indices.
    #[inline]
    fn node_links(&self, node: usize) -> Range<usize> {
        let levels = self.leaves.trailing_zeros();
        let depth = usize::BITS - 1 - node.leading_zeros();
        let height = levels - depth;
        let first = (node << height) - self.leaves;
        let end = ((node + 1) << height) - self.leaves;
        (first * LEAF).min(self.links)..(end * LEAF).min(self.links)
    }

    /// Calls `pair(meter, i, j)` for every pair of links `i < j` with more than `span` links between
    /// them whose leaves' boxes overlap, in ascending order of `i`, then of `j` (a sweep from the tail
    /// to the head, the order the contacts are pushed in), after charging `meter` for each pair of
    /// boxes tested ([`cost::NODE_PAIR`]). Returns `false` as soon as the meter runs out or `pair`
    /// returns `false`.
    pub(super) fn close_pairs(
        &mut self,
        meter: &mut Meter,
        span: usize,
        mut pair: impl FnMut(&mut Meter, usize, usize) -> bool,
    ) -> bool {
        if !self.overlapping_leaves(meter, span) {
            return false;
        }
        self.pairs.sort_unstable();
        let pairs = core::mem::take(&mut self.pairs);
        let mut done = true;
        let mut g = 0;
        'groups: while g < pairs.len() {
            let a = pairs[g].0;
            let end = g + pairs[g..].iter().take_while(|p| p.0 == a).count();
            for i in self.leaf_links(a as usize) {
                for &(_, b) in &pairs[g..end] {
                    let b = self.leaf_links(b as usize);
                    for j in b.start.max(i + span + 1)..b.end {
                        if !pair(meter, i, j) {
                            done = false;
                            break 'groups;
                        }
                    }
                }
            }
            g = end;
        }
        self.pairs = pairs;
        done
    }

    /// Collects into `self.pairs` every pair of leaves (a leaf with itself included, the lower first)
    /// whose boxes overlap and that holds a pair of links more than `span` apart, charging `meter` for
    /// each pair of boxes tested; `false` if it ran out.
    fn overlapping_leaves(&mut self, meter: &mut Meter, span: usize) -> bool {
        let mut stack = core::mem::take(&mut self.stack);
        stack.clear();
        self.pairs.clear();
        stack.push((1, 1));
        let mut done = true;
        while let Some((a, b)) = stack.pop() {
            let (a, b) = (a as usize, b as usize);
            // No pair of links far enough apart along the chain to be tested.
            let (la, lb) = (self.node_links(a), self.node_links(b));
            if la.is_empty() || lb.is_empty() || lb.end - 1 <= la.start + span {
                continue;
            }
            if a != b {
                if !meter.charge(cost::NODE_PAIR) {
                    done = false;
                    break;
                }
                if !self.overlap(a, b) {
                    continue;
                }
            }
            if a >= self.leaves {
                self.pairs.push((a as u32, b as u32));
                continue;
            }
            let (al, ar) = (2 * a as u32, 2 * a as u32 + 1);
            if a == b {
                stack.extend([(ar, ar), (al, ar), (al, al)]);
            } else {
                let (bl, br) = (2 * b as u32, 2 * b as u32 + 1);
                stack.extend([(ar, br), (ar, bl), (al, br), (al, bl)]);
            }
        }
        self.stack = stack;
        done
    }
}

/// How far beyond the clearance the kept candidate pairs reach, as a share of the clearance (the
/// list's skin), at most [`SKIN_LINKS`] of the shortest link.
pub(super) const SKIN: f64 = 0.5;

/// The skin's cap in shortest links: on a rope finer than it is thick a skin of half a clearance
/// spans dozens of links, and the list holds several times the pairs the tree would test (at 10,000
/// links of a 40-unit rope 0.2 thick the contact bench's scale curve was 15 % slower at p50 and
/// three times slower at its longest move).
pub(super) const SKIN_LINKS: f64 = 2.0;

/// The candidate pairs of capsule self-collision kept from pass to pass (a Verlet list): every pair
/// of links the tree finds whose boxes come within the clearance plus a skin, with the joints where
/// they were then. While no joint has moved half the skin since, a pair not in the list is still
/// farther apart than the clearance, so a pass tests only the list: the passes of a knot that creeps
/// toward its tolerance (hundreds per substep, each joint moving a fraction of the tolerance) refit
/// no tree and descend no boxes.
#[derive(Clone, Debug, Default)]
pub(super) struct NearPairs<T: Real, const D: usize> {
    /// The pairs `(i, j)`, `i < j`, in the tree's order (ascending `i`, then `j`).
    pub(super) pairs: Vec<(u32, u32)>,
    /// The joints when the list was made.
    at: Vec<Vector<T, D>>,
    /// How far a pass has pushed each joint.
    pushes: Vec<T>,
    /// The farthest the last pass pushed a joint.
    last_push: T,
    /// Whether the list may be used (made for this chain's span and clearance, and no pass since
    /// moved a joint past what the skin allows).
    valid: bool,
    span: usize,
    clearance: T,
    skin: T,
}

impl<T: Real, const D: usize> NearPairs<T, D> {
    /// The skin for a clearance and a shortest link: [`SKIN`] of the clearance, at most
    /// [`SKIN_LINKS`] links.
    pub(super) fn skin(clearance: T, min_len: T) -> T {
        (clearance * T::lit(SKIN)).min(min_len * T::lit(SKIN_LINKS))
    }

    /// How far the joints `pos` moved since the list was made (the largest distance), when the list
    /// is valid for `span`, `clearance` and `skin` and that is at most a quarter of the skin; else
    /// `None` (make it again).
    pub(super) fn moved(
        &self,
        pos: &[Vector<T, D>],
        span: usize,
        clearance: T,
        skin: T,
    ) -> Option<T> {
        if !self.valid
            || self.span != span
            || self.clearance != clearance
            || self.skin != skin
            || self.at.len() != pos.len()
        {
            return None;
        }
        let quarter = skin * T::lit(0.25);
        let limit = quarter * quarter;
        let mut worst = T::zero();
        for (p, q) in pos.iter().zip(&self.at) {
            let d = (p - q).norm_squared();
            if !matches!(
                d.partial_cmp(&limit),
                Some(core::cmp::Ordering::Less | core::cmp::Ordering::Equal)
            ) {
                return None;
            }
            worst = worst.max(d);
        }
        Some(worst.sqrt())
    }

    /// Makes the list from the joints `pos`: refits `tree` with the skin and keeps every pair whose
    /// links' boxes come within the clearance plus the skin, each pair of link boxes charged to
    /// `meter` as a box test. `false` (the list left invalid) when the meter ran out.
    pub(super) fn make(
        &mut self,
        pos: &[Vector<T, D>],
        tree: &mut ChainTree<T, D>,
        span: usize,
        clearance: T,
        skin: T,
        meter: &mut Meter,
    ) -> bool {
        let reach = clearance + skin;
        tree.refit(pos, reach * T::lit(0.5));
        self.pairs.clear();
        self.valid = false;
        let pairs = &mut self.pairs;
        let done = tree.close_pairs(meter, span, |meter, i, j| {
            if !meter.charge(cost::NODE_PAIR) {
                return false;
            }
            if !boxes_apart(&pos[i], &pos[i + 1], &pos[j], &pos[j + 1], reach) {
                pairs.push((i as u32, j as u32));
            }
            true
        });
        if done {
            self.at.clear();
            self.at.extend_from_slice(pos);
            self.span = span;
            self.clearance = clearance;
            self.skin = skin;
            self.valid = true;
        }
        done
    }

    /// The pairs, and each joint's push in the pass about to run (zeroed, one per joint of `pos`).
    pub(super) fn pairs_and_pushes(&mut self, joints: usize) -> (&[(u32, u32)], &mut Vec<T>) {
        self.pushes.clear();
        self.pushes.resize(joints, T::zero());
        (&self.pairs, &mut self.pushes)
    }

    /// The farthest the last pass pushed a joint (zero before any).
    pub(super) fn last_push(&self) -> T {
        self.last_push
    }

    /// Records the farthest the pass just done pushed a joint.
    pub(super) fn set_last_push(&mut self, d: T) {
        self.last_push = d;
    }

    /// Marks the list as unusable (a pass moved joints past what the skin allows).
    pub(super) fn invalidate(&mut self) {
        self.valid = false;
    }
}

/// `true` when the bounding boxes of segments `a0`–`a1` and `b0`–`b1` are more than `gap` apart along
/// some axis (then the segments are too).
#[inline]
pub(super) fn boxes_apart<T: Real, const D: usize>(
    a0: &Vector<T, D>,
    a1: &Vector<T, D>,
    b0: &Vector<T, D>,
    b1: &Vector<T, D>,
    gap: T,
) -> bool {
    (0..D).any(|k| {
        let (alo, ahi) = (a0[k].min(a1[k]), a0[k].max(a1[k]));
        let (blo, bhi) = (b0[k].min(b1[k]), b0[k].max(b1[k]));
        blo - ahi > gap || alo - bhi > gap
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// Every pair of links more than `span` apart along the chain whose axes come within twice the
    /// margin is reported, once, in ascending order: checked against all pairs on random piles, over
    /// spans 0 to 5; on a straight rope only links in the same or neighbouring leaves are.
    #[test]
    fn the_tree_reports_every_close_pair_once_in_order() {
        let mut rnd = uniform(0x9e37_79b9_7f4a_7c15);
        let mut tree = ChainTree::<f64, 3>::default();
        for &n in &[1usize, 2, 3, 4, 5, 7, 8, 9, 17, 40, 63] {
            for trial in 0..20 {
                let span = trial % 6;
                // A random walk folded into a small box: many close pairs.
                let mut pos = vec![Vector3::zeros()];
                for _ in 0..n {
                    let last = *pos.last().unwrap();
                    let step = Vector3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
                    pos.push(last + step * 0.5);
                }
                let margin = 0.15;
                tree.refit(&pos, margin);
                let mut seen = Vec::new();
                let all = tree.close_pairs(&mut Meter::default(), span, |_, i, j| {
                    assert!(j > i + span, "{i} {j} span {span}");
                    seen.push((i, j));
                    true
                });
                assert!(all);
                assert!(
                    seen.windows(2).all(|w| w[0] < w[1]),
                    "not in order: {seen:?}"
                );
                for i in 0..n {
                    for j in i + span + 1..n {
                        let d = segment_distance(&pos[i], &pos[i + 1], &pos[j], &pos[j + 1]);
                        if d <= 2.0 * margin {
                            assert!(seen.contains(&(i, j)), "n {n}: links {i} and {j} at {d}");
                        }
                    }
                }
            }
        }
        // A straight rope: only links of the same or the next leaf.
        let pos: Vec<Vector3<f64>> = (0..=64).map(|i| Vector3::new(i as f64, 0.0, 0.0)).collect();
        tree.refit(&pos, 0.1);
        let mut pairs = 0;
        tree.close_pairs(&mut Meter::default(), 1, |_, i, j| {
            assert!(j / LEAF <= i / LEAF + 1, "{i} {j}");
            pairs += 1;
            true
        });
        assert!(pairs > 0);
    }

    /// The kept list holds every pair that can touch while it is valid: on random piles, each joint
    /// then moved at random by up to a quarter of the skin (what `moved` still accepts), every pair
    /// more than `span` apart whose links come within the clearance plus a quarter of the skin (what
    /// a pass's own pushes may still spend of the half skin) is in the list, in order; a joint moved
    /// farther, or another span, makes `moved` ask for a new list.
    #[test]
    fn the_kept_pairs_hold_every_pair_that_can_touch_while_valid() {
        let mut rnd = uniform(0x2545_f491_4f6c_dd1d);
        let mut tree = ChainTree::<f64, 3>::default();
        let mut near = NearPairs::<f64, 3>::default();
        let clearance = 0.2;
        // Links of 0.25: the skin is half the clearance.
        let skin = NearPairs::<f64, 3>::skin(clearance, 0.25);
        assert_eq!(skin, clearance * SKIN);
        let quarter = skin * 0.25;
        for &n in &[3usize, 9, 40, 63] {
            for trial in 0..20 {
                let span = trial % 4;
                let mut pos = vec![Vector3::zeros()];
                for _ in 0..n {
                    let last = *pos.last().unwrap();
                    let step = Vector3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
                    pos.push(last + step * 0.25);
                }
                assert!(near.make(
                    &pos,
                    &mut tree,
                    span,
                    clearance,
                    skin,
                    &mut Meter::default()
                ));
                assert!(near.pairs.windows(2).all(|w| w[0] < w[1]));
                let mut moved = pos.clone();
                for p in &mut moved {
                    let d = Vector3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
                    *p += d.normalize() * (quarter * rnd());
                }
                let d = near
                    .moved(&moved, span, clearance, skin)
                    .expect("within a quarter of the skin");
                assert!(d <= quarter);
                for i in 0..n {
                    for j in i + span + 1..n {
                        let g =
                            segment_distance(&moved[i], &moved[i + 1], &moved[j], &moved[j + 1]);
                        // Half the skin less the quarter spent: what a pass's pushes may still use.
                        if g <= clearance + quarter {
                            assert!(
                                near.pairs.contains(&(i as u32, j as u32)),
                                "n {n}: links {i} and {j} at {g}"
                            );
                        }
                    }
                }
                moved[n / 2] = pos[n / 2] + Vector3::new(quarter * 1.01, 0.0, 0.0);
                assert!(near.moved(&moved, span, clearance, skin).is_none());
                assert!(near.moved(&pos, span + 1, clearance, skin).is_none());
                assert!(near.moved(&pos, span, clearance, skin * 0.5).is_none());
            }
        }
    }

    /// The meter stops the search: with room for a few box tests only, it reports running out.
    #[test]
    fn the_tree_stops_when_the_meter_runs_out() {
        let pos: Vec<Vector3<f64>> = (0..=64).map(|i| Vector3::new(i as f64, 0.0, 0.0)).collect();
        let mut tree = ChainTree::<f64, 3>::default();
        tree.refit(&pos, 0.1);
        let mut meter = Meter {
            limit: 3 * cost::NODE_PAIR,
            ..Meter::default()
        };
        assert!(!tree.close_pairs(&mut meter, 1, |_, _, _| true));
    }

    /// Uniform numbers in [0, 1) from a xorshift generator with this seed (the tests' own).
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The distance between two segments by sampling both finely (the test's own, coarse but
    /// independent): an upper bound within 1e-3 of the true distance for these lengths.
    fn segment_distance(
        a0: &Vector3<f64>,
        a1: &Vector3<f64>,
        b0: &Vector3<f64>,
        b1: &Vector3<f64>,
    ) -> f64 {
        let k = 400;
        let mut best = f64::INFINITY;
        for s in 0..=k {
            let p = a0 + (a1 - a0) * (s as f64 / k as f64);
            // The closest point of the other segment to p, exactly.
            let d = b1 - b0;
            let t = ((p - b0).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
            best = best.min((p - (b0 + d * t)).norm());
        }
        best
    }
}
