//! `watch`: subscribes to the service's state stream (every accepted change, in order) and writes it as
//! CSV, as SVG frames, or to a live Rerun viewer.
//!
//! ```text
//! watch --csv states.csv --duration 10            # every change of every chain for 10 s
//! watch --chain snake --svg frames/ --every 20    # every 20th state of the snake as frames/snake-SEQ.svg
//! watch --rerun                                   # to a viewer started with `rerun` (feature `rerun`)
//! watch --save states.rrd --count 500             # the same, recorded into a file
//! ```
//!
//! What the Rerun view shows is listed in `clients::viewer`.
//!
//! A scene's bundles (`[[bundle]]`, many strands) come on a stream of their own; `watch` subscribes
//! to it when a bundle is among the chains it watches, and draws a bundle's strands as one polyline
//! each. A bundle's `sequence` counts its own changes.
//!
//! CSV columns: `sequence,chain,command,request_id,joint,x,y,z`, one row per joint (a bundle's joints
//! numbered strand after strand, each strand tail first: joint `s·(links + 1) + j`), numbers printed
//! so they read back bit for bit. A gap in `sequence`
//! (a viewer too slow for its buffer) is counted and reported at the end. The streams are read on a
//! thread of their own that only copies each state into a queue (up to [`QUEUE`] states), so writing a
//! recording, CSV or frames never keeps `watch` from reading: it falls behind only when that thread
//! does not get the CPU for as long as the service fills the subscriber's buffer
//! (`solver-service --state-buffer`). Stops after `--count` states,
//! after `--duration` seconds, or on Ctrl-C. Exit codes: 0 ok, 1 failure, 2 usage.

use anyhow::{Context, Result};
use clap::Parser;
use clients::ToolArgs;
use clients::cli::usage;
use clients::render::{Frame, Polyline, View, write_frames_svg};
use clients::viewer::{self, LimitView, RerunView, Sink};
use shared::{ChainKind, Command, RequestHeader};
use std::collections::HashMap;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError};
use std::time::{Duration, Instant};

#[derive(Parser, Debug)]
#[command(
    version,
    about = "Write the state stream of a running solver-service as CSV and SVG"
)]
struct Args {
    /// Only these chains (by name; repeatable). Default: all.
    #[arg(long)]
    chain: Vec<String>,
    /// CSV output file ("-" for standard output).
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Write SVG frames into DIR (each state's rope, its tissue, eyelets and capsule instruments).
    #[arg(long)]
    svg: Option<PathBuf>,
    /// Keep every Nth state of each chain for the SVG frames.
    #[arg(long, default_value_t = 1)]
    every: u64,
    /// With --svg: draw only the last state of each chain, when the stream ends.
    #[arg(long, requires = "svg")]
    svg_last: bool,
    /// With --svg: draw only the knotted stretch of a chain whose states carry its knot (the scene's
    /// `knot = true`; `knots::knotted_stretch`) and a fifth of its length either side.
    #[arg(long, requires = "svg")]
    svg_knot: bool,
    /// Write one SVG of a chain's key frames to FILE when the stream ends: its first state, each
    /// state after which its held joints or its eyelets changed (a hand took or let go of it, a
    /// needle went into or out of tissue) or another end began to move (the head, the tail, or
    /// neither: an instrument), and its last; at most `--sheet-frames` of them (spread evenly when
    /// there are more). Needs exactly one `--chain`.
    #[arg(long, value_name = "FILE.svg")]
    sheet: Option<PathBuf>,
    /// Most frames of `--sheet`.
    #[arg(long, default_value_t = 8, requires = "sheet")]
    sheet_frames: usize,
    /// View of the frames, azimuth,elevation in degrees (default: planar chains from above, spatial
    /// ones oblique).
    #[arg(long)]
    view: Option<String>,
    /// Stream every state to a Rerun viewer at URL (without URL: a viewer started with `rerun` on this
    /// machine). Needs a build with the cargo feature `rerun`.
    #[arg(long, num_args = 0..=1, default_missing_value = viewer::DEFAULT_URL, value_name = "URL")]
    rerun: Option<String>,
    /// Record what `--rerun` would stream into FILE.rrd instead (open it with `rerun FILE.rrd`).
    #[arg(long, value_name = "FILE.rrd", conflicts_with = "rerun")]
    save: Option<PathBuf>,
    /// Stop after this many states.
    #[arg(long)]
    count: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long)]
    duration: Option<f64>,
    /// Pin the viewer to this core (a latency run keeps it off the hands' core).
    #[arg(long)]
    pin: Option<usize>,
    /// Check every state of each free chain with thickness for links passing through each other
    /// since its previous state (the swept-volume check, `knots::check::crossings_between`) and for
    /// non-adjacent capsules closer than the thickness; print each crossing and a count at the end.
    /// The exit code is 3 when a crossing was seen. Needs every state (`--state-buffer` on the
    /// service), and it reports the states it missed.
    #[arg(long)]
    crossings: bool,
    /// Keep every state of each free chain with thickness, and when the stream ends name each one
    /// in order with the fast knot namer (`knots::Namer`), timed, and a sample with the
    /// six-closure identification; print one line per chain (`clients::naming`). Needs every
    /// state (`--state-buffer` on the service).
    #[arg(long)]
    name_knots: bool,
    #[command(flatten)]
    service: ToolArgs,
}

