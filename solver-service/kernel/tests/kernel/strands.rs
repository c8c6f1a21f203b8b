//! Many strands at once: the SIMD sweep against one `Chain` per strand, against its own baseline build
//! bit for bit, split in halves, at the degenerate pushes, and over many moves.

use crate::support::Rng;
use nalgebra::Vector3;
use tractrix::strands::{LANES, Simd, Strands, StrandsError};
use tractrix::{Chain, MoveOptions, Substeps};

type V = Vector3<f64>;

/// A strand's joints, tail first, as the strands give them.
fn strand_joints<T: tractrix::strands::StrandReal>(s: &Strands<T>, i: usize) -> Vec<V> {
    let mut out = Vec::new();
    s.for_each_joint(i, |p| {
        out.push(V::new(p.x.to_f64(), p.y.to_f64(), p.z.to_f64()))
    });
    out
}

/// A move for strand `i`: mostly ordinary, some tiny, some large, some zero, some straight along the
/// strand's first link (the push the lanes hand back to `tractrix_step`).
fn target(rng: &mut Rng, head: V, first_link: V, len: f64) -> V {
    match rng.below(10) {
        0 => head,
        1 => head + rng.dir3() * 1e-9 * len,
        2 => head + rng.dir3() * 5.0 * len,
        3 => head + first_link * rng.range(-0.7, 0.7),
        _ => head + rng.dir3() * rng.range(0.01, 0.6) * len,
    }
}

fn chains_for(heads: &[V], links: usize, len: f64, dir: V) -> Vec<Chain<f64, 3>> {
    heads
        .iter()
        .map(|h| Chain::straight(links, len, h + dir * (links as f64 * len), -dir).unwrap())
        .collect()
}

#[test]
fn strands_agree_with_one_chain_per_strand() {
    for substeps in [1usize, 3, 40] {
        let mut rng = Rng(7 + substeps as u64);
        let (n, links, len) = (37, 20, 0.5);
        let dir = V::new(0.1, -1.0, 0.2).normalize();
        let heads: Vec<V> = (0..n)
            .map(|i| V::new(i as f64 * 0.3, 0.0, rng.unit()))
            .collect();
        let mut strands = Strands::<f64>::straight(&heads, links, len, dir).unwrap();
        let mut chains = chains_for(&heads, links, len, dir);
        let opts = MoveOptions {
            substeps: Substeps::Fixed(substeps as u32),
            ..MoveOptions::default()
        };
        let mut worst = 0.0f64;
        for _ in 0..200 {
            let targets: Vec<V> = (0..n)
                .map(|i| target(&mut rng, strands.head(i), strands.link(i, 0), len))
                .collect();
            strands.move_heads(&targets, substeps, Simd::Best).unwrap();
            for (c, t) in chains.iter_mut().zip(&targets) {
                let h = c.head_index();
                c.move_joint(h, *t, &opts).unwrap();
            }
            for (i, c) in chains.iter().enumerate() {
                let a = strand_joints(&strands, i);
                let b = c.positions();
                assert_eq!(a.len(), b.len());
                for (p, q) in a.iter().zip(&b) {
                    worst = worst.max((p - q).norm() / len);
                }
            }
        }
        // The lanes' exponential differs from the platform's by an ulp or two: after 200 moves of
        // 37 strands the joints agree to a few hundred ulps of a link (measured: 2e-13 at most).
        assert!(
            worst < 1e-11,
            "substeps {substeps}: joints differ by {worst:e} links"
        );
        println!("substeps {substeps}: largest joint difference {worst:.2e} links");
    }
}

