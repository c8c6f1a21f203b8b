//! Hostile moves in process (issue 68): where a request's time goes as random moves crumple a knot
//! rope, the solve and the knot's name timed apart, against the work the meter charged.
//!
//! `cargo bench -p solver-service --bench crumple` loads the shipped `knots.toml` at the default
//! frame (16,000 link-steps) and, for each rope named below, sends the hostile bench's moves
//! (`cargo bench -p clients --bench hostile`) straight to the request handler
//! (`World::apply_wire`: decode, the kernel with its meter, the undo copy), back to back: a random
//! joint sent to where a random joint of the rope is, up to three thicknesses off it. The rope's
//! knot naming is turned off in the world and done by the bench's own `knots::Namer` on the same
//! states after each move, timed alone, so the two are measured apart with the same work as the
//! service does.
//!
//! Per row, one third of the run in order (the rope crumples as the moves go on): the solve's time
//! per move, its time per charged link-step (the solve's time divided by `World::last_work`), and
//! the namer's time per state. A plain tractrix link-step of a straight chain of the same links,
//! without collision (what a charged link-step is priced as), is timed in the same run, before and
//! after the ropes (its spread is the machine's noise). The bench pins itself to core 1.
//! `CRUMPLE_BENCH_MOVES` (default 9,000) sets the moves per rope.

use nalgebra::Vector3;
use shared::{Command, RequestHeader, Vec3};
use solver_service::wire::WireWorld;
use std::time::Instant;
use tractrix::{Chain, MoveOptions, Substeps};
use world::World;
use world::scene::parse_scene;

/// The ropes moved into (`knots.toml`), as the hostile bench does.
const ROPES: &[&str] = &["hands-160", "hands-320", "tie-320"];

/// How many parts of the run each rope's rows show.
const PARTS: usize = 3;

/// A small xorshift generator: the same moves every run (the hostile bench's seed).
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

/// Nanoseconds per link-step of plain tractrix moves (no collision) of a straight chain of `n` links
/// of length `len`: the head led along a helix a link per move, one substep each, median of 15
/// batches (as the budget bench measures it).
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

/// The nearest-rank quantile `p` of `v` (sorted here).
fn q(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 * p).ceil() as usize).clamp(1, v.len()) - 1]
}

/// One move's measurements.
struct Sample {
    solve_us: f64,
    /// The solve's ns per charged link-step (moves that charged nothing left out).
    per_step_ns: Option<f64>,
    namer_us: f64,
    stopped_short: bool,
    refused: bool,
}

