//! Knot identification on ropes built here, by hand, independently of the knot scripts and of the
//! identification's own test shapes: a long trefoil drawn as a pulled-out overhand knot (a helix-like
//! curl with the ends run out straight), its mirror, the square and granny knots composed from two of
//! them along one rope, and randomly perturbed versions of each. The identification must name each
//! with all named closures agreeing, and must not name a knot in an unknotted rope of the same picture
//! (the same curl climbing steadily, so the later strand passes over at every crossing).

use knots::{KnotType, identify};
use nalgebra::Vector3;

type V = Vector3<f64>;

/// SplitMix64, for reproducible perturbations.
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn sym(&mut self, a: f64) -> f64 {
        a * (2.0 * self.unit() - 1.0)
    }
}

/// An overhand knot as a rope would lie, loosely tied and pulled out along x, centred at `x0`.
///
/// Drawn from the torus-knot picture of the trefoil: the (2,3) torus knot `r = 2 + cos 3t`,
/// `θ = 2t`, `z = ± sin 3t` is cut open at its left-most point and both cut ends are run straight out
/// along −x and +x. `hand` = +1 or −1 picks the chirality (the mirror flips z).
fn overhand(x0: f64, hand: f64, samples: usize) -> Vec<V> {
    // The closed (2,3) torus knot, sampled.
    let closed: Vec<V> = (0..samples)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / samples as f64;
            let r = 2.0 + (3.0 * t).cos();
            V::new(
                r * (2.0 * t).cos(),
                r * (2.0 * t).sin(),
                hand * (3.0 * t).sin(),
            )
        })
        .collect();
    open_out(&closed, x0)
}

/// Cuts a closed curve open at its left-most point and runs both ends out along x, 15 units beyond
/// the knot, the first end leaving to the left and the last to the right (as the two ends of a knot
/// in the middle of a rope); shifted by `x0`.
fn open_out(closed: &[V], x0: f64) -> Vec<V> {
    let n = closed.len();
    let c = (0..n)
        .min_by(|&i, &j| closed[i].x.total_cmp(&closed[j].x))
        .expect("points");
    let max_x = closed.iter().map(|p| p.x).fold(f64::MIN, f64::max);
    let min_x = closed[c].x;
    let mut out = Vec::new();
    // The first end comes in from far left at the cut's height.
    let first = closed[(c + 1) % n];
    out.push(V::new(min_x - 15.0, first.y, first.z));
    for k in 1..n {
        out.push(closed[(c + k) % n]);
    }
    // The last end goes up and over (clear of the knot, z = 4) and out to the far right.
    let last = closed[(c + n - 1) % n];
    out.push(V::new(min_x - 1.0, last.y, 4.0));
    out.push(V::new(max_x + 15.0, last.y, 4.0));
    for p in &mut out {
        p.x += x0;
    }
    out
}

/// Two overhand knots along one rope: the first's right end leads into the second's left end.
fn two_knots(first: f64, second: f64) -> Vec<V> {
    in_series(overhand(0.0, first, 150), &overhand(0.0, second, 150))
}

/// Two ropes in series: `b` placed to the right of `a`'s right end, joined by a straight run.
fn in_series(a: Vec<V>, b: &[V]) -> Vec<V> {
    let shift = *a.last().expect("a") - b[0] + V::new(5.0, 0.0, 0.0);
    let mut rope = a;
    rope.extend(b.iter().map(|p| p + shift));
    rope
}

/// The curl of [`overhand`] seen from above (the same three crossings in the picture) but with its
/// height climbing steadily along the rope, so at every crossing the later strand passes over: a
/// spiral, not a knot.
fn unknotted_curl(samples: usize) -> Vec<V> {
    let closed: Vec<V> = (0..samples)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / samples as f64;
            let r = 2.0 + (3.0 * t).cos();
            V::new(r * (2.0 * t).cos(), r * (2.0 * t).sin(), t)
        })
        .collect();
    open_out(&closed, 0.0)
}