fn main() -> std::process::ExitCode {
    clients::cli::main("watch", || run(Args::parse()))
}

struct ChainInfo {
    name: String,
    planar: bool,
    thickness: f64,
    free: bool,
    /// Joint limits the view draws.
    limit: Option<LimitView>,
    seen: u64,
    /// A bundle's strands: joints per strand (`links + 1`) and the link length.
    bundle: Option<(usize, f64)>,
    /// The chain's block of tissue (scene `tissue`): its corners, from the describe.
    tissue: Option<([f64; 3], [f64; 3])>,
}

/// The swept-volume check of `--crossings`: each free chain's previous state, the crossings seen and
/// the closest pair of capsules.
#[derive(Default)]
struct Crossings {
    last: std::collections::HashMap<u32, Vec<nalgebra::Vector3<f64>>>,
    count: u64,
    states: u64,
    /// The smallest distance between the axes of links with a thickness of rope between them, over the
    /// thickness (1: touching; below 1: overlapping).
    closest: f64,
}

impl Crossings {
    fn state(&mut self, sequence: u64, chain: u32, joints: &[[f64; 3]], thickness: f64) {
        let now: Vec<nalgebra::Vector3<f64>> = joints
            .iter()
            .map(|p| nalgebra::Vector3::new(p[0], p[1], p[2]))
            .collect();
        if self.states == 0 {
            self.closest = f64::INFINITY;
        }
        self.states += 1;
        if let Some(d) = knots::check::closest_links_with_rope_between(&now, thickness) {
            self.closest = self.closest.min(d / thickness);
        }
        if let Some(before) = self.last.get(&chain)
            && before.len() == now.len()
        {
            let shortest = now
                .windows(2)
                .map(|w| (w[1] - w[0]).norm())
                .fold(f64::INFINITY, f64::min);
            for c in knots::check::crossings_between(before, &now, 2, 1e-9 * shortest) {
                self.count += 1;
                if self.count <= 20 {
                    eprintln!(
                        "watch: crossing at state {sequence} of chain {chain}: links {} and {} pass \
                         through each other {:.3} of the way from the state before",
                        c.i, c.j, c.t
                    );
                }
            }
        }
        self.last.insert(chain, now);
    }

    fn report(&self) {
        eprintln!(
            "watch: crossings: {} in {} states; closest capsules {:.4} of the thickness apart",
            self.count, self.states, self.closest
        );
    }
}

/// Missed ranges of sequence numbers listed at the end (all are counted).
const MISSED_RANGES: usize = 50;

/// How often the Rerun view times a `query` round trip.
const PROBE_EVERY: Duration = Duration::from_millis(100);

