//! What joint limits cost, and the fixed-base reach with joint ranges.
//!
//! `cargo bench -p tractrix --bench limits` prints two tables.
//!
//! 1. *Cost per move*: the same sequence of targets moved by a chain without limits and by the same
//!    chain with limits, move by move in alternation (so both share the machine's noise), from the same
//!    start: a free rope's head on a random walk (steps of a tenth of a unit), the same rope held at
//!    its tail, and the paper's 10-link planar arm reaching for random targets. Medians and p99 of the
//!    time per move, their ratio, and the share of link steps that were turned back into their limit
//!    (how often the limits were met; not counted inside a held side's solve). Held sides iterate at
//!    most 64 times (a limited chain's default in a scene), with and without limits. The limited rope
//!    is a rope of the same length with a bend radius of 1.5 units; the arm's joints are limited to
//!    [−60°, 30°].
//! 2. *Reach with ranges*: 500 targets drawn by putting the arm's joints at random angles *within* the
//!    ranges (so every target is inside the limited workspace), solved one after the other from the pose
//!    the last one left, by each strategy with the ranges and without them: success, iterations, how
//!    many solved poses break a range by more than 1e-9 rad (computed here, from the joint positions),
//!    and time per solve.
//!
//! `LIMITS_BENCH_SCALE` (default 1) scales the number of moves.

#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

mod common;
use common::Rng;
use nalgebra::{Vector2, Vector3};
use std::time::Instant;
use tractrix::pseudo_inverse::{DlsOptions, RangeHandling, reach_dls_ranges};
use tractrix::{
    Chain, JointLimits, MoveOptions, ReachOptions, ReachWorkspace, Strategy, Substeps, reach,
};

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * p).round() as usize]
}

const R_MIN: f64 = 1.5;
const LO: f64 = -60.0;
const HI: f64 = 30.0;

/// Times `moves` of a pair (free, limited): each closure makes move `i` and returns the limited one's
/// clamped link steps (0 for the free one).
fn pair(
    moves: usize,
    links_per_move: usize,
    mut free: impl FnMut(usize),
    mut limited: impl FnMut(usize) -> u32,
) -> (f64, f64, f64, f64, f64) {
    let (mut a, mut b) = (Vec::with_capacity(moves), Vec::with_capacity(moves));
    let mut clamped = 0u64;
    for i in 0..moves {
        let t = Instant::now();
        free(i);
        a.push(t.elapsed().as_nanos() as f64);
        let t = Instant::now();
        clamped += limited(i) as u64;
        b.push(t.elapsed().as_nanos() as f64);
    }
    let share = clamped as f64 / (moves * links_per_move) as f64;
    let (ma, mb) = (pct(&mut a, 0.5), pct(&mut b, 0.5));
    (ma, pct(&mut a, 0.99), mb, pct(&mut b, 0.99), share)
}

fn row(what: &str, links: usize, k: u32, r: (f64, f64, f64, f64, f64), counted: bool) {
    let (ma, pa, mb, pb, share) = r;
    let share = if counted {
        format!("{:.1} %", 100.0 * share)
    } else {
        "–".into()
    };
    println!(
        "| {what} | {links} | {k} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2}× | {share} |",
        ma / 1e3,
        pa / 1e3,
        mb / 1e3,
        pb / 1e3,
        mb / ma,
    );
}

/// A random walk of the head in steps of 0.1 from where it starts (40, 0, 0), drawn back toward the
/// tail's start whenever it strays beyond 30 units of it (so a held rope is rarely asked beyond reach).
fn rope_walk(moves: usize, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = Rng(seed);
    let mut p = Vector3::new(40.0, 0.0, 0.0);
    (0..moves)
        .map(|_| {
            let mut d = Vector3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            if p.norm() > 30.0 {
                d -= p.normalize() * 1.5;
            }
            p += d.normalize() * 0.1;
            p
        })
        .collect()
}