/// Moves every point by up to `amp` in each coordinate.
fn perturbed(points: &[V], amp: f64, rng: &mut Rng) -> Vec<V> {
    points
        .iter()
        .map(|p| p + V::new(rng.sym(amp), rng.sym(amp), rng.sym(amp)))
        .collect()
}

/// The rope is named `want`, by every closure that could be named, and at least five of six were.
fn check(points: &[V], want: KnotType, what: &str) {
    let r = identify(points);
    assert_eq!(r.kind, want, "{what}: {r:?}");
    assert!(r.closures >= 5, "{what}: most closures named: {r:?}");
    assert_eq!(
        r.agreeing, r.closures,
        "{what}: every closure agrees: {r:?}"
    );
}

#[test]
fn hand_built_trefoil_and_its_mirror() {
    let left = overhand(0.0, 1.0, 150);
    let right = overhand(0.0, -1.0, 150);
    check(&left, KnotType::Trefoil, "trefoil");
    check(&right, KnotType::Trefoil, "mirror trefoil");
    let (a, b) = (identify(&left), identify(&right));
    assert_eq!((a.crossings, b.crossings), (3, 3));
    assert_eq!(a.writhe, -b.writhe, "mirrors have opposite writhe");
    assert_eq!(a.writhe.abs(), 3);
    assert_eq!((a.determinant, b.determinant), (3, 3));
}

#[test]
fn square_and_granny_composed_from_hand_built_trefoils() {
    check(
        &two_knots(1.0, -1.0),
        KnotType::Square,
        "trefoil then mirror",
    );
    check(
        &two_knots(-1.0, 1.0),
        KnotType::Square,
        "mirror then trefoil",
    );
    check(&two_knots(1.0, 1.0), KnotType::Granny, "two trefoils");
    check(&two_knots(-1.0, -1.0), KnotType::Granny, "two mirrors");
    let sq = identify(&two_knots(1.0, -1.0));
    let gr = identify(&two_knots(1.0, 1.0));
    assert_eq!((sq.writhe, sq.determinant), (0, 9));
    assert_eq!((gr.writhe.abs(), gr.determinant), (6, 9));
}

#[test]
fn unknotted_curls_are_not_knots() {
    check(&unknotted_curl(150), KnotType::Unknot, "climbing curl");
    let straight: Vec<V> = (0..=40).map(|k| V::new(k as f64, 0.0, 0.0)).collect();
    check(&straight, KnotType::Unknot, "straight rope");
}

#[test]
fn perturbed_knots_keep_their_names() {
    // Each point moved by up to 0.1 in each coordinate: a tenth of the knot's strand separation
    // (the torus curve's strands are about 1 apart at the crossings), 20 draws per knot.
    let mut rng = Rng(0xC0FFEE);
    let cases: Vec<(Vec<V>, KnotType, &str)> = vec![
        (overhand(0.0, 1.0, 150), KnotType::Trefoil, "trefoil"),
        (overhand(0.0, -1.0, 150), KnotType::Trefoil, "mirror"),
        (two_knots(1.0, -1.0), KnotType::Square, "square"),
        (two_knots(1.0, 1.0), KnotType::Granny, "granny"),
        (unknotted_curl(150), KnotType::Unknot, "curl"),
    ];
    for (rope, want, what) in cases {
        for draw in 0..20 {
            let p = perturbed(&rope, 0.1, &mut rng);
            check(&p, want, &format!("{what}, draw {draw}"));
        }
    }
}

