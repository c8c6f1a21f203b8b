//! What collision handling costs per move, and what it buys, measured side by side in one run.
//!
//! `cargo bench -p clients --bench collision` prints, for a rope 40 units long in 40, 160 and 320 links
//! (thickness 0.2), with no collision, the paper's spheres (section 4.2) and capsules on a hash grid:
//!
//! * **tying**: the built-in overhand script's head path (the `hand run --builtin overhand` moves): time
//!   per move (median, p99, max), the ratio of medians to no collision, moves refused as locked, and the
//!   knot the rope holds at the end (the accuracy side: without collision the rope passes through itself);
//! * **free**: as many moves of the head leading the rope forward along a wide circle, nothing ever
//!   touching: the cost of detection alone.
//!
//! Schemes are interleaved round by round so machine noise hits them alike. `COLLISION_BENCH_ROUNDS`
//! (default 5) sets the rounds.

use clients::script::Script;
use nalgebra::Vector3;
use solver::kernel::chain::{Chain, MoveOptions};
use solver::kernel::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, Scheme, move_joint_colliding,
};
use solver::kernel::knot::identify;
use std::time::Instant;

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

struct Run {
    ns: Vec<u64>,
    locked: usize,
    knot: String,
}

fn run(n: usize, handling: Handling, targets: &[V]) -> Run {
    let len = 40.0 / n as f64;
    let mut chain = Chain::<f64, 3>::straight(n, len, V::zeros(), V::x()).expect("chain");
    let model = CollisionModel {
        options: CollisionOptions {
            scheme: if handling == Handling::Paper {
                Scheme::PaperSpheres
            } else {
                Scheme::Capsules
            },
            thickness: 0.2,
            ..CollisionOptions::default()
        },
        obstacles: vec![],
    };
    let mut ws = CollisionWorkspace::new();
    let opts = MoveOptions::default();
    let mut ns = Vec::with_capacity(targets.len());
    let mut locked = 0;
    for t in targets {
        let t0 = Instant::now();
        let r = match handling {
            Handling::None => chain.move_joint(n, *t, &opts),
            _ => move_joint_colliding(&mut chain, n, *t, &opts, &model, &mut ws),
        };
        ns.push(t0.elapsed().as_nanos() as u64);
        if r.is_err() {
            locked += 1;
        }
    }
    let knot = format!("{:?}", identify(&chain.positions()).kind).to_lowercase();
    Run { ns, locked, knot }
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
        "collision cost per move, 40-unit rope, thickness 0.2, {} moves per run, {rounds} rounds \
         (cargo bench -p clients --bench collision)",
        tying.len()
    );
    println!(
        "{:<8} {:>5} {:<14} {:>10} {:>10} {:>10} {:>8} {:>7}  {:<8}",
        "scenario",
        "links",
        "collision",
        "median µs",
        "p99 µs",
        "max µs",
        "× none",
        "locked",
        "knot"
    );
    for (scenario, targets) in [("tying", &tying), ("free", &free)] {
        for n in [40usize, 160, 320] {
            let mut all: Vec<Vec<u64>> = vec![Vec::new(); schemes.len()];
            let mut last: Vec<(usize, String)> = vec![(0, String::new()); schemes.len()];
            for r in 0..rounds {
                for k in 0..schemes.len() {
                    let i = (k + r) % schemes.len();
                    let out = run(n, schemes[i], targets);
                    all[i].extend(out.ns);
                    last[i] = (out.locked, out.knot);
                }
            }
            let base = pct(&mut all[0].clone(), 0.5);
            for (i, h) in schemes.iter().enumerate() {
                let med = pct(&mut all[i], 0.5);
                println!(
                    "{:<8} {:>5} {:<14} {:>10.2} {:>10.2} {:>10.2} {:>8.1} {:>7}  {:<8}",
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
}