fn run(a: Args) -> Result<u8> {
    let view = a
        .view
        .as_deref()
        .map(View::parse)
        .transpose()
        .map_err(usage)?;
    if a.every == 0 || a.duration.is_some_and(|d| !(d.is_finite() && d > 0.0)) {
        return Err(usage("--every must be ≥ 1 and --duration positive"));
    }
    if let Some(core) = a.pin {
        shared::pin_current_thread(core).map_err(anyhow::Error::msg)?;
    }
    let mut conn = a.service.connect()?;
    let (mut chains, bundle_seq_at_start, first) = describe(&mut conn)?;
    for name in &a.chain {
        if !chains.values().any(|c| &c.name == name) {
            anyhow::bail!("the service has no chain {name:?}");
        }
    }
    let mut rr = match (&a.rerun, &a.save) {
        (Some(url), _) => Some(RerunView::open(Sink::Viewer(url))?),
        (None, Some(file)) => Some(RerunView::open(Sink::File(file))?),
        (None, None) => None,
    };
    let watched = |info: &ChainInfo| a.chain.is_empty() || a.chain.contains(&info.name);
    if let Some(v) = &mut rr {
        for (&c, info) in &chains {
            match (watched(info), info.bundle) {
                (false, _) => {}
                (true, None) => {
                    v.add_chain(c, &info.name, info.thickness, info.free, info.limit);
                    if let Some(t) = info.tissue {
                        v.tissue(c, t)?;
                    }
                }
                (true, Some(_)) => v.add_bundle(c, &info.name),
            }
        }
    }
    let mut probe_at = Instant::now();
    // The bundles' stream, only when a bundle is watched (it exists only in a scene with bundles).
    let bundles = chains.values().any(|i| i.bundle.is_some() && watched(i));
    let reader = Reader::start(a.service.clone(), bundles)?;

    let mut csv: Option<Box<dyn Write>> = match &a.csv {
        Some(p) if p.as_os_str() == "-" => Some(Box::new(std::io::stdout().lock())),
        Some(p) => Some(Box::new(std::io::BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("create {}", p.display()))?,
        ))),
        None => None,
    };
    if let Some(w) = &mut csv {
        writeln!(w, "sequence,chain,command,request_id,joint,x,y,z")?;
    }
    if a.sheet.is_some() && a.chain.len() != 1 {
        anyhow::bail!("--sheet draws one chain: give exactly one --chain");
    }
    let mut sheet = Sheet::default();
    let mut crossings = Crossings::default();
    let mut kept: HashMap<u32, Vec<Vec<nalgebra::Vector3<f64>>>> = HashMap::new();
    if let Some(dir) = &a.svg {
        std::fs::create_dir_all(dir).with_context(|| format!("create {}", dir.display()))?;
    }
    let deadline = a
        .duration
        .map(|d| Instant::now() + Duration::from_secs_f64(d));
    let (mut states, mut frames) = (0u64, 0u64);
    let mut tally = Tally::new(&first, bundle_seq_at_start);
    // Frames are drawn when the queue is empty (drawing takes about a millisecond, while the reader
    // thread goes on reading), at most one per idle turn, and all at the end.
    let mut pending = std::collections::VecDeque::new();
    let mut last_frames: HashMap<u32, Pending> = HashMap::new();
    eprintln!("watch: listening (Ctrl-C to stop)");
    'outer: loop {
        // Drain what is waiting, then sleep a millisecond: a viewer need not spin.
        loop {
            let Some((h, joints, held, instruments, from_bundles)) = reader.try_next()? else {
                break;
            };
            if let Some(missed) = tally.sequence(&h, from_bundles)
                && let Some(v) = &mut rr
            {
                v.missed(h.sequence, missed)?;
            }
            tally.lengths(&h, &joints, chains.get(&h.chain).and_then(|i| i.bundle));
            let Some(info) = chains.get_mut(&h.chain) else {
                continue;
            };
            if !a.chain.is_empty() && !a.chain.contains(&info.name) {
                continue;
            }
            states += 1;
            info.seen += 1;
            if let Some(v) = &mut rr {
                match info.bundle {
                    Some((per, _)) => v.bundle_state(h.sequence, h.chain, &joints, per)?,
                    None => v.state(
                        h.sequence,
                        h.chain,
                        &joints,
                        clients::viewer::Around {
                            held: &held,
                            instruments: &instruments.0,
                            instrument_pulls: &instruments.1,
                            eyelets: &instruments.2,
                        },
                    )?,
                }
            }
            if a.crossings && info.free && info.bundle.is_none() && info.thickness > 0.0 {
                crossings.state(h.sequence, h.chain, &joints, info.thickness);
            }
            if a.sheet.is_some() {
                sheet.state(h.sequence, &joints, &held, (&instruments.0, &instruments.2));
            }
            if a.name_knots && info.free && info.bundle.is_none() && info.thickness > 0.0 {
                kept.entry(h.chain).or_default().push(
                    joints
                        .iter()
                        .map(|p| nalgebra::Vector3::new(p[0], p[1], p[2]))
                        .collect(),
                );
            }
            if let Some(w) = &mut csv {
                let cmd = Command::from_u32(h.command).map_or("unknown", |c| c.name());
                for (j, p) in joints.iter().enumerate() {
                    writeln!(
                        w,
                        "{},{},{cmd},{},{j},{:?},{:?},{:?}",
                        h.sequence, info.name, h.request_id, p[0], p[1], p[2]
                    )?;
                }
            }
            if a.svg.is_some() && (info.seen - 1).is_multiple_of(a.every) {
                let v = view.unwrap_or(if info.planar {
                    View::TOP
                } else {
                    View::OBLIQUE
                });
                let per = info.bundle.map_or(joints.len(), |(per, _)| per);
                let eyelets = instruments
                    .2
                    .iter()
                    .filter(|e| e.threaded)
                    .map(|e| e.at.to_array())
                    .collect();
                let frame = (
                    info.name.clone(),
                    h.sequence,
                    h.knot,
                    v,
                    joints,
                    info.planar,
                    per,
                    a.svg_knot,
                    eyelets,
                    info.tissue,
                    capsule_axes(&instruments.0),
                );
                if a.svg_last {
                    last_frames.insert(h.chain, frame);
                } else {
                    pending.push_back(frame);
                }
            }
            if a.count.is_some_and(|c| states >= c) {
                break 'outer;
            }
        }
        if let (Some(dir), Some(f)) = (&a.svg, pending.pop_front()) {
            frames += draw(dir, f)?;
            continue;
        }
        if let Some(v) = &mut rr {
            if probe_at.elapsed() >= PROBE_EVERY {
                probe_at = Instant::now();
                conn.call(RequestHeader::new(Command::Query, 0), &[])?;
                v.round_trip(tally.last_seq.unwrap_or(0), probe_at.elapsed())?;
                continue;
            }
            if v.identify_one()? {
                continue;
            }
        }
        if deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        // SIGINT / SIGTERM (not a stop and continue).
        if shared::stop_requested(conn.node(), Duration::from_millis(1)) {
            break;
        }
    }
    if let Some(dir) = &a.svg {
        let mut last: Vec<_> = last_frames.into_values().collect();
        last.sort_by_key(|f| f.1);
        for f in pending.into_iter().chain(last) {
            frames += draw(dir, f)?;
        }
    }
    if let (Some(file), Some(info)) = (
        &a.sheet,
        chains.values().find(|i| a.chain.contains(&i.name)),
    ) {
        let v = view.unwrap_or(if info.planar {
            View::TOP
        } else {
            View::OBLIQUE
        });
        let n = sheet.write(file, &info.name, info.tissue, v, a.sheet_frames)?;
        eprintln!(
            "watch: {n} key frames of {} in {}",
            info.name,
            file.display()
        );
    }
    if let Some(w) = &mut csv {
        w.flush()?;
    }
    if let Some(v) = rr {
        eprintln!("watch: {} states sent to Rerun", v.logged());
        v.finish()?;
    }
    tally.report(states, frames);
    let mut named: Vec<_> = kept.into_iter().collect();
    named.sort_by_key(|c| c.0);
    for (c, states) in named {
        let name = chains.get(&c).map_or("?", |i| i.name.as_str());
        let n = clients::naming::name_states(&states, 100);
        eprintln!("watch: knot names of {name}: {n}");
    }
    if a.crossings {
        crossings.report();
        if crossings.count > 0 {
            return Ok(3);
        }
    }
    Ok(0)
}

