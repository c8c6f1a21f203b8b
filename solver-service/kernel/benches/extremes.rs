//! The extremes report: what each method does, in f64 and f32, at the edges of its domain.
//!
//! `cargo bench -p tractrix --bench extremes` prints one row per extreme × method × precision:
//! whether every coordinate stayed finite, the drift of the link lengths (largest relative error of any
//! link at the end), the landing error of the moved joint (relative to its link), the error against a
//! reference where one is exact, in links, and the time. The references:
//!
//! * tiny and huge links: the same helix path on unit links in f64 by the same method, scaled;
//! * a huge move: the chain ends straight behind the head (every joint on the line the head came along);
//! * collinear pull and push (the head moved along its own link): the continuous motion is a rigid
//!   translation, since every joint's velocity is the head's projected on a parallel link;
//! * 10⁶ links: the same move on 1000 links, compared on the 1000 joints nearest the head.
//!
//! "–" means no exact reference. Long rows print progress on stderr.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

use nalgebra::Vector3;
use std::time::Instant;
use tractrix::ground_truth::helix;
use tractrix::{Chain, Method, MoveOptions, Real, Substeps};

type V = Vector3<f64>;

const METHODS: [Method; 3] = [
    Method::Tractrix,
    Method::TractrixPaper,
    Method::FollowTheLeader,
];

/// A scenario: a straight chain along +x, moves of one joint, and maybe a reference end state.
struct Extreme {
    name: &'static str,
    links: usize,
    link: f64,
    joint: usize,
    /// The targets, computed from the start chain (f64).
    targets: Vec<V>,
    /// Exact end positions (f64) or, for `compare_prefix`, the first joints to compare.
    reference: Option<Vec<V>>,
    /// Compare only the joints nearest the head, this many (for the 10⁶-link row).
    compare_head_joints: Option<usize>,
}

fn straight(n: usize, link: f64) -> Chain<f64, 3> {
    Chain::<f64, 3>::straight(n, link, V::zeros(), V::x()).unwrap()
}

fn run_f64(n: usize, link: f64, joint: usize, targets: &[V], method: Method) -> Vec<V> {
    let mut c = straight(n, link);
    let opts = MoveOptions {
        method,
        substeps: Substeps::Fixed(1),
        ..MoveOptions::default()
    };
    for t in targets {
        c.move_joint(joint, *t, &opts).unwrap();
    }
    c.positions()
}

fn extremes(method: Method) -> Vec<Extreme> {
    let mut v = Vec::new();
    // Tiny moves: the head circles with radius 1e-12 of a link, 10⁵ moves.
    v.push(Extreme {
        name: "tiny moves (1e-12 link) ×10⁵",
        links: 40,
        link: 1.0,
        joint: 40,
        targets: (1..=100_000)
            .map(|k| {
                let a = k as f64 * 0.01;
                V::new(40.0 + 1e-12 * (a.cos() - 1.0), 1e-12 * a.sin(), 0.0)
            })
            .collect(),
        reference: None,
        compare_head_joints: None,
    });
    // A huge move: 1e9 links sideways and up, in one step.
    let d = V::new(0.3, 1.0, 0.5).normalize();
    let far = V::new(40.0, 0.0, 0.0) + d * 1e9;
    v.push(Extreme {
        name: "huge move (1e9 links)",
        links: 40,
        link: 1.0,
        joint: 40,
        targets: vec![far],
        reference: Some((0..=40).map(|i| far - d * (40 - i) as f64).collect()),
        compare_head_joints: None,
    });
    // Tiny and huge links: the helix path of the accuracy bench, scaled.
    let unit_path = helix(V::new(40.0, 0.0, 0.0), 4.0, 3.0, 1.5, 30);
    let unit_end = run_f64(40, 1.0, 40, &unit_path, method);
    for (name, s) in [
        ("tiny links (1e-9), helix", 1e-9),
        ("huge links (1e9), helix", 1e9),
    ] {
        v.push(Extreme {
            name,
            links: 40,
            link: s,
            joint: 40,
            targets: unit_path.iter().map(|p| p * s).collect(),
            reference: Some(unit_end.iter().map(|p| p * s).collect()),
            compare_head_joints: None,
        });
    }
    // Collinear pull and push: the head along its own link, 20 moves of half a link.
    for (name, sign) in [
        ("collinear pull, 20 × ½ link", 1.0),
        ("collinear push, 20 × ½ link", -1.0),
    ] {
        let shift = V::new(sign * 10.0, 0.0, 0.0);
        v.push(Extreme {
            name,
            links: 40,
            link: 1.0,
            joint: 40,
            targets: (1..=20)
                .map(|k| V::new(40.0 + sign * 0.5 * k as f64, 0.0, 0.0))
                .collect(),
            reference: Some(
                straight(40, 1.0)
                    .positions()
                    .iter()
                    .map(|p| p + shift)
                    .collect(),
            ),
            compare_head_joints: None,
        });
    }
    v.push(Extreme {
        name: "collinear push, 3 links in one move",
        links: 40,
        link: 1.0,
        joint: 40,
        targets: vec![V::new(37.0, 0.0, 0.0)],
        reference: Some(
            straight(40, 1.0)
                .positions()
                .iter()
                .map(|p| p - V::new(3.0, 0.0, 0.0))
                .collect(),
        ),
        compare_head_joints: None,
    });
    // 10⁶ moves in a row: the head wanders on a slow Lissajous curve, a third of a link per move.
    v.push(Extreme {
        name: "10⁶ moves in a row",
        links: 40,
        link: 1.0,
        joint: 40,
        targets: (1..=1_000_000)
            .map(|k| {
                let a = k as f64 / 30.0;
                V::new(
                    40.0 + 10.0 * (a * 0.1).sin(),
                    10.0 * (a * 0.13).sin(),
                    10.0 * (a * 0.07).cos() - 10.0,
                )
            })
            .collect(),
        reference: None,
        compare_head_joints: None,
    });
    // 10⁶ links, ten moves of the head: compared with the same moves on 1000 links.
    let n = 1_000_000;
    let path = helix(V::new(n as f64, 0.0, 0.0), 4.0, 3.0, 0.25, 10);
    let short_path: Vec<V> = path
        .iter()
        .map(|p| p - V::new((n - 1000) as f64, 0.0, 0.0))
        .collect();
    let short = run_f64(1000, 1.0, 1000, &short_path, method);
    v.push(Extreme {
        name: "10⁶ links, 10 head moves",
        links: n,
        link: 1.0,
        joint: n,
        targets: path,
        reference: Some(
            short
                .iter()
                .map(|p| p + V::new((n - 1000) as f64, 0.0, 0.0))
                .collect(),
        ),
        compare_head_joints: Some(1000),
    });
    v
}

