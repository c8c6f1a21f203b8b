//! A second client's queries while another client sends hostile moves (issue 68): no request holds
//! the service longer than its frame, so the others are served within a few frames.
//!
//! `cargo bench -p clients --bench hostile` starts the release `solver-service` on the shipped
//! `knots.toml` (its default frame: 16,000 link-steps, 1 ms of work per request), pinned to core 0
//! and waiting on events. On core 1 this bench runs two clients, each waiting on events (no spinning):
//! the *querier* sends a query of the 40-link rope `hands` on a 1 ms schedule (sleeping between) and
//! times each round trip; the *hostile* client sends moves into one knot rope back to back, each the
//! next as soon as the last is answered: a random joint sent to where another random joint of the rope
//! was in the last answer, a few thicknesses off it, so that most moves drive through the rope and
//! cost far more than a frame if nothing stopped them. First the querier alone, then beside the
//! hostile client on each rope, `HOSTILE_BENCH_SECONDS` (default 10) each. Per row: the hostile
//! moves' own time in the service (`solve_ns`) and how they were answered, and the querier's round
//! trip at p50, p99, p99.9 and max. The machine's noise is measured first.
//!
//! The binaries must be built first (`cargo build --release --bins`; `scripts/bench-report.sh` does).

use anyhow::{Context, Result};
use clients::connection::count_refusal;
use clients::latency_bench::nearest_rank_us;
use clients::process::{Proc, release_bin, workspace};
use clients::{ConnectOptions, Connection};
use shared::{Command, RequestHeader, Status, Vec3};
use std::process::Stdio;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The ropes the hostile client moves into (`knots.toml`).
const ROPES: &[&str] = &["hands-160", "hands-320", "tie-320"];

/// The rope the querier asks for.
const QUERIED: &str = "hands";

/// A small xorshift generator: the same moves every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

fn connect(prefix: &str) -> Result<Connection> {
    Ok(Connection::connect(ConnectOptions {
        prefix: prefix.to_string(),
        wait: clients::Wait::Event,
        connect_timeout: Duration::from_secs(10),
        call_timeout: Duration::from_secs(10),
        ..ConnectOptions::default()
    })?)
}

/// The querier: a query of [`QUERIED`] every millisecond until `stop`; each round trip in ns.
fn querier(prefix: &str, stop: &AtomicBool) -> Result<Vec<u64>> {
    let mut conn = connect(prefix)?;
    let chain = conn.require_chain(QUERIED)?;
    let mut trips = Vec::new();
    let t0 = Instant::now();
    let mut k = 0u32;
    while !stop.load(Ordering::Relaxed) {
        k += 1;
        let due = t0 + Duration::from_millis(u64::from(k));
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
        let sent = Instant::now();
        let r = conn.call(RequestHeader::new(Command::Query, chain), &[])?;
        anyhow::ensure!(r.is_ok(), "query refused: {}", r.header.reason_str());
        trips.push(sent.elapsed().as_nanos() as u64);
    }
    Ok(trips)
}

/// What the hostile client's moves gave: each one's `solve_ns`, and the answers by status.
#[derive(Default)]
struct Hostile {
    /// The rope's links, as the service describes it.
    links: u32,
    solve_ns: Vec<u64>,
    statuses: Vec<(String, u64)>,
}

/// The hostile client: moves into `rope` back to back until `stop`.
fn hostile(prefix: &str, rope: &str, stop: &AtomicBool) -> Result<Hostile> {
    let mut conn = connect(prefix)?;
    let chain = conn.require_chain(rope)?;
    let d = conn.call(RequestHeader::new(Command::Describe, chain), &[])?;
    let thickness = d.header.thickness;
    let mut joints: Vec<Vec3> = conn
        .call(RequestHeader::new(Command::Query, chain), &[])?
        .joints()
        .to_vec();
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut out = Hostile {
        links: d.header.n_links,
        ..Hostile::default()
    };
    while !stop.load(Ordering::Relaxed) {
        let n = joints.len();
        let (i, j) = (rng.below(n), rng.below(n));
        let off = |r: &mut Rng| (r.unit() - 0.5) * 6.0 * thickness;
        let p = joints[j];
        let target = Vec3::new(
            p.x + off(&mut rng),
            p.y + off(&mut rng),
            p.z + off(&mut rng),
        );
        let mut h = RequestHeader::new(Command::Move, chain);
        h.joint = i as u32;
        let r = conn.call(h, &[target])?;
        out.solve_ns.push(r.header.solve_ns);
        let name = Status::from_u32(r.header.status).map_or("unknown", |s| s.name());
        count_refusal(&mut out.statuses, name);
        if r.is_ok() && r.joints().len() == n {
            joints.copy_from_slice(r.joints());
        }
    }
    Ok(out)
}