/// What `watch` knows of each chain, by index.
type Chains = HashMap<u32, ChainInfo>;

/// The service's chains (names, kinds, limits) and each bundle's sequence as `watch` starts, with the
/// first description (its sequence is where the stream is read from).
fn describe(conn: &mut clients::Connection) -> Result<(Chains, HashMap<u32, u64>, clients::Reply)> {
    let mut chains: HashMap<u32, ChainInfo> = HashMap::new();
    let mut bundle_seq_at_start: HashMap<u32, u64> = HashMap::new();
    let first = conn.call(RequestHeader::new(Command::Describe, 0), &[])?;
    for c in 0..first.header.n_chains {
        let d = conn.call(RequestHeader::new(Command::Describe, c), &[])?;
        let links = d.header.n_links as usize;
        if d.header.kind == ChainKind::Bundle as u32 {
            bundle_seq_at_start.insert(c, d.header.sequence);
        }
        chains.insert(
            c,
            ChainInfo {
                name: d.header.name_str(),
                planar: d.header.dims == 2,
                thickness: d.header.thickness,
                free: d.header.kind == 0,
                limit: LimitView::from_describe(d.header.limits, d.header.limit_value),
                seen: 0,
                bundle: (d.header.kind == ChainKind::Bundle as u32 && links > 0)
                    .then(|| (links + 1, d.header.total_length / links as f64)),
                tissue: d
                    .parts()
                    .tissue_box()
                    .map(|(lo, hi)| (lo.to_array(), hi.to_array())),
            },
        );
    }
    Ok((chains, bundle_seq_at_start, first))
}

/// The state stream's accounting: the states missed (sequence gaps) and duplicated, and the largest
/// relative deviation of any link from its length.
struct Tally {
    missed: u64,
    duplicated: u64,
    /// Which states of the chains' stream were missed: ranges of sequence numbers (the first
    /// [`MISSED_RANGES`] kept, all counted).
    missed_ranges: Vec<(u64, u64)>,
    missed_range_count: u64,
    /// The sequence of the chains' stream last seen: from the scene's description, a state published
    /// after it and not seen is missed, the first one included.
    last_seq: Option<u64>,
    /// A bundle's sequence counts its own changes: the last seen per bundle, from its description.
    last_bundle_seq: HashMap<u32, u64>,
    /// Link lengths per chain, read off the first state seen (lengths never change).
    lengths: HashMap<u32, Vec<f64>>,
    length_error: f64,
}

