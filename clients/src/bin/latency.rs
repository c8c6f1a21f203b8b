//! `latency`: round-trip latency of joint moves against a running service, the raw iceoryx2 echo it is
//! compared with, and the bench that runs them side by side on two pinned cores.
//!
//! ```text
//! latency client --chain rope --samples 20000 --pin 1          # back to back, percentiles in µs
//! latency client --chain rope --joint tail --rate 1000         # a 1 kHz hand, latency from due time
//! latency probe --rate 1000 --seconds 10 --pin 1               # the machine's own wake-up lateness
//! solver-service echo --prefix raw_ --elements 41 --wait spin  # the echo baseline (same serving loop)
//! latency bench                                                # everything, Markdown tables
//! ```
//!
//! Exit codes: 0 ok, 1 failure, 2 usage.

use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use clients::cli::usage;
use clients::latency::{Plan, Target, WaitMode, connect_options, run as run_plan};
use clients::latency_bench::{BenchConfig, LoadConfig, load, run as run_bench};
use shared::JOINT_HEAD;
use std::path::PathBuf;
use std::time::Duration;

#[derive(Parser, Debug)]
#[command(
    version,
    about = "Round-trip latency of the solver service, its baselines, and the two-core bench"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Measure round trips of one joint's moves against a running service (or a baseline).
    Client(ClientArgs),
    /// Start everything in turn and print the tables of BENCHMARKS.md.
    Bench(BenchArgs),
    /// The machine's own lateness: wait for a fixed-rate schedule exactly as a hand does, send
    /// nothing, and print the wake-up lateness and the CPU share (one JSON line with --json).
    Probe(ProbeArgs),
    /// The load run: a hand at full speed and one at 1 kHz on one rope plus a viewer; checks that no
    /// change is lost or answered twice and that link lengths hold, and prints the tails. Exits 1 if a
    /// check fails.
    Load(LoadArgs),
}

/// How a fixed-rate sender waits for each due time.
#[derive(Args, Debug, Clone)]
struct ScheduleArgs {
    /// Sleep until this many µs before each due time, then spin (yielding) the rest of the way;
    /// 0 sleeps all the way.
    #[arg(long, default_value_t = 250.0)]
    spin_before_due_us: f64,
    /// Align due times to the system clock's millisecond grid plus this many µs (keeps processes
    /// started apart at fixed phases against each other).
    #[arg(long)]
    phase_us: Option<f64>,
}

impl ScheduleArgs {
    fn schedule(&self) -> Result<clients::latency::Schedule> {
        let us = |name: &str, v: f64| {
            if v.is_finite() && (0.0..=1e6).contains(&v) {
                Ok(Duration::from_secs_f64(v * 1e-6))
            } else {
                Err(usage(format!("--{name} {v}: expected 0 to 10^6 µs")))
            }
        };
        Ok(clients::latency::Schedule {
            spin_before_due: us("spin-before-due-us", self.spin_before_due_us)?,
            phase: self.phase_us.map(|p| us("phase-us", p)).transpose()?,
        })
    }
}

