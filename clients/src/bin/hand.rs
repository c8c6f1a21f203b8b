//! `hand`: a hand controller. It grasps a joint of a chain and drives it through a script's turns,
//! taking turns with the script's other hands (each its own process); it can record what it sent and
//! replay recordings bit for bit.
//!
//! ```text
//! hand run --builtin overhand --identify overhand
//! hand run --builtin square --hand A --record a.jsonl &   hand run --builtin square --hand B --record b.jsonl
//! hand run --script my.toml --hand A --rate 1000
//! hand replay a.jsonl b.jsonl          # resets the chains, re-sends in order, compares every state
//! hand print square                    # a built-in script as TOML, to start your own
//! ```
//!
//! Exit codes: 0 ok, 1 failure (no service, a turn timed out, a replay differed), 2 usage.

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use clients::hand::{
    HandConfig, knot_line, knot_of, read_records, replay, run_hand, series_line, series_of,
};
use clients::render::{Frame, Polyline, View, write_frames_svg};
use clients::{ConnectOptions, Connection};
use knots::script::{BUILTINS, Script};
use std::path::PathBuf;
use std::time::Duration;

#[derive(Parser, Debug)]
#[command(
    version,
    about = "Drive a chain of a running solver-service like a hand"
)]
struct Args {
    #[command(subcommand)]
    cmd: Cmd,
    /// iceoryx2 prefix of the service.
    #[arg(long, global = true, env = shared::PREFIX_ENV, default_value = shared::DEFAULT_PREFIX)]
    prefix: String,
    /// Seconds to wait for the service to appear.
    #[arg(long, global = true, default_value_t = 5.0)]
    wait_for_service: f64,
}

// Parsed once per process: the size of the largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand, Debug)]
enum Cmd {
    /// Run one hand of a script.
    Run {
        /// Script file (TOML).
        #[arg(long, conflicts_with = "builtin")]
        script: Option<PathBuf>,
        /// Built-in script.
        #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(BUILTINS))]
        builtin: Option<String>,
        /// Which hand of the script this process is.
        #[arg(long, default_value = "A")]
        hand: String,
        /// Requests per second (0: as fast as the service answers; with `--device` its sampling
        /// rate, default 1000).
        #[arg(long)]
        rate: Option<f64>,
        /// Play the script's moves as a haptic device does: the path walked at `--speed` and sampled
        /// at `--rate`, each request the hand's position at the first sample after the previous
        /// answer (a late answer skips samples), never halved or sent again, the tremor always on;
        /// at a turn's end the hand holds still until its joint is within `--settle` of it (or
        /// `--settle-timeout`). The hand moves on at its speed while within `--feel` rope thicknesses
        /// of its joint, and is held there by the coupling's pull while the rope catches up (held
        /// longer than `--settle-timeout`, it pushes on until the joint is within the feel); a
        /// tightening pull stops where the rope stops the joint; instrument turns are played as
        /// without it.
        #[arg(long)]
        device: bool,
        /// With `--device`: the hand's speed along its path, length units per second.
        #[arg(long, default_value_t = 10.0, requires = "device")]
        speed: f64,
        /// With `--device`: how near (length units) the joint must come to the hand at a turn's end.
        #[arg(long, default_value_t = 0.05, requires = "device")]
        settle: f64,
        /// With `--device`: the longest wait at a turn's end for the joint, seconds.
        #[arg(long, default_value_t = 2.0, requires = "device")]
        settle_timeout: f64,
        /// With `--device`: how far ahead of its joint, in rope thicknesses, the person's hand gets
        /// before the virtual coupling's pull holds it back (the force a person at the device
        /// feels); positive, `inf` for a device without force feedback (the script played open loop).
        #[arg(long, default_value_t = clients::hand::FEEL, requires = "device")]
        feel: f64,
        /// Override the script's longest hand motion per request.
        #[arg(long)]
        max_step: Option<f64>,
        /// Run every turn on this chain instead of the script's.
        #[arg(long)]
        chain: Option<String>,
        /// Record every request (JSON lines) to this file.
        #[arg(long)]
        record: Option<PathBuf>,
        /// Seconds to wait for another hand's turn.
        #[arg(long, default_value_t = 120.0)]
        turn_timeout: f64,
        /// After the script, name the knot tied in this chain.
        #[arg(long)]
        identify: Option<String>,
        /// No progress lines.
        #[arg(long)]
        quiet: bool,
        /// Write key frames of this hand's turns to DIR/SCRIPT-HAND.svg (figures 5 and 6).
        #[arg(long)]
        svg: Option<PathBuf>,
        /// Key frames per turn.
        #[arg(long, default_value_t = 3)]
        frames: usize,
        /// View of the pictures, azimuth,elevation in degrees (default: from above, tilted 20°).
        #[arg(long, default_value = "-90,70")]
        view: String,
        /// Hold the joints this hand drives for the whole script, whatever the script says (released
        /// at the end and on Ctrl-C; `kill -9` leaves them held until `chainctl release`).
        #[arg(long, conflicts_with = "no_grasp")]
        grasp: bool,
        /// Do not hold them, whatever the script says: the hand only pushes its joint along.
        #[arg(long)]
        no_grasp: bool,
        /// Perturb the script as a person's hand would, with this seed (every hand of a script must
        /// get the same seed; 0: as written): sizes ±10 %, directions ±0.05, every waypoint moved by up
        /// to 0.1 units, and a tremor of up to `--tremor` units on every step. See `Script::perturb`.
        #[arg(long, default_value_t = 0)]
        perturb: u64,
        /// The tremor of a perturbed run: every target sent moved by a fresh random offset of up to
        /// this many units (0: none; without `--perturb` none).
        #[arg(long, default_value_t = knots::script::HAND_TREMOR)]
        tremor: f64,
        /// Write the times of every move and instrument request sent (the halves of a split move
        /// included) to this file, one line each: the round trip as the hand waited for it (µs), the
        /// service's own time (`solve_ns`, µs), the status, 1 for a tightening pull's request
        /// (else 0) and the collision passes the service reports (the response's `iterations`)
        /// (the knot sweep's time per request, the contact, stitch and tighten benches').
        #[arg(long)]
        timings: Option<PathBuf>,
        /// After the script, tighten the knot: every hand pulls the end it holds away from the knot,
        /// this many length units per request, with the pull flag, until the knot stops shrinking
        /// (taut or jammed), twice round (every hand of a script must get the same value; see
        /// `Tighten`). With `--identify`, also prints the knotted stretch.
        #[arg(long)]
        tighten: Option<f64>,
        /// The tail a draw turn leaves before the first eyelet (the whole stitch's pass,
        /// `stitch-pass`: 15.25 by default), in the chain's units: the suture is drawn through the
        /// tissue until the rope before the entry is at most this long (see `Draw`).
        #[arg(long)]
        tail: Option<f64>,
    },
    /// Replay recordings: reset their chains, re-send in the recorded order, compare every state.
    Replay {
        /// Recording files (several hands' recordings are merged by sequence number).
        #[arg(required = true)]
        records: Vec<PathBuf>,
        /// Do not reset the chains first.
        #[arg(long)]
        no_reset: bool,
    },
    /// Print a built-in script as TOML.
    Print {
        /// The script.
        #[arg(value_parser = clap::builder::PossibleValuesParser::new(BUILTINS))]
        name: String,
    },
}

