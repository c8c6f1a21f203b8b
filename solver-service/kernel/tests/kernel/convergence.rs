//! Convergence against the continuous ground truth: a 40-link rope of unit links whose head follows a
//! helix (sampled into straight moves). Each doubling of substeps should cut the largest joint error about
//! 4× for the tractrix (second order) and 2× for follow-the-leader (first order).

use nalgebra::Vector3;
use tractrix::ground_truth::{GroundTruthOptions, follow_path, helix};
use tractrix::{Chain, Method, MoveOptions, Substeps};

fn errors(method: Method, substeps: &[u32]) -> Vec<f64> {
    let rope = Chain::<f64, 3>::straight(40, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
    let path = helix(rope.head(), 4.0, 3.0, 1.5, 30);
    let truth = follow_path(&rope.positions(), 40, &path, &GroundTruthOptions::default()).unwrap();
    substeps
        .iter()
        .map(|&k| {
            let mut c = rope.clone();
            let opts = MoveOptions {
                method,
                substeps: Substeps::Fixed(k),
                ..MoveOptions::default()
            };
            c.move_along(40, &path, &opts).unwrap();
            c.positions()
                .iter()
                .zip(&truth)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0, f64::max)
        })
        .collect()
}

#[test]
fn error_falls_4x_per_doubling_for_tractrix_and_2x_for_ftl() {
    let ks = [1, 2, 4, 8, 16, 32, 64];
    for (method, lo, hi) in [
        (Method::Tractrix, 3.5, 4.5),
        (Method::TractrixPaper, 3.5, 4.5),
        (Method::FollowTheLeader, 1.8, 2.2),
    ] {
        let e = errors(method, &ks);
        let ratios: Vec<f64> = e.windows(2).map(|w| w[0] / w[1]).collect();
        println!(
            "{:>9}: errors {:?}",
            method.name(),
            e.iter().map(|x| format!("{x:.2e}")).collect::<Vec<_>>()
        );
        println!(
            "{:>9}: ratios {:?}",
            method.name(),
            ratios.iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>()
        );
        // The asymptotic regime: the last three doublings.
        for r in &ratios[ratios.len() - 3..] {
            assert!(
                *r > lo && *r < hi,
                "{method:?}: ratio {r:.3} outside ({lo}, {hi}); errors {e:?}"
            );
        }
    }
}
