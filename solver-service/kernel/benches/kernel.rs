//! The kernel's cost per link per substep: the closed-form tractrix, the paper's TRACTRIX3D and
//! follow-the-leader, in f64 and f32, on chains of 10, 40, 1000 and 10⁶ links, measured side by side.
//!
//! `cargo bench -p tractrix --bench kernel` prints a Markdown table (as BENCHMARKS.md shows it), one
//! row per (links, precision, method): the median and the slowest of the batches' mean ns per link per
//! substep, and the ratio of medians to follow-the-leader of the same size and precision. Each batch is a run of head moves (a third of a link each, one
//! substep) along a wide helix, timed as a whole so the clock's own cost (~20 ns) does not count; methods
//! are interleaved batch by batch. `KERNEL_BENCH_SCALE` (default 1.0) scales the work per row.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Instant;
use tractrix::{Chain, Method, MoveOptions, Real, Substeps};

/// Link-steps per timed batch.
const BATCH_WORK: usize = 200_000;

fn target<T: Real>(n: usize, k: usize) -> Vector3<T> {
    // A helix of radius n/4 (at most 50) about the initial chain's axis, a third of a link per move.
    let r = (n as f64 / 4.0).min(50.0);
    let s = k as f64 / 3.0;
    let a = s / r.max(1.0);
    Vector3::new(
        T::lit(n as f64 + s * 0.3),
        T::lit(r * (1.0 - a.cos())),
        T::lit(r * a.sin()),
    )
}

struct Bench<T: Real> {
    chain: Chain<T, 3>,
    opts: MoveOptions<T>,
    k: usize,
}

impl<T: Real> Bench<T> {
    fn new(n: usize, method: Method) -> Self {
        let chain = Chain::<T, 3>::straight(n, T::one(), Vector3::zeros(), Vector3::x())
            .expect("a straight chain");
        let opts = MoveOptions {
            method,
            substeps: Substeps::Fixed(1),
            ..MoveOptions::default()
        };
        let mut b = Bench { chain, opts, k: 0 };
        // Warm up: bend the chain so no method sees a straight line.
        b.batch(4.max(1000 / n.max(1)));
        b
    }

    /// `moves` head moves; returns ns per link per substep.
    fn batch(&mut self, moves: usize) -> f64 {
        let n = self.chain.n_links();
        let t0 = Instant::now();
        for _ in 0..moves {
            self.k += 1;
            let t = target::<T>(n, self.k);
            black_box(self.chain.move_joint(n, t, &self.opts).expect("a move"));
        }
        t0.elapsed().as_nanos() as f64 / (moves * n) as f64
    }
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn row<T: Real>(n: usize, precision: &str, scale: f64) {
    let methods = [
        Method::Tractrix,
        Method::TractrixPaper,
        Method::FollowTheLeader,
    ];
    let mut benches: Vec<Bench<T>> = methods.iter().map(|m| Bench::new(n, *m)).collect();
    let moves = (BATCH_WORK / n).max(1);
    let batches = ((40.0 * scale) as usize)
        .max(5)
        .min(((2e8 * scale) as usize / (moves * n)).max(5));
    let mut ns: Vec<Vec<f64>> = vec![Vec::new(); methods.len()];
    for b in 0..batches {
        for k in 0..methods.len() {
            let i = (k + b) % methods.len();
            ns[i].push(benches[i].batch(moves));
        }
    }
    let ftl = pct(&mut ns[2].clone(), 0.5);
    let size = if n == 1_000_000 {
        "10⁶".to_string()
    } else {
        n.to_string()
    };
    for (i, m) in methods.iter().enumerate() {
        let med = pct(&mut ns[i], 0.5);
        println!(
            "| {size} | {precision} | {} | {batches} | {med:.1} | {:.1} | {:.2} |",
            describe(*m),
            pct(&mut ns[i], 1.0),
            med / ftl
        );
    }
}

fn describe(m: Method) -> &'static str {
    match m {
        Method::Tractrix => "closed-form tractrix",
        Method::TractrixPaper => "paper's TRACTRIX3D",
        Method::FollowTheLeader => "follow-the-leader",
    }
}

fn main() {
    let scale: f64 = std::env::var("KERNEL_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|s: &f64| s.is_finite() && *s > 0.0)
        .unwrap_or(1.0);
    println!(
        "Head moves of a third of a link along a helix, one substep each; each batch (~{BATCH_WORK} \
         link-steps) timed as a whole, methods interleaved batch by batch; ns per link per substep:\n"
    );
    println!(
        "| links | precision | method | batches | median of batch means (ns) | slowest batch mean (ns) \
         | median ÷ follow-the-leader's |"
    );
    println!("|---:|---|---|---:|---:|---:|---:|");
    for n in [10usize, 40, 1000, 1_000_000] {
        row::<f64>(n, "f64", scale);
        row::<f32>(n, "f32", scale);
    }
}
