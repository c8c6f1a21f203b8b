//! Hair: 10⁴ strands of 20 links, every strand's head moved to its own target each frame.
//!
//! `cargo bench -p solver-service --bench strands` prints one table, ns per link-step (a frame's time over
//! strands × links × substeps; median and p90 over timed batches, the variants interleaved batch by
//! batch so they share the machine's state):
//!
//! * *one Chain per strand*: the kernel's `Chain::move_joint` (closed-form tractrix) on each strand;
//! * *strands, baseline*: `tractrix::strands` on the target's baseline instructions (SSE2), one thread;
//! * *strands, SIMD*: the same sweep on the best instructions the CPU has (run-time detection);
//! * *strands, SIMD, 2 threads spawned per frame*: the state cut in two halves, one swept on a scoped
//!   thread spawned for the frame and one on the caller (the spawn is timed with the frame);
//! * *bundle on two cores (the service's)*: `world::two_cores::Bundle`, the halves owned by the
//!   caller and by a helper thread that sleeps between frames (its wake-up is timed with the frame);
//! * *service: decode + move*: the same move as a wire request to a scene's `[[bundle]]`
//!   (`World::apply_wire`: the request checked, the wire targets converted, the bundle moved), what
//!   the service reports as `solve_ns`;
//! * *service: decode + move + response payload*: the same, plus writing the response's joints (all
//!   strands × (links + 1), as the serving loop writes them into shared memory) into a buffer
//!   (`World::respond`).
//!
//! After the run the strands' joints are compared with the chains' (*max joint difference*, links),
//! and the SIMD state with the baseline and two-core states (bit for bit).
//!
//! A second table trades speed for accuracy: 5000 strands whose heads all follow the same helix
//! (30 moves), for 1 to 16 substeps, each variant timed over the whole path (median of a few runs
//! from the same start) and its end state compared with the continuous ground truth (DOP853,
//! `tractrix::ground_truth`): the largest joint distance over three strands, in links. ★ marks the
//! rows no other row of the same precision beats in both time and error. `STRANDS_BENCH_SCALE`
//! (default 1.0) scales the number of batches and frames.

use nalgebra::Vector3;
use shared::{Command, RequestHeader, SubstepMode, Vec3};
use solver_service::serve::respond;
use solver_service::service::Solver;
use solver_service::wire::WireWorld;
use std::hint::black_box;
use std::time::Instant;
use tractrix::ground_truth::{GroundTruthOptions, follow_path, helix};
use tractrix::strands::{Simd, StrandReal, Strands, best_simd};
use tractrix::{Chain, MoveOptions, Real, Substeps};
use world::World;
use world::owners::LOCAL;
use world::scene::parse_scene;
use world::two_cores::Bundle;

const STRANDS: usize = 10_000;
const LINKS: usize = 20;

fn heads<T: Real>() -> Vec<Vector3<T>> {
    (0..STRANDS)
        .map(|i| {
            let (a, b) = ((i % 100) as f64, (i / 100) as f64);
            Vector3::new(T::lit(a * 0.3), T::lit(0.0), T::lit(b * 0.3))
        })
        .collect()
}

/// Frame `f`'s target for the head that started at `h0`: a small circle, phase by strand.
fn target<T: Real>(h0: &Vector3<T>, i: usize, f: usize) -> Vector3<T> {
    let a = f as f64 * 0.37 + i as f64 * 0.001;
    h0 + Vector3::new(T::lit(0.3 * a.cos()), T::lit(0.1), T::lit(0.3 * a.sin()))
}

fn stats(v: &mut [f64]) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[(v.len() - 1) * 9 / 10])
}

struct Row {
    name: &'static str,
    median: f64,
    p90: f64,
}

/// The bench's strands as a scene's bundle: the same grid, links and hanging direction.
fn scene(precision: &str) -> World {
    let text = format!(
        "[[bundle]]\nname = \"hair\"\nstrands = {STRANDS}\nlinks = {LINKS}\nlink_length = 0.1\n\
         columns = 100\nspacing = 0.3\nhang = [0, -1, 0]\nprecision = \"{precision}\"\n"
    );
    let mut set = World::new(&parse_scene(&text, "bench").unwrap()).unwrap();
    // Four substeps are 100,000 block-steps, over the service's default budget (`--budget`).
    set.set_budget(u64::MAX);
    set
}

