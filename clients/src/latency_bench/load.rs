//! The load run (`latency load`): a hand at full speed and one at 1 kHz on one rope plus a viewer;
//! every change accounted for exactly once.

use super::{Viewer, row, us};
use crate::latency::{Summary, WaitMode};
use crate::process::{Proc, output_line};
use anyhow::{Context, Result, bail};
use std::io::Write;
use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

/// The load run: one hand at full speed on the head of the default scene's rope, one at 1 kHz on its
/// tail, a viewer on the state stream, for a bounded time. Checked: every response answers its own
/// request; the sequence numbers of all `ok` responses of both hands together are exactly 1, 2, 3 …
/// (no change lost, none answered twice); every response's and every viewed state's link lengths are
/// the chain's; the viewer sees no state twice. Tails are recorded per hand.
#[derive(Debug, Clone)]
pub struct LoadConfig {
    /// Where `solver-service`, `latency` and `watch` are.
    pub bin_dir: PathBuf,
    pub seconds: f64,
    /// Pin the service to core 0 and both hands to core 1.
    pub pin: bool,
    /// The service's `--wait`.
    pub service_wait: WaitMode,
    /// The hands' `--wait`.
    pub hand_wait: WaitMode,
}

/// What the load run found.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct LoadReport {
    pub full_speed: Summary,
    pub one_khz: Summary,
    /// Accepted changes (distinct sequence numbers over both hands).
    pub changes: u64,
    /// Sequence numbers in 1..=max that no hand got.
    pub lost: u64,
    /// Sequence numbers that came back more than once.
    pub duplicated: u64,
    /// The viewer's summary line.
    pub viewer: String,
    /// The service's resources over the run (sampled every 20 ms).
    pub resources: Resources,
}

/// What the service held over the run, sampled from outside: its resident memory (`/proc/PID/status`),
/// the journal's size on disk (`journal.bin` and any segments waiting for a snapshot), and how many
/// snapshots were written (each replaces `snapshot.bin` by a rename: a new inode).
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct Resources {
    pub samples: u64,
    pub rss_start_kib: u64,
    pub rss_end_kib: u64,
    pub rss_max_kib: u64,
    pub journal_max_bytes: u64,
    pub journal_end_bytes: u64,
    pub snapshots: u64,
}