fn cost(scale: f64) {
    println!(
        "Cost of joint limits per move: the same targets moved by the chain without limits and with \
         them, alternating move by move. Rope: 40 units long, its head on a random walk (steps of \
         0.1); limited by a bend radius of {R_MIN}. Arm: the paper's 10 links of 0.2, planar, reaching \
         for random targets inside the limited workspace (translate-back); limited to [{LO}°, {HI}°] at \
         every joint. Held sides iterate at most 64 times (a limited chain's default in a scene), \
         with and without limits. *clamped*: link steps turned back into their limit, share of all link steps (– where \
         the solve does not count them: held sides, the reach). *refused*: moves refused (beyond the \
         held rope's reach; with limits also not converged or a joint left beyond its limit), of the \
         same targets.\n"
    );
    println!(
        "| chain | links | substeps | free p50 µs | free p99 µs | limited p50 µs | limited p99 µs | limited ÷ free (p50) | clamped |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for links in [40usize, 1000] {
        for k in [1u32, 8] {
            let moves = ((if links > 100 { 1000.0 } else { 10000.0 }) * scale).max(50.0) as usize;
            let walk = rope_walk(moves, 0xB0 ^ links as u64);
            let len = 40.0 / links as f64;
            // Held sides iterate at most 64 times, a limited chain's default in a scene.
            let mut opts = MoveOptions {
                substeps: Substeps::Fixed(k),
                ..MoveOptions::default()
            };
            opts.held.max_iterations = 64;
            for held in [false, true] {
                let mut a =
                    Chain::<f64, 3>::straight(links, len, Vector3::zeros(), Vector3::x()).unwrap();
                if held {
                    a.hold(0).unwrap();
                }
                let mut b = a.clone();
                b.set_limits(Some(JointLimits::bend_radius(b.lengths(), R_MIN).unwrap()))
                    .unwrap();
                let (mut fa, mut fb) = (0, 0);
                let r = pair(
                    moves,
                    links * k as usize,
                    |i| {
                        if a.move_joint(links, walk[i], &opts).is_err() {
                            fa += 1;
                        }
                    },
                    |i| match b.move_joint(links, walk[i], &opts) {
                        Ok(o) => o.limited,
                        Err(_) => {
                            fb += 1;
                            0
                        }
                    },
                );
                let what = if held {
                    format!("rope, tail held (refused {fa} free, {fb} limited)")
                } else {
                    "rope, free".to_string()
                };
                row(&what, links, k, r, !held);
            }
        }
    }
    let targets = arm_targets(((1000.0 * scale) as usize).max(50), 0xA4);
    // The default options, then the reach hierarchy sooner (both chains alike): the knob that trades
    // the tractrix's character for speed, which the limited arm needs more (its iteration converges
    // more slowly with the ranges, so more of its solves run to the hierarchy).
    for hierarchy_after in [None, Some(8), Some(4)] {
        let mut a = Chain::<f64, 2>::straight(10, 0.2, Vector2::zeros(), Vector2::x()).unwrap();
        let mut b = a.clone();
        b.set_limits(Some(arm_limits())).unwrap();
        let mut opts = ReachOptions::default();
        if let Some(h) = hierarchy_after {
            opts.hierarchy_after = h;
        }
        let (mut wa, mut wb) = (ReachWorkspace::default(), ReachWorkspace::default());
        let r = pair(
            targets.len(),
            10,
            |i| {
                let _ = reach(&mut a, &targets[i], &opts, &mut wa);
            },
            |i| {
                let _ = reach(&mut b, &targets[i], &opts, &mut wb);
                0
            },
        );
        let what = match hierarchy_after {
            None => format!(
                "arm, reach (per solve; hierarchy after {} iterations, the default)",
                opts.hierarchy_after
            ),
            Some(h) => format!("arm, reach (per solve; hierarchy after {h} iterations)"),
        };
        row(&what, 10, 1, r, false);
    }
}

fn arm_limits() -> JointLimits<f64> {
    JointLimits::ranges(&[LO.to_radians(); 11], &[HI.to_radians(); 11]).unwrap()
}

/// Targets the limited arm can reach: its head with every joint at a random angle in its range (the
/// base's own angle free).
fn arm_targets(n: usize, seed: u64) -> Vec<Vector2<f64>> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let mut a = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
            let mut p = Vector2::zeros();
            for j in 0..10 {
                if j > 0 {
                    a += rng.range(LO.to_radians(), HI.to_radians());
                }
                p += Vector2::new(a.cos(), a.sin()) * 0.2;
            }
            p
        })
        .collect()
}