fn main() {
    let moves: usize = std::env::var("CRUMPLE_BENCH_MOVES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(9000)
        .clamp(PARTS, 1_000_000);
    shared::pin_current_thread(1).ok();
    let text = include_str!("../scenes/knots.toml");
    let mut scene = parse_scene(text, "knots.toml").expect("the shipped scene");
    let budget = scene.budget.unwrap_or(world::chains::DEFAULT_BUDGET);
    let before: Vec<f64> = [160, 320]
        .iter()
        .map(|&n| ns_per_link_step(n, 0.25))
        .collect();
    let mut rows = Vec::new();
    let mut refusals = Vec::new();
    for rope in ROPES {
        let index = scene
            .chains
            .iter()
            .position(|c| c.name == *rope)
            .expect("a rope of knots.toml");
        // The world names no knot; the bench's namer names the same states, timed alone.
        scene.chains[index].knot = false;
        let mut set = World::new(&scene).expect("chains");
        scene.chains[index].knot = true;
        set.set_budget(budget);
        let chain = index as u32;
        let spec = &set.specs()[index];
        let (links, thickness) = (spec.lengths.len(), spec.thickness);
        let mut namer = knots::Namer::new();
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut joints: Vec<Vec3> = Vec::new();
        let mut points: Vec<Vector3<f64>> = Vec::new();
        let mut samples = Vec::with_capacity(moves);
        let mut causes: Vec<(String, usize)> = Vec::new();
        for _ in 0..moves {
            joints.clear();
            set.elements_of(chain, false)
                .gather_into(&mut joints, links + 1);
            let n = joints.len();
            let (i, j) = (rng.below(n), rng.below(n));
            let off = |r: &mut Rng| (r.unit() - 0.5) * 6.0 * thickness;
            let p = joints[j];
            let target = Vec3::new(
                p.x + off(&mut rng),
                p.y + off(&mut rng),
                p.z + off(&mut rng),
            );
            let mut h = RequestHeader::new(Command::Move, chain);
            h.joint = i as u32;
            let t0 = Instant::now();
            let r = set.apply_wire(&h, &[target]);
            let solve_ns = t0.elapsed().as_nanos() as f64;
            let work = set.last_work();
            joints.clear();
            set.elements_of(chain, false)
                .gather_into(&mut joints, links + 1);
            points.clear();
            points.extend(joints.iter().map(|p| Vector3::new(p.x, p.y, p.z)));
            let t1 = Instant::now();
            std::hint::black_box(namer.name(std::hint::black_box(&points)));
            let namer_ns = t1.elapsed().as_nanos() as f64;
            if let Err(e) = &r {
                let cause = format!("{:?}", e.cause);
                match causes.iter_mut().find(|(c, _)| *c == cause) {
                    Some((_, k)) => *k += 1,
                    None => causes.push((cause, 1)),
                }
            }
            samples.push(Sample {
                solve_us: solve_ns / 1e3,
                per_step_ns: (work > 0).then(|| solve_ns / work as f64),
                namer_us: namer_ns / 1e3,
                stopped_short: r.as_ref().is_ok_and(|a| a.stopped.is_some()),
                refused: r.is_err(),
            });
        }
        let causes: Vec<String> = causes.iter().map(|(c, k)| format!("{c} {k}")).collect();
        refusals.push(format!(
            "{rope}: {}",
            if causes.is_empty() {
                "none".to_string()
            } else {
                causes.join(", ")
            }
        ));
        let per = moves.div_ceil(PARTS);
        for (k, part) in samples.chunks(per).enumerate() {
            let mut solve: Vec<f64> = part.iter().map(|s| s.solve_us).collect();
            let mut step: Vec<f64> = part.iter().filter_map(|s| s.per_step_ns).collect();
            let mut name: Vec<f64> = part.iter().map(|s| s.namer_us).collect();
            let short = part.iter().filter(|s| s.stopped_short).count();
            let refused = part.iter().filter(|s| s.refused).count();
            rows.push(format!(
                "| {rope} | {links} | {}–{} | {short} | {refused} | {:.0} | {:.0} | {:.0} | {:.0} | \
                 {:.1} | {:.1} | {:.0} | {:.0} | {:.0} | {:.0} |",
                k * per + 1,
                k * per + part.len(),
                q(&mut solve, 0.5),
                q(&mut solve, 0.99),
                q(&mut solve, 0.999),
                q(&mut solve, 1.0),
                q(&mut step, 0.5),
                q(&mut step, 0.99),
                q(&mut name, 0.5),
                q(&mut name, 0.99),
                q(&mut name, 0.999),
                q(&mut name, 1.0),
            ));
        }
    }
    let after: Vec<f64> = [160, 320]
        .iter()
        .map(|&n| ns_per_link_step(n, 0.25))
        .collect();
    println!("### Hostile moves in process: the solve and the knot's name apart\n");
    println!(
        "{moves} hostile moves into each rope of `knots.toml` at the frame of {budget} link-steps, sent \
         to the request handler back to back, one third of the run per row. `solve`: the request \
         handler's time per move; `ns per charged link-step`: the solve's time divided by the work the \
         meter charged it; `namer`: naming the state the move left (the rope's own namer, timed \
         alone). A plain link-step without collision, timed in this run before and after the ropes: \
         {:.1} / {:.1} ns (160 links), {:.1} / {:.1} ns (320 links). Times in µs unless named.\n",
        before[0], after[0], before[1], after[1]
    );
    println!(
        "| rope | links | moves | stopped short | refused | solve p50 µs | p99 | p99.9 | max | \
         ns per charged link-step p50 | p99 | namer p50 µs | p99 | p99.9 | max |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        println!("{r}");
    }
    println!("\nRefused, by cause: {}.", refusals.join("; "));
}