/// Samples the service `pid` and its state directory every 20 ms until `stop` is set.
fn monitor(
    pid: u32,
    state: PathBuf,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> std::thread::JoinHandle<Resources> {
    use std::os::unix::fs::MetadataExt;
    std::thread::spawn(move || {
        let rss = || -> Option<u64> {
            let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
            let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
            line.split_whitespace().nth(1)?.parse().ok()
        };
        let journal = || -> u64 {
            std::fs::read_dir(&state)
                .map(|d| {
                    d.filter_map(|e| e.ok())
                        .filter(|e| e.file_name().to_string_lossy().starts_with("journal"))
                        .filter_map(|e| e.metadata().ok())
                        .map(|m| m.len())
                        .sum()
                })
                .unwrap_or(0)
        };
        let snapshot = || {
            std::fs::metadata(state.join("snapshot.bin"))
                .ok()
                .map(|m| m.ino())
        };
        let mut r = Resources::default();
        let mut last_snapshot = snapshot();
        while !stop.load(std::sync::atomic::Ordering::Relaxed) {
            if let Some(kib) = rss() {
                if r.samples == 0 {
                    r.rss_start_kib = kib;
                }
                r.rss_end_kib = kib;
                r.rss_max_kib = r.rss_max_kib.max(kib);
                r.samples += 1;
            }
            let j = journal();
            r.journal_end_bytes = j;
            r.journal_max_bytes = r.journal_max_bytes.max(j);
            let s = snapshot();
            if s.is_some() && s != last_snapshot {
                r.snapshots += 1;
                last_snapshot = s;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        r
    })
}

impl LoadReport {
    /// Whether every check passed (tails are reported, not judged).
    pub fn problems(&self) -> Vec<String> {
        let mut p = Vec::new();
        for (name, h) in [("full speed", &self.full_speed), ("1 kHz", &self.one_khz)] {
            if h.refused + h.mismatched + h.out_of_order > 0 {
                p.push(format!(
                    "{name} hand: {} refused, {} mismatched, {} out of order",
                    h.refused, h.mismatched, h.out_of_order
                ));
            }
            if h.max_length_error > 1e-12 {
                p.push(format!(
                    "{name} hand: link length error {:e}",
                    h.max_length_error
                ));
            }
        }
        if self.lost + self.duplicated > 0 {
            p.push(format!(
                "{} changes lost, {} answered twice",
                self.lost, self.duplicated
            ));
        }
        if self.changes == 0 {
            p.push("no change was made".into());
        }
        if !self.viewer.contains(" 0 duplicated") {
            p.push(format!("viewer: {}", self.viewer));
        }
        match self
            .viewer
            .rsplit("link length error ")
            .next()
            .map(str::parse::<f64>)
        {
            Some(Ok(e)) if e <= 1e-12 => {}
            _ => p.push(format!("viewer: {}", self.viewer)),
        }
        p
    }
}

pub fn load(cfg: &LoadConfig, out: &mut impl Write) -> Result<LoadReport> {
    if !(cfg.seconds.is_finite() && cfg.seconds > 0.0 && cfg.seconds <= 86_400.0) {
        bail!("--seconds {}: expected (0, 86400]", cfg.seconds);
    }
    let secs = cfg.seconds;
    let tmp = tempfile::tempdir()?;
    let prefix = format!("load{}_", std::process::id());
    let mut svc = Command::new(cfg.bin_dir.join("solver-service"));
    svc.args(["--prefix", &prefix, "--wait", cfg.service_wait.name()])
        .args([
            "--state-dir",
            &tmp.path().join("state").display().to_string(),
        ]);
    if cfg.pin {
        svc.args(["--pin", "0"]);
    }
    let mut service = Proc::ready(svc, "solver-service (load)")?;
    let stop_monitor = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let monitor = monitor(
        service.child.id(),
        tmp.path().join("state"),
        stop_monitor.clone(),
    );
    let viewer = Viewer::start(&cfg.bin_dir, &prefix, Some("rope"), secs + 2.0)?;
    eprintln!("[load] a hand at full speed and one at 1 kHz on the rope + a viewer, {secs} s");
    let hand = |joint: &str, rate: f64, seq: PathBuf| {
        let mut cmd = Command::new(cfg.bin_dir.join("latency"));
        cmd.args(["client", "--prefix", &prefix, "--chain", "rope"])
            .args(["--joint", joint, "--wait", cfg.hand_wait.name()])
            .args(["--rate", &rate.to_string(), "--seconds", &secs.to_string()])
            .args(["--sequences", &seq.display().to_string(), "--json"])
            .args(if rate > 0.0 {
                // Sleeps all the way to each due time: the full-speed hand already spins on this
                // core (never two spinning threads on one core).
                ["--warmup", "0", "--spin-before-due-us", "0"]
            } else {
                ["--warmup", "1000", "--spin-before-due-us", "0"]
            })
            .args([
                "--samples",
                &if rate > 0.0 {
                    ((rate * secs).ceil() as u64).to_string()
                } else {
                    "1000000000".to_string()
                },
            ]);
        if cfg.pin {
            cmd.args(["--pin", "1"]);
        }
        let timeout = Duration::from_secs_f64(secs + 60.0);
        std::thread::spawn(move || -> Result<Summary> {
            let line = output_line(cmd, "latency client (load hand)", timeout)?;
            Ok(serde_json::from_str(&line)?)
        })
    };
    let seq_a = tmp.path().join("full.seq");
    let seq_b = tmp.path().join("khz.seq");
    let a = hand("head", 0.0, seq_a.clone());
    let b = hand("tail", 1000.0, seq_b.clone());
    let join = |h: std::thread::JoinHandle<Result<Summary>>| {
        h.join()
            .map_err(|_| anyhow::anyhow!("hand thread panicked"))?
    };
    let full_speed = join(a)?;
    let one_khz = join(b)?;
    let viewer = viewer.finish(Duration::from_secs_f64(secs + 30.0))?;
    stop_monitor.store(true, std::sync::atomic::Ordering::Relaxed);
    let resources = monitor
        .join()
        .map_err(|_| anyhow::anyhow!("monitor thread panicked"))?;
    service.stop();
    let mut all = Vec::new();
    for path in [&seq_a, &seq_b] {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("read {}", path.display()))?;
        for l in text.lines() {
            all.push(
                l.parse::<u64>()
                    .with_context(|| format!("{}: {l:?}", path.display()))?,
            );
        }
    }
    all.sort_unstable();
    let total = all.len() as u64;
    all.dedup();
    let duplicated = total - all.len() as u64;
    let max = all.last().copied().unwrap_or(0);
    let report = LoadReport {
        full_speed,
        one_khz,
        changes: all.len() as u64,
        lost: max - all.len() as u64,
        duplicated,
        viewer: viewer.trim_start_matches("watch: ").trim().to_string(),
        resources,
    };
    writeln!(
        out,
        "Load run ({secs} s; service --wait {}, hands --wait {}{}): {} changes, {} lost, {} answered twice\n",
        cfg.service_wait.name(),
        cfg.hand_wait.name(),
        if cfg.pin {
            ", service on core 0, hands on core 1"
        } else {
            ""
        },
        report.changes,
        report.lost,
        report.duplicated
    )?;
    writeln!(
        out,
        "| hand | requests | ok | refused | mismatched | out of order | largest link length error | round trip p50 (µs) | round trip p90 | round trip p99 | round trip p99.9 | round trip max | from due p99.9 | from due max |"
    )?;
    writeln!(
        out,
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for (name, h) in [
        ("full speed (head)", &report.full_speed),
        ("1 kHz (tail)", &report.one_khz),
    ] {
        let due = h.from_due.unwrap_or_default();
        writeln!(
            out,
            "| {name} | {} | {} | {} | {} | {} | {:.1e} | {} | {} | {} |",
            h.round_trip.count,
            h.ok,
            h.refused,
            h.mismatched,
            h.out_of_order,
            h.max_length_error,
            row(&h.round_trip),
            if h.from_due.is_some() {
                us(due.p999)
            } else {
                "–".into()
            },
            if h.from_due.is_some() {
                us(due.max)
            } else {
                "–".into()
            },
        )?;
    }
    writeln!(out, "\nViewer: {}", report.viewer)?;
    let r = &report.resources;
    writeln!(
        out,
        "\nThe service, sampled every 20 ms ({} samples): resident memory {} KiB at the start, {} KiB at \
         the end, {} KiB at most; journal on disk {} bytes at the end, {} at most; {} snapshots written \
         (one every 10 s while the state changes, the default).",
        r.samples,
        r.rss_start_kib,
        r.rss_end_kib,
        r.rss_max_kib,
        r.journal_end_bytes,
        r.journal_max_bytes,
        r.snapshots
    )?;
    Ok(report)
}
