//! What independent work in flight buys the closed-form tractrix step, which on one rope is a chain of
//! dependent divisions, square roots and exponentials (each link waits for the shift of the one before).
//!
//! `cargo bench -p tractrix --bench throughput` prints two tables, ns per link-step (median and
//! p90 over timed batches, variants interleaved batch by batch):
//!
//! 1. **Wavefront over substeps**, one rope of 1000 links: a move of `k` substeps done substep after
//!    substep (as `Chain::move_joint` does), against a wavefront that runs substep `s` of link `i`
//!    beside substep `s − 1` of link `i + 1` (they are independent), keeping up to `k` steps in flight.
//!    Both orders do the same operations on the same inputs: the bench checks the results are identical
//!    bit for bit. A third column times the kernel's own `Chain::move_joint` on the same rope and
//!    moves (it runs `k ≥ 2` substeps as such wavefronts, with SIMD across the steps in flight from
//!    `k = 4`), checked against the loops to 1e-12.
//! 2. **Many chains**: hair, 10⁴ strands of 20 links, every head moved each frame; strands one after
//!    another, against groups of G strands advanced link by link together (G independent steps in
//!    flight).

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Instant;
use tractrix::link::tractrix_step;
use tractrix::{Chain, MoveOptions, Substeps};

type V = Vector3<f64>;

/// Link vectors (tail − head, head end first) of a rope bent into a gentle helix, so no step is
/// degenerate.
fn rope(n: usize) -> Vec<V> {
    (0..n)
        .map(|i| {
            let a = i as f64 * 0.05;
            V::new(-1.0, 0.2 * a.sin(), 0.2 * a.cos()).normalize()
        })
        .collect()
}

/// `k` substeps of `delta / k`, one after another. Returns the tail's total shift.
fn sequential(links: &mut [V], delta: V, k: usize) -> V {
    // The length from memory, as the kernel reads it (a literal 1.0 would fold divisions away).
    let len = black_box(1.0);
    let sub = delta / k as f64;
    let mut tail = V::zeros();
    for _ in 0..k {
        let mut s = sub;
        for l in links.iter_mut() {
            let st = tractrix_step(l, &s, len);
            *l = st.link;
            s = st.tail_shift;
        }
        tail += s;
    }
    tail
}

/// The same substeps as a wavefront: at diagonal `d`, lane `s` steps link `d − s`.
fn wavefront(links: &mut [V], delta: V, k: usize, lanes: &mut Vec<V>) -> V {
    let len = black_box(1.0);
    let n = links.len();
    lanes.clear();
    lanes.resize(k, delta / k as f64);
    let mut tail = V::zeros();
    for d in 0..n + k - 1 {
        let lo = d.saturating_sub(n - 1);
        let hi = d.min(k - 1);
        for (s, lane) in lanes.iter_mut().enumerate().take(hi + 1).skip(lo) {
            let i = d - s;
            let st = tractrix_step(&links[i], lane, len);
            links[i] = st.link;
            *lane = st.tail_shift;
        }
        // From d = n − 1 on, lane `lo` has just stepped the last link: its shift is the tail's.
        if d + 1 >= n {
            tail += lanes[lo];
        }
    }
    tail
}

/// The bench's rope as a kernel chain (link vectors `Xᵢ − Xᵢ₋₁` tail first, joint `n` the head).
fn as_chain(links: &[V]) -> Chain<f64, 3> {
    let l: Vec<V> = links.iter().rev().map(|l| -l).collect();
    let n = l.len();
    Chain::from_raw_parts(V::zeros(), l, vec![1.0; n]).expect("a unit rope")
}

fn head_move(frame: usize) -> V {
    let a = frame as f64 * 0.37;
    V::new(0.3 * a.cos(), 0.3 * a.sin(), 0.1)
}

fn stats(v: &mut [f64]) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[(v.len() - 1) * 9 / 10])
}