fn run<T: StrandReal + Send>(
    precision: &str,
    k: usize,
    batches: usize,
    frames: usize,
) -> (Vec<Row>, f64, bool) {
    let h0 = heads::<T>();
    let mut solver = Solver::new(scene(precision), None, std::time::Duration::ZERO);
    let set = solver.set();
    let mut request = RequestHeader::new(Command::Move, 0);
    request.substep_mode = SubstepMode::Fixed as u32;
    request.substeps = k as u32;
    // The scene's heads lie in z = 0 on the same grid; each gets the same circle as in `target`.
    let wire_heads: Vec<Vec3> = set.bundles()[0]
        .spec
        .heads
        .iter()
        .map(|h| Vec3::new(h.x, h.y, h.z))
        .collect();
    let mut wire: Vec<Vec3> = Vec::new();
    let mut out: Vec<Vec3> = Vec::new();
    let down = Vector3::new(T::zero(), -T::one(), T::zero());
    let len = T::lit(0.1);
    let mut chains: Vec<Chain<T, 3>> = h0
        .iter()
        .map(|h| Chain::straight(LINKS, len, h + down * T::lit(LINKS as f64 * 0.1), -down).unwrap())
        .collect();
    let fresh = Strands::<T>::straight(&h0, LINKS, len, down).unwrap();
    let (mut base, mut simd, mut two) = (fresh.clone(), fresh.clone(), fresh.clone());
    let mut bundle = Bundle::new(fresh, true).unwrap();
    assert!(bundle.on_two_cores());
    let opts = MoveOptions {
        substeps: Substeps::Fixed(k as u32),
        ..MoveOptions::default()
    };
    // Each batch's targets, computed before its timed loops (frame-major).
    let mut targets: Vec<Vector3<T>> = Vec::new();
    let mut times: [Vec<f64>; 7] = Default::default();
    let work = (STRANDS * LINKS * k * frames) as f64;
    let mut frame = 0;
    for _ in 0..batches {
        let f0 = frame;
        targets.clear();
        for f in f0..f0 + frames {
            targets.extend(h0.iter().enumerate().map(|(i, h)| target(h, i, f)));
        }
        let t = Instant::now();
        for frame_targets in targets.chunks_exact(STRANDS) {
            for (c, x) in chains.iter_mut().zip(frame_targets) {
                c.move_joint(LINKS, *x, &opts).unwrap();
            }
        }
        times[0].push(t.elapsed().as_nanos() as f64 / work);
        for (v, s, mode) in [(1, &mut base, Simd::Baseline), (2, &mut simd, Simd::Best)] {
            let t = Instant::now();
            for frame_targets in targets.chunks_exact(STRANDS) {
                s.move_heads(black_box(frame_targets), k, mode).unwrap();
            }
            times[v].push(t.elapsed().as_nanos() as f64 / work);
        }
        let t = Instant::now();
        for frame_targets in targets.chunks_exact(STRANDS) {
            two.stage(black_box(frame_targets)).unwrap();
            let staged = two.take_staged();
            let at = two.n_blocks() / 2;
            let (left, right) = two.split_at_block(at);
            std::thread::scope(|sc| {
                sc.spawn(|| left.sweep(&staged, k, Simd::Best));
                right.sweep(&staged, k, Simd::Best);
            });
            two.restore_staged(staged);
        }
        times[3].push(t.elapsed().as_nanos() as f64 / work);
        let t = Instant::now();
        for frame_targets in targets.chunks_exact(STRANDS) {
            bundle.move_heads(black_box(frame_targets), k).unwrap();
        }
        times[4].push(t.elapsed().as_nanos() as f64 / work);
        wire.clear();
        for f in f0..f0 + frames {
            wire.extend(wire_heads.iter().enumerate().map(|(i, h)| {
                let p = target(&Vector3::new(h.x, h.y, h.z), i, f);
                Vec3::new(p.x, p.y, p.z)
            }));
        }
        let t = Instant::now();
        for frame_targets in wire.chunks_exact(STRANDS) {
            let o = solver
                .set_mut()
                .apply_wire(&request, black_box(frame_targets))
                .unwrap();
            assert!(o.changed);
        }
        times[5].push(t.elapsed().as_nanos() as f64 / work);
        let t = Instant::now();
        for frame_targets in wire.chunks_exact(STRANDS) {
            let (h, _) = respond(
                &mut solver,
                LOCAL,
                &request,
                black_box(frame_targets),
                &mut out,
            );
            assert_eq!(h.status, 0, "{}", h.reason_str());
            black_box(&out);
        }
        times[6].push(t.elapsed().as_nanos() as f64 / work);
        frame += frames;
    }
    let mut worst = 0.0f64;
    for (i, c) in chains.iter().enumerate() {
        let mut j = 0;
        simd.for_each_joint(i, |p| {
            worst = worst.max((p - c.joint(j)).norm().to_f64() / 0.1);
            j += 1;
        });
    }
    let mut same = base == simd && simd == two;
    for i in 0..STRANDS {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        simd.for_each_joint(i, |p| a.push(p));
        bundle.for_each_joint(i, |p| b.push(p));
        same &= a == b;
    }
    let names = [
        "one Chain per strand",
        "strands, baseline",
        "strands, SIMD",
        "strands, SIMD, 2 threads spawned per frame",
        "bundle on two cores (the service's)",
        "service: decode + move",
        "service: decode + move + response payload",
    ];
    let rows = names
        .iter()
        .zip(times.iter_mut())
        .map(|(name, t)| {
            let (median, p90) = stats(t);
            Row { name, median, p90 }
        })
        .collect();
    (rows, worst, same)
}

