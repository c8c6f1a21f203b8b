//! How close the kernel's `Chain::move_joint` comes to a minimal loop (issue 18, "a lean step").
//!
//! `cargo bench -p tractrix --bench lean` moves the head of a chain of 40 and of 1000 unit links along a
//! helix (a third of a link per move, one substep), in f64 and f32, with the closed-form tractrix and with
//! follow-the-leader, side by side in one run, batches interleaved:
//!
//! * **kernel**: `Chain::move_joint(head, target)`, everything a caller gets (checks, substep count,
//!   holds, the moved joint landing on its target);
//! * **minimal loop**, the floor (issue 40): written here as a user would write the method from its
//!   formula, a flat array of link vectors and lengths and the head's position, and no guard — for the
//!   tractrix `p = 1 − c`, `m = 1 + c` as they stand, `exp` for every move, one Gram–Schmidt pass and the
//!   trailing end's displacement as new less old; for follow-the-leader a plain norm;
//! * **guarded loop**: the same flat loop with the kernel's arithmetic applied to every link (both
//!   cancellation rewrites, `expm1` for short moves, the second Gram–Schmidt pass): what the guards cost
//!   where the kernel runs them everywhere.
//!
//! The kernel runs each guard only for the inputs that need it (`tractrix::link`). The table shows what
//! the guards buy in accuracy: the largest relative link-length error after the run, after 10⁶ moves of
//! a 40-link chain along the same helix, and after collinear pushes of 10⁻¹² to 10⁹ links, for the
//! kernel (or the guarded loop) and the minimal loop. Every figure is a median over the batches' mean ns
//! per link-step; the ratio columns divide medians measured in the same run. The kernel's joints are
//! compared with the minimal loop's after the run (*max joint difference*).
//! `LEAN_BENCH_SCALE` (default 1.0) scales the work.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print.
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

fn target(n: usize, k: usize) -> [f64; 3] {
    // A helix of radius n/4 (at most 50) about the initial chain's axis, a third of a link per move.
    let r = (n as f64 / 4.0).min(50.0);
    let s = k as f64 / 3.0;
    let a = s / r.max(1.0);
    [n as f64 + s * 0.3, r * (1.0 - a.cos()), r * a.sin()]
}

type P<T> = [T; 3];

