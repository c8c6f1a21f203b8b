//! An independent knot check for the end-to-end tests: the knot determinant of a rope, computed here
//! from the joints a test reads from the service, sharing no code with the `knots` crate's namer
//! (which closes the rope its own way, reduces a Gauss code and evaluates the Jones polynomial).
//!
//! The rope is turned by a fixed generic rotation and seen from above; it is closed through a point
//! far above its centroid (both ends joined to it, so the closing arcs pass over everything: the
//! closure at infinity along the view); the crossings of the picture give the arcs between
//! undercrossings, and each crossing a row of the Fox colouring matrix (twice the over-arc, minus the
//! two under-arcs). Any minor of order `c − 1` of that matrix has the knot determinant `|Δ(−1)|` as
//! its absolute value: 1 for the unknot, 3 for the trefoil, 5 for the figure eight and 5₁ (the double
//! overhand), 7 for 5₂ and 7₁, 9 for the square and the granny knots, 15 for the surgeon's knot (the
//! determinant does not tell square from granny, nor 5₁ from the figure eight). The minor is reduced modulo a large prime,
//! exactly. Three views are taken and the value most of them give is returned, with how many agreed.

/// Views tried: rotations about z, then x, then z again (Euler angles, radians, generic).
const VIEWS: [[f64; 3]; 3] = [[0.37, 0.91, 1.23], [1.71, 0.53, 2.29], [2.83, 1.37, 0.61]];

/// The Mersenne prime 2⁶¹ − 1, the modulus of the exact elimination.
const P: u64 = (1 << 61) - 1;

/// The knot determinant of the open rope `joints` closed at infinity above each of three views: the
/// value most views give and how many gave it.
pub fn determinant(joints: &[[f64; 3]]) -> (u64, usize) {
    let dets: Vec<u64> = VIEWS.iter().map(|e| view_determinant(joints, *e)).collect();
    dets.iter()
        .map(|d| (*d, dets.iter().filter(|x| *x == d).count()))
        .max_by_key(|(d, n)| (*n, std::cmp::Reverse(*d)))
        .unwrap_or((1, 0))
}

fn rotate(p: [f64; 3], [a, b, c]: [f64; 3]) -> [f64; 3] {
    let rz = |p: [f64; 3], t: f64| {
        let (s, c) = t.sin_cos();
        [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]]
    };
    let rx = |p: [f64; 3], t: f64| {
        let (s, c) = t.sin_cos();
        [p[0], c * p[1] - s * p[2], s * p[1] + c * p[2]]
    };
    rz(rx(rz(p, a), b), c)
}

/// One crossing of the picture: where along the closed polygon the over and the under strand pass
/// (segment index plus the fraction along it).
struct Crossing {
    over: f64,
    under: f64,
}

fn view_determinant(joints: &[[f64; 3]], euler: [f64; 3]) -> u64 {
    let mut v: Vec<[f64; 3]> = joints.iter().map(|p| rotate(*p, euler)).collect();
    if v.len() < 2 {
        return 1;
    }
    let n = v.len() as f64;
    let c = v.iter().fold([0.0; 3], |a, p| {
        [a[0] + p[0] / n, a[1] + p[1] / n, a[2] + p[2] / n]
    });
    let radius = v
        .iter()
        .map(|p| ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt())
        .fold(0.0, f64::max);
    v.push([c[0], c[1], c[2] + 1000.0 * (radius + 1.0)]);
    let crossings = crossings(&v);
    colouring_minor_determinant(&crossings)
}

/// The proper crossings of the closed polygon `v` seen along z.
fn crossings(v: &[[f64; 3]]) -> Vec<Crossing> {
    let n = v.len();
    let seg = |k: usize| (v[k], v[(k + 1) % n]);
    let mut out = Vec::new();
    for i in 0..n {
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue; // neighbours across the closing point
            }
            let ((a, b), (p, q)) = (seg(i), seg(j));
            let d1 = [b[0] - a[0], b[1] - a[1]];
            let d2 = [q[0] - p[0], q[1] - p[1]];
            let den = d1[0] * d2[1] - d1[1] * d2[0];
            if den == 0.0 {
                continue;
            }
            let w = [p[0] - a[0], p[1] - a[1]];
            let s = (w[0] * d2[1] - w[1] * d2[0]) / den;
            let t = (w[0] * d1[1] - w[1] * d1[0]) / den;
            if !(s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0) {
                continue;
            }
            let za = a[2] + s * (b[2] - a[2]);
            let zp = p[2] + t * (q[2] - p[2]);
            let (pi, pj) = (i as f64 + s, j as f64 + t);
            out.push(if za > zp {
                Crossing {
                    over: pi,
                    under: pj,
                }
            } else {
                Crossing {
                    over: pj,
                    under: pi,
                }
            });
        }
    }
    out
}

/// `|det|` of the colouring matrix with its last row and column struck out.
fn colouring_minor_determinant(crossings: &[Crossing]) -> u64 {
    let c = crossings.len();
    if c < 2 {
        return 1;
    }
    let mut unders: Vec<f64> = crossings.iter().map(|x| x.under).collect();
    unders.sort_by(f64::total_cmp);
    // Arc k runs from undercrossing k − 1 to undercrossing k (arc 0 wraps round the closing point).
    let arc_of = |pos: f64| unders.partition_point(|u| *u < pos) % c;
    let mut m = vec![vec![0u64; c]; c];
    let sub = |x: u64| (x + P - 1) % P;
    for (row, x) in crossings.iter().enumerate() {
        let k = unders.partition_point(|u| *u < x.under);
        let (incoming, outgoing) = (k % c, (k + 1) % c);
        let over = arc_of(x.over);
        m[row][over] = (m[row][over] + 2) % P;
        m[row][incoming] = sub(m[row][incoming]);
        m[row][outgoing] = sub(m[row][outgoing]);
    }
    let d = det_mod(
        m[..c - 1]
            .iter()
            .map(|r| r[..c - 1].to_vec())
            .collect::<Vec<_>>(),
    );
    d.min(P - d)
}

