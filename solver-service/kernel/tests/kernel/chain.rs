//! Invariants of RESOLUTION-TRACTRIX on whole chains.

use crate::support::{Rng, max_length_error, max_position_length_error};
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;
use tractrix::link::step;
use tractrix::{Chain, ChainError, Method, MoveOptions, Substeps};

fn curled_rope(n: usize, seed: u64) -> Chain<f64, 3> {
    let mut rng = Rng(seed);
    let mut p = vec![Vector3::zeros()];
    let mut dir = Vector3::x();
    for _ in 0..n {
        dir = (dir + rng.dir3() * 0.6).normalize();
        p.push(p.last().unwrap() + dir);
    }
    Chain::from_points(&p).unwrap()
}

fn opts(method: Method, k: u32) -> MoveOptions<f64> {
    MoveOptions {
        method,
        substeps: Substeps::Fixed(k),
        ..MoveOptions::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// The compensated sum's running sum and carry are, bit for bit, those of Neumaier's form written
    /// here (the error of each addition taken after comparing magnitudes), over terms of any size.
    #[test]
    fn the_compensated_sum_is_neumaiers_bit_for_bit(
        terms in proptest::collection::vec((-1e6f64..1e6, -30i32..30, 0usize..3), 1..200),
    ) {
        let mut sum = tractrix::math::CompensatedSum::<f64, 3>::new(Vector3::zeros());
        let (mut s, mut c) = ([0.0f64; 3], [0.0f64; 3]);
        for &(m, e, k) in &terms {
            let mut v = Vector3::new(m * 0.37, -m * 1.3, m);
            v[k] *= 2f64.powi(e);
            sum.add(&v);
            for j in 0..3 {
                let t = s[j] + v[j];
                c[j] += if s[j].abs() >= v[j].abs() { (s[j] - t) + v[j] } else { (v[j] - t) + s[j] };
                s[j] = t;
            }
        }
        let (got_s, got_c) = sum.parts();
        for j in 0..3 {
            prop_assert_eq!(got_s[j].to_bits(), s[j].to_bits());
            prop_assert_eq!(got_c[j].to_bits(), c[j].to_bits());
        }
    }

    /// A move of `k` substeps equals, bit for bit, `k` substeps run one after the other over the whole
    /// chain (the order written here, link by link from the moved joint outward), however the kernel
    /// schedules them (it runs them as wavefronts: several substeps in flight along the chain). The
    /// exception is the closed form from `SIMD_FROM` substeps on, whose lanes take the exponential
    /// from a polynomial: there the links agree to 1e-12 of a link.
    #[test]
    fn substeps_in_any_order_give_the_sequential_result(
        seed in 0u64..1000, n in 1usize..60, joint_frac in 0.0f64..=1.0, m in 0usize..3,
        k in 1u32..40, tx in -30.0f64..30.0, ty in -30.0f64..30.0, tz in -30.0f64..30.0,
    ) {
        let method = [Method::Tractrix, Method::TractrixPaper, Method::FollowTheLeader][m];
        let mut c = curled_rope(n, seed);
        let joint = (joint_frac * n as f64).round() as usize;
        let target = Vector3::new(tx, ty, tz);
        // The substep as the chain divides the move (from where it says the joint is), and the
        // expected links, computed here substep by substep.
        let sub = (target - c.joint(joint)) / k as f64;
        let mut links = c.links().to_vec();
        let lengths = c.lengths().to_vec();
        let mut fallbacks = 0u32;
        for _ in 0..k {
            let mut shift = sub;
            for i in (0..joint).rev() {
                let (st, fb) = step(method, &(-links[i]), &shift, lengths[i]);
                links[i] = -st.link;
                shift = st.tail_shift;
                fallbacks += fb as u32;
            }
            let mut shift = sub;
            for i in joint..n {
                let (st, fb) = step(method, &links[i], &shift, lengths[i]);
                links[i] = st.link;
                shift = st.tail_shift;
                fallbacks += fb as u32;
            }
        }
        let out = c.move_joint(joint, target, &opts(method, k)).unwrap();
        prop_assert_eq!(out.substeps, k);
        prop_assert_eq!(out.paper_fallbacks, fallbacks);
        let simd = method == Method::Tractrix && k as usize >= tractrix::chain::SIMD_FROM;
        for (i, (a, b)) in c.links().iter().zip(&links).enumerate() {
            for (x, y) in a.iter().zip(b.iter()) {
                if simd {
                    prop_assert!((x - y).abs() <= 1e-12, "link {} of {}, joint {}, k {}: {} vs {}", i, n, joint, k, x, y);
                } else {
                    prop_assert_eq!(x.to_bits(), y.to_bits(), "link {} of {}, joint {}, k {}", i, n, joint, k);
                }
            }
        }
    }

    /// Any joint, any method, any substeps: the joint lands on its target (its position summed here from
    /// the chain's origin and link vectors), lengths are kept, everything is finite.
    #[test]
    fn moved_joint_lands_and_lengths_are_kept(
        seed in 0u64..1000, joint_frac in 0.0f64..=1.0, m in 0usize..3, k in 1u32..8,
        tx in -30.0f64..30.0, ty in -30.0f64..30.0, tz in -30.0f64..30.0,
    ) {
        let mut c = curled_rope(20, seed);
        let joint = (joint_frac * 20.0).round() as usize;
        let target = Vector3::new(tx, ty, tz);
        c.move_joint(joint, target, &opts(Method::ALL[m], k)).unwrap();
        let summed = c.links()[..joint].iter().fold(c.origin(), |p, l| p + l);
        prop_assert!((summed - target).norm() <= 1e-12 * (1.0 + target.norm()));
        prop_assert!(max_length_error(&c) <= 1e-12);
        prop_assert!(max_position_length_error(&c) <= 1e-12);
        prop_assert!(c.positions().iter().all(|p| p.iter().all(|x| x.is_finite())));
    }

    /// Observation 4 of section 4: for a single straight move of the head, dr₀ ≤ dr₁ ≤ … ≤ drₙ. Checked on
    /// the displacements the sweep propagates (relative, so it holds for moves of 1e-12 too), and on the
    /// published positions for moves large enough to stand above their rounding (ε·|X|).
    #[test]
    fn displacements_die_out_from_head_to_tail(
        seed in 0u64..1000, m in 0usize..3, log_d in -12.0f64..2.0,
        dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in -1.0f64..1.0,
    ) {
        let d = Vector3::new(dx, dy, dz);
        prop_assume!(d.norm() > 1e-3);
        let method = Method::ALL[m];
        let mut c = curled_rope(30, seed);
        let mut shift = d.normalize() * 10f64.powf(log_d);
        let target = c.head() + shift;
        for (l, &len) in c.links().iter().zip(c.lengths()).rev() {
            let (st, _) = step(method, &(-l), &shift, len);
            // The paper's form gets the shift as new position − old position, through asech(z) with
            // z = (distance of the tail from the line of motion) / L. asech is ill-conditioned near z = 1
            // (a link across the motion): a rounding ε in z moves the tail by about ε·L / (z·√(1 − z²)),
            // and by √(2ε)·L at z = 1. Below that the tail must not move more than the head.
            let slack = if method == Method::TractrixPaper {
                let along = l.dot(&shift) / shift.norm();
                let z = ((l.norm_squared() - along * along).max(0.0).sqrt() / len).min(1.0);
                let cond = 1.0 / (z * (1.0 - z * z).sqrt()).max(f64::EPSILON.sqrt());
                4.0 * f64::EPSILON * len * (1.0 + cond)
            } else {
                0.0
            };
            prop_assert!(st.tail_shift.norm() <= shift.norm() * (1.0 + 1e-12) + slack,
                "{method:?}: tail shift {:e} > head shift {:e}", st.tail_shift.norm(), shift.norm());
            shift = st.tail_shift;
        }
        let before = c.positions();
        c.move_joint(30, target, &opts(method, 1)).unwrap();
        let after = c.positions();
        let dr: Vec<f64> = before.iter().zip(&after).map(|(a, b)| (b - a).norm()).collect();
        let rounding = 8.0 * f64::EPSILON * before.iter().chain(&after).map(|p| p.norm()).fold(1.0, f64::max);
        for i in 1..dr.len() {
            prop_assert!(dr[i - 1] <= dr[i] * (1.0 + 1e-12) + rounding,
                "dr[{}] = {:e} > dr[{}] = {:e}", i - 1, dr[i - 1], i, dr[i]);
        }
    }
}

/// The continuous motion, integrated here with no kernel code: joint `m` moves at constant velocity
/// along the straight segment to `target` over t ∈ [0, 1]; every other joint is dragged by its
/// neighbour toward `m` at fixed distance (the tractrix: its velocity is the component of the
/// neighbour's velocity along the link). Classical RK4 with `steps` steps. Returns every joint.
fn dragged_by_rk4(
    start: &[Vector3<f64>],
    m: usize,
    target: Vector3<f64>,
    steps: usize,
) -> Vec<Vector3<f64>> {
    let v = target - start[m];
    // Velocities of every joint for positions `p` (joint m at its place on the segment).
    let velocities = |p: &[Vector3<f64>]| -> Vec<Vector3<f64>> {
        let mut w = vec![Vector3::zeros(); p.len()];
        w[m] = v;
        for i in (0..m).rev() {
            let u = (p[i + 1] - p[i]).normalize();
            w[i] = u * u.dot(&w[i + 1]);
        }
        for i in m + 1..p.len() {
            let u = (p[i - 1] - p[i]).normalize();
            w[i] = u * u.dot(&w[i - 1]);
        }
        w
    };
    let h = 1.0 / steps as f64;
    let mut p = start.to_vec();
    let shifted = |p: &[Vector3<f64>], k: &[Vector3<f64>], s: f64| -> Vec<Vector3<f64>> {
        p.iter().zip(k).map(|(a, b)| a + b * s).collect()
    };
    for _ in 0..steps {
        let k1 = velocities(&p);
        let k2 = velocities(&shifted(&p, &k1, h / 2.0));
        let k3 = velocities(&shifted(&p, &k2, h / 2.0));
        let k4 = velocities(&shifted(&p, &k3, h));
        for i in 0..p.len() {
            p[i] += (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (h / 6.0);
        }
    }
    p
}

/// Where a move puts the whole chain, against the continuous motion integrated independently
/// ([`dragged_by_rk4`]): the tractrix with k substeps converges to it at second order (each doubling of
/// k divides the largest joint error by about 4), and at 64 substeps every joint is within 1e-3 of it;
/// the moved joint lands on the target the integration reaches.
#[test]
fn a_move_puts_every_joint_where_the_continuous_motion_does() {
    for (seed, m) in [(1, 20), (2, 0), (3, 9), (4, 14)] {
        let rope = curled_rope(20, seed);
        let target = rope.joint(m) + Vector3::new(3.0, -2.0, 1.5);
        let truth = dragged_by_rk4(&rope.positions(), m, target, 20_000);
        assert!(
            (truth[m] - target).norm() < 1e-9,
            "the integration misses its end"
        );
        let error = |k: u32| {
            let mut c = rope.clone();
            c.move_joint(m, target, &opts(Method::Tractrix, k)).unwrap();
            // Joints summed here from the origin and the link vectors.
            let mut p = c.origin();
            let mut worst = (p - truth[0]).norm();
            for (l, t) in c.links().iter().zip(&truth[1..]) {
                p += l;
                worst = worst.max((p - t).norm());
            }
            worst
        };
        let e: Vec<f64> = [8, 16, 32, 64].into_iter().map(error).collect();
        let shown: Vec<String> = e.iter().map(|x| format!("{x:.2e}")).collect();
        println!("joint {m}: largest joint error at 8, 16, 32, 64 substeps {shown:?}");
        assert!(e[3] < 1e-3, "joint {m}: {e:?}");
        for w in e.windows(2) {
            let r = w[0] / w[1];
            assert!(r > 3.0 && r < 5.0, "joint {m}: ratio {r:.2}, errors {e:?}");
        }
    }
}

/// A spatial chain lying in a plane, moved within the plane, stays in it exactly; and a planar (2D)
/// chain gives the same answer as its 3D embedding.
#[test]
fn planar_stays_planar_and_matches_its_embedding() {
    let mut rng = Rng(5);
    let mut p2 = vec![Vector2::zeros()];
    for _ in 0..25 {
        let a = rng.range(-1.0, 1.0);
        p2.push(p2.last().unwrap() + Vector2::new(a.cos(), a.sin()) * 0.2);
    }
    let p3: Vec<_> = p2.iter().map(|p| Vector3::new(p.x, p.y, 0.0)).collect();
    for method in Method::ALL {
        let mut c2 = Chain::<f64, 2>::from_points(&p2).unwrap();
        let mut c3 = Chain::<f64, 3>::from_points(&p3).unwrap();
        for _ in 0..200 {
            let joint = rng.below(26);
            let t = Vector2::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0));
            c2.move_joint(joint, t, &opts(method, 3)).unwrap();
            c3.move_joint(joint, Vector3::new(t.x, t.y, 0.0), &opts(method, 3))
                .unwrap();
        }
        for (a, b) in c2.positions().iter().zip(c3.positions()) {
            assert_eq!(b.z, 0.0, "{method:?}: left the plane");
            assert!(
                (a - b.xy()).norm() < 1e-9,
                "{method:?}: 2D {a:?} vs 3D {b:?}"
            );
        }
    }
}