/// The closure of a braid on `strands` strands (generators `k` and `-k`: strands `k − 1` and `k`
/// cross, the one moving outward passing over for `k` and under for `-k`), drawn round the z axis:
/// slot `i` at radius `1.5 + i` and height `0.8 i` (a cone, so that no view sees the strands edge
/// on), each generator over an equal arc of the circle, the crossing strands changing radius by a
/// half cosine and rising or sinking by up to 0.5 more as they pass. The strand in
/// slot 0 at angle 0 is followed round until it comes back (a knot when the braid's permutation is
/// one cycle), then cut open at its left-most point with the ends run out as in [`open_out`].
fn closed_braid(word: &[i32], strands: usize, per_generator: usize) -> Vec<V> {
    let g = word.len();
    let arc = std::f64::consts::TAU / g as f64;
    let mut closed = Vec::new();
    let mut slot = 0usize;
    for _lap in 0..strands {
        for (k, &w) in word.iter().enumerate() {
            let lo = w.unsigned_abs() as usize - 1;
            let (to, sign) = if slot == lo {
                (lo + 1, if w > 0 { 1.0 } else { -1.0 })
            } else if slot == lo + 1 {
                (lo, if w > 0 { -1.0 } else { 1.0 })
            } else {
                (slot, 0.0)
            };
            for j in 0..per_generator {
                let s = j as f64 / per_generator as f64;
                let theta = arc * (k as f64 + s);
                let blend = (1.0 - (std::f64::consts::PI * s).cos()) / 2.0;
                let r = 1.5 + slot as f64 + (to as f64 - slot as f64) * blend;
                let z = sign * 0.5 * (std::f64::consts::PI * s).sin() + 0.8 * (r - 1.5);
                closed.push(V::new(r * theta.cos(), r * theta.sin(), z));
            }
            slot = to;
        }
        if slot == 0 {
            break;
        }
    }
    open_out(&closed, 0.0)
}

#[test]
fn hand_built_double_overhand_and_its_mirror() {
    // The double overhand is 5₁, the (2, 5) torus knot: the closure of the two-strand braid σ₁⁵,
    // and its mirror (every crossing the other way).
    let five_one = closed_braid(&[1, 1, 1, 1, 1], 2, 16);
    let mirror = closed_braid(&[-1, -1, -1, -1, -1], 2, 16);
    check(&five_one, KnotType::DoubleOverhand, "5₁");
    check(&mirror, KnotType::DoubleOverhand, "mirror 5₁");
    let (a, b) = (identify(&five_one), identify(&mirror));
    assert_eq!((a.determinant, b.determinant), (5, 5));
    // No diagram of 5₁ has fewer than 5 crossings (Reidemeister I and II alone need not reach 5).
    assert!(a.crossings >= 5 && b.crossings >= 5, "{a:?} {b:?}");
    assert_eq!(a.writhe, -b.writhe, "mirrors have opposite writhe");
    // V = t² + t⁴ − t⁵ + t⁶ − t⁷ for one of them, its mirror (t → 1/t) for the other.
    let (mut ja, mut jb) = (a.jones.1.clone(), b.jones.1.clone());
    if ja != [1, 0, 1, -1, 1, -1] {
        std::mem::swap(&mut ja, &mut jb);
    }
    assert_eq!(ja, [1, 0, 1, -1, 1, -1], "{a:?} {b:?}");
    assert_eq!(jb, [-1, 1, -1, 1, 0, 1], "{a:?} {b:?}");
    // Other closed braids are not called so: the trefoil (σ₁³), the three-twist knot 5₂
    // (σ₁³σ₂σ₁⁻¹σ₂, the Knot Atlas's representative: determinant 7, other) and the figure eight
    // (σ₁σ₂⁻¹σ₁σ₂⁻¹: the same determinant as 5₁, other).
    check(&closed_braid(&[1, 1, 1], 2, 40), KnotType::Trefoil, "σ₁³");
    let five_two = closed_braid(&[1, 1, 1, 2, -1, 2], 3, 16);
    check(&five_two, KnotType::Other, "5₂");
    assert_eq!(identify(&five_two).determinant, 7);
    check(&closed_braid(&[1, -2, 1, -2], 3, 40), KnotType::Other, "4₁");
    let mut rng = Rng(0x005E_ED51);
    for draw in 0..20 {
        let p = perturbed(&five_one, 0.1, &mut rng);
        check(&p, KnotType::DoubleOverhand, &format!("5₁, draw {draw}"));
    }
}

