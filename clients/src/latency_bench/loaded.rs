//! The bench's loaded run: two hands at 1 kHz on one rope and a viewer, with the machine's own
//! lateness measured beside them, in six set-ups (see [`SETUPS`]): the service in its default mode
//! (hybrid) with hands that sleep all the way to each due time, the same with hands that spin the last
//! stretch, the service in hybrid mode with a spin budget longer than the hands' interval (it spins
//! while they send and sleeps when they stop), the service spinning with hands that spin the last
//! stretch and for their responses, the same without the journal (whether the journal's `write` is
//! in the solve's tail), and the raw echo (the same serving loop, no solver) in that spinning set-up:
//! what the transport and the machine give a spinning server under the same load, beside which the
//! service's round trip is read.
//!
//! The two hands and the probe share core 1 at fixed phases of the millisecond grid (head 0, tail
//! 500 µs, probe 800 µs). A thread spins at most [`SPIN_US`] before its due time and a hand then
//! spins for its answer, so the core's millisecond reads: head's answer from 0, tail's stretch from
//! 300, tail's answer from 500, probe's stretch from 600, head's stretch from 800. Nothing overlaps
//! while an answer takes under 100 µs: one spinning thread per core. (An earlier layout, probe at
//! 750 µs after stretches of 250, started the probe's stretch as the tail hand sent: the tail hand
//! then waited for the core, and its round trip's tail was the probe's stretch.)

use super::{BenchConfig, Viewer, us};
use crate::latency::{Percentiles, Summary, WaitMode};
use crate::process::{Proc, output_line};
use anyhow::{Context, Result};
use serde::Deserialize;
use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

/// One set-up of the loaded run.
struct Setup {
    /// The raw echo instead of the service.
    echo: bool,
    service: WaitMode,
    /// Hybrid: the server's spin budget after each request, µs (`None`: the service's default).
    spin_budget_us: Option<u32>,
    /// How the hands wait for a response.
    hands: WaitMode,
    /// The hands' and the probe's spinning stretch before each due time, µs.
    spin_us: u32,
    /// Whether the service journals every change (`--state-dir`); the set-up without tells whether
    /// the journal's `write` is in the solve's tail.
    journal: bool,
}

impl Setup {
    fn server(&self) -> String {
        let who = if self.echo { "raw echo" } else { "service" };
        let journal = if self.echo || self.journal {
            ""
        } else {
            ", no journal"
        };
        match self.spin_budget_us {
            Some(b) => format!("{who} {} (spins {b} µs){journal}", self.service.name()),
            None => format!("{who} {}{journal}", self.service.name()),
        }
    }
    fn viewer(&self) -> &'static str {
        if self.echo { "none" } else { "not pinned" }
    }
}

/// The hybrid server's spin budget that bridges the hands' 500 µs interval with room to spare.
const BRIDGE_US: u32 = 1500;

/// The hands' and the probe's spinning stretch before each due time, µs, where they spin: enough for
/// this machine's usual wake-up lateness (its p99), and short enough that the three stretches and the
/// hands' waits for their answers fit in the millisecond side by side (see the module docs).
const SPIN_US: u32 = 200;

/// The probe's phase in the millisecond grid, µs: its stretch ends where the head hand's begins.
const PROBE_PHASE_US: u32 = 800;

const SETUPS: [Setup; 6] = [
    Setup {
        echo: false,
        service: WaitMode::Hybrid,
        spin_budget_us: None,
        hands: WaitMode::Hybrid,
        spin_us: 0,
        journal: true,
    },
    Setup {
        echo: false,
        service: WaitMode::Hybrid,
        spin_budget_us: None,
        hands: WaitMode::Hybrid,
        spin_us: SPIN_US,
        journal: true,
    },
    // Hands that wait in hybrid mode notify the server after sending: a hybrid server that went to
    // sleep in a gap (the machine's) is woken at once, not at its next tick.
    Setup {
        echo: false,
        service: WaitMode::Hybrid,
        spin_budget_us: Some(BRIDGE_US),
        hands: WaitMode::Hybrid,
        spin_us: SPIN_US,
        journal: true,
    },
    Setup {
        echo: false,
        service: WaitMode::Spin,
        spin_budget_us: None,
        hands: WaitMode::Spin,
        spin_us: SPIN_US,
        journal: true,
    },
    // The spinning set-up again without the journal: the solve's tail with and without its `write`.
    Setup {
        echo: false,
        service: WaitMode::Spin,
        spin_budget_us: None,
        hands: WaitMode::Spin,
        spin_us: SPIN_US,
        journal: false,
    },
    Setup {
        echo: true,
        service: WaitMode::Spin,
        spin_budget_us: None,
        hands: WaitMode::Spin,
        spin_us: SPIN_US,
        journal: false,
    },
];