/// Remark 2: an interior joint splits the chain; both parts follow outward. Moving joint m equals moving
/// the head of the tail part and the tail of the head part separately.
#[test]
fn interior_move_splits_the_chain() {
    let c0 = curled_rope(24, 9);
    let pts = c0.positions();
    let m = 10;
    let target = pts[m] + Vector3::new(0.7, -0.4, 1.1);
    let mut whole = c0.clone();
    whole
        .move_joint(m, target, &opts(Method::Tractrix, 4))
        .unwrap();
    let mut lower = Chain::from_points(&pts[..=m]).unwrap();
    lower
        .move_joint(m, target, &opts(Method::Tractrix, 4))
        .unwrap();
    let mut upper = Chain::from_points(&pts[m..]).unwrap();
    upper
        .move_joint(0, target, &opts(Method::Tractrix, 4))
        .unwrap();
    let w = whole.positions();
    for (i, p) in lower.positions().iter().enumerate() {
        assert!((w[i] - p).norm() < 1e-12);
    }
    for (i, p) in upper.positions().iter().enumerate() {
        assert!((w[m + i] - p).norm() < 1e-12);
    }
}

/// Moving the tail is moving the head of the reversed chain.
#[test]
fn tail_move_is_head_move_of_reversed_chain() {
    let c = curled_rope(15, 21);
    let mut pts = c.positions();
    let target = pts[0] + Vector3::new(-2.0, 1.0, 0.5);
    let mut a = c.clone();
    a.move_joint(0, target, &opts(Method::Tractrix, 2)).unwrap();
    pts.reverse();
    let mut b = Chain::from_points(&pts).unwrap();
    b.move_joint(15, target, &opts(Method::Tractrix, 2))
        .unwrap();
    let mut pb = b.positions();
    pb.reverse();
    for (x, y) in a.positions().iter().zip(&pb) {
        assert!((x - y).norm() < 1e-12);
    }
}

