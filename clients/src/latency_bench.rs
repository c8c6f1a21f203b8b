//! The latency bench (`latency bench`): starts the service, the raw iceoryx2 echo and the Unix-socket
//! server in turn, each pinned to core 0, and a `latency client` pinned to core 1 against each; then a
//! loaded run (two hands at 1 kHz on one rope pinned to core 1, a viewer, the service in its default
//! mode pinned to core 0). Prints Markdown tables.
//!
//! Every child is a separate process started from the directory of this executable (so `cargo build
//! --release --bins` first), killed and reaped when the bench ends, and every wait has a deadline.

use crate::latency::{Percentiles, Summary, WaitMode};
use crate::process::{Proc, output_line};
use anyhow::{Context, Result, bail};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// What the bench runs.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    /// Where `solver-service`, `latency` and `watch` are.
    pub bin_dir: PathBuf,
    /// Timed round trips per row.
    pub samples: usize,
    pub warmup: usize,
    /// Chain sizes (links).
    pub sizes: Vec<u32>,
    pub modes: Vec<WaitMode>,
    /// Length of the loaded run (0: skip it).
    pub loaded_seconds: f64,
}

const TIMEOUT: Duration = Duration::from_secs(30);

fn client_summary(cfg: &BenchConfig, args: &[String], what: &str) -> Result<Summary> {
    let mut cmd = Command::new(cfg.bin_dir.join("latency"));
    cmd.arg("client").args(args).arg("--json");
    let budget = Duration::from_secs(60) + Duration::from_millis(2 * cfg.samples as u64);
    let line = output_line(cmd, what, budget)?;
    serde_json::from_str(&line).with_context(|| format!("{what}: summary line {line:?}"))
}

/// The bench scene: one straight rope per size, named `rope<N>`.
pub fn scene(sizes: &[u32]) -> String {
    let mut s = String::from("# Written by `latency bench`.\n");
    for n in sizes {
        s += &format!(
            "\n[[chain]]\nname = \"rope{n}\"\nkind = \"free\"\nspace = \"spatial\"\nlinks = {n}\n\
             link_length = 1.0\nbase = [0.0, 0.0, 0.0]\nshape = \"straight\"\naxis = [1.0, 0.0, 0.0]\n\
             thickness = 0.2\nmethod = \"tractrix\"\nsubsteps = 1\n"
        );
    }
    s
}

fn mode_name(m: WaitMode) -> &'static str {
    m.name()
}

fn us(ns: u64) -> String {
    format!("{:.1}", ns as f64 / 1000.0)
}

fn row(p: &Percentiles) -> String {
    format!(
        "{} | {} | {} | {} | {}",
        us(p.p50),
        us(p.p90),
        us(p.p99),
        us(p.p999),
        us(p.max)
    )
}

struct Measured {
    links: u32,
    transport: &'static str,
    mode: &'static str,
    s: Summary,
}

/// Runs the bench, printing tables on `out` and progress on stderr.
pub fn run(cfg: &BenchConfig, out: &mut impl Write) -> Result<()> {
    for b in ["solver-service", "latency", "watch"] {
        if !cfg.bin_dir.join(b).exists() {
            bail!(
                "{} is missing: build the binaries first (cargo build --release --bins)",
                cfg.bin_dir.join(b).display()
            );
        }
    }
    let tmp = tempfile::tempdir()?;
    let scene_path = tmp.path().join("latency.toml");
    std::fs::write(&scene_path, scene(&cfg.sizes))?;
    let scene_arg = scene_path.display().to_string();
    let tag = format!("lat{}_", std::process::id());
    let common = |chain: &str| -> Vec<String> {
        vec![
            "--chain".into(),
            chain.into(),
            "--samples".into(),
            cfg.samples.to_string(),
            "--warmup".into(),
            cfg.warmup.to_string(),
            "--pin".into(),
            "1".into(),
        ]
    };
    let total = cfg.sizes.len() * (2 * cfg.modes.len() + 1);
    let mut results: Vec<Measured> = Vec::new();
    // Starts `server`, runs a client with `args` against it, stops the server.
    let mut measure = |server: Command, args: Vec<String>, m: Measured| -> Result<()> {
        eprintln!(
            "[{}/{total}] {} links, {}, {}",
            results.len() + 1,
            m.links,
            m.transport,
            m.mode
        );
        let mut p = Proc::ready(server, m.transport)?;
        let s = client_summary(cfg, &args, &format!("latency client ({})", m.transport))?;
        p.stop();
        results.push(Measured { s, ..m });
        Ok(())
    };
    let planned = |links, transport, mode| Measured {
        links,
        transport,
        mode,
        s: Summary::default(),
    };
    for &n in &cfg.sizes {
        let chain = format!("rope{n}");
        for &mode in &cfg.modes {
            // Side by side: the raw echo, then the service, in the same wait mode.
            let wait = mode_name(mode);
            let prefix = format!("{tag}r{n}{wait}_");
            let mut raw = Command::new(cfg.bin_dir.join("solver-service"));
            raw.args(["echo", "--prefix", &prefix, "--wait", wait])
                .args(["--elements", &(n + 1).to_string(), "--pin", "0"]);
            let mut args = common(&chain);
            args.extend(["--raw", "--prefix", &prefix, "--wait", wait].map(String::from));
            measure(raw, args, planned(n, "raw iceoryx2", wait))?;

            let prefix = format!("{tag}s{n}{wait}_");
            let mut svc = Command::new(cfg.bin_dir.join("solver-service"));
            svc.args(["--scene", &scene_arg, "--prefix", &prefix, "--no-persist"])
                .args(["--wait", wait, "--pin", "0"]);
            let mut args = common(&chain);
            args.extend(["--prefix", &prefix, "--wait", wait].map(String::from));
            measure(svc, args, planned(n, "service, iceoryx2", wait))?;
        }
        let sock = tmp.path().join(format!("s{n}.sock"));
        let sock_arg = sock.display().to_string();
        let mut svc = Command::new(cfg.bin_dir.join("solver-service"));
        svc.args(["--scene", &scene_arg, "unix", "--socket", &sock_arg])
            .args(["--pin", "0", "--connections", "1"]);
        let mut args = common(&chain);
        args.extend(["--unix".to_string(), sock_arg.clone()]);
        measure(
            svc,
            args,
            planned(n, "service, Unix socket", "blocking read"),
        )?;
    }

    writeln!(
        out,
        "Round trips of a head move, service pinned to core 0, client to core 1, {} timed after {} \
         warm-up (µs):\n",
        cfg.samples, cfg.warmup
    )?;
    writeln!(
        out,
        "| links | transport | wait | p50 | p90 | p99 | p99.9 | max | solve p50 | refused |"
    )?;
    writeln!(out, "|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")?;
    for m in &results {
        writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} |",
            m.links,
            m.transport,
            m.mode,
            row(&m.s.round_trip),
            if m.transport == "raw iceoryx2" {
                "–".into()
            } else {
                us(m.s.solve.p50)
            },
            m.s.refused + m.s.mismatched
        )?;
    }
    writeln!(
        out,
        "\nRatios of medians (aim: spin ≤ 1.2 × (raw + solve)):\n\n\
         | links | wait | service ÷ raw | service ÷ (raw + solve) | Unix socket ÷ service |"
    )?;
    writeln!(out, "|---:|---|---:|---:|---:|")?;
    for &n in &cfg.sizes {
        let find = |t: &str, m: &str| {
            results
                .iter()
                .find(|r| r.links == n && r.transport == t && r.mode == m)
        };
        let unix = find("service, Unix socket", "blocking read");
        for &mode in &cfg.modes {
            let (Some(raw), Some(svc)) = (
                find("raw iceoryx2", mode_name(mode)),
                find("service, iceoryx2", mode_name(mode)),
            ) else {
                continue;
            };
            let s = svc.s.round_trip.p50 as f64;
            let r = raw.s.round_trip.p50 as f64;
            let solve = svc.s.solve.p50 as f64;
            writeln!(
                out,
                "| {n} | {} | {:.2} | {:.2} | {} |",
                mode_name(mode),
                s / r,
                s / (r + solve),
                unix.map(|u| format!("{:.2}", u.s.round_trip.p50 as f64 / s))
                    .unwrap_or_else(|| "–".into())
            )?;
        }
    }
    if cfg.loaded_seconds > 0.0 {
        loaded(cfg, &scene_arg, &tag, tmp.path(), out)?;
    }
    Ok(())
}