#[derive(Args, Debug)]
struct ProbeArgs {
    /// Due times per second.
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    #[command(flatten)]
    schedule: ScheduleArgs,
    /// Pin this process to a CPU core.
    #[arg(long)]
    pin: Option<usize>,
    /// Print one JSON line.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct LoadArgs {
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Do not pin (the service to core 0, the hands to core 1).
    #[arg(long)]
    no_pin: bool,
    /// The service's wait mode.
    #[arg(long, value_enum, default_value_t = WaitMode::Hybrid)]
    service_wait: WaitMode,
    /// The hands' wait mode.
    #[arg(long, value_enum, default_value_t = WaitMode::Hybrid)]
    hand_wait: WaitMode,
    /// Print the report as one JSON line after the table.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct ClientArgs {
    /// iceoryx2 prefix of the service (or of the raw echo).
    #[arg(long, env = shared::PREFIX_ENV, default_value = shared::DEFAULT_PREFIX)]
    prefix: String,
    /// The target is the raw echo (`solver-service echo`), not the service.
    #[arg(long)]
    raw: bool,
    /// Talk to `solver-service unix --socket PATH` instead of iceoryx2.
    #[arg(long)]
    unix: Option<PathBuf>,
    /// How to wait for a response.
    #[arg(long, value_enum, default_value_t = WaitMode::Hybrid)]
    wait: WaitMode,
    /// Chain to move.
    #[arg(long, default_value = "rope")]
    chain: String,
    /// Joint to move: head, tail or an index.
    #[arg(long, default_value = "head")]
    joint: String,
    #[arg(long, default_value_t = 20_000)]
    samples: usize,
    #[arg(long, default_value_t = 2_000)]
    warmup: usize,
    /// Requests per second (0: back to back).
    #[arg(long, default_value_t = 0.0)]
    rate: f64,
    /// Radius of the joint's circle, in links.
    #[arg(long, default_value_t = 0.5)]
    radius: f64,
    /// Pin this process to a CPU core.
    #[arg(long)]
    pin: Option<usize>,
    /// Print one JSON line instead of a table.
    #[arg(long)]
    json: bool,
    /// Stop after this many seconds even if samples remain (warmup included).
    #[arg(long)]
    seconds: Option<f64>,
    /// Write the sequence number of every ok response to this file, one per line.
    #[arg(long)]
    sequences: Option<PathBuf>,
    #[command(flatten)]
    schedule: ScheduleArgs,
}

#[derive(Args, Debug)]
struct BenchArgs {
    #[arg(long, default_value_t = 20_000)]
    samples: usize,
    #[arg(long, default_value_t = 2_000)]
    warmup: usize,
    /// Chain sizes in links, comma-separated.
    #[arg(long, default_value = "40,1000")]
    sizes: String,
    /// Wait modes, comma-separated.
    #[arg(long, default_value = "spin,event,hybrid")]
    modes: String,
    /// Seconds of the loaded run (0 skips it).
    #[arg(long, default_value_t = 10.0)]
    loaded_seconds: f64,
}

fn main() -> std::process::ExitCode {
    clients::cli::main("latency", || run(Cli::parse()))
}

/// One line of percentiles in µs.
fn print_percentiles(name: &str, q: &clients::latency::Percentiles) {
    println!(
        "{name:>10}: p50 {:.1} µs, p90 {:.1}, p99 {:.1}, p99.9 {:.1}, max {:.1} ({} samples)",
        q.p50 as f64 / 1e3,
        q.p90 as f64 / 1e3,
        q.p99 as f64 / 1e3,
        q.p999 as f64 / 1e3,
        q.max as f64 / 1e3,
        q.count
    )
}

fn pin(core: Option<usize>) -> Result<()> {
    if let Some(c) = core {
        shared::pin_current_thread(c).map_err(usage)?;
    }
    Ok(())
}

