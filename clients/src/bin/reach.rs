//! `reach`: the planar manipulator reaches a sequence of targets by the tractrix (on the service) and by
//! the pseudo-inverse baseline (here, on a copy), and prints their joint rotations side by side
//! (figures 7 and 8).
//!
//! ```text
//! reach                                   # the default scene's 10-link arm, three targets
//! reach --targets "1.0,0.9 -0.8,1.2" --steps 10 --svg out/   # out/reach.svg, out/rotations.svg
//! ```
//!
//! Exit codes: 0 ok, 1 failure (no service, a reach refused or not converged), 2 usage.

use anyhow::{Context, Result};
use clap::Parser;
use clients::ToolArgs;
use clients::cli::usage;
use clients::reach::{Leg, ReachConfig, TargetResult, parse_targets, run_reach};
use clients::render::{Frame, Panel, Polyline, Series, View, write_frames_svg, write_plot_svg};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    version,
    about = "Reach targets with a planar manipulator: tractrix against pseudo-inverse"
)]
struct Args {
    /// The chain (a planar fixed-base chain).
    #[arg(long, default_value = "arm")]
    chain: String,
    /// Targets, space-separated x,y pairs, reached in order.
    #[arg(long, default_value = "1.0,0.9 -0.8,1.2 0.6,-1.3")]
    targets: String,
    /// Straight-line steps of the head towards each target.
    #[arg(long, default_value_t = 5)]
    steps: usize,
    /// Reach tolerance, fraction of the chain's length (0: the chain's default).
    #[arg(long, default_value_t = 0.0)]
    tolerance: f64,
    /// Start from the chain's current pose instead of resetting it.
    #[arg(long)]
    no_reset: bool,
    /// An orientation goal at every step: the last link along dx,dy (both methods).
    #[arg(long)]
    direction: Option<String>,
    /// Write DIR/reach.svg (figure 7) and DIR/rotations.svg (figure 8).
    #[arg(long)]
    svg: Option<PathBuf>,
    #[command(flatten)]
    service: ToolArgs,
}

fn main() -> std::process::ExitCode {
    clients::cli::main("reach", || run(Args::parse()))
}

const BLUE: (u8, u8, u8) = (30, 70, 220);
const BLACK: (u8, u8, u8) = (0, 0, 0);

fn run(a: Args) -> Result<u8> {
    let targets = parse_targets(&a.targets).map_err(|e| usage(format!("--targets: {e}")))?;
    let direction = a
        .direction
        .as_deref()
        .map(|d| match parse_targets(d).as_deref() {
            Ok([d]) if d[0] != 0.0 || d[1] != 0.0 => Ok(*d),
            _ => Err(usage(format!(
                "--direction: {d:?} is not dx,dy (finite, not both zero)"
            ))),
        })
        .transpose()?;
    let mut conn = a.service.connect()?;
    let cfg = ReachConfig {
        chain: a.chain.clone(),
        targets,
        steps: a.steps,
        tolerance: a.tolerance,
        reset: !a.no_reset,
        direction,
    };
    let results = run_reach(&mut conn, &cfg)?;
    if let Some(d) = direction {
        println!(
            "orientation goal: the last link along ({}, {}) at every step",
            d[0], d[1]
        );
    }
    for (i, r) in results.iter().enumerate() {
        print_target(i, r, a.steps);
    }
    if let Some(dir) = &a.svg {
        std::fs::create_dir_all(dir).with_context(|| format!("create {}", dir.display()))?;
        write_pictures(dir, &a.chain, &results)?;
    }
    Ok(0)
}

fn print_target(i: usize, r: &TargetResult, steps: usize) {
    println!(
        "target {} ({:.4}, {:.4}) in {steps} steps",
        i + 1,
        r.target[0],
        r.target[1]
    );
    println!(
        "  {:<15} {:>10} {:>10} {:>10} {:>11} {:>10}",
        "method", "iterations", "residual", "solve µs", "Σ|Δθ| deg", "base half"
    );
    for (name, leg) in [
        ("tractrix", &r.tractrix),
        ("pseudo-inverse", &r.pseudo_inverse),
    ] {
        println!(
            "  {:<15} {:>10} {:>10.2e} {:>10.1} {:>11.2} {:>9.1}%",
            name,
            leg.iterations,
            leg.residual,
            leg.solve_ns as f64 / 1e3,
            leg.total_rotation().to_degrees(),
            100.0 * leg.base_share()
        );
    }
    let row = |leg: &Leg| {
        leg.rotation
            .iter()
            .map(|x| format!("{:>8.2}", x.to_degrees()))
            .collect::<String>()
    };
    let joints: String = (1..=r.tractrix.rotation.len())
        .map(|j| format!("{j:>8}"))
        .collect();
    println!("  {:<15}{joints}", "joint");
    println!("  {:<15}{}", "tractrix °", row(&r.tractrix));
    println!("  {:<15}{}", "pseudo-inv. °", row(&r.pseudo_inverse));
}

fn write_pictures(dir: &std::path::Path, chain: &str, results: &[TargetResult]) -> Result<()> {
    let line = |joints: &Vec<[f64; 3]>, color| Polyline {
        joints: joints.clone(),
        color,
        markers: true,
    };
    let frames: Vec<Frame> = results
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let mut lines = vec![line(&r.start.0, (150, 150, 150))];
            for (t, p) in r.tractrix.poses.iter().zip(&r.pseudo_inverse.poses) {
                lines.push(line(p, BLACK));
                lines.push(line(t, BLUE));
            }
            Frame {
                label: format!(
                    "target {}: tractrix (blue), pseudo-inverse (black), start (grey)",
                    i + 1
                ),
                lines,
                marks: vec![[r.target[0], r.target[1], 0.0]],
            }
        })
        .collect();
    let file = dir.join("reach.svg");
    write_frames_svg(
        &file,
        &format!("{chain}: intermediate configurations (figure 7)"),
        &frames,
        View::TOP,
        results.len().min(3),
    )?;
    println!("wrote {}", file.display());
    let series = |leg: &Leg, label: &str, color, dotted| Series {
        label: label.to_string(),
        points: leg
            .rotation
            .iter()
            .enumerate()
            .map(|(j, x)| ((j + 1) as f64, x.to_degrees()))
            .collect(),
        color,
        dotted,
    };
    let panels: Vec<Panel> = results
        .iter()
        .enumerate()
        .map(|(i, r)| Panel {
            title: format!("target {} ({:.2}, {:.2})", i + 1, r.target[0], r.target[1]),
            series: vec![
                series(&r.tractrix, "tractrix", BLUE, true),
                series(&r.pseudo_inverse, "pseudo-inverse", BLACK, false),
            ],
        })
        .collect();
    let file = dir.join("rotations.svg");
    write_plot_svg(
        &file,
        &format!("{chain}: joint rotations (figure 8)"),
        ("joint (1 at the base)", "rotation (degrees)"),
        &panels,
        results.len().min(3),
    )?;
    println!("wrote {}", file.display());
    Ok(())
}