impl Tally {
    fn new(first: &clients::Reply, bundle_seq_at_start: HashMap<u32, u64>) -> Self {
        Tally {
            missed: 0,
            duplicated: 0,
            missed_ranges: Vec::new(),
            missed_range_count: 0,
            last_seq: (first.header.kind != ChainKind::Bundle as u32)
                .then_some(first.header.sequence),
            last_bundle_seq: bundle_seq_at_start,
            lengths: HashMap::new(),
            length_error: 0.0,
        }
    }

    /// Counts the state `h`; the states missed so far when it follows a gap in the chains' stream.
    fn sequence(&mut self, h: &shared::StateHeader, from_bundles: bool) -> Option<u64> {
        let last = if from_bundles {
            self.last_bundle_seq.get(&h.chain).copied()
        } else {
            self.last_seq
        };
        let mut gap = None;
        if let Some(prev) = last {
            if h.sequence > prev + 1 {
                self.missed += h.sequence - prev - 1;
                if !from_bundles {
                    self.missed_range_count += 1;
                    if self.missed_ranges.len() < MISSED_RANGES {
                        self.missed_ranges.push((prev + 1, h.sequence - 1));
                    }
                    gap = Some(self.missed);
                }
            } else if h.sequence <= prev {
                self.duplicated += 1;
            }
        }
        let newest = h.sequence.max(last.unwrap_or(0));
        if from_bundles {
            self.last_bundle_seq.insert(h.chain, newest);
        } else {
            self.last_seq = Some(newest);
        }
        gap
    }

    /// Checks the link lengths of a state against the chain's (a bundle's: `(joints per strand,
    /// link length)`), or learns them from the chain's first state.
    fn lengths(
        &mut self,
        h: &shared::StateHeader,
        joints: &[[f64; 3]],
        bundle: Option<(usize, f64)>,
    ) {
        let dist = |a: &[f64; 3], b: &[f64; 3]| (b[0] - a[0]).hypot(b[1] - a[1]).hypot(b[2] - a[2]);
        let worst = &mut self.length_error;
        match (bundle, self.lengths.get(&h.chain)) {
            // A bundle's links all have the bundle's length, strand by strand.
            (Some((per, l)), _) => {
                for s in joints.chunks(per) {
                    for w in s.windows(2) {
                        *worst = worst.max(((dist(&w[0], &w[1]) - l) / l).abs());
                    }
                }
            }
            (None, Some(l)) if l.len() + 1 == joints.len() => {
                for (w, l) in joints.windows(2).zip(l) {
                    *worst = worst.max(((dist(&w[0], &w[1]) - l) / l).abs());
                }
            }
            (None, Some(_)) => {}
            (None, None) => {
                self.lengths.insert(
                    h.chain,
                    joints.windows(2).map(|w| dist(&w[0], &w[1])).collect(),
                );
            }
        }
    }

    /// The last lines on stderr: the missed ranges, then the summary (the load run reads the last).
    fn report(&self, states: u64, frames: u64) {
        let (missed, duplicated, length_error) = (self.missed, self.duplicated, self.length_error);
        let (missed_ranges, missed_range_count) = (&self.missed_ranges, self.missed_range_count);
        // The ranges first: the summary stays the last line (the load run reads it).
        if missed_range_count > 0 {
            let shown: Vec<String> = missed_ranges
                .iter()
                .map(|&(a, b)| {
                    if a == b {
                        a.to_string()
                    } else {
                        format!("{a}-{b}")
                    }
                })
                .collect();
            let more = missed_range_count - missed_ranges.len() as u64;
            eprintln!(
                "watch: missed states (sequence numbers): {}{}",
                shown.join(", "),
                if more > 0 {
                    format!(" and {more} more ranges")
                } else {
                    String::new()
                }
            );
        }
        eprintln!(
            "watch: {states} states, {frames} SVG frames, {missed} missed (sequence gaps), \
         {duplicated} duplicated, link length error {length_error:.1e}"
        );
    }
}

/// What the reader thread hands over: one state, owned (header, joints, held joints, instrument
/// poses, whether it came from the bundles' stream), or why reading failed.
type Read = (
    shared::StateHeader,
    Vec<[f64; 3]>,
    Vec<clients::viewer::Held>,
    (
        Vec<shared::InstrumentPose>,
        Vec<[f64; 3]>,
        Vec<shared::EyeletState>,
    ),
    bool,
);

