//! `episode`: one episode of a sweep, printed as one JSON line (clients/python/tractrix_sweep.py runs
//! it on Ray workers).
//!
//! ```text
//! episode accuracy --scenario helix --method tractrix --precision f64 --substeps 4 --reps 3
//! ```
//!
//! `accuracy`: one configuration of the speed-against-accuracy measurement (`clients::accuracy`, the
//! same scenarios and code as `cargo bench -p clients --bench accuracy`): plays the scenario `--reps`
//! times and prints `{scenario, method, precision, substeps, moves, us_per_move (median of the reps),
//! error_links (largest joint error against the ground truth, in links), truth_s}`. `--truth-cache DIR`
//! shares the ground truth between episodes. Exit codes: 0 ok, 1 failure, 2 usage.

use anyhow::Result;
use clap::{Parser, Subcommand};
use clients::accuracy::{play, scenarios, truth_cached};
use clients::cli::usage;
use std::path::PathBuf;
use tractrix::Method;

#[derive(Parser, Debug)]
#[command(version, about = "One episode of a sweep, as one JSON line")]
struct Args {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// One configuration of the speed-against-accuracy measurement.
    Accuracy {
        /// helix, overhand or square.
        #[arg(long)]
        scenario: String,
        /// tractrix, paper or ftl.
        #[arg(long)]
        method: String,
        /// f64 or f32.
        #[arg(long, default_value = "f64")]
        precision: String,
        /// Substeps per move (1 to 4096).
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4096))]
        substeps: u32,
        /// Timed plays of the whole scenario (1 to 100); the median is reported.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
        reps: u32,
        /// Directory where episodes share the ground truth.
        #[arg(long)]
        truth_cache: Option<PathBuf>,
    },
}

fn main() -> std::process::ExitCode {
    clients::cli::main("episode", || run(Args::parse()))
}

fn run(a: Args) -> Result<u8> {
    match a.cmd {
        Cmd::Accuracy {
            scenario,
            method,
            precision,
            substeps,
            reps,
            truth_cache,
        } => {
            let all = scenarios();
            let keys: Vec<&str> = all.iter().map(|s| s.key).collect();
            let s = all
                .iter()
                .find(|s| s.key == scenario)
                .ok_or_else(|| usage(format!("no scenario {scenario:?} (there are {keys:?})")))?;
            let m = Method::ALL
                .into_iter()
                .find(|m| m.name() == method)
                .ok_or_else(|| usage(format!("no method {method:?} (tractrix, paper, ftl)")))?;
            let f32 = match precision.as_str() {
                "f64" => false,
                "f32" => true,
                p => return Err(usage(format!("no precision {p:?} (f64, f32)"))),
            };
            let (gt, truth_s) = truth_cached(s, truth_cache.as_deref())?;
            let mut times = Vec::new();
            let mut error = 0.0;
            for _ in 0..reps {
                let (t, e) = if f32 {
                    play::<f32>(s, m, substeps, &gt)
                } else {
                    play::<f64>(s, m, substeps, &gt)
                };
                times.push(t);
                error = e;
            }
            times.sort_by(f64::total_cmp);
            let moves = s.moves();
            let row = serde_json::json!({
                "scenario": s.key,
                "method": m.name(),
                "precision": precision,
                "substeps": substeps,
                "moves": moves,
                "us_per_move": times[times.len() / 2] / moves as f64 * 1e6,
                "error_links": error,
                "truth_s": truth_s,
            });
            println!("{row}");
            Ok(0)
        }
    }
}
