//! The latency bench (`latency bench`): starts the service, the raw iceoryx2 echo and the Unix-socket
//! server in turn, each pinned to core 0, and a `latency client` pinned to core 1 against each; then a
//! loaded run (two hands at 1 kHz on one rope pinned to core 1, a viewer, the service in its default
//! mode pinned to core 0). Prints Markdown tables.
//!
//! `load.rs` is the load run (`latency load`), `loaded.rs` the bench's loaded run.
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

mod load;
mod loaded;
mod noise;
pub use noise::noise;

pub use load::{LoadConfig, LoadReport, load};
use loaded::loaded;

/// The `q` quantile (0 to 1, nearest rank) of `sorted` (ascending, in ns), in µs; NaN when empty.
pub fn nearest_rank_us(sorted: &[u64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let k = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1;
    sorted[k] as f64 / 1e3
}

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
    eprintln!("[noise] the machine's own noise on cores 0 and 1");
    noise::noise(out, 2000, 1.0)?;
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
            let wait = mode.name();
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
        "\nRatios of medians (aim: spin ≤ 1.1 × (raw + solve)):\n\n\
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
                find("raw iceoryx2", mode.name()),
                find("service, iceoryx2", mode.name()),
            ) else {
                continue;
            };
            let s = svc.s.round_trip.p50 as f64;
            let r = raw.s.round_trip.p50 as f64;
            let solve = svc.s.solve.p50 as f64;
            writeln!(
                out,
                "| {n} | {} | {:.2} | {:.2} | {} |",
                mode.name(),
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
    /// `chain`: the chain to watch (`None`: every chain, for a server without any).
    fn start(bin_dir: &Path, prefix: &str, chain: Option<&str>, secs: f64) -> Result<Viewer> {
        let mut cmd = Command::new(bin_dir.join("watch"));
        cmd.args(["--prefix", prefix])
            .args(["--duration", &format!("{secs}")])
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        if let Some(c) = chain {
            cmd.args(["--chain", c]);
        }
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