/// States the reader thread may hold for the writer: beyond, it waits (and the subscriber's own buffer
/// fills, then the service's overflow drops the oldest, which `watch` counts as missed). About 1 KB per
/// state of a 40-link rope.
const QUEUE: usize = 16_384;

/// How long the reader sleeps when both streams are empty (not a spin: the core stays free).
const READER_IDLE: Duration = Duration::from_micros(200);

/// The thread that reads the state stream into a queue; dropped, it is stopped and joined.
struct Reader {
    rx: Option<Receiver<Result<Read, String>>>,
    stop: Arc<AtomicBool>,
    handle: Option<std::thread::JoinHandle<()>>,
}

impl Reader {
    /// The next state read, if one is waiting.
    fn try_next(&self) -> Result<Option<Read>> {
        match self.rx.as_ref().map(|rx| rx.try_recv()) {
            Some(Ok(Ok(r))) => Ok(Some(r)),
            Some(Ok(Err(e))) => Err(anyhow::anyhow!(e)),
            Some(Err(TryRecvError::Empty)) => Ok(None),
            Some(Err(TryRecvError::Disconnected)) | None => {
                anyhow::bail!("the reader thread ended")
            }
        }
    }

    /// Starts the thread that reads the state stream (and the bundles' when `bundles`) on a
    /// connection of its own (iceoryx2's ports stay on the thread that made them); returns once it
    /// subscribed, so every state published after this returns is read.
    fn start(service: ToolArgs, bundles: bool) -> Result<Reader> {
        let stop = Arc::new(AtomicBool::new(false));
        let stop_reader = stop.clone();
        let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Read, String>>(QUEUE);
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<(), String>>();
        let reader = std::thread::Builder::new()
            .name("watch-reader".into())
            .spawn(move || {
                let setup = || -> Result<_> {
                    let conn = service.connect()?;
                    let stream = conn.subscribe()?;
                    let bundle_stream = if bundles {
                        Some(conn.subscribe_bundles()?)
                    } else {
                        None
                    };
                    Ok((conn, stream, bundle_stream))
                };
                let (_conn, stream, bundle_stream) = match setup() {
                    Ok(x) => {
                        let _ = ready_tx.send(Ok(()));
                        x
                    }
                    Err(e) => {
                        let _ = ready_tx.send(Err(format!("{e:#}")));
                        return;
                    }
                };
                let read = |h: &shared::StateHeader, pts: &[shared::Vec3]| {
                    let parts = shared::Parts::of_state(h, pts);
                    (
                        *h,
                        parts
                            .joints
                            .iter()
                            .map(|p| p.to_array())
                            .collect::<Vec<_>>(),
                        clients::viewer::Held::of(&parts),
                        (
                            parts.instrument_poses().collect::<Vec<_>>(),
                            parts
                                .instrument_pulls()
                                .iter()
                                .map(|p| p.to_array())
                                .collect::<Vec<_>>(),
                            parts.eyelet_states().collect::<Vec<_>>(),
                        ),
                    )
                };
                while !stop_reader.load(Ordering::Relaxed) {
                    // The chains' stream first, then the bundles'.
                    let got = match stream.try_next(read) {
                        Ok(Some(g)) => Ok(Some((g, false))),
                        Ok(None) => match &bundle_stream {
                            Some(b) => b.try_next(read).map(|g| g.map(|g| (g, true))),
                            None => Ok(None),
                        },
                        Err(e) => Err(e),
                    };
                    match got {
                        Ok(Some(((h, joints, held, instruments), from_bundles))) => {
                            if tx
                                .send(Ok((h, joints, held, instruments, from_bundles)))
                                .is_err()
                            {
                                return;
                            }
                        }
                        Ok(None) => std::thread::sleep(READER_IDLE),
                        Err(e) => {
                            let _ = tx.send(Err(e.to_string()));
                            return;
                        }
                    }
                }
            })
            .context("start the reader thread")?;
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(Reader {
                rx: Some(rx),
                stop,
                handle: Some(reader),
            }),
            Ok(Err(e)) => {
                let _ = reader.join();
                Err(anyhow::anyhow!(e))
            }
            Err(_) => {
                let _ = reader.join();
                anyhow::bail!("the reader thread ended before it subscribed")
            }
        }
    }
}