/// Substeps by maximum step: the count follows the shortest link, and a path is a sequence of moves.
#[test]
fn substeps_and_paths() {
    let mut c = Chain::<f64, 3>::from_parts(
        Vector3::zeros(),
        vec![Vector3::x(); 4],
        vec![1.0, 0.5, 2.0, 1.0],
    )
    .unwrap();
    let o = MoveOptions {
        substeps: Substeps::MaxStep(0.1),
        ..MoveOptions::default()
    };
    assert_eq!(c.substep_count(&Vector3::new(1.0, 0.0, 0.0), &o), Ok(20));
    let path = [
        Vector3::new(4.0, 1.0, 0.0),
        Vector3::new(3.0, 2.0, 0.0),
        Vector3::new(2.0, 2.0, 1.0),
    ];
    let mut stepwise = c.clone();
    let out = c.move_along(4, &path, &o).unwrap();
    let mut total = 0;
    for p in &path {
        total += stepwise.move_joint(4, *p, &o).unwrap().substeps;
    }
    assert_eq!(out.substeps, total);
    assert_eq!(c, stepwise);
}

/// Bad input gets an error and changes nothing.
#[test]
fn errors_change_nothing() {
    let c0 = curled_rope(10, 1);
    let mut c = c0.clone();
    let nan = Vector3::new(f64::NAN, 0.0, 0.0);
    assert_eq!(
        c.move_joint(3, nan, &MoveOptions::default()),
        Err(ChainError::NonFinite)
    );
    assert!(matches!(
        c.move_joint(11, Vector3::zeros(), &MoveOptions::default()),
        Err(ChainError::JointOutOfRange {
            joint: 11,
            last: 10
        })
    ));
    let tight = MoveOptions {
        substeps: Substeps::MaxStep(1e-9),
        max_substeps: 1000,
        ..MoveOptions::default()
    };
    assert!(matches!(
        c.move_joint(10, Vector3::new(50.0, 0.0, 0.0), &tight),
        Err(ChainError::TooManySubsteps { limit: 1000, .. })
    ));
    for bad in [
        Substeps::Fixed(0),
        Substeps::MaxStep(0.0),
        Substeps::MaxStep(f64::NAN),
        Substeps::MaxStep(-1.0),
    ] {
        let o = MoveOptions {
            substeps: bad,
            ..MoveOptions::default()
        };
        assert!(matches!(
            c.move_joint(10, Vector3::zeros(), &o),
            Err(ChainError::BadOption(_))
        ));
    }
    // A path with one bad point moves nothing, even the points before it.
    let path = [Vector3::new(1.0, 2.0, 3.0), nan];
    assert_eq!(
        c.move_along(10, &path, &MoveOptions::default()),
        Err(ChainError::NonFinite)
    );
    assert_eq!(c, c0);
    // Construction errors.
    assert_eq!(
        Chain::<f64, 3>::from_points(&[Vector3::zeros()]),
        Err(ChainError::Empty)
    );
    assert!(matches!(
        Chain::<f64, 3>::from_points(&[Vector3::zeros(), Vector3::zeros()]),
        Err(ChainError::BadLength { link: 1, .. })
    ));
}

/// The paper's method falls back to the closed form exactly where it is undefined, and says so.
#[test]
fn paper_method_counts_its_fallbacks() {
    let mut c = Chain::<f64, 3>::straight(8, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
    // Pulling a straight chain along its axis: every link is collinear with its head's motion.
    let out = c
        .move_joint(
            8,
            Vector3::new(9.0, 0.0, 0.0),
            &opts(Method::TractrixPaper, 1),
        )
        .unwrap();
    assert_eq!(out.paper_fallbacks, 8);
    assert!((c.origin() - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
    // Off the line: no fallback.
    let out = c
        .move_joint(
            8,
            Vector3::new(9.0, 1.0, 0.0),
            &opts(Method::TractrixPaper, 1),
        )
        .unwrap();
    assert_eq!(out.paper_fallbacks, 0);
}