#[derive(Deserialize)]
struct ProbeLine {
    late: Percentiles,
    cpu_share: Option<f64>,
}

struct Outcome {
    hands: Vec<Summary>,
    probe: ProbeLine,
    viewer: String,
}

fn run_setup(
    cfg: &BenchConfig,
    scene_arg: &str,
    prefix: &str,
    chain: &str,
    state_dir: &Path,
    setup: &Setup,
) -> Result<Outcome> {
    let secs = cfg.loaded_seconds;
    let samples = (1000.0 * secs).round() as usize;
    let mut svc = Command::new(cfg.bin_dir.join("solver-service"));
    if setup.echo {
        let links: usize = chain.trim_start_matches("rope").parse()?;
        svc.args(["echo", "--prefix", prefix, "--pin", "0"])
            .args(["--elements", &(links + 1).to_string()]);
    } else {
        svc.args(["--scene", scene_arg, "--prefix", prefix, "--pin", "0"]);
        if setup.journal {
            svc.args(["--state-dir", &state_dir.display().to_string()]);
        }
    }
    svc.args(["--wait", setup.service.name()]);
    if let Some(b) = setup.spin_budget_us {
        svc.args(["--spin-us", &b.to_string()]);
    }
    let mut service = Proc::ready(svc, "solver-service (loaded)")?;
    // The echo publishes no states (and has no state stream to subscribe to): no viewer.
    let viewer = if setup.echo {
        None
    } else {
        Some(Viewer::start(
            &cfg.bin_dir,
            prefix,
            Some(chain),
            secs + 3.0,
        )?)
    };
    let spin = setup.spin_us.to_string();
    let wait = setup.hands.name();
    let hands: Vec<_> = [("head", "0"), ("tail", "500")]
        .into_iter()
        .map(|(joint, phase)| {
            let (prefix, chain, spin) = (prefix.to_string(), chain.to_string(), spin.clone());
            let echo = setup.echo;
            let bin = cfg.bin_dir.join("latency");
            std::thread::spawn(move || -> Result<Summary> {
                let mut cmd = Command::new(bin);
                cmd.args(["client", "--prefix", &prefix, "--chain", &chain])
                    .args(if echo { &["--raw"][..] } else { &[][..] })
                    .args(["--joint", joint, "--rate", "1000", "--warmup", "500"])
                    .args([
                        "--pin",
                        "1",
                        "--phase-us",
                        phase,
                        "--spin-before-due-us",
                        &spin,
                    ])
                    .args(["--wait", wait])
                    .args(["--samples", &samples.to_string(), "--json"]);
                let line = output_line(
                    cmd,
                    "latency client (hand)",
                    Duration::from_secs_f64(secs + 60.0),
                )?;
                Ok(serde_json::from_str(&line)?)
            })
        })
        .collect();
    let mut probe = Command::new(cfg.bin_dir.join("latency"));
    probe
        .args(["probe", "--rate", "1000", "--pin", "1", "--phase-us"])
        .arg(PROBE_PHASE_US.to_string())
        .args(["--seconds", &(secs + 0.5).to_string(), "--json"])
        .args(["--spin-before-due-us", &spin]);
    let probe_line = output_line(probe, "latency probe", Duration::from_secs_f64(secs + 60.0))?;
    let probe: ProbeLine =
        serde_json::from_str(&probe_line).with_context(|| format!("probe line {probe_line:?}"))?;
    let hands: Vec<Summary> = hands
        .into_iter()
        .map(|h| {
            h.join()
                .map_err(|_| anyhow::anyhow!("hand thread panicked"))?
        })
        .collect::<Result<_>>()?;
    let viewer = match viewer {
        Some(v) => v.finish(Duration::from_secs_f64(secs + 30.0))?,
        None => "none (the echo publishes no states)".into(),
    };
    service.stop();
    Ok(Outcome {
        hands,
        probe,
        viewer,
    })
}

/// The worse hand's round-trip p99.9, ns.
fn worse_p999(o: &Outcome) -> u64 {
    o.hands.iter().map(|h| h.round_trip.p999).max().unwrap_or(0)
}

fn share(c: Option<f64>) -> String {
    c.map_or("–".into(), |c| format!("{:.0} %", 100.0 * c))
}