/// A `watch` process on the state stream, subscribed before it is returned.
struct Viewer {
    child: Child,
    lines: mpsc::Receiver<String>,
}

impl Viewer {
    fn start(bin_dir: &Path, prefix: &str, chain: &str, secs: f64) -> Result<Viewer> {
        let mut cmd = Command::new(bin_dir.join("watch"));
        cmd.args(["--prefix", prefix, "--chain", chain])
            .args(["--duration", &format!("{secs}")])
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        let mut child = cmd.spawn().context("start the viewer (watch)")?;
        let err = child.stderr.take().expect("piped stderr");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(err).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        let v = Viewer { child, lines };
        let deadline = Instant::now() + TIMEOUT;
        loop {
            match v
                .lines
                .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            {
                Ok(l) if l.contains("listening") => return Ok(v),
                Ok(_) => {}
                Err(_) => bail!("the viewer did not subscribe within {TIMEOUT:?}"),
            }
        }
    }

    /// Waits (at most `timeout`) for the viewer to end and returns its summary line.
    fn finish(mut self, timeout: Duration) -> Result<String> {
        let deadline = Instant::now() + timeout;
        let mut summary = String::new();
        while Instant::now() < deadline {
            if let Ok(l) = self.lines.recv_timeout(Duration::from_millis(100))
                && l.contains("states")
            {
                summary = l;
            }
            if self.child.try_wait()?.is_some() {
                while let Ok(l) = self.lines.try_recv() {
                    if l.contains("states") {
                        summary = l;
                    }
                }
                break;
            }
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
        Ok(summary)
    }
}

/// Two hands at 1 kHz (the two ends of one rope) on core 1 and a viewer, with the service in its
/// default mode (hybrid, journal written) on core 0.
fn loaded(
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
        "| hand | requests | refused or mismatched | from due p50 | p90 | p99 | p99.9 | max | round trip p50 | p99.9 | max | sent late p99 | p99.9 |"
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
    let viewer = Viewer::start(&cfg.bin_dir, &prefix, "rope", secs + 2.0)?;
    eprintln!("[load] a hand at full speed and one at 1 kHz on the rope + a viewer, {secs} s");
    let hand = |joint: &str, rate: f64, seq: PathBuf| {
        let mut cmd = Command::new(cfg.bin_dir.join("latency"));
        cmd.args(["client", "--prefix", &prefix, "--chain", "rope"])
            .args(["--joint", joint, "--wait", cfg.hand_wait.name()])
            .args(["--rate", &rate.to_string(), "--seconds", &secs.to_string()])
            .args(["--sequences", &seq.display().to_string(), "--json"])
            .args(if rate > 0.0 {
                ["--warmup", "0"]
            } else {
                ["--warmup", "1000"]
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
        "| hand | requests | ok | refused | mismatched | out of order | length error | round trip p50 µs | p90 | p99 | p99.9 | max | from due p99.9 | max |"
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
    Ok(report)
}
