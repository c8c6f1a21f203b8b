//! Numerical stability at the extremes.

use crate::support::{Rng, max_length_error, max_position_length_error};
use nalgebra::{SVector, Vector3};
use tractrix::math::Embed3;
use tractrix::{Chain, Method, MoveOptions, Real, Substeps};

/// The kinds of move mixed into the long random sequences.
#[derive(Clone, Copy, Debug)]
enum Kind {
    Zero,
    CollinearPush,
    CollinearPull,
    Perpendicular,
    Tiny,
    Huge,
    Ordinary,
}

const KINDS: [Kind; 7] = [
    Kind::Zero,
    Kind::CollinearPush,
    Kind::CollinearPull,
    Kind::Perpendicular,
    Kind::Tiny,
    Kind::Huge,
    Kind::Ordinary,
];

/// Picks a joint and a target of the given kind for `chain`. Collinear and perpendicular moves are taken
/// relative to the link next to the moved joint (after a huge move the whole chain lies straight, so the
/// collinear moves that follow are collinear for every link).
fn random_move<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    rng: &mut Rng,
    kind: Kind,
) -> (usize, SVector<T, D>)
where
    SVector<T, D>: Embed3<T>,
{
    let n = chain.n_links();
    let joint = match rng.below(3) {
        0 => n,
        1 => 0,
        _ => rng.below(n + 1),
    };
    let here = chain.joint(joint);
    // The link adjacent to the joint, pointing away from it.
    let away: SVector<T, D> = if joint == n {
        -chain.links()[n - 1]
    } else {
        chain.links()[joint]
    };
    let len = chain.lengths()[if joint == n { n - 1 } else { joint }];
    let unit = away / away.norm();
    let rand_dir = SVector::<T, D>::from_fn(|k, _| T::lit(rng.dir3()[k]));
    let rand_dir = rand_dir / rand_dir.norm();
    let delta = match kind {
        Kind::Zero => SVector::zeros(),
        Kind::CollinearPush => unit * len * T::lit(rng.range(0.01, 3.0)),
        Kind::CollinearPull => -unit * len * T::lit(rng.range(0.01, 3.0)),
        Kind::Perpendicular => {
            let p = rand_dir - unit * rand_dir.dot(&unit);
            p / p.norm() * len * T::lit(rng.range(0.01, 3.0))
        }
        Kind::Tiny => rand_dir * len * T::lit(1e-12),
        Kind::Huge => rand_dir * len * T::lit(1e9),
        Kind::Ordinary => rand_dir * len * T::lit(rng.range(0.01, 3.0)),
    };
    (joint, here + delta)
}

struct Drift {
    /// Largest relative link-length error seen over the run (state).
    state: f64,
    /// Largest relative landing error of the moved joint, relative to (|target| + chain length).
    landing: f64,
}

fn random_walk<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    moves: usize,
    seed: u64,
    method: Method,
    kinds: &[Kind],
) -> Drift
where
    SVector<T, D>: Embed3<T>,
{
    let mut rng = Rng(seed);
    let opts = MoveOptions {
        method,
        substeps: Substeps::Fixed(1),
        ..MoveOptions::default()
    };
    let total = chain.total_length().to_f64();
    let mut drift = Drift {
        state: 0.0,
        landing: 0.0,
    };
    for i in 0..moves {
        let kind = kinds[rng.below(kinds.len())];
        let (joint, target) = random_move(chain, &mut rng, kind);
        chain
            .move_joint(joint, target, &opts)
            .unwrap_or_else(|e| panic!("move {i} ({kind:?}) failed: {e}"));
        // A huge move sends the chain 1e9 link lengths away; the next move brings it back near the
        // origin half the time, so the walk visits both scales.
        let land = (chain.joint(joint) - target).norm().to_f64() / (target.norm().to_f64() + total);
        drift.landing = drift.landing.max(land);
        if i % 64 == 0 || matches!(kind, Kind::Huge | Kind::Tiny) {
            drift.state = drift.state.max(crate::support::max_length_error(chain));
            assert!(
                chain
                    .links()
                    .iter()
                    .all(|l| l.iter().all(|x| x.is_finite())),
                "move {i}: non-finite link"
            );
            assert!(
                chain.origin().iter().all(|x| x.is_finite()),
                "move {i}: non-finite origin"
            );
        }
        if matches!(kind, Kind::Huge) && rng.below(2) == 0 {
            let back = SVector::<T, D>::from_fn(|_, _| T::lit(rng.range(-1.0, 1.0) * total));
            chain.move_joint(joint, back, &opts).unwrap();
        }
    }
    drift.state = drift.state.max(max_length_error(chain));
    drift
}

