//! `snake`: the head of a chain crawls along a curve in space and the body follows (figure 4).
//!
//! ```text
//! snake                                   # the default scene's snake, a 60-unit crawl
//! snake --curve helix --length 80 --rate 1000
//! snake --curve my_curve.csv --svg out/   # x,y,z per line; out/snake.svg holds the key frames
//! ```
//!
//! Prints the head error, the link-length error and how closely the body followed the head's path.
//! Exit codes: 0 ok, 1 failure (no service, a move refused), 2 usage.

use anyhow::{Context, Result};
use clap::Parser;
use clients::ToolArgs;
use clients::cli::usage;
use clients::render::{Frame, Polyline, View, write_frames_svg};
use clients::snake::{Curve, SnakeConfig, run_snake};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(version, about = "Drive a snake's head along a curve in space")]
struct Args {
    /// The chain.
    #[arg(long, default_value = "snake")]
    chain: String,
    /// crawl, helix, or a file of x,y,z points.
    #[arg(long, default_value = "crawl")]
    curve: String,
    /// Arc length of a built-in curve.
    #[arg(long, default_value_t = 60.0)]
    length: f64,
    /// Arc between two head targets (one move request each).
    #[arg(long, default_value_t = 0.25)]
    step: f64,
    /// Requests per second (0: as fast as the service answers).
    #[arg(long, default_value_t = 0.0)]
    rate: f64,
    /// Write the key frames to DIR/snake.svg.
    #[arg(long)]
    svg: Option<PathBuf>,
    /// Key frames in the picture.
    #[arg(long, default_value_t = 6)]
    frames: usize,
    /// View of the picture, azimuth,elevation in degrees (default: side on to the crawl, from 45° up).
    #[arg(long)]
    view: Option<String>,
    /// No progress lines.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    service: ToolArgs,
}

fn main() -> std::process::ExitCode {
    clients::cli::main("snake", || run(Args::parse()))
}

fn run(a: Args) -> Result<u8> {
    if !(a.rate.is_finite() && a.rate >= 0.0 && (1..=64).contains(&a.frames)) {
        return Err(usage("--rate must be ≥ 0 and --frames 1 to 64"));
    }
    let view = a
        .view
        .as_deref()
        .map(View::parse)
        .transpose()
        .map_err(usage)?;
    let curve = Curve::parse(&a.curve).map_err(usage)?;
    let mut conn = a.service.connect()?;
    let cfg = SnakeConfig {
        chain: a.chain.clone(),
        curve,
        length: a.length,
        step: a.step,
        rate_hz: a.rate,
        frames: if a.svg.is_some() { a.frames } else { 0 },
        progress: !a.quiet,
    };
    let r = run_snake(&mut conn, &cfg)?;
    let refused: Vec<String> = r.refused.iter().map(|(n, c)| format!("{c} {n}")).collect();
    println!(
        "snake {}: {} moves, {} ok{} in {:.3} s; head travelled {:.3}",
        a.chain,
        r.requests,
        r.ok,
        if refused.is_empty() {
            String::new()
        } else {
            format!(", refused: {}", refused.join(", "))
        },
        r.elapsed.as_secs_f64(),
        r.travelled
    );
    println!(
        "head error {:.3e}, link length error {:.3e}, body from the head's path: max {:.4}, mean {:.4}",
        r.head_error, r.length_error, r.body_deviation_max, r.body_deviation_mean
    );
    if let Some(dir) = &a.svg {
        std::fs::create_dir_all(dir).with_context(|| format!("create {}", dir.display()))?;
        let path_line = Polyline {
            joints: r.path.clone(),
            color: (190, 190, 190),
            markers: false,
        };
        let frames: Vec<Frame> = r
            .frames
            .iter()
            .map(|(k, joints)| Frame {
                label: format!("after {k} moves"),
                lines: vec![
                    path_line.clone(),
                    Polyline {
                        joints: joints.clone(),
                        color: (20, 110, 40),
                        markers: false,
                    },
                ],
                marks: vec![],
            })
            .collect();
        let file = dir.join("snake.svg");
        write_frames_svg(
            &file,
            &format!("{}: the head follows a {} (figure 4)", a.chain, a.curve),
            &frames,
            view.unwrap_or_else(|| {
                let (s, e) = (r.path[0], r.path[r.path.len() - 1]);
                View::side_on([e[0] - s[0], e[1] - s[1], e[2] - s[2]], 45.0)
            }),
            2,
        )?;
        println!("wrote {}", file.display());
    }
    Ok(if r.refused.is_empty() { 0 } else { 1 })
}
