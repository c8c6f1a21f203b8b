//! Round-trip latency of joint moves, and the two baselines the bench puts beside the service: a raw
//! iceoryx2 request-response echo with the same payload sizes and no solving (`solver-service echo`, served
//! by the service's own serving loop), and the
//! same protocol over a Unix domain socket (`solver-service unix`).
//!
//! A run moves one joint of one chain around a small circle, one move per request, either back to back
//! (closed loop) or at a fixed rate. At a fixed rate, request `i` is due at `start + i / rate` and its
//! latency is counted from that due time, not from when it was sent: a stall delays the requests queued
//! behind it and they are all charged for it (no coordinated omission). Histograms are HDR (3 significant
//! digits), in nanoseconds.

use crate::connection::{ConnectOptions, Connection};
use hdrhistogram::Histogram;
use serde::{Deserialize, Serialize};
use shared::Wait;
use shared::{Command, JOINT_HEAD, RequestHeader, ResponseHeader, Status, Vec3};
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Where the requests go.
#[derive(Debug, Clone)]
pub enum Target {
    /// The solver service over iceoryx2.
    Service(ConnectOptions),
    /// The raw echo (`solver-service echo`) over iceoryx2: chain 0, no describe, any response accepted.
    Raw(ConnectOptions),
    /// The service's protocol over a Unix domain socket.
    Unix(PathBuf),
}

/// What to measure.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Chain name (ignored by the raw echo).
    pub chain: String,
    /// Joint to move ([`JOINT_HEAD`] for the head).
    pub joint: u32,
    /// Timed requests.
    pub samples: usize,
    /// Untimed requests first (page faults, caches, the spin budgets settling).
    pub warmup: usize,
    /// Requests per second; 0 sends each request as soon as the previous one is answered.
    pub rate_hz: f64,
    /// Radius of the joint's circle, in units of the chain's first link.
    pub radius: f64,
    /// Moves per turn of the circle.
    pub points_per_turn: usize,
    /// Stop sending after this long, even before `samples` (warmup included).
    pub duration: Option<Duration>,
    /// Write the sequence number of every `ok` response (warmup included), one per line: the load
    /// test merges the files of all hands and checks that no change was lost or answered twice.
    pub sequences: Option<PathBuf>,
    /// At a fixed rate: how the sender waits for each due time ([`wait_until`]).
    pub schedule: Schedule,
}

/// How a fixed-rate sender keeps its schedule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Schedule {
    /// Sleep until this long before the due time, then spin (yielding) the rest of the way: zero
    /// sleeps all the way (the wake-up's lateness is then the sender's); a longer stretch keeps the
    /// schedule on a machine whose sleeps overshoot, for the CPU the stretch costs.
    pub spin_before_due: Duration,
    /// Align the due times to the system clock's millisecond grid plus this offset, so that
    /// processes started apart keep fixed phases against each other (two hands and a probe on one
    /// core do not spin at the same time). `None`: due times count from the start.
    pub phase: Option<Duration>,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule {
            spin_before_due: WAKE_EARLY,
            phase: None,
        }
    }
}

impl Schedule {
    /// The first due time for a `period`: now, or with a phase, the next point of the grid.
    pub fn start(&self, period: Duration) -> Instant {
        let now = Instant::now();
        let Some(phase) = self.phase else {
            return now;
        };
        let since = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default()
            .as_nanos();
        let p = period.as_nanos().max(1);
        let into = (since + p - phase.as_nanos() % p) % p;
        now + Duration::from_nanos((p - into) as u64)
    }
}

/// The CPU time this thread has used (Linux: `/proc/thread-self/schedstat`), or `None`.
pub fn thread_cpu_time() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = s.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(ns))
}

impl Default for Plan {
    fn default() -> Self {
        Plan {
            chain: "rope".into(),
            joint: JOINT_HEAD,
            samples: 20_000,
            warmup: 2_000,
            rate_hz: 0.0,
            radius: 0.5,
            points_per_turn: 200,
            duration: None,
            sequences: None,
            schedule: Schedule::default(),
        }
    }
}

/// Percentiles of one histogram, in nanoseconds.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct Percentiles {
    pub count: u64,
    pub p50: u64,
    pub p90: u64,
    pub p99: u64,
    pub p999: u64,
    pub max: u64,
    pub mean: f64,
}