#[test]
fn the_simd_sweep_equals_the_baseline_bit_for_bit() {
    fn run<T: tractrix::strands::StrandReal>(tag: &str) {
        let mut rng = Rng(99);
        let n = 3 * LANES + 5;
        let heads: Vec<Vector3<T>> = (0..n)
            .map(|i| Vector3::new(T::lit(i as f64), T::lit(0.0), T::lit(rng.unit())))
            .collect();
        let dir = Vector3::new(T::lit(0.0), T::lit(-1.0), T::lit(0.0));
        let mut a = Strands::<T>::straight(&heads, 12, T::lit(1.0), dir).unwrap();
        let mut b = a.clone();
        for k in [1usize, 2, 5] {
            for _ in 0..100 {
                let targets: Vec<Vector3<T>> = (0..n)
                    .map(|i| {
                        let h = a.head(i);
                        let hf = V::new(h.x.to_f64(), h.y.to_f64(), h.z.to_f64());
                        let l = a.link(i, 0);
                        let lf = V::new(l.x.to_f64(), l.y.to_f64(), l.z.to_f64());
                        let t = target(&mut rng, hf, lf, 1.0);
                        Vector3::new(T::lit(t.x), T::lit(t.y), T::lit(t.z))
                    })
                    .collect();
                a.move_heads(&targets, k, Simd::Best).unwrap();
                b.move_heads(&targets, k, Simd::Baseline).unwrap();
                assert!(a == b, "{tag}, substeps {k}: SIMD and baseline differ");
            }
        }
        println!(
            "{tag}: {} equal bit for bit",
            tractrix::strands::best_simd()
        );
    }
    run::<f64>("f64");
    run::<f32>("f32");
}

#[test]
fn halves_swept_on_two_threads_equal_the_whole() {
    let mut rng = Rng(5);
    let n = 10 * LANES + 3;
    let heads: Vec<V> = (0..n).map(|i| V::new(i as f64, 0.0, 0.0)).collect();
    let mut whole = Strands::<f64>::straight(&heads, 20, 1.0, -V::y()).unwrap();
    let mut split = whole.clone();
    for _ in 0..50 {
        let targets: Vec<V> = (0..n).map(|i| whole.head(i) + rng.dir3() * 0.4).collect();
        whole.move_heads(&targets, 2, Simd::Best).unwrap();
        split.stage(&targets).unwrap();
        let staged = split.take_staged();
        let at = split.n_blocks() / 2;
        {
            let (left, right) = split.split_at_block(at);
            std::thread::scope(|s| {
                s.spawn(|| left.sweep(&staged, 2, Simd::Best));
                right.sweep(&staged, 2, Simd::Best);
            });
        }
        split.restore_staged(staged);
        assert!(whole == split, "the halves differ from the whole");
    }
}

#[test]
fn refused_moves_change_nothing() {
    let heads: Vec<V> = (0..10).map(|i| V::new(i as f64, 0.0, 0.0)).collect();
    let mut s = Strands::<f64>::straight(&heads, 5, 1.0, -V::y()).unwrap();
    let before = s.clone();
    let mut targets: Vec<V> = heads.iter().map(|h| h + V::x()).collect();
    assert_eq!(
        s.move_heads(&targets[..9], 1, Simd::Best),
        Err(StrandsError::TargetCount { got: 9, want: 10 })
    );
    targets[4].y = f64::NAN;
    assert_eq!(
        s.move_heads(&targets, 1, Simd::Best),
        Err(StrandsError::NonFinite(4))
    );
    targets[4].y = 0.0;
    assert_eq!(
        s.move_heads(&targets, 0, Simd::Best),
        Err(StrandsError::NoSubsteps)
    );
    let mut heads_of_s = Vec::new();
    for i in 0..10 {
        heads_of_s.push(s.head(i));
    }
    assert_eq!(heads_of_s, heads);
    assert!(s.max_length_error() == before.max_length_error());
    for i in 0..10 {
        assert_eq!(strand_joints(&s, i), strand_joints(&before, i));
    }
    assert!(Strands::<f64>::straight(&[], 5, 1.0, V::x()).is_err());
    assert!(Strands::<f64>::straight(&heads, 5, 0.0, V::x()).is_err());
    assert!(Strands::<f64>::straight(&heads, 5, 1.0, V::zeros()).is_err());
}