fn mul(a: u64, b: u64) -> u64 {
    ((a as u128 * b as u128) % P as u128) as u64
}

fn inverse(a: u64) -> u64 {
    // Fermat: a^(P−2).
    let (mut base, mut e, mut r) = (a, P - 2, 1u64);
    while e > 0 {
        if e & 1 == 1 {
            r = mul(r, base);
        }
        base = mul(base, base);
        e >>= 1;
    }
    r
}

/// Determinant modulo [`P`] by Gaussian elimination.
fn det_mod(mut a: Vec<Vec<u64>>) -> u64 {
    let n = a.len();
    let mut det = 1u64;
    for col in 0..n {
        let Some(piv) = (col..n).find(|&r| a[r][col] != 0) else {
            return 0;
        };
        if piv != col {
            a.swap(piv, col);
            det = (P - det) % P;
        }
        det = mul(det, a[col][col]);
        let inv = inverse(a[col][col]);
        for r in col + 1..n {
            let f = mul(a[r][col], inv);
            if f == 0 {
                continue;
            }
            let (top, rest) = a.split_at_mut(r);
            for (x, p) in rest[0][col..].iter_mut().zip(&top[col][col..]) {
                *x = (*x + P - mul(f, *p)) % P;
            }
        }
    }
    det
}

#[cfg(test)]
mod tests {
    use super::determinant;
    use std::f64::consts::TAU;

    /// A closed (p, q) torus knot, sampled (the last point is not the first again: the closure
    /// through the far point joins them).
    fn torus(p: f64, q: f64, samples: usize, mirror: bool) -> Vec<[f64; 3]> {
        let z = if mirror { -1.0 } else { 1.0 };
        (0..samples)
            .map(|k| {
                let t = TAU * k as f64 / samples as f64;
                let r = 2.0 + (q * t).cos();
                [r * (p * t).cos(), r * (p * t).sin(), z * (q * t).sin()]
            })
            .collect()
    }

    /// Two closed curves tied in series along one open rope: `a` opened at its right-most point,
    /// `b` (moved 10 along x) at its left-most, `a`'s last point joined to `b`'s first; the rope's
    /// ends then rise 5 and run far out over their own knots (to x = −30 and x = 40).
    fn in_series(a: &[[f64; 3]], b: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let open_at = |c: &[[f64; 3]], right: bool| {
            let k = (0..c.len())
                .max_by(|&i, &j| {
                    let (x, y) = (c[i][0], c[j][0]);
                    if right {
                        x.total_cmp(&y)
                    } else {
                        y.total_cmp(&x)
                    }
                })
                .unwrap();
            (0..c.len())
                .map(|i| c[(k + i) % c.len()])
                .collect::<Vec<_>>()
        };
        let a = open_at(a, true);
        let b: Vec<[f64; 3]> = open_at(b, false)
            .into_iter()
            .map(|p| [p[0] + 10.0, p[1], p[2]])
            .collect();
        let (s, e) = (a[0], b[b.len() - 1]);
        let mut out = vec![[-30.0, s[1], s[2] + 5.0], [s[0], s[1], s[2] + 5.0]];
        out.extend(a);
        out.extend(b);
        out.extend([[e[0], e[1], e[2] + 5.0], [40.0, e[1], e[2] + 5.0]]);
        out
    }

    #[test]
    fn the_determinants_of_curves_drawn_here() {
        let circle: Vec<[f64; 3]> = (0..60)
            .map(|k| {
                let t = TAU * k as f64 / 60.0;
                [3.0 * t.cos(), 3.0 * t.sin(), 0.1 * (2.0 * t).sin()]
            })
            .collect();
        assert_eq!(determinant(&circle), (1, 3));
        let trefoil = torus(2.0, 3.0, 200, false);
        assert_eq!(determinant(&trefoil), (3, 3));
        assert_eq!(determinant(&torus(2.0, 3.0, 200, true)), (3, 3));
        // The (2, 5) and (2, 7) torus knots, 5₁ and 7₁: determinants 5 and 7.
        assert_eq!(determinant(&torus(2.0, 5.0, 300, false)), (5, 3));
        assert_eq!(determinant(&torus(2.0, 7.0, 400, false)), (7, 3));
        // Square (trefoil and mirror) and granny (two alike): 9.
        let square = in_series(&trefoil, &torus(2.0, 3.0, 200, true));
        assert_eq!(determinant(&square), (9, 3));
        assert_eq!(determinant(&in_series(&trefoil, &trefoil)), (9, 3));
        // The surgeon's knot (5₁ and a mirror trefoil in series): 15.
        let five = torus(2.0, 5.0, 300, false);
        assert_eq!(
            determinant(&in_series(&five, &torus(2.0, 3.0, 200, true))),
            (15, 3)
        );
        // An open rope: the trefoil cut open and its ends run far out; the same rope run straight.
        let mut open = trefoil.clone();
        let first = open[0];
        open.insert(0, [first[0] + 30.0, first[1], first[2]]);
        let last = *open.last().unwrap();
        open.push([last[0] + 30.0, last[1] + 0.5, last[2]]);
        assert_eq!(determinant(&open).0, 3);
        let straight: Vec<[f64; 3]> = (0..40).map(|k| [k as f64, 0.0, 0.0]).collect();
        assert_eq!(determinant(&straight), (1, 3));
    }
}