impl Percentiles {
    pub fn of(h: &Histogram<u64>) -> Self {
        Percentiles {
            count: h.len(),
            p50: h.value_at_quantile(0.5),
            p90: h.value_at_quantile(0.9),
            p99: h.value_at_quantile(0.99),
            p999: h.value_at_quantile(0.999),
            max: h.max(),
            mean: h.mean(),
        }
    }
}

/// The outcome of one run (the `latency client --json` line).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct Summary {
    /// Requests answered `ok` (timed ones).
    pub ok: u64,
    /// Requests refused by the service (timed ones).
    pub refused: u64,
    /// Elements in each response.
    pub elements: u32,
    /// Send to answer.
    pub round_trip: Percentiles,
    /// Due time to answer (fixed rate only; equals `round_trip` plus the sender's own lateness).
    pub from_due: Option<Percentiles>,
    /// How late the sender itself sent each request after its due time (fixed rate only: the
    /// client's sleep overshoot, not the service's doing).
    pub late: Option<Percentiles>,
    /// The service's own solve time (`solve_ns`; zero for the raw echo).
    pub solve: Percentiles,
    /// Responses whose `request_id` was not the one sent (must be 0).
    pub mismatched: u64,
    /// `ok` responses whose sequence number was not above the previous one's (a duplicated or stale
    /// response; must be 0).
    #[serde(default)]
    pub out_of_order: u64,
    /// Largest relative deviation of a link length read off any response's joints from the chain's
    /// link lengths (the service's own published positions, f64 rounding included).
    #[serde(default)]
    pub max_length_error: f64,
    /// The sender's CPU time over the run's wall time (Linux; `None` where it cannot be read): what
    /// its way of waiting costs.
    #[serde(default)]
    pub cpu_share: Option<f64>,
}

fn histogram() -> Histogram<u64> {
    Histogram::new_with_bounds(1, 600_000_000_000, 3).expect("valid HDR bounds")
}

enum Link {
    Iox(Box<Connection>),
    Unix {
        stream: UnixStream,
        buf: Vec<u8>,
        elements: Vec<Vec3>,
    },
}

impl Link {
    /// One request; returns the response header, a checksum of the payload (every element read) and
    /// the largest relative link-length error of its joints against `lengths` (0 if `lengths` is empty).
    /// Sends one request and reads its response. Returns the response header, a checksum of its
    /// elements, the largest link-length error in its joints, and when the response was in hand
    /// (before those checks: the round trip ends there, the client's own checks are not the server's).
    fn call(
        &mut self,
        h: &RequestHeader,
        points: &[Vec3],
        lengths: &[f64],
    ) -> anyhow::Result<(ResponseHeader, f64, f64, Instant)> {
        let read = |r: &ResponseHeader, p: &[Vec3]| {
            let arrived = Instant::now();
            let joints = &p[..(r.n_joints as usize).min(p.len())];
            (
                *r,
                p.iter().map(|v| v.x + v.y + v.z).sum::<f64>(),
                length_error(joints, lengths),
                arrived,
            )
        };
        match self {
            Link::Iox(c) => Ok(c.call_with(*h, points, read)?),
            Link::Unix {
                stream,
                buf,
                elements,
            } => {
                shared::unix_frame::write_request(stream, buf, h, points)?;
                let r = shared::unix_frame::read_response(stream, elements)?;
                Ok(read(&r, elements))
            }
        }
    }
}

/// Largest relative deviation of the distances between consecutive joints from `lengths` (0 when the
/// counts do not match: an error response, or no lengths to compare with).
pub fn length_error(joints: &[Vec3], lengths: &[f64]) -> f64 {
    if joints.len() != lengths.len() + 1 {
        return 0.0;
    }
    joints
        .windows(2)
        .zip(lengths)
        .map(|(w, l)| {
            let d = (w[1].x - w[0].x)
                .hypot(w[1].y - w[0].y)
                .hypot(w[1].z - w[0].z);
            ((d - l) / l).abs()
        })
        .fold(0.0, f64::max)
}