#[test]
fn hand_built_surgeons_knot_and_its_granny_form() {
    // The surgeon's knot: the double overhand (σ₁⁵ closed, as above) and then an overhand of the
    // other hand along the same rope; with an overhand of the same hand it is the granny form
    // (5₁ # 3₁), the same determinant 15 and another knot. Which overhand is of the other hand is
    // not assumed: of the two compositions exactly one is the surgeon's, and it is the one whose
    // crossings mostly cancel (writhe ±5 ∓ 3 = ±2; the granny form's is ±8).
    let five_one = closed_braid(&[1, 1, 1, 1, 1], 2, 16);
    let mirror = closed_braid(&[-1, -1, -1, -1, -1], 2, 16);
    let mut surgeons = Vec::new();
    // The double overhand and its mirror, each with an overhand of either hand. Every closure of the
    // first agrees; with the mirror a closure may pass through the tangle, so the majority is checked.
    for (double, all_agree) in [(&five_one, true), (&mirror, false)] {
        let mut names = Vec::new();
        for hand in [1.0, -1.0] {
            let rope = in_series(double.clone(), &overhand(0.0, hand, 150));
            let r = identify(&rope);
            if all_agree {
                assert!(r.closures >= 5 && r.agreeing == r.closures, "{r:?}");
            }
            names.push((r.kind, r.writhe.abs(), r.determinant));
            if r.kind == KnotType::Surgeons {
                surgeons.push(rope);
            }
        }
        names.sort();
        assert_eq!(
            names,
            [(KnotType::Surgeons, 2, 15), (KnotType::Other, 8, 15)]
        );
    }
    // Perturbed, it keeps its name; the square and granny of two trefoils are not called so.
    let mut rng = Rng(0x5E_6E0);
    for draw in 0..20 {
        let p = perturbed(&surgeons[0], 0.1, &mut rng);
        check(&p, KnotType::Surgeons, &format!("surgeon's, draw {draw}"));
    }
    check(&two_knots(1.0, -1.0), KnotType::Square, "square");
    check(&two_knots(1.0, 1.0), KnotType::Granny, "granny");
}

/// The square and granny of two trefoils tied one after the other are found in series: a cut leaves
/// a trefoil in each half (of the hands they were tied with); a single trefoil, the spiral and a
/// straight rope have no such cut. (A reef tied round itself, whose halves are unknotted, is not built
/// here; the check of a half is the same `identify`.)
#[test]
fn knots_in_series_are_found_and_single_knots_are_not() {
    use knots::in_series as series;
    for (first, second) in [(1.0, -1.0), (1.0, 1.0), (-1.0, -1.0)] {
        let rope = two_knots(first, second);
        let s = series(&rope, 24).expect("two knots in series");
        assert_eq!(s.first.kind, KnotType::Trefoil, "{s:?}");
        assert_eq!(s.second.kind, KnotType::Trefoil, "{s:?}");
        // The writhes say the hands: opposite for the square, equal for the granny.
        assert_eq!(
            s.first.writhe.signum() == s.second.writhe.signum(),
            first == second,
            "{s:?}"
        );
        // The cut lies between the two knots (each made of 150 samples plus its run-out).
        assert!(s.cut > 100 && s.cut < rope.len() - 100, "cut at {}", s.cut);
    }
    assert!(series(&overhand(0.0, 1.0, 150), 24).is_none());
    assert!(series(&unknotted_curl(300), 24).is_none());
    let straight: Vec<V> = (0..60).map(|i| V::new(i as f64, 0.0, 0.0)).collect();
    assert!(series(&straight, 24).is_none());
}

