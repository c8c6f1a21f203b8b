//! What collision handling costs per move, and what it buys, measured side by side in one run.
//!
//! `cargo bench -p tractrix --bench collision` prints, for a rope 40 units long in 40, 160 and 320 links
//! (thickness 0.2), with no collision, the paper's spheres (section 4.2) and capsules (candidate pairs
//! from the kernel's tree of boxes over the chain):
//!
//! * **tying**: the built-in overhand script's head path (the `hand run --builtin overhand` moves): time
//!   per move (median, p99, max), the ratio of medians to no collision, moves refused as locked, and the
//!   knot the rope holds at the end (the accuracy side: without collision the rope passes through itself);
//! * **free**: as many moves of the head leading the rope forward along a wide circle, nothing ever
//!   touching: the cost of detection alone.
//!
//! Schemes are interleaved round by round so machine noise hits them alike. `COLLISION_BENCH_ROUNDS`
//! (default 5) sets the rounds; `COLLISION_BENCH_COST_ONLY` prints the first table only.
//!
//! A second table is the speed/accuracy trade: the tying path at 160 and 320 links, for each scheme,
//! over the resolution passes allowed per substep (`max_iterations` 1 to 256, tolerance 1 %), over
//! the tolerance (10 %, 1 %, 0.1 %, 256 passes) and over the pushes' over-relaxation (1, the default
//! 1.5 and 1.9, 64 passes). The accuracy side is measured independently of the
//! solver's own bookkeeping: after every accepted move, every pair of links with at least a rope
//! thickness of rope between them is tested (all pairs, O(n²)) and the worst penetration of the real
//! rope (thickness 0.2) is kept, as a fraction of the thickness; with it, the moves refused as locked,
//! the mean passes per move and the knot at the end.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

use knots::identify;
use knots::script::Script;
use nalgebra::Vector3;
use std::time::Instant;
use tractrix::chain::{Chain, MoveOptions};
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, Scheme, move_joint_colliding,
};

type V = Vector3<f64>;

#[derive(Clone, Copy, PartialEq)]
enum Handling {
    None,
    Paper,
    Capsules,
}

impl Handling {
    fn name(self) -> &'static str {
        match self {
            Handling::None => "none",
            Handling::Paper => "paper spheres",
            Handling::Capsules => "capsules",
        }
    }
}

const THICKNESS: f64 = 0.2;

struct Run {
    ns: Vec<u64>,
    locked: usize,
    knot: String,
    /// Resolution passes that pushed something, summed over accepted moves.
    passes: u64,
    /// Worst penetration of the real rope after any accepted move, as a fraction of the thickness
    /// (only measured when asked: it costs O(n²) per move).
    worst: f64,
}

/// The worst penetration of a rope of [`THICKNESS`] through itself, as a fraction of the thickness,
/// testing every pair of links with at least a thickness of rope between them. Computed by
/// `knots::check`, which shares no code with the kernel's collision handling it checks.
fn penetration(positions: &[V]) -> f64 {
    knots::check::closest_links_with_rope_between(positions, THICKNESS)
        .map_or(0.0, |d| ((THICKNESS - d) / THICKNESS).max(0.0))
}

fn run(
    n: usize,
    handling: Handling,
    targets: &[V],
    max_iterations: u32,
    tolerance: f64,
    over_relaxation: f64,
    check: bool,
) -> Run {
    let len = 40.0 / n as f64;
    let mut chain = Chain::<f64, 3>::straight(n, len, V::zeros(), V::x()).expect("chain");
    let model = CollisionModel {
        options: CollisionOptions {
            scheme: if handling == Handling::Paper {
                Scheme::PaperSpheres
            } else {
                Scheme::Capsules
            },
            thickness: THICKNESS,
            max_iterations,
            tolerance,
            over_relaxation,
            ..CollisionOptions::default()
        },
        obstacles: vec![],
        holding: Vec::new(),
    };
    let mut ws = CollisionWorkspace::new();
    let opts = MoveOptions::default();
    let mut out = Run {
        ns: Vec::with_capacity(targets.len()),
        locked: 0,
        knot: String::new(),
        passes: 0,
        worst: 0.0,
    };
    for t in targets {
        let t0 = Instant::now();
        let r = match handling {
            Handling::None => chain.move_joint(n, *t, &opts),
            _ => move_joint_colliding(&mut chain, n, *t, &opts, &model, &mut ws),
        };
        out.ns.push(t0.elapsed().as_nanos() as u64);
        match r {
            Ok(o) => out.passes += u64::from(o.collision_iterations),
            Err(_) => out.locked += 1,
        }
        if check {
            out.worst = out.worst.max(penetration(&chain.positions()));
        }
    }
    out.knot = format!("{:?}", identify(&chain.positions()).kind).to_lowercase();
    out
}