impl Drop for Reader {
    fn drop(&mut self) {
        // Told to stop, and its queue gone (it may be waiting on a full one).
        self.stop.store(true, Ordering::Relaxed);
        self.rx.take();
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// The knotted stretch of a rope whose state names its knot (`knot`, the wire's code) and a fifth of
/// its length either side; the whole rope when it names none or no stretch carries it.
fn knotted_part(joints: &[[f64; 3]], knot: u32) -> Vec<[f64; 3]> {
    use knots::KnotType;
    let kinds = [
        KnotType::Trefoil,
        KnotType::Square,
        KnotType::Granny,
        KnotType::DoubleOverhand,
        KnotType::Surgeons,
    ];
    let Some(kind) = kinds
        .into_iter()
        .find(|k| shared::knot_name(knot) == Some(k.name()))
    else {
        return joints.to_vec();
    };
    let points: Vec<nalgebra::Vector3<f64>> = joints
        .iter()
        .map(|p| nalgebra::Vector3::new(p[0], p[1], p[2]))
        .collect();
    match knots::knotted_stretch(&points, kind) {
        Some((a, b)) => {
            let margin = (b - a) / 5 + 1;
            joints[a.saturating_sub(margin)..=(b + margin).min(joints.len() - 1)].to_vec()
        }
        None => joints.to_vec(),
    }
}

/// A frame to draw: chain name, sequence, view, joints, planar, joints per polyline (a bundle's
/// strand; all of them for a chain).
/// A frame to draw: the chain's name, the state's sequence and knot code, the view, the joints,
/// whether planar, joints per strand, whether to draw only the knotted stretch, the threaded eyelets'
/// points (drawn as marks), the chain's tissue (drawn as a box).
type Pending = (
    String,
    u64,
    u32,
    View,
    Vec<[f64; 3]>,
    bool,
    usize,
    bool,
    Vec<[f64; 3]>,
    Option<([f64; 3], [f64; 3])>,
    Vec<Vec<[f64; 3]>>,
);

/// A state of `--sheet`: its sequence, joints and threaded eyelets' points, and its instruments'
/// axes (the driver's jaws, a needle's capsules).
type Shot = (u64, Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<Vec<[f64; 3]>>);

/// The key frames of `--sheet`: the states after which the chain's held joints or eyelets changed
/// or another end began to move, and the last one.
#[derive(Default)]
struct Sheet {
    /// Each key frame, and what changed after it.
    kept: Vec<(Shot, String)>,
    last: Option<Shot>,
    /// The held joints and the threaded eyelets' links of the last state, and which end moved into
    /// it.
    was: Option<(Vec<u32>, Vec<u32>, &'static str)>,
}

impl Sheet {
    fn state(
        &mut self,
        sequence: u64,
        joints: &[[f64; 3]],
        held: &[clients::viewer::Held],
        (instruments, eyelets): (&[shared::InstrumentPose], &[shared::EyeletState]),
    ) {
        let axes = capsule_axes(instruments);
        let now = (
            held.iter().map(|h| h.joint).collect::<Vec<_>>(),
            eyelets
                .iter()
                .filter(|e| e.threaded)
                .map(|e| e.link)
                .collect::<Vec<_>>(),
        );
        let marks = eyelets
            .iter()
            .filter(|e| e.threaded)
            .map(|e| e.at.to_array())
            .collect::<Vec<_>>();
        // Which end moved into this state: the head first (a free tail trails a moved head); the
        // rope moved by neither end, an instrument; a state that moved nothing (a grasp) keeps the
        // last.
        let moved_before = self.was.as_ref().map_or("", |w| w.2);
        let mover = match &self.last {
            Some((_, j, _, _)) if j.len() == joints.len() && !joints.is_empty() => {
                if j[j.len() - 1] != joints[joints.len() - 1] {
                    "the head moves"
                } else if j[0] != joints[0] {
                    "the tail moves"
                } else if j != joints {
                    "an instrument moves"
                } else {
                    moved_before
                }
            }
            _ => "",
        };
        match &self.was {
            None => self.kept.push((
                (sequence, joints.to_vec(), marks.clone(), axes.clone()),
                "first".into(),
            )),
            Some((held_was, eyelets_was, moved)) => {
                let what = if held_was != &now.0 {
                    Some(if held_was.len() < now.0.len() {
                        "held"
                    } else {
                        "let go"
                    })
                } else if eyelets_was.len() != now.1.len() {
                    Some("an eyelet made")
                } else if !moved.is_empty() && *moved != mover {
                    Some(mover)
                } else {
                    None
                };
                if let (Some(what), Some(shot)) = (what, self.last.take())
                    && self.kept.last().is_none_or(|k| k.0.0 != shot.0)
                {
                    self.kept.push((shot, format!("before: {what}")));
                }
            }
        }
        self.was = Some((now.0, now.1, mover));
        self.last = Some((sequence, joints.to_vec(), marks, axes));
    }

    /// Writes the sheet; returns the frames drawn.
    fn write(
        mut self,
        file: &std::path::Path,
        name: &str,
        tissue: Option<([f64; 3], [f64; 3])>,
        view: View,
        most: usize,
    ) -> Result<usize> {
        if let Some(shot) = self.last.take()
            && self.kept.last().is_none_or(|k| k.0.0 != shot.0)
        {
            self.kept.push((shot, "last".into()));
        }
        let n = self.kept.len();
        let most = most.max(2);
        // Spread evenly when there are more, the first and the last kept.
        let picked: Vec<usize> = if n <= most {
            (0..n).collect()
        } else {
            (0..most).map(|k| k * (n - 1) / (most - 1)).collect()
        };
        let frames: Vec<Frame> = picked
            .into_iter()
            .map(|k| {
                let ((s, joints, marks, axes), what) = &self.kept[k];
                Frame {
                    label: format!("{name} after change {s} ({what})"),
                    lines: tissue_lines(tissue)
                        .chain(instrument_lines(axes))
                        .chain(std::iter::once(Polyline {
                            joints: joints.clone(),
                            color: (20, 60, 160),
                            markers: false,
                        }))
                        .collect(),
                    marks: marks.clone(),
                }
            })
            .collect();
        if let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("create {}", dir.display()))?;
        }
        write_frames_svg(file, name, &frames, view, 4)?;
        Ok(frames.len())
    }
}

/// The axes of a chain's capsule instruments (the driver's jaws, a needle's capsules), end to end.
fn capsule_axes(instruments: &[shared::InstrumentPose]) -> Vec<Vec<[f64; 3]>> {
    instruments
        .iter()
        .filter(|i| i.capsule)
        .map(|i| vec![i.a.to_array(), i.b.to_array()])
        .collect()
}

/// Capsule instruments' axes as grey polylines.
fn instrument_lines(axes: &[Vec<[f64; 3]>]) -> impl Iterator<Item = Polyline> + '_ {
    axes.iter().map(|a| Polyline {
        joints: a.clone(),
        color: (110, 110, 120),
        markers: false,
    })
}