/// Lengths, checked from the joints by the test's own distances, over 10⁵ moves of every size.
#[test]
fn lengths_hold_over_many_moves() {
    let mut rng = Rng(2024);
    let n = LANES + 1;
    let heads: Vec<V> = (0..n).map(|i| V::new(i as f64, 0.0, 0.0)).collect();
    let mut s = Strands::<f64>::straight(&heads, 20, 1.0, -V::y()).unwrap();
    let mut s32 = Strands::<f32>::straight(
        &heads.iter().map(|h| h.cast::<f32>()).collect::<Vec<_>>(),
        20,
        1.0,
        -Vector3::<f32>::y(),
    )
    .unwrap();
    for _ in 0..100_000 / n {
        let targets: Vec<V> = (0..n)
            .map(|i| target(&mut rng, s.head(i), s.link(i, 0), 1.0))
            .collect();
        s.move_heads(&targets, 1, Simd::Best).unwrap();
        let t32: Vec<Vector3<f32>> = targets.iter().map(|t| t.cast::<f32>()).collect();
        s32.move_heads(&t32, 1, Simd::Best).unwrap();
    }
    let mut worst = 0.0f64;
    let mut worst32 = 0.0f64;
    for i in 0..n {
        for j in 0..20 {
            let l = s.link(i, j);
            worst = worst.max(((l.x * l.x + l.y * l.y + l.z * l.z).sqrt() - 1.0).abs());
            let l = s32.link(i, j).cast::<f64>();
            worst32 = worst32.max(((l.x * l.x + l.y * l.y + l.z * l.z).sqrt() - 1.0).abs());
        }
    }
    assert!(worst < 1e-12, "f64 length error {worst:e}");
    assert!(worst32 < 1e-5, "f32 length error {worst32:e}");
    println!("10⁵ moves: length error f64 {worst:.1e}, f32 {worst32:.1e}");
}

#[test]
fn strands_split_off_move_as_the_whole_did() {
    let mut rng = Rng(11);
    let n = 5 * LANES + 2;
    let heads: Vec<V> = (0..n).map(|i| V::new(i as f64, 0.0, 0.0)).collect();
    let mut whole = Strands::<f64>::straight(&heads, 7, 1.0, -V::y()).unwrap();
    let mut first = whole.clone();
    let mut rest = first.split_off_blocks(2).unwrap();
    assert_eq!(
        (first.n_strands(), rest.n_strands()),
        (2 * LANES, n - 2 * LANES)
    );
    assert_eq!(rest.head(0), whole.head(2 * LANES));
    for _ in 0..30 {
        let targets: Vec<V> = (0..n).map(|i| whole.head(i) + rng.dir3() * 0.5).collect();
        whole.move_heads(&targets, 3, Simd::Best).unwrap();
        first
            .move_heads(&targets[..2 * LANES], 3, Simd::Best)
            .unwrap();
        rest.stage(&targets[2 * LANES..]).unwrap();
        rest.sweep_staged(3, Simd::Best).unwrap();
        // The staging is used up: a second sweep is refused.
        assert!(rest.sweep_staged(3, Simd::Best).is_err());
    }
    for i in 0..n {
        let part = if i < 2 * LANES {
            strand_joints(&first, i)
        } else {
            strand_joints(&rest, i - 2 * LANES)
        };
        assert_eq!(part, strand_joints(&whole, i), "strand {i}");
    }
    // A block's joints at once are each strand's, bit for bit (the last block is partial).
    let mut block = Vec::new();
    for b in 0..whole.n_blocks() {
        whole.block_joints(b, &mut block);
        let lanes = LANES.min(n - b * LANES);
        assert_eq!(block.len(), lanes * 8);
        for l in 0..lanes {
            assert_eq!(
                &block[l * 8..(l + 1) * 8],
                &strand_joints(&whole, b * LANES + l)[..],
                "block {b} lane {l}"
            );
        }
    }
    whole.block_joints(whole.n_blocks(), &mut block);
    assert!(block.is_empty());
    // Appended back, the halves are the whole; strands of other links are refused.
    let other = Strands::<f64>::straight(&heads[..3], 6, 1.0, -V::y()).unwrap();
    assert!(first.append_blocks(other).is_err());
    first.append_blocks(rest).unwrap();
    assert!(first == whole);
    let mut one = Strands::<f64>::straight(&heads[..3], 7, 1.0, -V::y()).unwrap();
    assert!(one.split_off_blocks(1).is_none());
    let more = Strands::<f64>::straight(&heads[..3], 7, 1.0, -V::y()).unwrap();
    assert!(
        one.append_blocks(more).is_err(),
        "3 strands do not fill their block"
    );
}

