//! The bench's loaded run: two hands at 1 kHz on one rope and a viewer, with the machine's own
//! lateness measured beside them, in three set-ups: the service in its default mode (hybrid) with hands
//! that sleep all the way to each due time, the same with hands that spin the last stretch, and the
//! service spinning with hands that spin the last stretch and spin for their responses.
//!
//! The two hands and the probe share core 1 at fixed phases of the millisecond grid (head 0, tail
//! 500 µs, probe 750 µs), so their spinning stretches (at most 250 µs each) never overlap: one spinning
//! thread per core at any time.

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
    service: WaitMode,
    /// How the hands wait for a response.
    hands: WaitMode,
    /// The hands' and the probe's spinning stretch before each due time, µs.
    spin_us: u32,
}

const SETUPS: [Setup; 3] = [
    Setup {
        service: WaitMode::Hybrid,
        hands: WaitMode::Hybrid,
        spin_us: 0,
    },
    Setup {
        service: WaitMode::Hybrid,
        hands: WaitMode::Hybrid,
        spin_us: 250,
    },
    Setup {
        service: WaitMode::Spin,
        hands: WaitMode::Spin,
        spin_us: 250,
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
    svc.args(["--scene", scene_arg, "--prefix", prefix, "--pin", "0"])
        .args(["--wait", setup.service.name()])
        .args(["--state-dir", &state_dir.display().to_string()]);
    let mut service = Proc::ready(svc, "solver-service (loaded)")?;
    let viewer = Viewer::start(&cfg.bin_dir, prefix, chain, secs + 3.0)?;
    let spin = setup.spin_us.to_string();
    let wait = setup.hands.name();
    let hands: Vec<_> = [("head", "0"), ("tail", "500")]
        .into_iter()
        .map(|(joint, phase)| {
            let (prefix, chain, spin) = (prefix.to_string(), chain.to_string(), spin.clone());
            let bin = cfg.bin_dir.join("latency");
            std::thread::spawn(move || -> Result<Summary> {
                let mut cmd = Command::new(bin);
                cmd.args(["client", "--prefix", &prefix, "--chain", &chain])
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
        .args(["probe", "--rate", "1000", "--pin", "1", "--phase-us", "750"])
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
    let viewer = viewer.finish(Duration::from_secs_f64(secs + 30.0))?;
    service.stop();
    Ok(Outcome {
        hands,
        probe,
        viewer,
    })
}

fn share(c: Option<f64>) -> String {
    c.map_or("–".into(), |c| format!("{:.0} %", 100.0 * c))
}

/// Two hands at 1 kHz (the two ends of one rope) on core 1, a probe beside them, and a viewer, with
/// the service (journal written) on core 0, in each set-up.
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
            "[loaded] service {}, hands spin {} µs before due: two hands at 1 kHz on {chain} + a \
             probe + a viewer, {secs} s",
            setup.service.name(),
            setup.spin_us
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
         probe pinned to core 1 at phases 0, 500 and 750 µs of the millisecond grid, a viewer on the \
         state stream (not pinned), the service (journal written) pinned to core 0. The probe waits \
         for its due times exactly as the hands do and sends nothing: its lateness is the machine's \
         own, measured beside the hands. *Sent late* is the hand's own lateness; *round trip* (send \
         to answer) is what the service and the transport add, the hand's lateness excluded; *solve* \
         is the service's own time from decoding to journaling (`solve_ns`); *from due* adds both. \
         CPU is the thread's CPU time over the run's wall time (µs):\n"
    )?;
    writeln!(
        out,
        "| service waits | hands wait (response) | hands spin before due | who | requests | refused or mismatched | late p99 | late p99.9 | round trip p50 | round trip p99 | round trip p99.9 | round trip max | solve p99.9 | from due p99.9 | CPU |"
    )?;
    writeln!(
        out,
        "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for (setup, o) in SETUPS.iter().zip(&outcomes) {
        let head = format!(
            "| {} | {} | {} µs",
            setup.service.name(),
            setup.hands.name(),
            setup.spin_us
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
    writeln!(
        out,
        "\nAim: the service's own contribution to the p99.9 (the worse hand's round trip p99.9) \
         below 100 µs:\n"
    )?;
    for (setup, o) in SETUPS.iter().zip(&outcomes) {
        let worst = o.hands.iter().map(|h| h.round_trip.p999).max().unwrap_or(0);
        writeln!(
            out,
            "- service {}, hands {} and spinning {} µs before due: {} µs, {}; viewer: {}",
            setup.service.name(),
            setup.hands.name(),
            setup.spin_us,
            us(worst),
            if worst < 100_000 {
                "met"
            } else {
                "**not met**"
            },
            o.viewer.trim_start_matches("watch: ").trim()
        )?;
    }
    Ok(())
}