/// Two hands at 1 kHz (the two ends of one rope) on core 1, a probe beside them, and a viewer, with
/// the service on core 0 (journal written, except in the set-up without), in each set-up.
pub(super) fn loaded(
    cfg: &BenchConfig,
    scene_arg: &str,
    tag: &str,
    tmp: &Path,
    out: &mut impl Write,
) -> Result<()> {
    let n = cfg.sizes[0];
    let chain = format!("rope{n}");
    let secs = cfg.loaded_seconds;
    let mut outcomes = Vec::new();
    for (k, setup) in SETUPS.iter().enumerate() {
        eprintln!(
            "[loaded] {}, hands spin {} µs before due, viewer {}: two hands at 1 kHz on {chain} + \
             a probe + a viewer, {secs} s",
            setup.server(),
            setup.spin_us,
            setup.viewer()
        );
        let prefix = format!("{tag}load{k}_");
        let state_dir = tmp.join(format!("state{k}"));
        outcomes.push(run_setup(
            cfg, scene_arg, &prefix, &chain, &state_dir, setup,
        )?);
    }
    writeln!(
        out,
        "\nLoaded runs: two hands at 1 kHz ({secs} s each, the head and the tail of {chain}) and a \
         probe pinned to core 1 at phases 0, 500 and {PROBE_PHASE_US} µs of the millisecond grid, a viewer on the \
         state stream, the service (journal written unless the row says no journal) or the raw echo pinned to core 0. The probe waits \
         for its due times exactly as the hands do and sends nothing: its lateness is the machine's \
         own, measured beside the hands. *Sent late* is the hand's own lateness; *round trip* (send \
         to answer) is what the service and the transport add, the hand's lateness excluded; *solve* \
         is the service's own time from decoding to journaling (`solve_ns`; to encoding without a journal); *from due* adds both. \
         CPU is the thread's CPU time over the run's wall time (µs):\n"
    )?;
    writeln!(
        out,
        "| server waits | hands wait (response) | hands spin before due | viewer | who | requests | refused or mismatched | late p99 | late p99.9 | round trip p50 | round trip p99 | round trip p99.9 | round trip max | solve p99.9 | from due p99.9 | CPU |"
    )?;
    writeln!(
        out,
        "|---|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for (setup, o) in SETUPS.iter().zip(&outcomes) {
        let head = format!(
            "| {} | {} | {} µs | {}",
            setup.server(),
            setup.hands.name(),
            setup.spin_us,
            setup.viewer()
        );
        writeln!(
            out,
            "{head} | probe (machine's own) | {} | – | {} | {} | – | – | – | – | – | – | {} |",
            o.probe.late.count,
            us(o.probe.late.p99),
            us(o.probe.late.p999),
            share(o.probe.cpu_share)
        )?;
        for (name, h) in ["head hand", "tail hand"].iter().zip(&o.hands) {
            let late = h.late.unwrap_or_default();
            let due = h.from_due.unwrap_or_default();
            writeln!(
                out,
                "{head} | {name} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                h.round_trip.count,
                h.refused + h.mismatched,
                us(late.p99),
                us(late.p999),
                us(h.round_trip.p50),
                us(h.round_trip.p99),
                us(h.round_trip.p999),
                us(h.round_trip.max),
                us(h.solve.p999),
                us(due.p999),
                share(h.cpu_share)
            )?;
        }
    }
    // The echo's round trip under the same load, beside which the spinning set-ups are read.
    let echo = SETUPS
        .iter()
        .zip(&outcomes)
        .find(|(s, _)| s.echo)
        .map(|(_, o)| worse_p999(o));
    writeln!(
        out,
        "\nAim: the service's own contribution to the p99.9 below 100 µs. For each set-up of the service: \
         its own time (the worse hand's solve p99.9, receipt to answer), and the worse hand's round \
         trip p99.9, the transport and the machine's gaps on core 0 included; for the spinning \
         set-ups, also that round trip less the raw echo's under the same load (what the service adds \
         to what any server would see):\n"
    )?;
    for (setup, o) in SETUPS.iter().zip(&outcomes).filter(|(s, _)| !s.echo) {
        let worst = worse_p999(o);
        let solve = o.hands.iter().map(|h| h.solve.p999).max().unwrap_or(0);
        let verdict = |v: u64| if v < 100_000 { "met" } else { "**not met**" };
        let beside_echo = match echo {
            Some(e) if setup.service == WaitMode::Spin || setup.spin_budget_us.is_some() => {
                let added = worst.saturating_sub(e);
                format!(
                    "; less the echo's {} µs: {} µs, {}",
                    us(e),
                    us(added),
                    verdict(added)
                )
            }
            _ => String::new(),
        };
        writeln!(
            out,
            "- {}, hands {} and spinning {} µs before due, viewer {}: solve {} µs, {}; round trip {} \
             µs, {}{beside_echo}; viewer: {}",
            setup.server(),
            setup.hands.name(),
            setup.spin_us,
            setup.viewer(),
            us(solve),
            verdict(solve),
            us(worst),
            verdict(worst),
            o.viewer.trim_start_matches("watch: ").trim()
        )?;
    }
    Ok(())
}