/// The fast namer (`Namer`, one closure, remembered diagrams) names every hand-built rope above as
/// its construction says, perturbed or not, and moved or turned as a whole; a diagram it has named
/// is not evaluated again.
#[test]
fn the_fast_namer_names_the_hand_built_ropes() {
    use knots::Namer;
    let five_one = closed_braid(&[1, 1, 1, 1, 1], 2, 16);
    let cases: Vec<(Vec<V>, KnotType, &str)> = vec![
        (overhand(0.0, 1.0, 150), KnotType::Trefoil, "trefoil"),
        (overhand(0.0, -1.0, 150), KnotType::Trefoil, "mirror"),
        (two_knots(1.0, -1.0), KnotType::Square, "square"),
        (two_knots(1.0, 1.0), KnotType::Granny, "granny"),
        (unknotted_curl(150), KnotType::Unknot, "curl"),
        (five_one.clone(), KnotType::DoubleOverhand, "5₁"),
        (
            closed_braid(&[1, 1, 1, 2, -1, 2], 3, 16),
            KnotType::Other,
            "5₂",
        ),
        (closed_braid(&[1, -2, 1, -2], 3, 40), KnotType::Other, "4₁"),
        (
            vec![V::zeros(), V::x(), V::new(2.0, 0.0, 0.0)],
            KnotType::Unknot,
            "straight",
        ),
    ];
    // The surgeon's knot: the double overhand and whichever overhand makes it (see above).
    let surgeons = [1.0, -1.0]
        .into_iter()
        .map(|hand| in_series(five_one.clone(), &overhand(0.0, hand, 150)))
        .find(|r| identify(r).kind == KnotType::Surgeons)
        .expect("one composition is the surgeon's");
    let mut rng = Rng(0xFA57);
    let turn = nalgebra::Rotation3::from_euler_angles(0.4, -1.1, 2.3);
    for (rope, want, what) in cases
        .into_iter()
        .chain([(surgeons, KnotType::Surgeons, "surgeon's")])
    {
        let mut namer = Namer::new();
        let got = namer.name(&rope);
        assert_eq!(
            got,
            want,
            "{what}: {} crossings, identify {:?}",
            namer.crossings(),
            identify(&rope).crossings
        );
        let evaluated = namer.evaluations();
        assert_eq!(namer.name(&rope), want, "{what}, again");
        assert_eq!(namer.evaluations(), evaluated, "{what}: remembered");
        let moved: Vec<V> = rope
            .iter()
            .map(|p| turn * p + V::new(3.0, -7.0, 11.0))
            .collect();
        assert_eq!(namer.name(&moved), want, "{what}, moved and turned");
        for draw in 0..10 {
            let p = perturbed(&rope, 0.1, &mut rng);
            assert_eq!(namer.name(&p), want, "{what}, draw {draw}");
            assert_eq!(Namer::new().name(&p), want, "{what}, draw {draw}, new");
        }
    }
}

/// The namer's work is bounded: a rope of 20,000 points crumpled into a ball (a random walk kept
/// inside radius 3), whose every view crosses itself far more often than the namer evaluates, is
/// `Other`; the same walk's first 30 points (a few crossings) are still named.
#[test]
fn the_fast_namer_gives_up_on_a_crumpled_rope() {
    use knots::Namer;
    let mut rng = Rng(0xC2_0A1);
    let mut p = V::zeros();
    let mut walk = Vec::new();
    for _ in 0..20_000 {
        let step = V::new(rng.sym(1.0), rng.sym(1.0), rng.sym(1.0)).normalize() * 0.5;
        p = if (p + step).norm() > 3.0 {
            p - step
        } else {
            p + step
        };
        walk.push(p);
    }
    let mut namer = Namer::new();
    assert_eq!(namer.name(&walk), KnotType::Other);
    let short = namer.name(&walk[..30]);
    assert_eq!(short, identify(&walk[..30]).kind, "a short walk is named");
}
