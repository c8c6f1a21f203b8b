//! Fixed-base IK on the paper's 10-link planar manipulator (links of 0.2, base at the origin): the
//! tractrix reach (both of the paper's strategies) against FABRIK and the damped-least-squares
//! pseudo-inverse, on the same 500 random reachable targets, at several tolerances.
//!
//! `cargo bench -p tractrix --bench ik` prints, per tolerance (a fraction of the arm's length):
//! time per solve (median and p99, µs), iterations (mean and max), success, and how the joint motion is
//! spread (the share of the total joint rotation made by the five joints nearest the base). The targets
//! are uniform over the workspace disk (seeded, so every run sees the same ones) and solved in sequence,
//! each from the pose the previous one left, as a manipulator following targets would; each method keeps
//! its own pose. Methods alternate target by target so they share the machine's noise.
//!
//! FABRIK (Aristidou & Lasenby 2011) is written here, 30 lines on the same joint positions: the
//! `rebirth-ik` crate solves bone trees with effectors and would measure its tree bookkeeping, not the
//! algorithm.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

mod common;
use common::Rng;
use nalgebra::Vector2;
use std::time::Instant;
use tractrix::pseudo_inverse::{DlsOptions, reach_dls};
use tractrix::{Chain, ReachOptions, ReachWorkspace, Strategy, reach};

type V = Vector2<f64>;

const LINKS: usize = 10;
const LINK: f64 = 0.2;
const TARGETS: usize = 500;

fn targets() -> Vec<V> {
    let total = LINKS as f64 * LINK;
    let mut rng = Rng(0x5EED);
    (0..TARGETS)
        .map(|_| {
            // Uniform over the disk of full reach (a hair inside, so rounding keeps it reachable).
            let r = total * (1.0 - 1e-9) * rng.unit().sqrt();
            let a = std::f64::consts::TAU * rng.unit();
            V::new(r * a.cos(), r * a.sin())
        })
        .collect()
}

/// FABRIK on joint positions `p` (base `p[0]` fixed): returns iterations, or `None` if the limit was
/// reached first.
fn fabrik(p: &mut [V], lengths: &[f64], target: V, tol: f64, max_iter: u32) -> Option<u32> {
    let n = p.len() - 1;
    let base = p[0];
    for it in 0..=max_iter {
        if (p[n] - target).norm() <= tol {
            return Some(it);
        }
        if it == max_iter {
            break;
        }
        // Backward: the head onto the target, each joint toward its successor.
        p[n] = target;
        for i in (0..n).rev() {
            let d = p[i] - p[i + 1];
            p[i] = p[i + 1] + d * (lengths[i] / d.norm());
        }
        // Forward: the base back in place, each joint toward its predecessor.
        p[0] = base;
        for i in 0..n {
            let d = p[i + 1] - p[i];
            p[i + 1] = p[i] + d * (lengths[i] / d.norm());
        }
    }
    None
}

/// Relative joint angles (joint 1 at the base: the first link's angle from +x).
fn angles(c: &Chain<f64, 2>) -> Vec<f64> {
    let mut prev = 0.0;
    c.links()
        .iter()
        .map(|l| {
            let a = l.y.atan2(l.x);
            let mut d = a - prev;
            d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
            prev = a;
            d
        })
        .collect()
}

#[derive(Clone, Copy, PartialEq)]
enum Solver {
    TranslateBack,
    TwoLink,
    PullBack,
    Fabrik,
    Dls,
}

impl Solver {
    fn name(self) -> &'static str {
        match self {
            Solver::TranslateBack => "tractrix, translate back (i)",
            Solver::TwoLink => "tractrix + two-link (ii)",
            Solver::PullBack => "tractrix, pull back (not the paper's)",
            Solver::Fabrik => "FABRIK",
            Solver::Dls => "pseudo-inverse (DLS)",
        }
    }

    /// What the method minimises, for the table that compares them.
    fn objective(self) -> &'static str {
        match self {
            Solver::TranslateBack | Solver::PullBack => {
                "each pass: the motion of every link for the motion of its leading end (the tractrix, \
                 remark 5); nothing global"
            }
            Solver::TwoLink => {
                "the same down to the third link; the first two placed exactly (closed form)"
            }
            Solver::Fabrik => "nothing: alternating reaches to the target and back to the base",
            Solver::Dls => {
                "each step: the joint rates, ‖δq‖² + ‖J δq − e‖² / λ² (least joint motion in least \
                 squares); with ranges a penalty on them in the null space (\"What joint limits cost\")"
            }
        }
    }
}

