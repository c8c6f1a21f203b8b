//! Independent checks for the tests and benches: geometry computed here, sharing no code with the kernel
//! whose collision handling it checks (a check that called the kernel's own queries would agree with any
//! mistake they made).

use nalgebra::Vector3;

type V = Vector3<f64>;

/// Distance between the segments `p1 q1` and `p2 q2` (Ericson, *Real-Time Collision Detection*, 5.1.9).
pub fn segment_distance(p1: V, q1: V, p2: V, q2: V) -> f64 {
    const EPS: f64 = 1e-300;
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    let (s, t) = if a <= EPS && e <= EPS {
        (0.0, 0.0)
    } else if a <= EPS {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= EPS {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let s = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let t = (b * s + f) / e;
            if t < 0.0 {
                ((-c / a).clamp(0.0, 1.0), 0.0)
            } else if t > 1.0 {
                (((b - c) / a).clamp(0.0, 1.0), 1.0)
            } else {
                (s, t)
            }
        }
    };
    ((p1 + d1 * s) - (p2 + d2 * t)).norm()
}

/// The smallest distance between the axes of two links of the polyline `p` with at least `rope` of
/// length along it between them (pairs closer along the rope than its thickness touch even when it is
/// straight), by testing every pair: O(n²). `None` if no pair qualifies.
pub fn closest_links_with_rope_between(p: &[V], rope: f64) -> Option<f64> {
    // Arc length at each joint.
    let mut arc = vec![0.0; p.len()];
    for k in 1..p.len() {
        arc[k] = arc[k - 1] + (p[k] - p[k - 1]).norm();
    }
    let mut best: Option<f64> = None;
    for i in 0..p.len().saturating_sub(1) {
        for j in i + 1..p.len() - 1 {
            // Rope between link i (p[i]..p[i+1]) and link j (p[j]..p[j+1]).
            if arc[j] - arc[i + 1] < rope * (1.0 - 1e-9) {
                continue;
            }
            let d = segment_distance(p[i], p[i + 1], p[j], p[j + 1]);
            best = Some(best.map_or(d, |b: f64| b.min(d)));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On cases whose answer is known by hand.
    #[test]
    fn segment_distance_is_right_on_known_cases() {
        let v = V::new;
        let cases = [
            // Crossing at right angles, one above the other.
            (
                (v(-1., 0., 0.), v(1., 0., 0.), v(0., -1., 2.), v(0., 1., 2.)),
                2.0,
            ),
            // Parallel, overlapping.
            (
                (v(0., 0., 0.), v(2., 0., 0.), v(1., 3., 0.), v(3., 3., 0.)),
                3.0,
            ),
            // Collinear with a gap: end to end.
            (
                (v(0., 0., 0.), v(1., 0., 0.), v(3., 0., 0.), v(5., 0., 0.)),
                2.0,
            ),
            // A point against a segment, beyond its end: 3-4-5.
            (
                (v(4., 3., 0.), v(4., 3., 0.), v(-1., 0., 0.), v(0., 0., 0.)),
                5.0,
            ),
            // Skew, closest points inside both.
            (
                (v(0., 0., 0.), v(2., 2., 0.), v(2., 0., 1.), v(0., 2., 1.)),
                1.0,
            ),
        ];
        for ((a, b, c, d), want) in cases {
            assert!((segment_distance(a, b, c, d) - want).abs() < 1e-15);
        }
    }

    /// A hairpin: two parallel arms 0.5 apart joined by a bend link 0.5 long.
    #[test]
    fn links_with_rope_between_skip_near_neighbours() {
        let mut p: Vec<V> = (0..=10)
            .map(|k| V::new(f64::from(k) * 0.25, 0.0, 0.0))
            .collect();
        p.extend(
            (0..=10)
                .rev()
                .map(|k| V::new(f64::from(k) * 0.25, 0.5, 0.0)),
        );
        // With 0.2 of rope between, the link two before the bend (0.25 of rope between) is 0.25 from
        // the bend link; adjacent links (no rope between, distance 0) are left out.
        let d = closest_links_with_rope_between(&p, 0.2).unwrap();
        assert!((d - 0.25).abs() < 1e-12, "{d}");
        // With 0.6, only the arms face each other: 0.5 apart.
        let d = closest_links_with_rope_between(&p, 0.6).unwrap();
        assert!((d - 0.5).abs() < 1e-12, "{d}");
        // Asking for more rope than the whole hairpin has leaves no pair.
        assert_eq!(closest_links_with_rope_between(&p, 100.0), None);
    }
}