/// One row of the speed-against-accuracy table.
struct AccRow {
    precision: &'static str,
    k: usize,
    variant: &'static str,
    error: f64,
    frame_us: f64,
    ns_per_step: f64,
}

/// The helix path for 5000 strands, every variant and substep count in `ks`.
fn accuracy<T: StrandReal + Send>(
    precision: &'static str,
    ks: &[usize],
    reps: usize,
) -> Vec<AccRow> {
    // Enough strands for the bundle to use its second core (TWO_CORES_FROM link-steps).
    const N: usize = 5000;
    const MOVES: usize = 30;
    let len = 0.1;
    let h0: Vec<Vector3<T>> = heads::<T>().into_iter().take(N).collect();
    let path = helix(Vector3::zeros(), 0.5, 0.5, 1.0, MOVES);
    // The ground truth of one strand hanging from the origin (every strand moves the same way).
    let points: Vec<Vector3<f64>> = (0..=LINKS)
        .map(|j| Vector3::new(0.0, -((LINKS - j) as f64) * len, 0.0))
        .collect();
    let truth = follow_path(&points, LINKS, &path, &GroundTruthOptions::default())
        .expect("the ground truth integrates");
    let down = Vector3::new(T::zero(), -T::one(), T::zero());
    let to64 = |v: Vector3<T>| Vector3::new(v.x.to_f64(), v.y.to_f64(), v.z.to_f64());
    let targets: Vec<Vec<Vector3<T>>> = path
        .iter()
        .map(|o| {
            let o = Vector3::new(T::lit(o.x), T::lit(o.y), T::lit(o.z));
            h0.iter().map(|h| h + o).collect()
        })
        .collect();
    let probe = [0, N / 2, N - 1];
    let error_of = |joints: &dyn Fn(usize) -> Vec<Vector3<f64>>| {
        let mut worst = 0.0f64;
        for &i in &probe {
            let h = to64(h0[i]);
            for (p, t) in joints(i).iter().zip(&truth) {
                worst = worst.max((p - (h + t)).norm() / len);
            }
        }
        worst
    };
    let fresh = Strands::<T>::straight(&h0, LINKS, T::lit(len), down).unwrap();
    let mut rows = Vec::new();
    for &k in ks {
        let work = (N * LINKS * k * MOVES) as f64;
        let mut push = |variant, mut times: Vec<f64>, error| {
            times.sort_by(f64::total_cmp);
            let t = times[times.len() / 2];
            rows.push(AccRow {
                precision,
                k,
                variant,
                error,
                frame_us: t / MOVES as f64 / 1e3,
                ns_per_step: t / work,
            });
        };
        // One Chain per strand.
        let opts = MoveOptions {
            substeps: Substeps::Fixed(k as u32),
            ..MoveOptions::default()
        };
        let (mut times, mut error) = (Vec::new(), 0.0);
        for _ in 0..reps {
            let mut chains: Vec<Chain<T, 3>> = h0
                .iter()
                .map(|h| {
                    Chain::straight(
                        LINKS,
                        T::lit(len),
                        h + down * T::lit(LINKS as f64 * len),
                        -down,
                    )
                    .unwrap()
                })
                .collect();
            let t = Instant::now();
            for frame in &targets {
                for (c, x) in chains.iter_mut().zip(frame) {
                    c.move_joint(LINKS, *x, &opts).unwrap();
                }
            }
            times.push(t.elapsed().as_nanos() as f64);
            error = error_of(&|i| (0..=LINKS).map(|j| to64(chains[i].joint(j))).collect());
        }
        push("one Chain per strand", times, error);
        // Strands, SIMD, one core.
        let (mut times, mut error) = (Vec::new(), 0.0);
        for _ in 0..reps {
            let mut s = fresh.clone();
            let t = Instant::now();
            for frame in &targets {
                s.move_heads(frame, k, Simd::Best).unwrap();
            }
            times.push(t.elapsed().as_nanos() as f64);
            error = error_of(&|i| {
                let mut v = Vec::new();
                s.for_each_joint(i, |p| v.push(to64(p)));
                v
            });
        }
        push("strands, SIMD", times, error);
        // The service's bundle on two cores.
        let (mut times, mut error) = (Vec::new(), 0.0);
        for _ in 0..reps {
            let mut b = Bundle::new(fresh.clone(), true).unwrap();
            assert!(b.on_two_cores());
            let t = Instant::now();
            for frame in &targets {
                b.move_heads(frame, k).unwrap();
            }
            times.push(t.elapsed().as_nanos() as f64);
            error = error_of(&|i| {
                let mut v = Vec::new();
                b.for_each_joint(i, |p| v.push(to64(p)));
                v
            });
        }
        push("bundle on two cores", times, error);
    }
    rows
}