#[inline(always)]
fn dot<T: Real>(a: P<T>, b: P<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// What both flat tractrix loops start from, in units of the link length: the move's length `b`, its
/// direction `û` (by the reciprocal of `b`), the tail's component `c` along it and the rest `w` after
/// one Gram–Schmidt pass; `None` for a zero move.
#[inline(always)]
fn frame<T: Real>(t: P<T>, s: P<T>, len: T) -> Option<(T, P<T>, T, P<T>)> {
    let inv = T::one() / len;
    let ss = [s[0] * inv, s[1] * inv, s[2] * inv];
    let b = dot(ss, ss).sqrt();
    if b == T::zero() {
        return None;
    }
    let ib = T::one() / b;
    let u = [ss[0] * ib, ss[1] * ib, ss[2] * ib];
    let tt = [t[0] * inv, t[1] * inv, t[2] * inv];
    let c = dot(tt, u);
    Some((
        b,
        u,
        c,
        [tt[0] - u[0] * c, tt[1] - u[1] * c, tt[2] - u[2] * c],
    ))
}

/// The closed-form tractrix for one link, written flat: `t` the link from its moving end to its
/// trailing end, `s` the moving end's displacement. Returns (new link, trailing end's displacement).
/// With the kernel's guards everywhere: the cancellation rewrites, the second Gram–Schmidt pass and
/// `expm1` for moves under half a link (`û` by the reciprocal, as in the minimal loop; the kernel
/// divides).
#[inline(always)]
fn tractrix<T: Real>(t: P<T>, s: P<T>, len: T) -> (P<T>, P<T>) {
    let one = T::one();
    let two = T::lit(2.0);
    let Some((b, u, c, mut w)) = frame(t, s, len) else {
        return (t, [T::zero(); 3]);
    };
    let k = dot(w, u);
    w = [w[0] - u[0] * k, w[1] - u[1] * k, w[2] - u[2] * k];
    let y2 = dot(w, w);
    let (p, m) = if c > T::zero() {
        (y2 / (one + c), one + c)
    } else {
        (one - c, y2 / (one - c))
    };
    let (q, e1) = if b < T::lit(0.5) {
        let e1 = -(-b).exp_m1();
        (one - e1, e1)
    } else {
        let q = (-b).exp();
        (q, one - q)
    };
    let e = q * q;
    let d = p + e * m;
    let cw_num = if c > T::zero() {
        e1 * (q * m - p)
    } else {
        e1 * (two * c - e1 * m)
    };
    let cu_num = p * m * e1 * (one + q);
    let inv_d = one / d;
    let (lu, lw) = ((e * m - p) * inv_d * len, two * q * inv_d * len);
    let (su, sw) = ((b - cu_num * inv_d) * len, cw_num * inv_d * len);
    (
        [
            u[0] * lu + w[0] * lw,
            u[1] * lu + w[1] * lw,
            u[2] * lu + w[2] * lw,
        ],
        [
            u[0] * su + w[0] * sw,
            u[1] * su + w[1] * sw,
            u[2] * su + w[2] * sw,
        ],
    )
}

/// The closed-form tractrix as a user would write it from the paper's formula, with no guard: `p = 1 − c`
/// and `m = 1 + c` as they stand, `exp` for every move, one Gram–Schmidt pass, `û` by the reciprocal of
/// `b`, and the trailing end's displacement as the new trailing end less the old one. One `sqrt`, one
/// `exp`, three divisions per link (`1/L` too); only a zero move is returned as is (0/0 otherwise).
#[inline(always)]
fn tractrix_bare<T: Real>(t: P<T>, s: P<T>, len: T) -> (P<T>, P<T>) {
    let one = T::one();
    let two = T::lit(2.0);
    let Some((b, u, c, w)) = frame(t, s, len) else {
        return (t, [T::zero(); 3]);
    };
    let (p, m) = (one - c, one + c);
    let q = (-b).exp();
    let e = q * q;
    let k = len / (p + e * m);
    let (lu, lw) = ((e * m - p) * k, two * q * k);
    let nl = [
        u[0] * lu + w[0] * lw,
        u[1] * lu + w[1] * lw,
        u[2] * lu + w[2] * lw,
    ];
    (
        nl,
        [
            s[0] + nl[0] - t[0],
            s[1] + nl[1] - t[1],
            s[2] + nl[2] - t[2],
        ],
    )
}

/// Follow-the-leader for one link, written flat (the trailing end on the line from the new moving end
/// to its old place).
#[inline(always)]
fn ftl<T: Real>(t: P<T>, s: P<T>, len: T) -> (P<T>, P<T>) {
    let r = [t[0] - s[0], t[1] - s[1], t[2] - s[2]];
    let rn = dot(r, r).sqrt();
    let k = len / rn;
    let two_t = [
        t[0] * T::lit(2.0) - s[0],
        t[1] * T::lit(2.0) - s[1],
        t[2] * T::lit(2.0) - s[2],
    ];
    let f = dot(s, two_t) / (rn * (len + rn));
    (
        [r[0] * k, r[1] * k, r[2] * k],
        [r[0] * f, r[1] * f, r[2] * f],
    )
}

#[derive(Clone, Copy, PartialEq)]
enum Form {
    /// The kernel's arithmetic with its guards, flat.
    Tractrix,
    /// [`tractrix_bare`]: the floor.
    BareTractrix,
    Ftl,
}

/// The minimal loop's state: link vectors (tail toward head, as the kernel stores them), lengths and
/// the head.
struct Flat<T: Real> {
    links: Vec<P<T>>,
    lengths: Vec<T>,
    head: P<T>,
    form: Form,
}

impl<T: Real> Flat<T> {
    fn new(n: usize, form: Form) -> Self {
        Flat {
            links: vec![[T::one(), T::zero(), T::zero()]; n],
            lengths: vec![T::one(); n],
            head: [T::lit(n as f64), T::zero(), T::zero()],
            form,
        }
    }
    fn move_head(&mut self, to: P<T>) {
        let mut s = [
            to[0] - self.head[0],
            to[1] - self.head[1],
            to[2] - self.head[2],
        ];
        for (l, &len) in self.links.iter_mut().zip(&self.lengths).rev() {
            // The link seen from its moving end (the head side) is −l.
            let t = [-l[0], -l[1], -l[2]];
            let (nl, shift) = match self.form {
                Form::Tractrix => tractrix(t, s, len),
                Form::BareTractrix => tractrix_bare(t, s, len),
                Form::Ftl => ftl(t, s, len),
            };
            *l = [-nl[0], -nl[1], -nl[2]];
            s = shift;
        }
        self.head = to;
    }
    fn joints(&self) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; self.links.len() + 1];
        let mut p = self.head.map(|x| x.to_f64());
        out[self.links.len()] = p;
        for (i, l) in self.links.iter().enumerate().rev() {
            p = [
                p[0] - l[0].to_f64(),
                p[1] - l[1].to_f64(),
                p[2] - l[2].to_f64(),
            ];
            out[i] = p;
        }
        out
    }
    fn length_error(&self) -> f64 {
        self.links
            .iter()
            .zip(&self.lengths)
            .map(|(l, len)| (dot(*l, *l).sqrt() / *len - T::one()).to_f64().abs())
            .fold(0.0, f64::max)
    }
}