fn run(cli: Cli) -> Result<u8> {
    match cli.command {
        Cmd::Client(a) => {
            let wait = a.wait;
            let joint = match a.joint.as_str() {
                "head" => JOINT_HEAD,
                "tail" => 0,
                j => j
                    .parse()
                    .map_err(|_| usage(format!("--joint {j:?}: head, tail or an index")))?,
            };
            shared::iceoryx_config(&a.prefix).map_err(usage)?;
            let target = match (a.unix, a.raw) {
                (Some(_), true) => return Err(usage("--unix and --raw exclude each other")),
                (Some(p), false) => Target::Unix(p),
                (None, true) => Target::Raw(connect_options(&a.prefix, wait)),
                (None, false) => Target::Service(connect_options(&a.prefix, wait)),
            };
            let plan = Plan {
                chain: a.chain,
                joint,
                samples: a.samples,
                warmup: a.warmup,
                rate_hz: a.rate,
                radius: a.radius,
                duration: match a.seconds {
                    None => None,
                    Some(t) if t.is_finite() && t > 0.0 && t <= 1e6 => {
                        Some(Duration::from_secs_f64(t))
                    }
                    Some(t) => return Err(usage(format!("--seconds {t}: expected (0, 10^6]"))),
                },
                sequences: a.sequences,
                schedule: a.schedule.schedule()?,
                ..Plan::default()
            };
            pin(a.pin)?;
            let s = run_plan(&target, &plan)?;
            if a.json {
                println!("{}", serde_json::to_string(&s)?);
            } else {
                let p = print_percentiles;
                p("round trip", &s.round_trip);
                if let Some(d) = &s.from_due {
                    p("from due", d);
                }
                if let Some(d) = &s.late {
                    p("sent late", d);
                }
                p("solve", &s.solve);
                if let Some(c) = s.cpu_share {
                    println!("CPU share of the sender: {:.1} %", 100.0 * c);
                }
                println!(
                    "{} ok, {} refused, {} mismatched, {} out of order, {} elements per response, \
                     link length error {:.1e}",
                    s.ok, s.refused, s.mismatched, s.out_of_order, s.elements, s.max_length_error
                );
            }
            Ok(if s.refused + s.mismatched + s.out_of_order > 0 {
                1
            } else {
                0
            })
        }
        Cmd::Probe(a) => {
            let schedule = a.schedule.schedule()?;
            pin(a.pin)?;
            let (late, cpu) =
                clients::latency::probe(a.rate, a.seconds, schedule).map_err(usage)?;
            if a.json {
                println!("{}", serde_json::json!({ "late": late, "cpu_share": cpu }));
            } else {
                print_percentiles("wake-up lateness", &late);
                println!(
                    "CPU share: {}",
                    cpu.map_or("unknown".into(), |c| format!("{:.1} %", 100.0 * c))
                );
            }
            Ok(0)
        }
        Cmd::Load(a) => {
            let exe = std::env::current_exe()?;
            let cfg = LoadConfig {
                bin_dir: exe.parent().map(PathBuf::from).unwrap_or_default(),
                seconds: a.seconds,
                pin: !a.no_pin,
                service_wait: a.service_wait,
                hand_wait: a.hand_wait,
            };
            let report = load(&cfg, &mut std::io::stdout().lock())?;
            if a.json {
                println!("{}", serde_json::to_string(&report)?);
            }
            let problems = report.problems();
            for p in &problems {
                eprintln!("latency load: FAILED: {p}");
            }
            Ok(if problems.is_empty() { 0 } else { 1 })
        }
        Cmd::Bench(a) => {
            let sizes = a
                .sizes
                .split(',')
                .map(|s| match s.trim().parse::<u32>() {
                    Ok(n) if (1..=shared::MAX_LINKS).contains(&n) => Ok(n),
                    _ => Err(usage(format!(
                        "--sizes: {s:?} is not 1 to {}",
                        shared::MAX_LINKS
                    ))),
                })
                .collect::<Result<Vec<_>>>()?;
            let modes = a
                .modes
                .split(',')
                .map(|m| {
                    <WaitMode as clap::ValueEnum>::from_str(m.trim(), false)
                        .map_err(|e| usage(format!("--modes: {e}")))
                })
                .collect::<Result<Vec<_>>>()?;
            if a.samples == 0 || !(a.loaded_seconds.is_finite() && a.loaded_seconds >= 0.0) {
                return Err(usage("--samples ≥ 1 and --loaded-seconds ≥ 0"));
            }
            let exe = std::env::current_exe()?;
            let cfg = BenchConfig {
                bin_dir: exe.parent().map(PathBuf::from).unwrap_or_default(),
                samples: a.samples,
                warmup: a.warmup,
                sizes,
                modes,
                loaded_seconds: a.loaded_seconds,
            };
            run_bench(&cfg, &mut std::io::stdout().lock())?;
            Ok(0)
        }
    }
}