/// The largest excess of a joint over [LO, HI] (radians), from the joint positions.
fn worst_excess(c: &Chain<f64, 2>) -> f64 {
    let p = c.positions();
    p.windows(3)
        .map(|w| {
            let (a, b) = (w[1] - w[0], w[2] - w[1]);
            let t = (a.x * b.y - a.y * b.x).atan2(a.dot(&b));
            (t - HI.to_radians()).max(LO.to_radians() - t)
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

fn ranged_reach() {
    println!(
        "\nThe 10-link planar arm (links of 0.2) reaching 500 targets inside its limited workspace \
         (each the head of a pose with every joint drawn in [{LO}°, {HI}°]), in sequence from the \
         last pose, tolerance 1e-9 of the arm's length, at most 1000 iterations. *beyond a range*: \
         solved poses with a joint more than 1e-9 rad outside [{LO}°, {HI}°], computed here from the \
         joints. With ranges the reach hierarchy's pose (it places links without them) is kept only \
         when it lands within them, and a solve that stalls is finished by boundary following (its \
         passes come off the solve's budget of iterations; *iterations* counts the tractrix's). The \
         baselines of Korein & Badler: damped least squares (damping 1e-3, steps of at most 5 % of the \
         arm's length, 10 000 iterations) with a penalty on the ranges in the null space (gain 0.01), \
         or following the boundary (a joint that runs into its range is held there while the error \
         pushes it out).\n"
    );
    println!(
        "| strategy | ranges | solved | refused | mean iterations | max iterations | beyond a range | p50 µs | p99 µs |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let targets = arm_targets(500, 0x7A);
    let arm = |limited: bool| {
        let mut c = Chain::<f64, 2>::straight(10, 0.2, Vector2::zeros(), Vector2::x()).unwrap();
        if limited {
            c.set_limits(Some(arm_limits())).unwrap();
        }
        c
    };
    for (name, handling) in [
        (
            "DLS (pseudo-inverse), penalty",
            Some(RangeHandling::Penalty { gain: 0.01 }),
        ),
        (
            "DLS (pseudo-inverse), boundary following",
            Some(RangeHandling::Boundary),
        ),
        ("DLS (pseudo-inverse)", None),
    ] {
        let opts = DlsOptions::default();
        let handling_or_none = handling.unwrap_or(RangeHandling::Penalty { gain: 0.0 });
        solve_all(
            name,
            handling.is_some(),
            arm(handling.is_some()),
            &targets,
            |c, t| reach_dls_ranges(c, t, &opts, handling_or_none).map(|o| o.iterations),
        );
    }
    for (name, strategy, hierarchy_after) in [
        ("translate-back", Strategy::TranslateBack, None),
        (
            "translate-back, hierarchy after 8",
            Strategy::TranslateBack,
            Some(8),
        ),
        (
            "translate-back, hierarchy after 4",
            Strategy::TranslateBack,
            Some(4),
        ),
        ("pull-back", Strategy::PullBack, None),
        ("two-link", Strategy::TractrixTwoLink, None),
    ] {
        for limited in [false, true] {
            let mut opts = ReachOptions {
                strategy,
                ..ReachOptions::default()
            };
            if let Some(h) = hierarchy_after {
                opts.hierarchy_after = h;
            }
            let mut ws = ReachWorkspace::default();
            solve_all(name, limited, arm(limited), &targets, |c, t| {
                reach(c, t, &opts, &mut ws).map(|o| o.iterations)
            });
        }
    }
}

/// Solves the targets in sequence with `solve` (its iterations, or an error) and prints the row.
fn solve_all<E>(
    name: &str,
    ranges: bool,
    mut c: Chain<f64, 2>,
    targets: &[Vector2<f64>],
    mut solve: impl FnMut(&mut Chain<f64, 2>, &Vector2<f64>) -> Result<u32, E>,
) {
    let (mut ok, mut iters, mut max_it, mut beyond) = (0, 0u64, 0u32, 0);
    let mut times = Vec::new();
    for t in targets {
        let s = Instant::now();
        let r = solve(&mut c, t);
        times.push(s.elapsed().as_nanos() as f64);
        if let Ok(it) = r {
            ok += 1;
            iters += it as u64;
            max_it = max_it.max(it);
            if worst_excess(&c) > 1e-9 {
                beyond += 1;
            }
        }
    }
    println!(
        "| {name} | {} | {ok} | {} | {:.1} | {max_it} | {beyond} | {:.1} | {:.1} |",
        if ranges { "yes" } else { "no" },
        targets.len() - ok,
        iters as f64 / ok.max(1) as f64,
        pct(&mut times, 0.5) / 1e3,
        pct(&mut times, 0.99) / 1e3
    );
}

fn main() {
    let scale: f64 = std::env::var("LIMITS_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&s: &f64| s > 0.0)
        .unwrap_or(1.0);
    cost(scale);
    ranged_reach();
}
