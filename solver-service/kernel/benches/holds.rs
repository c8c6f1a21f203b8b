//! What holds cost per move (issue 16): a free move against a move with one held side and with two.
//!
//! `cargo bench -p tractrix --bench holds` prints a Markdown table (as BENCHMARKS.md shows it). The chain
//! (40 or 1000 unit links) starts slack, hanging in a U between ends 0.6 of its length apart. Cases:
//!
//! * *head, free*: the head moves, nothing held (the plain tractrix move);
//! * *head, tail held*: the head moves with the tail held: one held side, solved by the paper's
//!   fixed-base method (translate back; reach hierarchy after 16 iterations);
//! * *middle, free*: the middle joint moves, nothing held (both sides follow, remark 2);
//! * *middle, both ends held*: the middle joint moves with both ends held: two held sides.
//!
//! Each move takes the joint a tenth of a link along a circle of radius 1 through where it started, one
//! substep, no collision. Moves are timed one by one (the clock costs ~20 ns, far below a held move);
//! cases are interleaved in rounds of `MOVES` moves so the machine's noise falls on all alike. Printed:
//! median and 99th percentile of the time per move, the median's ratio to the free move of the same
//! joint, and the mean fixed-base iterations per move. `HOLDS_BENCH_ROUNDS` (default 20) sets the rounds.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Instant;
use tractrix::{Chain, MoveOptions, Substeps};

type V = Vector3<f64>;

/// Moves per case per round.
const MOVES: usize = 200;

/// A chain of `n` unit links hanging in a U: a circular arc through ends `0.6 n` apart.
fn u_chain(n: usize) -> Chain<f64, 3> {
    let length = n as f64;
    let chord = 0.6 * length;
    // Half angle `a` of the arc: sin a / a = chord / length (bisection).
    let (mut lo, mut hi) = (1e-6, std::f64::consts::PI - 1e-9);
    for _ in 0..200 {
        let a = 0.5 * (lo + hi);
        if a.sin() / a > chord / length {
            lo = a;
        } else {
            hi = a;
        }
    }
    let a = 0.5 * (lo + hi);
    let r = length / (2.0 * a);
    let centre = V::new(chord / 2.0, r * a.cos(), 0.0);
    let points: Vec<V> = (0..=n)
        .map(|k| {
            let t = -a + 2.0 * a * k as f64 / n as f64 - std::f64::consts::FRAC_PI_2;
            centre + V::new(r * t.cos(), r * t.sin(), 0.0)
        })
        .collect();
    Chain::from_points(&points).expect("a U")
}

#[derive(Clone, Copy, PartialEq)]
enum Case {
    HeadFree,
    HeadTailHeld,
    MiddleFree,
    MiddleBothHeld,
}

impl Case {
    fn name(self) -> &'static str {
        match self {
            Case::HeadFree => "head, free",
            Case::HeadTailHeld => "head, tail held (one held side)",
            Case::MiddleFree => "middle, free",
            Case::MiddleBothHeld => "middle, both ends held (two held sides)",
        }
    }
    /// The free case of the same joint.
    fn free(self) -> Case {
        match self {
            Case::HeadFree | Case::HeadTailHeld => Case::HeadFree,
            Case::MiddleFree | Case::MiddleBothHeld => Case::MiddleFree,
        }
    }
}

struct Run {
    chain: Chain<f64, 3>,
    joint: usize,
    centre: V,
    k: usize,
    opts: MoveOptions<f64>,
    ns: Vec<f64>,
    iterations: u64,
    refused: usize,
}

impl Run {
    fn new(n: usize, case: Case) -> Run {
        let mut chain = u_chain(n);
        let joint = match case {
            Case::HeadFree | Case::HeadTailHeld => n,
            Case::MiddleFree | Case::MiddleBothHeld => n / 2,
        };
        match case {
            Case::HeadTailHeld => chain.hold(0).expect("tail"),
            Case::MiddleBothHeld => {
                chain.hold(0).expect("tail");
                chain.hold(n).expect("head");
            }
            _ => {}
        }
        let centre = chain.joint(joint) - V::new(1.0, 0.0, 0.0);
        Run {
            chain,
            joint,
            centre,
            k: 0,
            opts: MoveOptions {
                substeps: Substeps::Fixed(1),
                ..MoveOptions::default()
            },
            ns: Vec::new(),
            iterations: 0,
            refused: 0,
        }
    }

    fn round(&mut self) {
        for _ in 0..MOVES {
            self.k += 1;
            // A tenth of a link per move along a circle of radius 1 (and a slow rise and fall).
            let a = self.k as f64 * 0.1;
            let t = self.centre + V::new(a.cos(), a.sin(), 0.5 * (0.1 * a).sin());
            let t0 = Instant::now();
            let r = black_box(self.chain.move_joint(self.joint, t, &self.opts));
            self.ns.push(t0.elapsed().as_nanos() as f64);
            match r {
                Ok(o) => self.iterations += u64::from(o.held_iterations),
                Err(_) => self.refused += 1,
            }
        }
    }
}

fn pct(v: &[f64], p: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let rounds: usize = std::env::var("HOLDS_BENCH_ROUNDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&r| r > 0)
        .unwrap_or(20);
    println!(
        "A chain of unit links hanging in a U; the joint moves a tenth of a link per move along a \
         circle, one substep, no collision; {rounds} rounds of {MOVES} moves per case, cases \
         interleaved round by round; each move timed alone:\n"
    );
    println!(
        "| links | joint moved, holds | moves | median per move (µs) | p99 per move (µs) | median ÷ \
         free move's | fixed-base iterations per move | moves refused |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|");
    let cases = [
        Case::HeadFree,
        Case::HeadTailHeld,
        Case::MiddleFree,
        Case::MiddleBothHeld,
    ];
    for n in [40usize, 1000] {
        let mut runs: Vec<Run> = cases.iter().map(|&c| Run::new(n, c)).collect();
        for r in 0..rounds {
            for i in 0..cases.len() {
                runs[(i + r) % cases.len()].round();
            }
        }
        let median = |c: Case| {
            let i = cases.iter().position(|&x| x == c).expect("case");
            pct(&runs[i].ns, 0.5)
        };
        for (case, run) in cases.iter().zip(&runs) {
            let moves = run.ns.len();
            let med = pct(&run.ns, 0.5);
            println!(
                "| {n} | {} | {moves} | {:.2} | {:.2} | {:.1} | {:.1} | {} |",
                case.name(),
                med / 1e3,
                pct(&run.ns, 0.99) / 1e3,
                med / median(case.free()),
                run.iterations as f64 / (moves - run.refused).max(1) as f64,
                run.refused
            );
        }
    }
}