enum Runner<T: Real> {
    Kernel(Chain<T, 3>, MoveOptions<T>),
    Flat(Flat<T>),
}

impl<T: Real> Runner<T> {
    fn batch(&mut self, n: usize, k: &mut usize, moves: usize) -> f64 {
        let t0 = Instant::now();
        for _ in 0..moves {
            *k += 1;
            let p = target(n, *k).map(T::lit);
            match self {
                Runner::Kernel(c, o) => {
                    black_box(c.move_joint(n, Vector3::from(p), o).expect("a move"));
                }
                Runner::Flat(f) => {
                    f.move_head(p);
                    black_box(&f.links);
                }
            }
        }
        t0.elapsed().as_nanos() as f64 / (moves * n) as f64
    }
    fn joints(&self) -> Vec<[f64; 3]> {
        match self {
            Runner::Kernel(c, _) => c
                .positions()
                .iter()
                .map(|p| [p.x.to_f64(), p.y.to_f64(), p.z.to_f64()])
                .collect(),
            Runner::Flat(f) => f.joints(),
        }
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Largest relative link-length error of a 40-link chain after `moves` head moves along the bench's
/// helix.
fn long_walk<T: Real>(form: Form, moves: usize) -> f64 {
    let mut f = Flat::<T>::new(40, form);
    for k in 1..=moves {
        f.move_head(target(40, k).map(T::lit));
    }
    f.length_error()
}

/// Largest relative link-length error after pushes of the head straight back along a straight chain
/// of 40 links (collinear, the tail ahead of every head), one push of each length 10⁻¹² … 10⁹ links,
/// each from a fresh chain: the kernel's (`form` none) or a flat loop's.
fn collinear_pushes<T: Real>(form: Option<Form>) -> f64 {
    let mut worst = 0.0f64;
    for k in -12..=9 {
        let to = [T::lit(40.0 - 10f64.powi(k)), T::zero(), T::zero()];
        let err = match form {
            None => {
                let mut c = Chain::<T, 3>::straight(40, T::one(), Vector3::zeros(), Vector3::x())
                    .expect("a straight chain");
                let o = MoveOptions {
                    substeps: Substeps::Fixed(1),
                    ..MoveOptions::default()
                };
                if c.move_joint(40, Vector3::from(to), &o).is_err() {
                    return f64::NAN;
                }
                c.links()
                    .iter()
                    .map(|l| (l.norm() - T::one()).to_f64().abs())
                    .fold(0.0, f64::max)
            }
            Some(form) => {
                let mut f = Flat::<T>::new(40, form);
                f.move_head(to);
                f.length_error()
            }
        };
        if err.is_nan() {
            return f64::NAN;
        }
        worst = worst.max(err);
    }
    worst
}

fn rows<T: Real>(precision: &str, scale: f64) {
    for n in [40usize, 1000] {
        for method in [Method::Tractrix, Method::FollowTheLeader] {
            let opts = MoveOptions {
                method,
                substeps: Substeps::Fixed(1),
                ..MoveOptions::default()
            };
            let chain = Chain::<T, 3>::straight(n, T::one(), Vector3::zeros(), Vector3::x())
                .expect("a straight chain");
            let tractrix = method == Method::Tractrix;
            let mut runners = vec![
                Runner::Kernel(chain, opts),
                Runner::Flat(Flat::new(
                    n,
                    if tractrix {
                        Form::BareTractrix
                    } else {
                        Form::Ftl
                    },
                )),
            ];
            if tractrix {
                runners.push(Runner::Flat(Flat::new(n, Form::Tractrix)));
            }
            let moves = (BATCH_WORK / n).max(1);
            let batches = ((40.0 * scale) as usize).max(5);
            let mut ks = vec![0usize; runners.len()];
            let mut ns = vec![Vec::new(); runners.len()];
            for b in 0..batches {
                for j in 0..runners.len() {
                    let i = (j + b) % runners.len();
                    ns[i].push(runners[i].batch(n, &mut ks[i], moves));
                }
            }
            // Every runner made the same moves: the kernel against the minimal loop.
            let (kj, fj) = (runners[0].joints(), runners[1].joints());
            let diff = kj
                .iter()
                .zip(&fj)
                .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f64::max))
                .fold(0.0, f64::max);
            let med: Vec<f64> = ns.iter_mut().map(|v| median(v)).collect();
            let (guarded, guarded_ratio, accuracy) = if tractrix {
                let (Runner::Kernel(kernel, _), Runner::Flat(bare)) = (&runners[0], &runners[1])
                else {
                    unreachable!()
                };
                let kernel_err = kernel
                    .links()
                    .iter()
                    .map(|l| (l.norm() - T::one()).to_f64().abs())
                    .fold(0.0, f64::max);
                let walk = (1_000_000.0 * scale) as usize;
                (
                    format!("{:.1}", med[2]),
                    format!("{:.2}", med[2] / med[1]),
                    format!(
                        "{:.1e} / {:.1e} | {:.1e} / {:.1e} | {:.1e} / {:.1e}",
                        kernel_err,
                        bare.length_error(),
                        long_walk::<T>(Form::Tractrix, walk),
                        long_walk::<T>(Form::BareTractrix, walk),
                        collinear_pushes::<T>(None),
                        collinear_pushes::<T>(Some(Form::BareTractrix)),
                    ),
                )
            } else {
                ("–".into(), "–".into(), "– | – | –".into())
            };
            println!(
                "| {n} | {precision} | {} | {batches} | {:.1} | {:.1} | **{:.2}** | {guarded} | {guarded_ratio} | {diff:.1e} | {accuracy} |",
                if tractrix {
                    "closed-form tractrix"
                } else {
                    "follow-the-leader"
                },
                med[0],
                med[1],
                med[0] / med[1],
            );
        }
    }
}