fn main() {
    let scale: f64 = std::env::var("STRANDS_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|s: &f64| s.is_finite() && *s > 0.0)
        .unwrap_or(1.0);
    let batches = ((20.0 * scale).round() as usize).max(3);
    let frames = 2;
    println!(
        "Every head moved each frame ({STRANDS} strands × {LINKS} links, {batches} batches of \
         {frames} frames per variant, interleaved); SIMD here: **{}**; the aim is ≤ 10 ns per \
         link-step in f64 and ≤ 5 ns in f32.\n",
        best_simd()
    );
    println!(
        "| precision | substeps | variant | median ns per link-step | p90 of batches | speed-up over \
         one Chain per strand (medians) | max joint difference from the chains, links | SIMD = \
         baseline = two cores, bit for bit |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|---|");
    for (tag, k) in [("f64", 1usize), ("f64", 4), ("f32", 1), ("f32", 4)] {
        let (rows, worst, same) = if tag == "f64" {
            run::<f64>(tag, k, batches, frames)
        } else {
            run::<f32>(tag, k, batches, frames)
        };
        let chain = rows[0].median;
        for r in &rows {
            println!(
                "| {tag} | {k} | {} | {:.2} | {:.2} | {:.1} | {worst:.1e} | {} |",
                r.name,
                r.median,
                r.p90,
                chain / r.median,
                if same { "yes" } else { "**no**" }
            );
        }
    }

    let reps = ((5.0 * scale).round() as usize).max(1);
    println!(
        "\n### Speed against accuracy: 5000 strands × {LINKS} links, every head along one helix \
         (30 moves; error: largest joint distance from the ground truth at the end, in links; \
         median of {reps} runs)\n"
    );
    println!(
        "| precision | substeps | variant | error, links | µs per frame (5000 strands) | ns per \
         link-step | ★ |"
    );
    println!("|---|---:|---|---:|---:|---:|---|");
    let ks = [1usize, 2, 4, 8, 16];
    let mut rows = accuracy::<f64>("f64", &ks, reps);
    rows.extend(accuracy::<f32>("f32", &ks, reps));
    for r in &rows {
        let front = !rows.iter().any(|o| {
            o.precision == r.precision
                && o.frame_us <= r.frame_us
                && o.error <= r.error
                && (o.frame_us < r.frame_us || o.error < r.error)
        });
        println!(
            "| {} | {} | {} | {:.1e} | {:.0} | {:.2} | {} |",
            r.precision,
            r.k,
            r.variant,
            r.error,
            r.frame_us,
            r.ns_per_step,
            if front { "★" } else { "" }
        );
    }
}
