//! Smooth key-frame paths (Korein & Badler: "realistic simulation requires that the acceleration be
//! everywhere finite ... This requirement prohibits use of linear interpolation schemes"): a natural
//! cubic spline through key points, C² everywhere, parameterised by chord length, sampled into the
//! points a move follows.
//!
//! Between two key points the spline is a cubic in the chord-length parameter `t`; its second
//! derivatives `M` at the key points solve the tridiagonal system of C² continuity, with `M = 0` at
//! both ends (natural). A path of two key points is the straight segment. Consecutive duplicate key
//! points are dropped (a zero chord has no direction).

use crate::math::{Real, Vector};

/// Samples the natural cubic spline through `keys` into `out` (cleared first): for each segment
/// between consecutive key points `per_segment(i, chord)` samples (at least one), evenly spaced in the
/// parameter, the last exactly the segment's end key point. The first key point itself is not
/// sampled (it is where the joint already is). Returns the number of samples. Allocates its work
/// arrays (three per key point): a key-frame tool, not a per-move step.
pub fn spline_samples<T: Real, const D: usize>(
    keys: &[Vector<T, D>],
    mut per_segment: impl FnMut(usize, T) -> usize,
    out: &mut Vec<Vector<T, D>>,
) -> usize {
    out.clear();
    let mut p: Vec<Vector<T, D>> = Vec::with_capacity(keys.len());
    for k in keys {
        if p.last() != Some(k) {
            p.push(*k);
        }
    }
    let n = p.len();
    if n < 2 {
        return 0;
    }
    let h: Vec<T> = p.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
    let m = second_derivatives(&p, &h);
    for i in 0..n - 1 {
        let k = per_segment(i, h[i]).max(1);
        for j in 1..=k {
            if j == k {
                out.push(p[i + 1]);
                continue;
            }
            let s = h[i] * T::lit(j as f64) / T::lit(k as f64);
            out.push(eval(&p, &h, &m, i, s));
        }
    }
    out.len()
}

/// The second derivatives at the key points (natural ends), by the Thomas algorithm: the system is
/// diagonally dominant, so it needs no pivoting.
fn second_derivatives<T: Real, const D: usize>(p: &[Vector<T, D>], h: &[T]) -> Vec<Vector<T, D>> {
    let n = p.len();
    let mut m = vec![Vector::<T, D>::zeros(); n];
    if n < 3 {
        return m;
    }
    let six = T::lit(6.0);
    // Interior rows i = 1..n-2: h[i-1] M[i-1] + 2 (h[i-1] + h[i]) M[i] + h[i] M[i+1] = rhs[i].
    let mut c = vec![T::zero(); n];
    let mut d = vec![Vector::<T, D>::zeros(); n];
    for i in 1..n - 1 {
        let rhs = ((p[i + 1] - p[i]) / h[i] - (p[i] - p[i - 1]) / h[i - 1]) * six;
        let diag = T::lit(2.0) * (h[i - 1] + h[i]) - h[i - 1] * c[i - 1];
        c[i] = h[i] / diag;
        d[i] = (rhs - d[i - 1] * h[i - 1]) / diag;
    }
    for i in (1..n - 1).rev() {
        m[i] = d[i] - m[i + 1] * c[i];
    }
    m
}

/// The spline on segment `i` at parameter `s` from its start (0 ≤ s ≤ h[i]).
fn eval<T: Real, const D: usize>(
    p: &[Vector<T, D>],
    h: &[T],
    m: &[Vector<T, D>],
    i: usize,
    s: T,
) -> Vector<T, D> {
    let hi = h[i];
    let (a, b) = (hi - s, s);
    let six = T::lit(6.0);
    m[i] * (a * a * a / (six * hi))
        + m[i + 1] * (b * b * b / (six * hi))
        + (p[i] / hi - m[i] * (hi / six)) * a
        + (p[i + 1] / hi - m[i + 1] * (hi / six)) * b
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    #[test]
    fn the_spline_passes_through_every_key_point_and_is_c2_there() {
        let keys = [
            Vector2::new(0.0, 0.0),
            Vector2::new(1.0, 1.0),
            Vector2::new(2.0, 0.0),
            Vector2::new(3.0, 2.0),
            Vector2::new(3.0, 3.0),
        ];
        let k = 200;
        let mut out = Vec::new();
        let n = spline_samples(&keys, |_, _| k, &mut out);
        assert_eq!(n, 4 * k);
        for (i, key) in keys[1..].iter().enumerate() {
            assert_eq!(out[(i + 1) * k - 1], *key, "key {}", i + 1);
        }
        // Across each interior key point the samples' second differences, divided by the squared
        // parameter step of each side, agree to the discretisation (no jump in curvature); at a
        // polyline's corner they would jump by the turn over one step.
        let h: Vec<f64> = keys.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
        let mut all = vec![keys[0]];
        all.extend_from_slice(&out);
        for i in 1..keys.len() - 1 {
            let at = i * k;
            let (dl, dr) = (h[i - 1] / k as f64, h[i] / k as f64);
            let left = (all[at] - all[at - 1] * 2.0 + all[at - 2]) / (dl * dl);
            let right = (all[at + 2] - all[at + 1] * 2.0 + all[at]) / (dr * dr);
            assert!((left - right).norm() < 0.1, "key {i}: {left:?} {right:?}");
        }
        // Natural ends: no curvature at the first and last key points.
        let d0 = h[0] / k as f64;
        let start = (all[2] - all[1] * 2.0 + all[0]) / (d0 * d0);
        assert!(start.norm() < 0.1, "{start:?}");
    }

    #[test]
    fn two_key_points_make_the_straight_segment_and_duplicates_are_dropped() {
        let keys = [
            Vector2::new(0.0, 0.0),
            Vector2::new(0.0, 0.0),
            Vector2::new(4.0, 2.0),
        ];
        let mut out = Vec::new();
        spline_samples(
            &keys,
            |_, chord: f64| (chord / 0.5).ceil() as usize,
            &mut out,
        );
        assert_eq!(out.len(), 9);
        for (j, q) in out.iter().enumerate() {
            let t = (j + 1) as f64 / 9.0;
            assert!(
                (q - Vector2::new(4.0, 2.0) * t).norm() < 1e-12,
                "{j}: {q:?}"
            );
        }
        assert_eq!(spline_samples(&keys[..1], |_, _| 3, &mut out), 0);
    }
}
