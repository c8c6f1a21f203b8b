//! Distances and closest points: point–segment, segment–segment, the closest pair of links of a chain,
//! and the way out of an obstacle. Stateless functions over positions.

use super::Obstacle;
use crate::math::{Embed3, Real, Vector, positive_finite};
use nalgebra::Vector3;

/// The smallest distance between the axes of two non-adjacent links, by testing every pair (O(n²)):
/// an independent check of what collision handling guarantees, for tests and tools. Returns the
/// distance and the two 0-based link indices, or `None` for a chain of fewer than three links.
pub fn closest_nonadjacent_links<T: Real, const D: usize>(
    positions: &[Vector<T, D>],
) -> Option<(T, usize, usize)>
where
    Vector<T, D>: Embed3<T>,
{
    closest_links_apart(positions, 1)
}

/// Like [`closest_nonadjacent_links`], testing only links more than `span` links apart (`span` from
/// [`neighbour_span`](super::neighbour_span) leaves out the neighbours capsule collision never tests).
pub fn closest_links_apart<T: Real, const D: usize>(
    positions: &[Vector<T, D>],
    span: usize,
) -> Option<(T, usize, usize)>
where
    Vector<T, D>: Embed3<T>,
{
    let n = positions.len().checked_sub(1)?;
    let mut best: Option<(T, usize, usize)> = None;
    for i in 0..n {
        for j in i + span + 1..n {
            let (a0, a1, b0, b1) = (
                positions[i],
                positions[i + 1],
                positions[j],
                positions[j + 1],
            );
            let (s, t) = closest_params_segment_segment(&a0, &a1, &b0, &b1);
            let d = (lerp(&a0, &a1, s) - lerp(&b0, &b1, t)).norm();
            if best.is_none_or(|(bd, _, _)| d < bd) {
                best = Some((d, i, j));
            }
        }
    }
    best
}

/// Unit direction from an obstacle to point `p`, the distance from the obstacle's core (centre, axis or
/// plane) and the obstacle's radius (0 for a plane). `axis` picks a direction when `p` is on the core.
pub(super) fn away_from<T: Real, const D: usize>(
    ob: &Obstacle<T, D>,
    p: &Vector<T, D>,
    axis: &Vector<T, D>,
) -> (Vector<T, D>, T, T)
where
    Vector<T, D>: Embed3<T>,
{
    match ob {
        Obstacle::Sphere { center, radius } => {
            let d = p - center;
            let dist = d.norm();
            (unit_or_perpendicular(&d, dist, axis, axis), dist, *radius)
        }
        Obstacle::Capsule { a, b, radius } => {
            let t = closest_param_point_segment(p, a, b);
            let d = p - lerp(a, b, t);
            let dist = d.norm();
            (
                unit_or_perpendicular(&d, dist, axis, &(b - a)),
                dist,
                *radius,
            )
        }
        Obstacle::HalfSpace { point, normal } => (*normal, (p - point).dot(normal), T::zero()),
        Obstacle::Block { lo, hi } => {
            let (n, sd) = block_signed_distance(lo, hi, p);
            (n, sd, T::zero())
        }
    }
}

/// The signed distance from the axis-aligned block `lo`–`hi` to `p` (its distance outside, minus its
/// depth inside) and the unit direction out of the block at `p` (from the block's nearest point
/// outside; along the nearest face's normal inside).
pub fn block_signed_distance<T: Real, const D: usize>(
    lo: &Vector<T, D>,
    hi: &Vector<T, D>,
    p: &Vector<T, D>,
) -> (Vector<T, D>, T) {
    let mut d = Vector::<T, D>::zeros();
    for k in 0..D {
        d[k] = if p[k] < lo[k] {
            p[k] - lo[k]
        } else if p[k] > hi[k] {
            p[k] - hi[k]
        } else {
            T::zero()
        };
    }
    let out = d.norm();
    if out > T::zero() {
        return (d / out, out);
    }
    // Inside (or on the surface): out through the nearest face.
    let mut best = (T::max_value().unwrap_or_else(T::one), 0usize, T::one());
    for k in 0..D {
        let (below, above) = (p[k] - lo[k], hi[k] - p[k]);
        if below < best.0 {
            best = (below, k, -T::one());
        }
        if above < best.0 {
            best = (above, k, T::one());
        }
    }
    let mut n = Vector::<T, D>::zeros();
    n[best.1] = best.2;
    (n, -best.0)
}

