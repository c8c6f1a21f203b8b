//! The smallest clearance a resolution keeps, the rope re-straightened from the hand, and the links never tested against each other.

use super::*;

/// The smallest clearance the resolution keeps anywhere on the chain: between two links, or between a
/// link and an obstacle. Half of it is how far a substep may move the hand and how far a re-solve may
/// move a joint: a joint that goes in by less than half a clearance is pushed back out the side it
/// came in by, so nothing is crossed.
pub(crate) fn smallest_clearance<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    model: &CollisionModel<T, D>,
) -> T
where
    Vector<T, D>: Embed3<T>,
{
    let link = match model.options.scheme {
        Scheme::Capsules => model.options.thickness,
        Scheme::PaperSpheres => chain.min_length(),
    };
    let link_r = link * T::lit(0.5);
    // Against a ball or a capsule a link keeps its radius plus the obstacle's (a needle or a tool
    // shaft as thick as the rope does not halve the substeps of the whole rope: before, any ball or
    // capsule did, and the 160-link two-hand pass with its needle locked 41 moves at the entry hole,
    // far from the needle, where a re-solve moved a joint 0.028 against a limit halved to 0.025).
    // Against a plane or a block a link keeps its radius; a block at least as thick as the links'
    // clearance on every axis cannot be crossed in a substep that moves a joint half of it (a joint
    // that goes in is pushed back out the side it came in by), and leaves it.
    let clearance = |o: &Obstacle<T, D>| match o {
        Obstacle::Sphere { radius, .. } | Obstacle::Capsule { radius, .. } => link_r + *radius,
        Obstacle::Block { lo, hi } if (0..D).all(|k| hi[k] - lo[k] >= link * T::lit(2.0)) => link,
        Obstacle::Block { .. } | Obstacle::HalfSpace { .. } => link_r,
    };
    model
        .obstacles
        .iter()
        .map(clearance)
        .fold(link, |a, b| if b < a { b } else { a })
}

/// Joint positions from the hand's position outward, along the current link vectors.
pub(super) fn positions_from<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    m: usize,
    hand: Vector<T, D>,
    pos: &mut [Vector<T, D>],
) where
    Vector<T, D>: Embed3<T>,
{
    let links = chain.links();
    pos[m] = hand;
    let mut acc = CompensatedSum::new(hand);
    for i in (0..m).rev() {
        acc.add(&-links[i]);
        pos[i] = acc.value();
    }
    let mut acc = CompensatedSum::new(hand);
    for i in m..links.len() {
        acc.add(&links[i]);
        pos[i + 1] = acc.value();
    }
}

/// Re-straightens the chain to its exact lengths, follow-the-leader outward from the hand (joint `m`,
/// which stays put): each link keeps the direction from its already placed inner joint to its pushed
/// outer joint. Writes the link vectors and the exact positions.
pub(super) fn restraighten<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    pos: &mut [Vector<T, D>],
) where
    Vector<T, D>: Embed3<T>,
{
    let (links, lengths, limits) = chain.links_lengths_limits_mut();
    for i in m..links.len() {
        let d = pos[i + 1] - pos[i];
        let n = d.norm();
        if positive_finite(n) {
            links[i] = d * (lengths[i] / n);
        }
        // With limits each link is turned back into its joint's limit about the link before it.
        crate::limits::turn_back(limits, links, lengths, i, true);
        pos[i + 1] = pos[i] + links[i];
    }
    for i in (0..m).rev() {
        let d = pos[i + 1] - pos[i];
        let n = d.norm();
        if positive_finite(n) {
            links[i] = d * (lengths[i] / n);
        }
        crate::limits::turn_back(limits, links, lengths, i, false);
        pos[i] = pos[i + 1] - links[i];
    }
}

/// How many links on each side of a link are its neighbours, never tested against it: those closer along
/// the rope than one thickness (`m` links of length `min_len` with `m·min_len ≥ thickness`). Two links
/// with fewer than a thickness of rope between them touch even when the rope is straight; testing them
/// would lock every move of a rope whose links are shorter than it is thick.
pub fn neighbour_span<T: Real>(min_len: T, thickness: T) -> usize {
    if !(positive_finite(min_len) && thickness.is_finite() && thickness > T::zero()) {
        return 1;
    }
    let m = (thickness / min_len).ceil().to_f64();
    if m.is_finite() {
        (m as usize).max(1)
    } else {
        1
    }
}