fn main() -> std::process::ExitCode {
    clients::cli::main("hand", || run(Args::parse()))
}

fn connect(prefix: &str, wait: f64) -> Result<Connection> {
    let opts = ConnectOptions::for_tool(prefix, wait).map_err(anyhow::Error::msg)?;
    Ok(Connection::connect(opts)?)
}

fn builtin(name: &str) -> Result<Script> {
    Script::builtin(name)
        .with_context(|| format!("no built-in script {name:?} (there are {BUILTINS:?})"))
}

fn run(a: Args) -> Result<u8> {
    match a.cmd {
        Cmd::Print { name } => {
            print!("{}", toml::to_string(&builtin(&name)?)?);
            Ok(0)
        }
        Cmd::Run {
            script,
            builtin: b,
            hand,
            rate,
            device,
            speed,
            settle,
            settle_timeout,
            feel,
            max_step,
            chain,
            record,
            turn_timeout,
            identify,
            quiet,
            svg,
            frames,
            view,
            grasp,
            no_grasp,
            perturb,
            tremor,
            timings,
            tighten,
            tail,
        } => {
            let view = View::parse(&view).map_err(anyhow::Error::msg)?;
            if !(1..=32).contains(&frames) {
                bail!("--frames must be 1 to 32");
            }
            let mut script = match (script, b) {
                (Some(p), None) => {
                    let text = std::fs::read_to_string(&p)
                        .with_context(|| format!("read {}", p.display()))?;
                    Script::parse(&text, &p.display().to_string()).map_err(anyhow::Error::msg)?
                }
                (None, Some(n)) => builtin(&n)?,
                _ => bail!("give --script FILE or --builtin NAME"),
            };
            if let Some(m) = max_step {
                script.max_step = m;
            }
            if grasp || no_grasp {
                script.grasp = grasp;
            }
            script.perturb(perturb);
            if let Some(speed) = tighten {
                script = script.with_tighten(speed);
            }
            if let Some(t) = tail {
                script = script.with_tail(t);
            }
            if let Some(c) = chain {
                for t in &mut script.turn {
                    t.chain = c.clone();
                }
            }
            script.check().map_err(anyhow::Error::msg)?;
            if !(tremor.is_finite() && (0.0..=1.0).contains(&tremor)) {
                bail!("--tremor must be 0 to 1 units");
            }
            let rate = rate.unwrap_or(if device { 1000.0 } else { 0.0 });
            if !(rate.is_finite() && rate >= 0.0 && turn_timeout.is_finite() && turn_timeout > 0.0)
            {
                bail!("--rate must be ≥ 0 and --turn-timeout positive");
            }
            let device = device
                .then(|| {
                    let ok = rate > 0.0
                        && speed.is_finite()
                        && speed > 0.0
                        && settle.is_finite()
                        && settle > 0.0
                        && settle_timeout.is_finite()
                        && settle_timeout >= 0.0
                        && feel > 0.0;
                    ok.then(|| clients::hand::DeviceOptions {
                        rate_hz: rate,
                        speed,
                        settle,
                        settle_timeout: Duration::from_secs_f64(settle_timeout),
                        feel,
                    })
                    .context(
                        "--device needs a positive --rate, --speed, --settle and --feel and a \
                         --settle-timeout ≥ 0",
                    )
                })
                .transpose()?;
            let mut conn = connect(&a.prefix, a.wait_for_service)?;
            let cfg = HandConfig {
                hand: hand.clone(),
                script,
                rate_hz: rate,
                turn_timeout: Duration::from_secs_f64(turn_timeout),
                record,
                progress: !quiet,
                frames_per_turn: if svg.is_some() { frames } else { 0 },
                tremor: (perturb, tremor),
                device,
            };
            let r = run_hand(&mut conn, &cfg)?;
            let refused: Vec<String> = r.refused.iter().map(|(n, c)| format!("{c} {n}")).collect();
            println!(
                "hand {hand}: {} requests, {} ok, {} locked{}",
                r.requests,
                r.ok,
                r.locked,
                if refused.is_empty() {
                    String::new()
                } else {
                    format!(", refused: {}", refused.join(", "))
                }
            );
            if cfg.device.is_some() {
                let d = &r.device;
                let lag = |q| d.lag(q).map_or("-".to_string(), |l| format!("{l:.4}"));
                println!(
                    "hand {hand}: device: {} samples sent, {} skipped while waiting for answers; the \
                     joint's lag behind the hand p50 {} / p99 {} / max {}; {} turns unsettled; \
                     held by the coupling {} ticks, pushed through it {} times",
                    d.sent,
                    d.skipped,
                    lag(0.5),
                    lag(0.99),
                    lag(1.0),
                    d.unsettled,
                    d.held,
                    d.pushed
                );
            }
            if let Some(path) = &timings {
                let text: String =
                    std::iter::once("# round_trip_us solve_us status pull passes\n".to_string())
                        .chain(r.timings.iter().map(|t| {
                            format!(
                                "{:.1} {:.3} {} {} {}\n",
                                t.round_trip_us,
                                t.solve_ns as f64 / 1e3,
                                t.status,
                                u8::from(t.pull),
                                t.passes
                            )
                        }))
                        .collect();
                std::fs::write(path, text).with_context(|| format!("write {}", path.display()))?;
            }
            if r.splits > 0 {
                println!(
                    "hand {hand}: {} moves over the service's work budget sent again in halves",
                    r.splits
                );
            }
            for t in &r.tightened {
                println!("hand {hand}: {t}");
            }
            if r.skipped_turns > 0 {
                println!(
                    "hand {hand}: {} turns skipped (their path could not be made; see above)",
                    r.skipped_turns
                );
            }
            if let Some(dir) = &svg {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("create {}", dir.display()))?;
                let file = dir.join(format!("{}-{hand}.svg", cfg.script.name));
                let panels: Vec<Frame> = r
                    .frames
                    .iter()
                    .map(|(label, joints)| Frame {
                        label: label.clone(),
                        lines: vec![Polyline {
                            joints: joints.clone(),
                            color: (150, 60, 20),
                            markers: false,
                        }],
                        marks: vec![],
                    })
                    .collect();
                let title = format!("{}: hand {hand}", cfg.script.name);
                write_frames_svg(&file, &title, &panels, view, 3)?;
                println!("wrote {}", file.display());
            }
            if let Some(name) = identify {
                let id = conn
                    .find_chain(&name)?
                    .with_context(|| format!("no chain {name:?}"))?;
                let k = knot_of(&mut conn, id)?;
                println!("{}", knot_line(&k));
                if cfg.script.turn.iter().any(|t| t.tighten.is_some())
                    && let Some(line) = clients::hand::knotted_stretch_line(&mut conn, id, &k)?
                {
                    println!("{line}");
                }
                if let Some(s) = clients::hand::strands_of(&mut conn, id, &k)? {
                    println!("{}", clients::hand::strands_line(&s));
                }
                if let Some(s) = series_of(&mut conn, id, &k)? {
                    println!("{}", series_line(&s));
                }
                if let Some(line) = clients::hand::eyelets_line(&mut conn, id)? {
                    println!("{line}");
                }
            }
            Ok(if r.refused.is_empty() { 0 } else { 1 })
        }
        Cmd::Replay { records, no_reset } => {
            let mut all = Vec::new();
            for p in &records {
                all.extend(read_records(p)?);
            }
            let mut conn = connect(&a.prefix, a.wait_for_service)?;
            let r = replay(&mut conn, all, !no_reset)?;
            for (i, what) in r.mismatches.iter().take(10) {
                println!("request {i}: {what}");
            }
            println!(
                "replayed {} requests: {} differed",
                r.sent,
                r.mismatches.len()
            );
            Ok(if r.mismatches.is_empty() { 0 } else { 1 })
        }
    }
}