/// Runs `plan` against `target`. `progress` is called now and then with the share done.
pub fn run(target: &Target, plan: &Plan) -> anyhow::Result<Summary> {
    if plan.samples == 0 || plan.points_per_turn == 0 {
        anyhow::bail!("samples and points per turn must be ≥ 1");
    }
    if !(plan.rate_hz.is_finite() && plan.rate_hz >= 0.0 && plan.rate_hz <= 1e6) {
        anyhow::bail!("rate {} Hz: expected 0 (closed loop) to 10^6", plan.rate_hz);
    }
    if !(plan.radius.is_finite() && plan.radius > 0.0 && plan.radius <= 1e3) {
        anyhow::bail!("radius {}: expected (0, 1000] links", plan.radius);
    }
    let (mut link, raw) = match target {
        Target::Service(o) => (Link::Iox(Box::new(Connection::connect(o.clone())?)), false),
        Target::Raw(o) => (Link::Iox(Box::new(Connection::connect(o.clone())?)), true),
        Target::Unix(p) => (
            Link::Unix {
                stream: UnixStream::connect(p)
                    .map_err(|e| anyhow::anyhow!("connect to {}: {e}", p.display()))?,
                buf: Vec::new(),
                elements: Vec::new(),
            },
            false,
        ),
    };
    // The chain and the joint's start, from describe (the raw echo knows no chains).
    let (chain, centre, lengths) = if raw {
        (0, Vec3::default(), Vec::new())
    } else {
        find(&mut link, &plan.chain, plan.joint)?
    };
    let link_len = lengths.first().copied().unwrap_or(1.0);
    let mut sequences = Vec::new();
    let mut last_sequence = 0;
    let mut header = RequestHeader::new(Command::Move, chain);
    header.joint = plan.joint;
    let r = plan.radius * link_len;
    let mut round_trip = histogram();
    let mut from_due = histogram();
    let mut solve = histogram();
    let mut late = histogram();
    let mut s = Summary::default();
    let period = (plan.rate_hz > 0.0).then(|| Duration::from_secs_f64(1.0 / plan.rate_hz));
    let start = period.map_or_else(Instant::now, |p| plan.schedule.start(p));
    let (wall0, cpu0) = (Instant::now(), thread_cpu_time());
    let mut checksum = 0.0;
    for i in 0..plan.warmup + plan.samples {
        if plan.duration.is_some_and(|d| start.elapsed() >= d) {
            break;
        }
        let due = period.map(|p| start + p.mul_f64(i as f64));
        if let Some(due) = due {
            wait_until(due, plan.schedule.spin_before_due);
        }
        // Around the circle, starting and ending at the joint's own start.
        let a =
            std::f64::consts::TAU * (i % plan.points_per_turn) as f64 / plan.points_per_turn as f64;
        let target = [Vec3::new(
            centre.x + r * (a.cos() - 1.0),
            centre.y + r * a.sin(),
            centre.z,
        )];
        header.request_id = i as u64 + 1;
        let sent = Instant::now();
        let (resp, sum, len_err, done) = link.call(&header, &target, &lengths)?;
        checksum += sum;
        s.max_length_error = s.max_length_error.max(len_err);
        if resp.status == Status::Ok as u32 && !raw {
            if resp.sequence <= last_sequence {
                s.out_of_order += 1;
            }
            last_sequence = resp.sequence;
            if plan.sequences.is_some() {
                sequences.push(resp.sequence);
            }
        }
        if i < plan.warmup {
            continue;
        }
        if resp.request_id != header.request_id && !raw {
            s.mismatched += 1;
        }
        if resp.status == Status::Ok as u32 {
            s.ok += 1;
        } else {
            s.refused += 1;
        }
        s.elements = resp.n_joints + resp.n_angles;
        let _ = round_trip.record((done - sent).as_nanos().max(1) as u64);
        if let Some(due) = due {
            let _ = from_due.record((done - due).as_nanos().max(1) as u64);
            let _ = late.record(sent.saturating_duration_since(due).as_nanos().max(1) as u64);
        }
        let _ = solve.record(resp.solve_ns.max(1));
    }
    if !checksum.is_finite() {
        anyhow::bail!("a response held a non-finite coordinate");
    }
    if let Some(path) = &plan.sequences {
        let text: String = sequences.iter().map(|q| format!("{q}\n")).collect();
        std::fs::write(path, text).map_err(|e| anyhow::anyhow!("write {}: {e}", path.display()))?;
    }
    s.round_trip = Percentiles::of(&round_trip);
    s.from_due = period.map(|_| Percentiles::of(&from_due));
    s.late = period.map(|_| Percentiles::of(&late));
    s.solve = Percentiles::of(&solve);
    s.cpu_share = cpu_share(wall0, cpu0);
    Ok(s)
}

fn cpu_share(wall0: Instant, cpu0: Option<Duration>) -> Option<f64> {
    let used = thread_cpu_time()?.checked_sub(cpu0?)?;
    Some(used.as_secs_f64() / wall0.elapsed().as_secs_f64().max(1e-9))
}