/// The edges of a chain's tissue as polylines in its flesh colour (none without tissue).
fn tissue_lines(tissue: Option<([f64; 3], [f64; 3])>) -> impl Iterator<Item = Polyline> {
    tissue
        .map(box_edges)
        .unwrap_or_default()
        .into_iter()
        .map(|edge| Polyline {
            joints: edge,
            color: (210, 150, 130),
            markers: false,
        })
}

/// The twelve edges of the box `lo`–`hi` as polylines: the bottom and top rectangles and the four
/// uprights.
fn box_edges((lo, hi): ([f64; 3], [f64; 3])) -> Vec<Vec<[f64; 3]>> {
    let corner = |x: bool, y: bool, z: f64| {
        [
            if x { hi[0] } else { lo[0] },
            if y { hi[1] } else { lo[1] },
            z,
        ]
    };
    let ring = |z| {
        vec![
            corner(false, false, z),
            corner(true, false, z),
            corner(true, true, z),
            corner(false, true, z),
            corner(false, false, z),
        ]
    };
    let mut edges = vec![ring(lo[2]), ring(hi[2])];
    for (x, y) in [(false, false), (true, false), (true, true), (false, true)] {
        edges.push(vec![corner(x, y, lo[2]), corner(x, y, hi[2])]);
    }
    edges
}

fn draw(
    dir: &std::path::Path,
    (name, sequence, knot, view, joints, planar, per, crop, eyelets, tissue, axes): Pending,
) -> Result<u64> {
    let joints = if crop {
        knotted_part(&joints, knot)
    } else {
        joints
    };
    let file = dir.join(format!("{name}-{sequence:08}.svg"));
    let eyelets = if crop { Vec::new() } else { eyelets };
    let eyelets_note = if eyelets.is_empty() {
        ""
    } else {
        " (crosses: eyelets)"
    };
    let frame = Frame {
        label: match shared::knot_name(knot) {
            Some(k) => {
                format!("{name} after change {sequence}: {k} (named by the service){eyelets_note}")
            }
            None => format!("{name} after change {sequence}{eyelets_note}"),
        },
        lines: tissue_lines(tissue.filter(|_| !crop))
            .chain(instrument_lines(if crop { &[] } else { &axes[..] }))
            .chain(joints.chunks(per.max(1)).map(|s| Polyline {
                joints: s.to_vec(),
                color: (20, 60, 160),
                markers: planar,
            }))
            .collect(),
        marks: eyelets,
    };
    write_frames_svg(&file, &name, &[frame], view, 1)?;
    Ok(1)
}