fn main() {
    let batches = 30;
    println!(
        "### Wavefront over substeps: one rope of 1000 links, ns per link-step \
         (medians of {batches} batches)\n"
    );
    println!(
        "| substeps k | substep after substep (bench loop), median ns | wavefront (bench loop), median ns \
         | speed-up (after ÷ wavefront) | kernel `Chain::move_joint`, median ns | speed-up (after ÷ kernel) |"
    );
    println!("|---:|---:|---:|---:|---:|---:|");
    for k in [1usize, 2, 4, 8, 16, 32] {
        let mut a = rope(1000);
        let mut b = a.clone();
        let mut c = as_chain(&a);
        let opts = MoveOptions {
            substeps: Substeps::Fixed(k as u32),
            ..MoveOptions::default()
        };
        let mut lanes = Vec::new();
        // Same results, bit for bit; the kernel's to rounding (it divides the move from where it
        // summed the head).
        for f in 0..5 {
            let ta = sequential(&mut a, head_move(f), k);
            let tb = wavefront(&mut b, head_move(f), k, &mut lanes);
            assert_eq!(a, b, "k = {k}: the wavefront changed the result");
            assert_eq!(ta, tb, "k = {k}: the tail shifts differ");
            let head = c.head_index();
            c.move_joint(head, c.head() + head_move(f), &opts).unwrap();
        }
        // Where the head is: the last target, exactly (the kernel lands it there).
        let mut at = c.head();
        let off = as_chain(&a)
            .links()
            .iter()
            .zip(c.links())
            .map(|(x, y)| (x - y).amax())
            .fold(0.0, f64::max);
        assert!(
            off < 1e-12,
            "k = {k}: the kernel differs from the loops by {off:e}"
        );
        let moves = (400 / k).max(4);
        let (mut ts, mut tw, mut tk) = (Vec::new(), Vec::new(), Vec::new());
        for batch in 0..batches {
            let t0 = Instant::now();
            for f in 0..moves {
                black_box(sequential(&mut a, head_move(batch * moves + f), k));
            }
            ts.push(t0.elapsed().as_nanos() as f64 / (moves * k * 1000) as f64);
            let t0 = Instant::now();
            for f in 0..moves {
                black_box(wavefront(
                    &mut b,
                    head_move(batch * moves + f),
                    k,
                    &mut lanes,
                ));
            }
            tw.push(t0.elapsed().as_nanos() as f64 / (moves * k * 1000) as f64);
            let head = c.head_index();
            let t0 = Instant::now();
            for f in 0..moves {
                at += head_move(batch * moves + f);
                black_box(c.move_joint(head, at, &opts).unwrap());
            }
            tk.push(t0.elapsed().as_nanos() as f64 / (moves * k * 1000) as f64);
        }
        let (s50, _) = stats(&mut ts);
        let (w50, _) = stats(&mut tw);
        let (k50, _) = stats(&mut tk);
        println!(
            "| {k} | {s50:.1} | {w50:.1} | {:.2} | {k50:.1} | {:.2} |",
            s50 / w50,
            s50 / k50
        );
    }

    println!(
        "\n### Hair: 10⁴ strands of 20 links, every head moved, ns per link-step \
         ({batches} batches)\n"
    );
    println!(
        "| strands in flight G | median ns | p90 of batches, ns | speed-up over G = 1 (medians) |"
    );
    println!("|---:|---:|---:|---:|");
    let strands = 10_000;
    let links = 20;
    let base: Vec<V> = rope(links);
    let mut hair: Vec<V> = (0..strands).flat_map(|_| base.iter().copied()).collect();
    let groups = [1usize, 2, 4, 8, 16];
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); groups.len()];
    let mut shifts = vec![V::zeros(); 16];
    for batch in 0..batches {
        for (gi, &g) in groups.iter().enumerate() {
            let t0 = Instant::now();
            for frame in 0..4 {
                let d = head_move(batch * 4 + frame) * 0.1;
                for group in hair.chunks_mut(g * links) {
                    let here = group.len() / links;
                    shifts[..here].fill(d);
                    for i in 0..links {
                        for (j, s) in shifts[..here].iter_mut().enumerate() {
                            let l = &mut group[j * links + i];
                            let st = tractrix_step(l, s, 1.0);
                            *l = st.link;
                            *s = st.tail_shift;
                        }
                    }
                }
            }
            black_box(&hair);
            times[gi].push(t0.elapsed().as_nanos() as f64 / (4 * strands * links) as f64);
        }
    }
    let base_median = stats(&mut times[0].clone()).0;
    for (gi, &g) in groups.iter().enumerate() {
        let (m, p90) = stats(&mut times[gi]);
        println!("| {g} | {m:.1} | {p90:.1} | {:.2} |", base_median / m);
    }
}