/// The machine's own lateness beside a run: a thread that waits for a `rate_hz` schedule exactly as
/// a sender with `schedule` does, for `seconds`, and sends nothing. Returns the wake-up lateness
/// (after the due time, ns) and the thread's CPU share.
pub fn probe(
    rate_hz: f64,
    seconds: f64,
    schedule: Schedule,
) -> anyhow::Result<(Percentiles, Option<f64>)> {
    if !(rate_hz.is_finite() && rate_hz > 0.0 && rate_hz <= 1e5) {
        anyhow::bail!("rate {rate_hz} Hz: expected (0, 10^5]");
    }
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0) {
        anyhow::bail!("seconds {seconds}: expected (0, 3600]");
    }
    let period = Duration::from_secs_f64(1.0 / rate_hz);
    let n = (seconds * rate_hz).round().max(1.0) as u64;
    let start = schedule.start(period);
    let (wall0, cpu0) = (Instant::now(), thread_cpu_time());
    let mut late = histogram();
    for i in 0..n {
        let due = start + period.mul_f64(i as f64);
        wait_until(due, schedule.spin_before_due);
        let _ = late.record(
            Instant::now()
                .saturating_duration_since(due)
                .as_nanos()
                .max(1) as u64,
        );
    }
    Ok((Percentiles::of(&late), cpu_share(wall0, cpu0)))
}

/// How early a fixed-rate sender wakes from its sleep before a request is due, by default: a sleep
/// usually overshoots by 50-150 µs on these VMs (timer slack and wake-up), so it sleeps short and
/// spins the rest of the way.
pub const WAKE_EARLY: Duration = Duration::from_micros(250);

/// Sleeps until `spin` before `due`, then spins until `due` (the stretch's CPU cost: yielding instead
/// hands the core to any runnable thread for a whole time slice, which on a busy machine is
/// milliseconds). `spin` zero sleeps all the way. Senders sharing a core should keep their stretches
/// apart ([`Schedule::phase`]): never two spinning threads on one core.
pub fn wait_until(due: Instant, spin: Duration) {
    let now = Instant::now();
    if due > now + spin {
        std::thread::sleep(due - now - spin);
    }
    while Instant::now() < due {
        std::hint::spin_loop();
    }
}

/// The chain's handle, the joint's position and the chain's link lengths.
fn find(link: &mut Link, name: &str, joint: u32) -> anyhow::Result<(u32, Vec3, Vec<f64>)> {
    let mut c = 0;
    loop {
        let mut elements = Vec::new();
        let (h, _) = match link {
            Link::Iox(conn) => {
                let r = conn.call(RequestHeader::new(Command::Describe, c), &[])?;
                elements = r.joints().to_vec();
                (r.header, 0.0)
            }
            Link::Unix { .. } => {
                let r = link.call(&RequestHeader::new(Command::Describe, c), &[], &[])?;
                if let Link::Unix { elements: e, .. } = link {
                    elements = e.clone();
                }
                (r.0, r.1)
            }
        };
        if h.status != Status::Ok as u32 {
            anyhow::bail!("no chain named {name:?} in the service's scene");
        }
        if h.name_str() == name {
            let j = if joint == JOINT_HEAD {
                h.n_links as usize
            } else {
                joint as usize
            };
            let p = *elements
                .get(j)
                .ok_or_else(|| anyhow::anyhow!("joint {joint} is past the head of {name:?}"))?;
            let lengths = elements[..=h.n_links as usize]
                .windows(2)
                .map(|w| {
                    (w[1].x - w[0].x)
                        .hypot(w[1].y - w[0].y)
                        .hypot(w[1].z - w[0].z)
                })
                .collect();
            return Ok((c, p, lengths));
        }
        c += 1;
        if c >= h.n_chains {
            anyhow::bail!("no chain named {name:?} in the service's scene");
        }
    }
}

/// How the server (and the client, see [`connect_options`]) waits.
pub use shared::WaitMode;

/// Client options for a wait mode: the client waits the way the server does (spin with spin, sleep
/// with event, spin briefly then sleep with hybrid).
pub fn connect_options(prefix: &str, wait: WaitMode) -> ConnectOptions {
    ConnectOptions {
        prefix: prefix.to_string(),
        wait: match wait {
            WaitMode::Spin => Wait::Spin,
            WaitMode::Event => Wait::Event,
            WaitMode::Hybrid => Wait::Hybrid(Duration::from_micros(200)),
        },
        connect_timeout: Duration::from_secs(10),
        call_timeout: Duration::from_secs(5),
        max_request_points: 1,
    }
}