fn pct(v: &mut [u64], p: f64) -> f64 {
    v.sort_unstable();
    v[((v.len() - 1) as f64 * p).round() as usize] as f64 / 1e3
}

fn main() {
    let rounds: usize = std::env::var("COLLISION_BENCH_ROUNDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5)
        .clamp(1, 100);
    let script = Script::builtin("overhand").expect("built-in overhand");
    let turn = &script.turn[0];
    let tying: Vec<V> = turn
        .targets([40.0, 0.0, 0.0], script.max_step)
        .into_iter()
        .map(V::from)
        .collect();
    // As many moves of the same length, the head leading the rope forward along a circle of radius 15:
    // the rope bends gently and never meets itself.
    let free: Vec<V> = (1..=tying.len())
        .map(|k| {
            let a = k as f64 * script.max_step / 15.0;
            V::new(40.0 + 15.0 * a.sin(), 15.0 - 15.0 * a.cos(), 0.0)
        })
        .collect();
    let schemes = [Handling::None, Handling::Paper, Handling::Capsules];
    println!(
        "### Collision cost per move\n\n40-unit rope of thickness 0.2, {} moves per run, {rounds} rounds \
         with the schemes interleaved (µs per move; `tying` is the built-in overhand's head moves, \
         `free` as many moves leading the rope along a wide circle where nothing touches; `knot` is \
         what the rope holds at the end of the last round):\n",
        tying.len()
    );
    println!(
        "| scenario | links | collision | median µs | p99 µs | max µs | median ÷ no collision's \
         | locked moves | knot |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|---:|---|");
    for (scenario, targets) in [("tying", &tying), ("free", &free)] {
        for n in [40usize, 160, 320] {
            let mut all: Vec<Vec<u64>> = vec![Vec::new(); schemes.len()];
            let mut last: Vec<(usize, String)> = vec![(0, String::new()); schemes.len()];
            for r in 0..rounds {
                for k in 0..schemes.len() {
                    let i = (k + r) % schemes.len();
                    let out = run(n, schemes[i], targets, 64, 0.01, 1.5, false);
                    all[i].extend(out.ns);
                    last[i] = (out.locked, out.knot);
                }
            }
            let base = pct(&mut all[0].clone(), 0.5);
            for (i, h) in schemes.iter().enumerate() {
                let med = pct(&mut all[i], 0.5);
                println!(
                    "| {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.1} | {} | {} |",
                    scenario,
                    n,
                    h.name(),
                    med,
                    pct(&mut all[i], 0.99),
                    pct(&mut all[i], 1.0),
                    med / base,
                    last[i].0,
                    last[i].1
                );
            }
        }
    }
    // `scripts/ab-collision.sh` compares the first table across commits and skips the trade.
    if std::env::var_os("COLLISION_BENCH_COST_ONLY").is_none() {
        trade(&tying);
    }
}

/// The speed/accuracy trade of collision handling: passes allowed and tolerance, per scheme.
fn trade(tying: &[V]) {
    println!(
        "\n### Collision handling: speed against accuracy\n\nThe tying path ({} moves), rope \
         thickness {THICKNESS}, for each scheme over the resolution passes allowed per substep and the \
         tolerance; after every accepted move the rope is checked independently of the solver \
         (`knots::check`: every pair of links with at least a thickness of rope between them) and \
         `worst penetration` is the deepest overlap found, as a fraction of the thickness:\n",
        tying.len()
    );
    println!(
        "| links | collision | passes allowed | tolerance | over-relaxation | mean µs | median µs \
         | p99 µs | passes per accepted move | locked moves | worst penetration | knot |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    let mut grid: Vec<(u32, f64, f64)> = [1u32, 2, 4, 8, 16, 64, 256]
        .iter()
        .map(|&m| (m, 0.01, 1.5))
        .collect();
    grid.extend([
        (256, 0.1, 1.5),
        (256, 0.001, 1.5),
        (64, 0.01, 1.0),
        (64, 0.01, 1.9),
    ]);
    for n in [160usize, 320] {
        for h in [Handling::Paper, Handling::Capsules] {
            for &(m, tol, omega) in &grid {
                let mut r = run(n, h, tying, m, tol, omega, true);
                let accepted = (r.ns.len() - r.locked).max(1);
                println!(
                    "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {:.4} | {} |",
                    n,
                    h.name(),
                    m,
                    tol,
                    omega,
                    r.ns.iter().sum::<u64>() as f64 / r.ns.len() as f64 / 1e3,
                    pct(&mut r.ns, 0.5),
                    pct(&mut r.ns, 0.99),
                    r.passes as f64 / accepted as f64,
                    r.locked,
                    r.worst,
                    r.knot
                );
            }
        }
    }
}