/// 10⁶ random moves in f64 on a spatial chain, every kind mixed (zero, collinear push and pull,
/// perpendicular, 1e-12·L, 1e9·L, ordinary): lengths kept to 1e-12 relative, every coordinate finite,
/// the moved joint on its target.
#[test]
fn a_million_random_moves_f64() {
    let mut c = Chain::<f64, 3>::from_parts(
        Vector3::zeros(),
        (0..8)
            .map(|i| Vector3::new(1.0, (i as f64).sin(), 0.3))
            .collect(),
        vec![1.0, 0.5, 2.0, 1.0, 0.25, 1.0, 3.0, 1.0],
    )
    .unwrap();
    let d = random_walk(&mut c, 1_000_000, 42, Method::Tractrix, &KINDS);
    println!(
        "f64 tractrix, 1e6 moves: max link-length drift {:.2e}, max landing error {:.2e}",
        d.state, d.landing
    );
    assert!(d.state <= 1e-12, "length drift {:e}", d.state);
    assert!(d.landing <= 1e-12, "landing error {:e}", d.landing);
}

/// The same walk for the other two methods (10⁵ moves each) and for a planar chain. The paper's form
/// computes the tail relative to the *old* head (`x_r − |S|` cancels), so a 1e9·L move costs it about
/// ε·1e9 of length (`link::paper_form_loses_length_on_huge_moves`); its walk leaves huge moves out.
#[test]
fn random_moves_other_methods_and_planar() {
    for method in [Method::TractrixPaper, Method::FollowTheLeader] {
        let mut c =
            Chain::<f64, 3>::straight(12, 0.7, Vector3::zeros(), Vector3::new(1.0, 1.0, 0.0))
                .unwrap();
        let kinds: Vec<Kind> = KINDS
            .iter()
            .copied()
            .filter(|k| method != Method::TractrixPaper || !matches!(k, Kind::Huge))
            .collect();
        let d = random_walk(&mut c, 100_000, 7, method, &kinds);
        println!(
            "f64 {}: max drift {:.2e}, landing {:.2e}",
            method.name(),
            d.state,
            d.landing
        );
        assert!(
            d.state <= 1e-12 && d.landing <= 1e-12,
            "{method:?}: drift {:e}, landing {:e}",
            d.state,
            d.landing
        );
    }
    let mut p =
        Chain::<f64, 2>::straight(10, 0.2, nalgebra::Vector2::zeros(), nalgebra::Vector2::x())
            .unwrap();
    let d = random_walk(&mut p, 200_000, 9, Method::Tractrix, &KINDS);
    assert!(
        d.state <= 1e-12 && d.landing <= 1e-12,
        "planar: drift {:e}, landing {:e}",
        d.state,
        d.landing
    );
}

/// f32: the same walk, drift measured and reported. Lengths live in each link vector, so f32 keeps them
/// to a few ulps of the link, not of the distance travelled.
#[test]
fn f32_drift_is_measured() {
    let mut c = Chain::<f32, 3>::from_parts(
        Vector3::zeros(),
        (0..8)
            .map(|i| Vector3::new(1.0, (i as f32).cos(), -0.2))
            .collect(),
        vec![1.0, 0.5, 2.0, 1.0, 0.25, 1.0, 3.0, 1.0],
    )
    .unwrap();
    let d = random_walk(&mut c, 200_000, 43, Method::Tractrix, &KINDS);
    println!(
        "f32 tractrix, 2e5 moves: max link-length drift {:.2e}, max landing error {:.2e}",
        d.state, d.landing
    );
    assert!(
        d.state <= 8.0 * f32::EPSILON as f64,
        "f32 length drift {:e}",
        d.state
    );
    assert!(d.landing <= 1e-5, "f32 landing error {:e}", d.landing);
}

/// Link lengths from 1e-6 to 1e6, all methods: a path of moves scaled to the link keeps lengths and lands.
#[test]
fn link_lengths_from_micro_to_mega() {
    for k in -6..=6 {
        let len = 10f64.powi(k);
        for method in Method::ALL {
            let mut c =
                Chain::<f64, 3>::straight(20, len, Vector3::new(1.0, 2.0, 3.0) * len, Vector3::z())
                    .unwrap();
            let mut rng = Rng((k + 100) as u64);
            let opts = MoveOptions {
                method,
                substeps: Substeps::MaxStep(0.25),
                ..MoveOptions::default()
            };
            for _ in 0..200 {
                let target = c.head() + rng.dir3() * len * rng.range(0.0, 4.0);
                c.move_joint(20, target, &opts).unwrap();
                assert!((c.head() - target).norm() <= 1e-12 * (target.norm() + 20.0 * len));
            }
            let e = max_length_error(&c).max(max_position_length_error(&c));
            assert!(e <= 1e-12, "L = {len:e}, {method:?}: length error {e:e}");
        }
    }
}

