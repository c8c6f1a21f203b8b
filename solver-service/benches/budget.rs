//! Every request inside its budget (issue 35): how long the longest accepted request takes against the
//! time of the budget, on the shipped scenes, with collision work metered by the kernel.
//!
//! `cargo bench -p solver-service --bench budget` loads `default.toml` and `knots.toml` (with the
//! budget a start gives each: the scene's `budget`, else the default) and, for every chain with
//! collision handling, sends moves through the service's request handler (`World::apply_wire`:
//! decode, estimate, the kernel with its meter, the undo copy), each timed: a random joint sent to where
//! another joint of the rope is, or a short random step, so that most moves push into the rope.
//!
//! **The budget's time** is the budget in link-steps times the time of one of the chain's own
//! link-steps, measured in the same run by plain tractrix moves (`Chain::move_joint`, no collision, one
//! substep) of a straight chain with the same links: what the estimate counts a link-step as. The last
//! column divides the slowest accepted request by it; the issue asks for at most 2. The requests
//! refused as over-budget were stopped by the meter (or the estimate) with the chain unchanged; their
//! time is in the column beside. `BUDGET_BENCH_MOVES` (default 60) sets the moves per chain.

use nalgebra::Vector3;
use shared::{Command, RequestHeader, Vec3};
use solver_service::wire::WireWorld;
use std::time::Instant;
use tractrix::{Chain, MoveOptions, Substeps};
use world::World;
use world::scene::parse_scene;

/// A small xorshift generator: the same moves every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Nanoseconds per link-step of plain tractrix moves (no collision) of a straight chain of `n` links of
/// length `len`: the head led along a helix a link per move, one substep each (what the estimate
/// counts as `n` link-steps), median of 15 batches.
fn ns_per_link_step(n: usize, len: f64) -> f64 {
    let mut c = Chain::<f64, 3>::straight(n, len, Vector3::zeros(), Vector3::x()).unwrap();
    let opts = MoveOptions {
        substeps: Substeps::Fixed(1),
        ..MoveOptions::default()
    };
    let per = (200_000 / n).max(1);
    let mut samples = Vec::new();
    let r = 0.25 * n as f64 * len;
    for k in 0..15 {
        let t0 = Instant::now();
        for i in 0..per {
            let a = (k * per + i) as f64 * len / r;
            let head = Vector3::new(n as f64 * len + r * a.cos(), r * a.sin(), 0.1 * a);
            c.move_joint(n, head, &opts).unwrap();
        }
        samples.push(t0.elapsed().as_nanos() as f64 / (per * n) as f64);
    }
    samples.sort_by(f64::total_cmp);
    samples[samples.len() / 2]
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let moves: usize = std::env::var("BUDGET_BENCH_MOVES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60)
        .clamp(1, 100_000);
    let scenes = [
        ("default.toml", include_str!("../scenes/default.toml")),
        ("knots.toml", include_str!("../scenes/knots.toml")),
    ];
    println!(
        "### Every request inside its budget\n\n{moves} moves per chain with collision handling, through \
         the request handler. `link-step ns`: a plain tractrix link-step of the same chain without \
         collision, measured in this run; the budget's time is the budget times it. Times in ms; \
         `slowest ÷ budget's time` divides the slowest accepted request by the budget's time.\n"
    );
    println!(
        "| scene | chain | links | budget (link-steps) | link-step ns | budget's time ms | accepted | over-budget | \
         locked | most work accepted (link-steps) | median ms | p99 ms | slowest accepted ms | \
         slowest refused ms | slowest ÷ budget's time |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut worst_ratio: f64 = 0.0;
    for (file, text) in scenes {
        let scene = parse_scene(text, file).expect("a shipped scene");
        let mut set = World::new(&scene).expect("chains");
        let budget = scene.budget.unwrap_or(world::chains::DEFAULT_BUDGET);
        set.set_budget(budget);
        for chain in 0..set.len() as u32 {
            let spec = &set.specs()[chain as usize];
            if spec.collision.is_none() {
                continue;
            }
            let (name, links) = (spec.name.clone(), spec.lengths.len());
            let shortest = spec.shortest;
            let step_ns = ns_per_link_step(links, spec.lengths[0]);
            let budget_ms = budget as f64 * step_ns / 1e6;
            let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ u64::from(chain + 1));
            let (mut ok_ms, mut refused_ms) = (Vec::new(), Vec::new());
            let (mut over, mut locked, mut most) = (0usize, 0usize, 0u64);
            let mut joints: Vec<Vec3> = Vec::new();
            for _ in 0..moves {
                joints.clear();
                set.elements_of(chain, false)
                    .gather_into(&mut joints, links + 1);
                let j = rng.below(links + 1);
                let target = if rng.unit() < 0.5 {
                    // Where another joint of the rope is: into the rope.
                    joints[rng.below(links + 1)]
                } else {
                    let p = joints[j];
                    let r = 3.0 * shortest;
                    Vec3::new(
                        p.x + r * (rng.unit() - 0.5),
                        p.y + r * (rng.unit() - 0.5),
                        p.z + r * (rng.unit() - 0.5),
                    )
                };
                let mut h = RequestHeader::new(Command::Move, chain);
                h.joint = j as u32;
                let t0 = Instant::now();
                let r = set.apply_wire(&h, &[target]);
                let ms = t0.elapsed().as_secs_f64() * 1e3;
                match r {
                    Ok(_) => {
                        ok_ms.push(ms);
                        most = most.max(set.last_work());
                    }
                    Err(e) => {
                        refused_ms.push(ms);
                        match e.cause {
                            world::refusal::Cause::OverBudget => over += 1,
                            world::refusal::Cause::Locked => locked += 1,
                            _ => {}
                        }
                    }
                }
            }
            let slowest = pct(&mut ok_ms.clone(), 1.0);
            let ratio = slowest / budget_ms;
            worst_ratio = worst_ratio.max(ratio);
            println!(
                "| {file} | {name} | {links} | {budget} | {step_ns:.1} | {budget_ms:.2} | {} | {over} | {locked} | \
                 {most} | {:.3} | {:.3} | {slowest:.3} | {:.3} | {ratio:.2} |",
                ok_ms.len(),
                pct(&mut ok_ms.clone(), 0.5),
                pct(&mut ok_ms, 0.99),
                pct(&mut refused_ms, 1.0),
            );
        }
    }
    println!("\nSlowest accepted request ÷ its budget's time, over every chain: {worst_ratio:.2}.");
}
