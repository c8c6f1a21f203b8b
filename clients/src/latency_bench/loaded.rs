//! The bench's loaded run: two hands at 1 kHz on one rope and a viewer, the service in its default mode.

use super::{BenchConfig, Viewer, row, us};
use crate::latency::Summary;
use crate::process::{Proc, output_line};
use anyhow::Result;
use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

/// Two hands at 1 kHz (the two ends of one rope) on core 1 and a viewer, with the service in its
/// default mode (hybrid, journal written) on core 0.
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
    let samples = (1000.0 * secs).round() as usize;
    eprintln!("[loaded] two hands at 1 kHz on {chain} + a viewer, {secs} s");
    let prefix = format!("{tag}load_");
    let state_dir = tmp.join("state");
    let mut svc = Command::new(cfg.bin_dir.join("solver-service"));
    svc.args(["--scene", scene_arg, "--prefix", &prefix, "--pin", "0"])
        .args(["--state-dir", &state_dir.display().to_string()]);
    let mut service = Proc::ready(svc, "solver-service (loaded)")?;
    let viewer = Viewer::start(&cfg.bin_dir, &prefix, &chain, secs + 3.0)?;
    let hands: Vec<_> = ["head", "tail"]
        .into_iter()
        .map(|joint| {
            let prefix = prefix.clone();
            let chain = chain.clone();
            let bin = cfg.bin_dir.join("latency");
            std::thread::spawn(move || -> Result<Summary> {
                let mut cmd = Command::new(bin);
                cmd.args(["client", "--prefix", &prefix, "--chain", &chain])
                    .args(["--joint", joint, "--rate", "1000", "--warmup", "500"])
                    .args(["--pin", "1"])
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
    let hands: Vec<Summary> = hands
        .into_iter()
        .map(|h| {
            h.join()
                .map_err(|_| anyhow::anyhow!("hand thread panicked"))?
        })
        .collect::<Result<_>>()?;
    let viewer_summary = viewer.finish(Duration::from_secs_f64(secs + 30.0))?;
    service.stop();
    writeln!(
        out,
        "\nLoaded run: two hands at 1 kHz ({secs} s each, the head and the tail of {chain}) pinned to \
         core 1, a viewer on the state stream (not pinned), the service in its default mode (hybrid, \
         journal written) pinned to core 0 (µs; \"from due\" counts from when the request was due, so \
         a stall is charged to every request behind it; \"sent late\" is the hand's own lateness):\n"
    )?;
    writeln!(
        out,
        "| hand | requests | refused or mismatched | from due p50 | from due p90 | from due p99 | from due p99.9 | from due max | round trip p50 | round trip p99.9 | round trip max | sent late p99 | sent late p99.9 |"
    )?;
    writeln!(
        out,
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for (name, h) in ["head", "tail"].iter().zip(&hands) {
        let due = h.from_due.unwrap_or_default();
        let late = h.late.unwrap_or_default();
        writeln!(
            out,
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} |",
            h.round_trip.count,
            h.refused + h.mismatched,
            row(&due),
            us(h.round_trip.p50),
            us(h.round_trip.p999),
            us(h.round_trip.max),
            us(late.p99),
            us(late.p999)
        )?;
    }
    writeln!(
        out,
        "\nViewer: {}",
        viewer_summary.trim_start_matches("watch: ").trim()
    )?;
    Ok(())
}