#[derive(Default)]
struct Tally {
    us: Vec<f64>,
    iterations: Vec<u32>,
    ok: usize,
    base_rotation: f64,
    all_rotation: f64,
    worst_residual: f64,
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let ts = targets();
    let solvers = [
        Solver::TranslateBack,
        Solver::TwoLink,
        Solver::PullBack,
        Solver::Fabrik,
        Solver::Dls,
    ];
    let total = LINKS as f64 * LINK;
    println!(
        "Fixed-base reach, {LINKS} links of {LINK}, {TARGETS} random reachable targets in sequence \
         (tolerance: a fraction of the arm's length {total}):\n"
    );
    println!(
        "| tolerance | method | median µs | p99 µs | mean iterations | max iterations | success | base-half share | worst residual / tolerance |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---:|");
    for tol in [1e-2, 1e-4, 1e-6, 1e-9] {
        let start = Chain::<f64, 2>::straight(LINKS, LINK, V::zeros(), V::x()).unwrap();
        let mut chains = vec![start.clone(); solvers.len()];
        let mut tallies: Vec<Tally> = solvers.iter().map(|_| Tally::default()).collect();
        let mut ws = ReachWorkspace::default();
        let mut pts: Vec<V> = Vec::with_capacity(LINKS + 1);
        let lengths = vec![LINK; LINKS];
        for t in &ts {
            for (k, s) in solvers.iter().enumerate() {
                let c = &mut chains[k];
                let before = angles(c);
                let t0 = Instant::now();
                let res: Option<(u32, f64)> = match s {
                    Solver::TranslateBack | Solver::TwoLink | Solver::PullBack => {
                        let opts = ReachOptions {
                            strategy: match s {
                                Solver::TwoLink => Strategy::TractrixTwoLink,
                                Solver::PullBack => Strategy::PullBack,
                                _ => Strategy::TranslateBack,
                            },
                            tolerance: tol,
                            ..ReachOptions::default()
                        };
                        reach(c, t, &opts, &mut ws)
                            .ok()
                            .map(|o| (o.iterations, o.residual))
                    }
                    Solver::Fabrik => {
                        pts.resize(LINKS + 1, V::zeros());
                        c.write_positions(&mut pts);
                        fabrik(&mut pts, &lengths, *t, tol * total, 1000).and_then(|it| {
                            c.set_positions(&pts).ok()?;
                            Some((it, (c.head() - t).norm()))
                        })
                    }
                    Solver::Dls => {
                        let opts = DlsOptions {
                            tolerance: tol,
                            ..DlsOptions::default()
                        };
                        reach_dls(c, t, &opts)
                            .ok()
                            .map(|o| (o.iterations, o.residual))
                    }
                };
                let us = t0.elapsed().as_secs_f64() * 1e6;
                let tally = &mut tallies[k];
                tally.us.push(us);
                if let Some((it, residual)) = res {
                    tally.ok += 1;
                    tally.iterations.push(it);
                    tally.worst_residual = tally.worst_residual.max(residual / (tol * total));
                    let after = angles(c);
                    for (j, (a, b)) in before.iter().zip(&after).enumerate() {
                        let d = (b - a).abs();
                        tally.all_rotation += d;
                        if j < LINKS / 2 {
                            tally.base_rotation += d;
                        }
                    }
                }
            }
        }
        for (s, t) in solvers.iter().zip(&mut tallies) {
            let n = t.iterations.len().max(1) as f64;
            println!(
                "| {tol:.0e} | {} | {:.2} | {:.2} | {:.1} | {} | {:.1} % | {:.2} | {:.3} |",
                s.name(),
                pct(&mut t.us, 0.5),
                pct(&mut t.us, 0.99),
                t.iterations.iter().map(|&i| i as f64).sum::<f64>() / n,
                t.iterations.iter().max().copied().unwrap_or(0),
                100.0 * t.ok as f64 / TARGETS as f64,
                t.base_rotation / t.all_rotation.max(f64::MIN_POSITIVE),
                t.worst_residual
            );
        }
    }
    println!("\n| method | what it minimises |\n|---|---|");
    for s in solvers {
        println!("| {} | {} |", s.name(), s.objective());
    }
    println!(
        "\nSuccess: converged within the limit (tractrix 1000 iterations with the reach hierarchy after 16, \
         FABRIK 1000, DLS 10 000); FABRIK's pose is written back through the chain, which keeps the link \
         lengths exact, and the residual is measured after that."
    );
}