fn main() {
    let scale: f64 = std::env::var("LEAN_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|s: &f64| s.is_finite() && *s > 0.0)
        .unwrap_or(1.0);
    println!(
        "Head moves of a third of a link along a helix, one substep each, batches of ~{BATCH_WORK} \
         link-steps timed whole and interleaved; medians of the batches' mean ns per link-step. The \
         floor is the *minimal loop*: the closed form as a user would write it, with no guard (for \
         follow-the-leader, the plain flat loop). *Guarded loop*: the same flat loop with the kernel's \
         arithmetic (its cancellation rewrites, `expm1` and the second Gram–Schmidt pass everywhere). \
         *Max joint difference*: the kernel against the minimal loop after the run. Largest relative \
         link-length errors, kernel / minimal loop: *after the run*; *10⁶ moves*: a 40-link chain \
         along the helix (guarded loop / minimal loop); *collinear pushes*: the head of a straight \
         40-link chain pushed straight back by 10⁻¹² to 10⁹ links, one push each (kernel / minimal \
         loop; NaN: a length came out NaN).\n"
    );
    println!(
        "| links | precision | method | batches | kernel `move_joint` (ns) | minimal loop (ns) | kernel ÷ minimal \
         | guarded loop (ns) | guarded ÷ minimal | max joint difference | after the run | 10⁶ moves | collinear pushes |"
    );
    println!("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---|---|---|");
    rows::<f64>("f64", scale);
    rows::<f32>("f32", scale);
}