fn quantiles(v: &mut [u64]) -> String {
    v.sort_unstable();
    format!(
        "{:.0} | {:.0} | {:.0} | {:.0}",
        nearest_rank_us(v, 0.5),
        nearest_rank_us(v, 0.99),
        nearest_rank_us(v, 0.999),
        nearest_rank_us(v, 1.0)
    )
}

fn main() -> Result<()> {
    let seconds: f64 = std::env::var("HOSTILE_BENCH_SECONDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|s: &f64| s.is_finite() && *s > 0.0)
        .unwrap_or(10.0);
    let scene = workspace().join("solver-service/scenes/knots.toml");
    clients::latency_bench::noise(&mut std::io::stdout(), 2000, 1.0)?;
    println!();
    println!("### A second client's queries during hostile moves\n");
    println!(
        "The service on `knots.toml` at its default frame (16,000 link-steps, 1 ms), pinned to core \
         0, waiting on events; on core 1 a client queries the 40-link rope `{QUERIED}` every 1 ms and \
         times each round trip (*query*), first alone, then while a hostile client sends moves into \
         the rope named back to back (a random joint to a random joint's place, up to three \
         thicknesses off it; *hostile*: the service's own time per move and how the moves were \
         answered), {seconds} s each. Times in µs.\n"
    );
    println!(
        "| hostile moves into | links | hostile moves | answered | hostile solve p50 µs | p99 | p99.9 | max \
         | queries | query round trip p50 µs | p99 | p99.9 | max |"
    );
    println!("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let rows: Vec<Option<&str>> = std::iter::once(None)
        .chain(ROPES.iter().map(|r| Some(*r)))
        .collect();
    for rope in rows {
        // A fresh service per row: the hostile moves of one row leave the rope where they left it.
        let prefix = format!("hostile_{}_{}_", std::process::id(), rope.unwrap_or("none"));
        let mut svc = std::process::Command::new(release_bin("solver-service")?);
        svc.args(["--prefix", &prefix, "--scene"])
            .arg(&scene)
            .args(["--wait", "event", "--no-persist", "--pin", "0"]);
        svc.stderr(Stdio::null());
        let mut svc = Proc::ready(svc, "solver-service")?;
        let stop = Arc::new(AtomicBool::new(false));
        let host = rope.map(|r| {
            let (p, s, r) = (prefix.clone(), stop.clone(), r.to_string());
            std::thread::spawn(move || {
                shared::pin_current_thread(1).ok();
                hostile(&p, &r, &s)
            })
        });
        let q = {
            let (p, s) = (prefix.clone(), stop.clone());
            std::thread::spawn(move || {
                shared::pin_current_thread(1).ok();
                querier(&p, &s)
            })
        };
        std::thread::sleep(Duration::from_secs_f64(seconds));
        stop.store(true, Ordering::Relaxed);
        let joined = |what: &str| anyhow::anyhow!("the {what} thread panicked");
        let mut trips = q
            .join()
            .map_err(|_| joined("querier"))?
            .context("querier")?;
        let host = match host {
            Some(h) => Some(
                h.join()
                    .map_err(|_| joined("hostile client's"))?
                    .context("hostile client")?,
            ),
            None => None,
        };
        svc.stop();
        let name = rope.map_or("(none: the querier alone)".to_string(), |r| {
            format!("`{r}`")
        });
        let links = host.as_ref().map_or(String::new(), |h| h.links.to_string());
        let (moves, answered, solve) = match host {
            Some(mut h) => {
                let answered = h
                    .statuses
                    .iter()
                    .map(|(s, n)| format!("{n} {s}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                (
                    h.solve_ns.len().to_string(),
                    answered,
                    quantiles(&mut h.solve_ns),
                )
            }
            None => (String::new(), String::new(), " |  |  | ".to_string()),
        };
        println!(
            "| {name} | {links} | {moves} | {answered} | {solve} | {} | {} |",
            trips.len(),
            quantiles(&mut trips)
        );
    }
    Ok(())
}