/// A chain of one link, and a chain of 10⁶ links (one move with substeps; O(n) per substep).
#[test]
fn one_link_and_a_million_links() {
    let mut one = Chain::<f64, 3>::straight(1, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
    for t in [
        Vector3::new(1.0, 5.0, 0.0),
        Vector3::new(-3.0, 0.0, 0.0),
        Vector3::new(-3.0, 0.0, 0.0),
    ] {
        for j in [0, 1] {
            one.move_joint(j, t, &MoveOptions::default()).unwrap();
            assert!((one.joint(j) - t).norm() <= 2.0 * f64::EPSILON * t.norm());
            assert!(max_length_error(&one) <= 1e-15);
        }
    }
    let n = 1_000_000;
    let mut big = Chain::<f64, 3>::straight(n, 1e-3, Vector3::zeros(), Vector3::x()).unwrap();
    // Pull forward and sideways (a push along the axis would move a straight rope rigidly).
    let target = big.head() + Vector3::new(5.0, 20.0, 3.0);
    let opts = MoveOptions {
        substeps: Substeps::Fixed(8),
        ..MoveOptions::default()
    };
    big.move_joint(n, target, &opts).unwrap();
    assert!(
        (big.head() - target).norm() <= 1e-12 * target.norm(),
        "head off by {:e}",
        (big.head() - target).norm()
    );
    assert!(max_length_error(&big) <= 1e-12);
    // A taut rope transmits the axial part of a pull to its far end (collinear pull: dr = dp); the
    // lateral part dies out. The tail of the kilometre-long rope slides along its axis only.
    let tail = big.origin();
    assert!(
        tail.yz().norm() < 1e-9,
        "tail moved sideways by {:e}",
        tail.yz().norm()
    );
    assert!(tail.x > 0.0 && tail.x <= (target - Vector3::new(1000.0, 0.0, 0.0)).norm());
    assert!(
        big.positions()
            .iter()
            .all(|p| p.iter().all(|x| x.is_finite()))
    );
}

/// One-substep collinear and nearly collinear pushes and pulls of every length from 1/4 link to 1000
/// links, in f32 and f64: finite, and the closed form keeps the lengths. Pushes of ~44–52 links (f32)
/// and ~354–372 links (f64) within 1e-19 of collinear once made 1/D overflow in the closed form and
/// published NaN (found by the request fuzzer, `solver-service/tests/fuzz_requests.rs`); there |w|² and
/// E = e^{−2b} are subnormal, and the closed form now uses |w| and q alone.
///
/// The paper's form (as printed) stays finite here but loses length in the same regime, up to 2e-3 of a
/// link in f64 and 2e-5 in f32 (measured by this test, reported on failure); the bound below is that
/// measurement's order, a characterisation of the baseline, not a guarantee of the service.
#[test]
fn collinear_pushes_of_every_length_stay_finite() {
    fn run<T: Real>(offsets: &[f64], closed_tol: f64, paper_tol: f64) {
        for (method, tol) in [
            (Method::Tractrix, closed_tol),
            (Method::TractrixPaper, paper_tol),
        ] {
            let mut worst = 0.0f64;
            for quarter in 1..=4000u32 {
                let dist = 0.25 * f64::from(quarter);
                for &y0 in offsets {
                    for (joint, dir) in [(0usize, 1.0), (0, -1.0), (3, -1.0), (3, 1.0)] {
                        let mut c = Chain::<T, 3>::straight(
                            3,
                            T::lit(0.25),
                            SVector::zeros(),
                            Vector3::x(),
                        )
                        .unwrap();
                        let start = c.joint(joint);
                        let target =
                            start + Vector3::new(T::lit(dir * dist * 0.25), T::lit(y0), T::zero());
                        let opts = MoveOptions {
                            method,
                            substeps: Substeps::Fixed(1),
                            ..MoveOptions::default()
                        };
                        c.move_joint(joint, target, &opts).unwrap();
                        let p = c.positions();
                        assert!(
                            p.iter().all(|v| v.iter().all(|x| x.is_finite())),
                            "{} {method:?}: joint {joint} moved {} links, offset {y0:e}: {p:?}",
                            std::any::type_name::<T>(),
                            dir * dist,
                        );
                        worst = worst.max(max_length_error(&c));
                    }
                }
            }
            assert!(
                worst <= tol,
                "{} {method:?}: length error {worst:e}",
                std::any::type_name::<T>()
            );
        }
    }
    run::<f32>(
        &[0.0, 1e-44, 1e-30, 1e-20, 1e-8],
        8.0 * f64::from(f32::EPSILON),
        1e-4,
    );
    run::<f64>(&[0.0, 1e-320, 1e-200, 1e-160, 1e-100, 1e-20], 1e-14, 1e-2);
}