struct Row {
    finite: bool,
    drift: f64,
    landing: f64,
    error: Option<f64>,
    ns_per_link_step: f64,
}

fn run<T: Real>(e: &Extreme, method: Method) -> Row {
    let cast = |p: &V| Vector3::new(T::lit(p.x), T::lit(p.y), T::lit(p.z));
    let targets: Vec<Vector3<T>> = e.targets.iter().map(cast).collect();
    let mut c =
        Chain::<T, 3>::straight(e.links, T::lit(e.link), Vector3::zeros(), Vector3::x()).unwrap();
    let opts = MoveOptions {
        method,
        substeps: Substeps::Fixed(1),
        ..MoveOptions::default()
    };
    let mut landing: f64 = 0.0;
    let mut ok = true;
    let t0 = Instant::now();
    for t in &targets {
        if c.move_joint(e.joint, *t, &opts).is_err() {
            ok = false;
            break;
        }
        let l = (c.joint(e.joint) - t).norm().to_f64() / e.link;
        landing = landing.max(l);
    }
    let secs = t0.elapsed().as_secs_f64();
    let p = c.positions();
    let finite = ok && p.iter().all(|q| q.iter().all(|x| x.is_finite()));
    let drift = c
        .links()
        .iter()
        .zip(c.lengths())
        .map(|(l, &len)| ((l.norm() - len) / len).to_f64().abs())
        .fold(0.0, f64::max);
    let error = e.reference.as_ref().map(|r| {
        let from = match e.compare_head_joints {
            Some(k) => p.len() - k,
            None => 0,
        };
        p[from..]
            .iter()
            .zip(r.iter().skip(r.len() - (p.len() - from)))
            .map(|(a, b)| (V::new(a.x.to_f64(), a.y.to_f64(), a.z.to_f64()) - b).norm() / e.link)
            .fold(0.0, f64::max)
    });
    Row {
        finite,
        drift,
        landing,
        error,
        ns_per_link_step: secs * 1e9 / (targets.len() * e.links) as f64,
    }
}

fn main() {
    println!(
        "Every extreme for every method, in f64 and f32 (length drift: largest relative link length \
         error at the end; landing error: distance of the moved joint from its target, in links):\n"
    );
    println!(
        "| extreme | method | precision | finite | length drift | landing error (links) | error vs reference (links) | ns per link-step |"
    );
    println!("|---|---|---|:---:|---:|---:|---:|---:|");
    let names: Vec<&str> = extremes(Method::Tractrix).iter().map(|e| e.name).collect();
    for (i, name) in names.iter().enumerate() {
        for m in METHODS {
            eprintln!("{name}: {}", m.name());
            let e = &extremes_one(m, i);
            for f32 in [false, true] {
                let r = if f32 {
                    run::<f32>(e, m)
                } else {
                    run::<f64>(e, m)
                };
                println!(
                    "| {name} | {} | {} | {} | {:.1e} | {:.1e} | {} | {:.0} |",
                    m.name(),
                    if f32 { "f32" } else { "f64" },
                    if r.finite { "yes" } else { "**no**" },
                    r.drift,
                    r.landing,
                    r.error
                        .map(|x| format!("{x:.1e}"))
                        .unwrap_or_else(|| "–".into()),
                    r.ns_per_link_step
                );
            }
        }
    }
}

/// The `i`th extreme for `method` (references depend on the method).
fn extremes_one(method: Method, i: usize) -> Extreme {
    extremes(method).swap_remove(i)
}