/// One chain's wavefront with SIMD across its steps in flight (`strands::chain_wave`, what a move of
/// eight or more closed-form substeps runs): the same bits on the best instruction set and the
/// baseline, and, against substeps written out here one after another with `tractrix_step`, the same
/// links to 1e-12 of a link, every link keeping its length; over links of mixed lengths, both sides
/// of a move, every wave width, tiny, large and along-the-link pushes.
#[test]
fn a_chains_simd_wavefront_matches_substeps_one_after_another() {
    use tractrix::link::tractrix_step;
    use tractrix::strands::{CHAIN_WAVE, chain_wave};
    let mut rng = Rng(0x5eed_c4a1);
    for case in 0..400 {
        let n = 1 + rng.below(50);
        let lengths: Vec<f64> = (0..n).map(|_| rng.range(0.05, 3.0)).collect();
        let links: Vec<V> = lengths.iter().map(|&l| rng.dir3() * l).collect();
        let w = 1 + rng.below(CHAIN_WAVE);
        let tail_side = rng.below(2) == 0;
        let scale = lengths.iter().copied().fold(0.0, f64::max);
        let s = match rng.below(6) {
            0 => rng.dir3() * 1e-9 * scale,
            1 => rng.dir3() * 4.0 * scale,
            // Along the first link stepped (a push the lanes hand back to `tractrix_step`).
            2 => {
                let first = if tail_side { -links[n - 1] } else { links[0] };
                first * rng.range(-0.3, 0.3)
            }
            _ => rng.dir3() * rng.range(0.01, 0.5) * scale,
        };
        let mut best = links.clone();
        let mut base = links.clone();
        chain_wave(&mut best, &lengths, s, w, tail_side, Simd::Best);
        chain_wave(&mut base, &lengths, s, w, tail_side, Simd::Baseline);
        for (a, b) in best.iter().zip(&base) {
            for k in 0..3 {
                assert_eq!(
                    a[k].to_bits(),
                    b[k].to_bits(),
                    "case {case}: SIMD ≠ baseline"
                );
            }
        }
        // Substep after substep, link by link from the moved joint outward.
        let mut want = links.clone();
        for _ in 0..w {
            let mut shift = s;
            for j in 0..n {
                let i = if tail_side { n - 1 - j } else { j };
                let t = if tail_side { -want[i] } else { want[i] };
                let st = tractrix_step(&t, &shift, lengths[i]);
                want[i] = if tail_side { -st.link } else { st.link };
                shift = st.tail_shift;
            }
        }
        for (i, (a, b)) in best.iter().zip(&want).enumerate() {
            let off = (a - b).amax();
            assert!(
                off <= 1e-12 * lengths[i].max(1.0),
                "case {case}: link {i} of {n} (w {w}, tail side {tail_side}) off by {off:e}"
            );
            let len_err = (a.norm() - lengths[i]).abs() / lengths[i];
            assert!(
                len_err <= 1e-12,
                "case {case}: link {i} length off by {len_err:e}"
            );
        }
    }
}
