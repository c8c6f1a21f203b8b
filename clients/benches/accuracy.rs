//! Speed against accuracy: the largest joint error against the continuous ground truth (DOP853, see
//! `tractrix::ground_truth`), in link lengths, against the time per move, over method × substeps ×
//! precision, for a 40-link rope whose head follows a helix and for the knot scripts' hand paths (the
//! overhand on 160 links, the square knot's two hands on 320; collision off, since the ground truth knows
//! no contacts).
//!
//! `cargo bench -p clients --bench accuracy` prints, per scenario, a table with the Pareto front marked,
//! the convergence order of each method, and the cost of each at equal accuracy (1 % and 0.1 % of a
//! link); it writes `target/accuracy/pareto.svg` (log-log, one panel per scenario). Times are medians of
//! repeated runs of the whole path; every configuration of a scenario runs interleaved with the others.

use clients::accuracy::{Scenario, play, scenarios, truth};
use clients::render::{Panel, Series, write_plot_svg};
use tractrix::Method;

#[derive(Clone)]
struct Point {
    method: Method,
    f32: bool,
    k: u32,
    us_per_move: f64,
    error: f64,
    pareto: bool,
}

const METHODS: [Method; 3] = [
    Method::Tractrix,
    Method::TractrixPaper,
    Method::FollowTheLeader,
];

fn label(method: Method, f32: bool) -> String {
    format!("{} {}", method.name(), if f32 { "f32" } else { "f64" })
}

fn main() {
    let reps: usize = std::env::var("ACCURACY_BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5)
        .max(1);
    let out_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/accuracy");
    std::fs::create_dir_all(&out_dir).expect("create target/accuracy");
    let mut panels = Vec::new();
    for s in scenarios() {
        let moves: usize = s.legs.iter().map(|l| l.targets.len()).sum();
        eprintln!("{}: ground truth of {moves} moves ...", s.name);
        let gt = truth(&s);
        let configs: Vec<(Method, bool, u32)> = METHODS
            .iter()
            .flat_map(|&m| [false, true].map(|f| (m, f)))
            .flat_map(|(m, f)| s.substeps.iter().map(move |&k| (m, f, k)))
            .collect();
        let mut times: Vec<Vec<f64>> = vec![Vec::new(); configs.len()];
        let mut errors = vec![0.0; configs.len()];
        for r in 0..reps {
            eprintln!("{}: pass {}/{reps}", s.name, r + 1);
            for (i, &(m, f, k)) in configs.iter().enumerate() {
                let (t, e) = if f {
                    play::<f32>(&s, m, k, &gt)
                } else {
                    play::<f64>(&s, m, k, &gt)
                };
                times[i].push(t);
                errors[i] = e;
            }
        }
        let mut pts: Vec<Point> = configs
            .iter()
            .zip(times.iter_mut())
            .zip(&errors)
            .map(|((&(method, f32, k), t), &error)| {
                t.sort_by(f64::total_cmp);
                Point {
                    method,
                    f32,
                    k,
                    us_per_move: t[t.len() / 2] / moves as f64 * 1e6,
                    error,
                    pareto: false,
                }
            })
            .collect();
        for i in 0..pts.len() {
            let dominated = pts.iter().enumerate().any(|(j, q)| {
                j != i
                    && q.us_per_move <= pts[i].us_per_move
                    && q.error <= pts[i].error
                    && (q.us_per_move < pts[i].us_per_move || q.error < pts[i].error)
            });
            pts[i].pareto = !dominated;
        }
        report(&s, moves, &pts);
        panels.push(Panel {
            title: s.name.to_string(),
            series: METHODS
                .iter()
                .flat_map(|&m| [false, true].map(|f| (m, f)))
                .map(|(m, f)| Series {
                    label: label(m, f),
                    points: pts
                        .iter()
                        .filter(|p| p.method == m && p.f32 == f)
                        .map(|p| (p.us_per_move.log10(), p.error.max(1e-17).log10()))
                        .collect(),
                    color: match m {
                        Method::Tractrix => (0, 90, 200),
                        Method::TractrixPaper => (0, 150, 80),
                        Method::FollowTheLeader => (200, 60, 0),
                    },
                    dotted: f,
                })
                .collect(),
        });
    }
    let svg = out_dir.join("pareto.svg");
    write_plot_svg(
        &svg,
        "Largest joint error against time per move (dotted: f32)",
        ("log10 µs per move", "log10 error (links)"),
        &panels,
        panels.len(),
    )
    .expect("write the plot");
    println!("\nPlot: `{}`", svg.display());
}

fn report(s: &Scenario, moves: usize, pts: &[Point]) {
    println!(
        "\n### {} ({moves} moves; error: largest joint distance from the ground truth at the end, in links)\n",
        s.name
    );
    println!(
        "| method | precision | substeps | µs per move (median of passes) | error (links) | Pareto front |"
    );
    println!("|---|---|---:|---:|---:|:---:|");
    for p in pts {
        println!(
            "| {} | {} | {} | {:.2} | {:.2e} | {} |",
            p.method.name(),
            if p.f32 { "f32" } else { "f64" },
            p.k,
            p.us_per_move,
            p.error,
            if p.pareto { "★" } else { "" }
        );
    }
    println!(
        "\n| method | precision | order (last doublings above the rounding floor) \
         | fastest µs per move with error ≤ 1 % of a link | with error ≤ 0.1 % |"
    );
    println!("|---|---|---:|---:|---:|");
    for m in METHODS {
        for f in [false, true] {
            let mine: Vec<&Point> = pts.iter().filter(|p| p.method == m && p.f32 == f).collect();
            // log2 of the error ratio per doubling, over doublings whose finer error is still well
            // above the precision's rounding floor.
            let floor = if f { 1e-5 } else { 1e-12 };
            let orders: Vec<f64> = mine
                .windows(2)
                .filter(|w| w[1].k == 2 * w[0].k && w[1].error > 10.0 * floor)
                .map(|w| (w[0].error / w[1].error).log2())
                .collect();
            let order = match orders.len() {
                0 => "–".to_string(),
                n => {
                    let last = &orders[n.saturating_sub(3)..];
                    format!("{:.2}", last.iter().sum::<f64>() / last.len() as f64)
                }
            };
            let cost = |tol: f64| {
                mine.iter()
                    .filter(|p| p.error <= tol)
                    .map(|p| p.us_per_move)
                    .min_by(f64::total_cmp)
                    .map(|t| format!("{t:.2}"))
                    .unwrap_or_else(|| "not reached".into())
            };
            println!(
                "| {} | {} | {order} | {} | {} |",
                m.name(),
                if f { "f32" } else { "f64" },
                cost(1e-2),
                cost(1e-3)
            );
        }
    }
}