/// Parameter in `[0, 1]` of the point of segment `a`–`b` with the least signed distance to the block
/// `lo`–`hi` ([`block_signed_distance`]): the point nearest the block, or the deepest inside it. The
/// signed distance to a convex set is convex along a segment, so a golden-section search finds it
/// (to 1e-9 of the segment).
pub fn closest_param_segment_block<T: Real, const D: usize>(
    a: &Vector<T, D>,
    b: &Vector<T, D>,
    lo: &Vector<T, D>,
    hi: &Vector<T, D>,
) -> T {
    let f = |s: T| block_signed_distance(lo, hi, &lerp(a, b, s)).1;
    let g = T::lit(0.618_033_988_749_894_9);
    let (mut x0, mut x1) = (T::zero(), T::one());
    let mut c = x1 - (x1 - x0) * g;
    let mut d = x0 + (x1 - x0) * g;
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..44 {
        if fc <= fd {
            x1 = d;
            d = c;
            fd = fc;
            c = x1 - (x1 - x0) * g;
            fc = f(c);
        } else {
            x0 = c;
            c = d;
            fc = fd;
            d = x0 + (x1 - x0) * g;
            fd = f(d);
        }
    }
    // The ends too: the minimum of a convex function on a segment may sit at an end exactly.
    let mid = (x0 + x1) * T::lit(0.5);
    let mut best = (f(mid), mid);
    for s in [T::zero(), T::one()] {
        let v = f(s);
        if v < best.0 {
            best = (v, s);
        }
    }
    best.1
}

#[inline]
pub(super) fn lerp<T: Real, const D: usize>(
    a: &Vector<T, D>,
    b: &Vector<T, D>,
    s: T,
) -> Vector<T, D> {
    a + (b - a) * s
}

/// `d / dist`, or when the two axes touch exactly, a direction perpendicular to both (to the first if
/// they are parallel): the contact normal must exist for every configuration.
pub(super) fn unit_or_perpendicular<T: Real, const D: usize>(
    d: &Vector<T, D>,
    dist: T,
    u: &Vector<T, D>,
    v: &Vector<T, D>,
) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    if positive_finite(dist) && dist > T::EPSILON * (u.norm() + v.norm()) {
        return d / dist;
    }
    let c = Vector::<T, D>::from_3d(&u.to_3d().cross(&v.to_3d()));
    let cn = c.norm();
    if positive_finite(cn) && D == 3 {
        return c / cn;
    }
    any_perpendicular(u)
}

/// A unit vector perpendicular to `u` (any unit vector when `u` is zero), deterministic.
pub(super) fn any_perpendicular<T: Real, const D: usize>(u: &Vector<T, D>) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let u3 = u.to_3d();
    for axis in [Vector3::z(), Vector3::x(), Vector3::y()] {
        let c = Vector::<T, D>::from_3d(&u3.cross(&axis));
        let cn = c.norm();
        if positive_finite(cn) {
            return c / cn;
        }
    }
    let mut e = Vector::<T, D>::zeros();
    e[0] = T::one();
    e
}

/// Parameter in `[0, 1]` of the point of segment `a`–`b` closest to `p`.
pub fn closest_param_point_segment<T: Real, const D: usize>(
    p: &Vector<T, D>,
    a: &Vector<T, D>,
    b: &Vector<T, D>,
) -> T {
    let ab = b - a;
    let den = ab.norm_squared();
    if den <= T::zero() {
        return T::zero();
    }
    ((p - a).dot(&ab) / den).max(T::zero()).min(T::one())
}

/// Parameters `(s, t)` in `[0, 1]²` of the closest points of segments `p1`–`q1` and `p2`–`q2`
/// (Ericson, *Real-Time Collision Detection*, 5.1.9), robust to parallel and degenerate segments.
pub fn closest_params_segment_segment<T: Real, const D: usize>(
    p1: &Vector<T, D>,
    q1: &Vector<T, D>,
    p2: &Vector<T, D>,
    q2: &Vector<T, D>,
) -> (T, T) {
    let (zero, one) = (T::zero(), T::one());
    let clamp = |x: T| x.max(zero).min(one);
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    if a <= zero && e <= zero {
        return (zero, zero);
    }
    if a <= zero {
        return (zero, clamp(f / e));
    }
    let c = d1.dot(&r);
    if e <= zero {
        return (clamp(-c / a), zero);
    }
    let b = d1.dot(&d2);
    let den = a * e - b * b;
    // Parallel segments (den ≈ 0 relative to a·e): any s works; take 0 and let t follow.
    let mut s = if den > T::EPSILON * a * e {
        clamp((b * f - c * e) / den)
    } else {
        zero
    };
    let mut t = (b * s + f) / e;
    if t < zero {
        t = zero;
        s = clamp(-c / a);
    } else if t > one {
        t = one;
        s = clamp((b - c) / a);
    }
    (s, t)
}
