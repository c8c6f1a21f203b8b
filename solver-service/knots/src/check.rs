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

/// Where two links pass through each other between two states of a rope: link `i` and link `j`
/// (non-adjacent) at the fraction `t` of the way from the first state to the second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    pub i: usize,
    pub j: usize,
    pub t: f64,
}

/// The swept-volume check between two consecutive states of a rope (`before`, `after`: its joints,
/// the same count): every joint is taken to move straight from where it was to where it is, and a
/// pair of links at least `apart` links apart (2: every non-adjacent pair) passes through each other
/// when their axes meet on the way: the four ends coplanar (a root of the cubic in `t` of the
/// triple product, where it changes sign) with the two segments within `tolerance` of each other
/// there. Axes that only come near each other are not a crossing (the discrete check of each state
/// finds capsules too close); a crossing changes the rope's topology. Pairs whose swept boxes lie
/// apart are skipped. O(n²) per pair of states.
pub fn crossings_between(before: &[V], after: &[V], apart: usize, tolerance: f64) -> Vec<Crossing> {
    let n = before.len().min(after.len()).saturating_sub(1);
    let mut out = Vec::new();
    // Each link's swept box.
    let boxes: Vec<(V, V)> = (0..n)
        .map(|k| {
            let pts = [before[k], before[k + 1], after[k], after[k + 1]];
            let lo = pts.iter().fold(pts[0], |m, p| m.inf(p));
            let hi = pts.iter().fold(pts[0], |m, p| m.sup(p));
            (lo, hi)
        })
        .collect();
    for i in 0..n {
        for j in i + apart.max(2)..n {
            let (a, b) = (boxes[i], boxes[j]);
            let sep = (0..3).any(|c| a.0[c] > b.1[c] + tolerance || b.0[c] > a.1[c] + tolerance);
            if sep {
                continue;
            }
            if let Some(t) = axes_meet(
                [before[i], before[i + 1], before[j], before[j + 1]],
                [after[i], after[i + 1], after[j], after[j + 1]],
                tolerance,
            ) {
                out.push(Crossing { i, j, t });
            }
        }
    }
    out
}

/// Whether segments `p0 p1` and `p2 p3`, each end moving straight from `from` to `to`, meet: the
/// first `t` in [0, 1] where the triple product `(p1 − p0) × (p2 − p0) · (p3 − p0)` changes sign
/// (found on 32 intervals, refined by bisection) and the segments lie within `tolerance` there.
fn axes_meet(from: [V; 4], to: [V; 4], tolerance: f64) -> Option<f64> {
    let at = |t: f64| -> [V; 4] {
        [
            from[0] + (to[0] - from[0]) * t,
            from[1] + (to[1] - from[1]) * t,
            from[2] + (to[2] - from[2]) * t,
            from[3] + (to[3] - from[3]) * t,
        ]
    };
    let f = |t: f64| {
        let p = at(t);
        (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&(p[3] - p[0]))
    };
    const STEPS: usize = 32;
    let mut t0 = 0.0;
    let mut f0 = f(0.0);
    for k in 1..=STEPS {
        let t1 = k as f64 / STEPS as f64;
        let f1 = f(t1);
        let root = if f0 == 0.0 {
            Some(t0)
        } else if f0 * f1 < 0.0 {
            let (mut lo, mut hi, mut flo) = (t0, t1, f0);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                let fm = f(mid);
                if flo * fm <= 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                    flo = fm;
                }
            }
            Some(0.5 * (lo + hi))
        } else {
            None
        };
        if let Some(t) = root {
            let p = at(t);
            if segment_distance(p[0], p[1], p[2], p[3]) <= tolerance {
                return Some(t);
            }
        }
        t0 = t1;
        f0 = f1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two links, one sliding through the other, cross; one passing above it does not; nor does a
    /// pair that only turns in its plane.
    #[test]
    fn a_link_through_another_crosses_and_one_above_it_does_not() {
        let v = V::new;
        // Link 0 along x at z = 0; link 2 along y, moving from z = 1 to z = −1 (through link 0).
        let rope = |z: f64| vec![v(-1., 0., 0.), v(1., 0., 0.), v(0., -1., z), v(0., 1., z)];
        let c = crossings_between(&rope(1.0), &rope(-1.0), 2, 1e-9);
        assert_eq!(c.len(), 1);
        assert!(
            (c[0].t - 0.5).abs() < 1e-9 && c[0].i == 0 && c[0].j == 2,
            "{c:?}"
        );
        // Moving from z = 1 to z = 0.5: no crossing.
        assert!(crossings_between(&rope(1.0), &rope(0.5), 2, 1e-9).is_empty());
        // Beside it (x beyond link 0's end) through the plane: the axes never meet.
        let beside = |z: f64| vec![v(-1., 0., 0.), v(1., 0., 0.), v(3., -1., z), v(3., 1., z)];
        assert!(crossings_between(&beside(1.0), &beside(-1.0), 2, 1e-9).is_empty());
    }

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
