//! Contact inside a haptic frame (issue 40): the service's own time per request along the tying path of
//! every built-in knot, through the product.
//!
//! `cargo bench -p clients --bench contact` starts, for each row, the release `solver-service` on the
//! shipped `knots.toml` (capsule self-collision, the scene's holds, instruments, anchors and budget;
//! its `knot = true` taken out, so the times are the move's and not the knot's name with it),
//! pinned to core 0 and waiting on events, and the script's `hand` processes as fast as the service
//! answers (`--rate 0`); each hand writes the times of every request it sent (`hand run --timings`:
//! moves and instrument poses, the halves of a move split after an over-budget refusal included). The
//! table gives the service's own time per request (`solve_ns` of the response: from decoding the
//! request to journaling it; no journal here) at p50, p99, p99.9 and max, with the requests refused
//! (locked, over the work budget, out of a held rope's reach), and the knot the rope holds at the end
//! (named by the service's identification, as `chainctl knot` names it), and the collision passes
//! each response reports (`iterations`): their median, the requests over a millisecond and those
//! requests' median passes, so a slow tail shows where its time went. The machine's own noise
//! (sleep and busy-loop probes on both cores, nothing of ours running) is measured first and printed
//! above the rows: a request's time is only as steady as the core it runs on.
//!
//! A second table is the scale curve: the round trip of a move as a client in this process sees it
//! (spinning on core 1, the service spinning on core 0), for a 40-unit rope of 40, 200, 1,000 and
//! 10,000 links, with capsule collision (thickness 0.2) and a bend radius of 1.5 (a rope finer than it
//! is thick kinks without one: links a thickness apart along it fold onto each other and lock), and
//! with neither, along the built-in `overhand-bend`'s head path (no corner): what a simulator author
//! picks a resolution from.
//!
//! A third table is what the resolution of held ropes bought: the held ropes whose passes creep, on
//! `knots.toml` with every chain given each of `collision_together_after` (the passes alone, or
//! contacts and lengths solved together after two passes) and `collision_pushed_weight` (how freely
//! the joints a pass pushed move when the rope is relaxed back to its lengths), time against refused
//! requests and the knot tied.
//!
//! The binaries must be built first (`cargo build --release --bins`; `scripts/bench-report.sh` does).
//! `CONTACT_BENCH_ONLY=overhand,tie-160` keeps the rows whose script or chain is named (`held` and
//! `scale` name the last two tables).

use anyhow::{Context, Result, bail};
use clients::process::{Proc, release_bin, workspace};
use knots::script::Script;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The rows: a built-in script, the chain of `knots.toml` it runs on (its links), and what the chain
/// has that costs (held joints, instruments, a bend limit).
const ROWS: &[(&str, &str, usize, &str)] = &[
    ("overhand-wide", "paper", 40, "free head, one wide loop"),
    ("overhand", "overhand", 160, "free head"),
    ("square", "reef", 320, "two free ends"),
    ("granny", "reef", 320, "two free ends"),
    ("overhand-anchored", "suture", 40, "tail anchored"),
    ("overhand-bend", "bend-80", 80, "bend limit"),
    ("overhand-bend", "bend-160", 160, "bend limit"),
    ("overhand-bend", "bend-320", 320, "bend limit"),
    ("square-held", "hands", 40, "both ends held, a finger"),
    ("square-held", "hands-160", 160, "both ends held, a finger"),
    ("square-held", "hands-320", 320, "both ends held, a finger"),
    ("instrument-tie", "tie", 40, "anchored, needle driver"),
    ("instrument-tie", "tie-160", 160, "anchored, needle driver"),
    ("instrument-tie", "tie-320", 320, "anchored, needle driver"),
    ("surgeons-knot", "tie", 40, "anchored, needle driver"),
    ("surgeons-knot", "tie-160", 160, "anchored, needle driver"),
    (
        "instrument-square",
        "tie-160",
        160,
        "anchored, needle driver",
    ),
];

/// How long one row may take before it is abandoned (a row is a few seconds to a few minutes).
const ROW_TIMEOUT: Duration = Duration::from_secs(900);

/// A row's hand processes, each with its timings file and its stderr's file; any still running when
/// the row ends (a failure, a timeout) are killed and reaped.
struct Hands(Vec<(std::process::Child, PathBuf, PathBuf)>);

impl Drop for Hands {
    fn drop(&mut self) {
        for (child, _, _) in &mut self.0 {
            if matches!(child.try_wait(), Ok(None)) {
                let _ = child.kill();
                let _ = child.wait();
            }
        }
    }
}

struct Row {
    /// Each request's time as the service measured it (`solve_ns`) and its collision passes (the
    /// response's `iterations`).
    passes: Vec<(u64, u32)>,
    /// The service's line on the chain's contact resolutions at shutdown.
    resolutions: Option<String>,
    refused: usize,
    knot: String,
    seconds: f64,
}

impl Row {
    /// The cells requests, refused, p50, p99, p99.9 and max (µs) of the row's times.
    fn cells(&self) -> String {
        let mut v: Vec<u64> = self.passes.iter().map(|&(ns, _)| ns).collect();
        v.sort_unstable();
        let v = &v;
        format!(
            "{} | {} | {:.1} | {:.1} | {:.1} | {:.1}",
            v.len(),
            self.refused,
            pct(v, 0.5),
            pct(v, 0.99),
            pct(v, 0.999),
            pct(v, 1.0)
        )
    }

    /// The cells long resolutions and joint projections stalled / all, from the service's line at
    /// shutdown (`–` without one).
    fn resolution_cells(&self) -> String {
        let Some(line) = &self.resolutions else {
            return "– | –".into();
        };
        let after = |key: &str| -> Option<u64> {
            let at = line.find(key)? + key.len();
            line[at..]
                .split(|c: char| !c.is_ascii_digit())
                .next()?
                .parse()
                .ok()
        };
        let cell = |v: Option<u64>| v.map_or("?".into(), |v| v.to_string());
        format!(
            "{} | {} / {}",
            cell(after(" resolutions (")),
            cell(after("converged, ")),
            cell(after("joint projections: "))
        )
    }

    /// The cells passes p50, requests over a millisecond and their passes' median: where the slow
    /// requests' time goes.
    fn pass_cells(&self) -> String {
        let mut all: Vec<u64> = self.passes.iter().map(|&(_, p)| u64::from(p)).collect();
        all.sort_unstable();
        let mut slow: Vec<u64> = self
            .passes
            .iter()
            .filter(|&&(ns, _)| ns > 1_000_000)
            .map(|&(_, p)| u64::from(p))
            .collect();
        slow.sort_unstable();
        let median = |v: &[u64]| v.get(v.len().saturating_sub(1) / 2).copied();
        format!(
            "{} | {} | {}",
            median(&all).map_or("–".into(), |m| m.to_string()),
            slow.len(),
            median(&slow).map_or("–".into(), |m| m.to_string())
        )
    }
}

fn run_row(script: &str, chain: &str, k: usize, dir: &Path, scene: &Path) -> Result<Row> {
    let hands: Vec<String> = {
        let s = Script::builtin(script).context("no such built-in script")?;
        let mut h: Vec<String> = s.turn.iter().map(|t| t.hand.clone()).collect();
        h.sort();
        h.dedup();
        h
    };
    let prefix = format!("contact_{}_{k}_", std::process::id());
    let mut svc = Command::new(release_bin("solver-service")?);
    let svc_err = dir.join(format!("{script}-{chain}-{k}-service.err"));
    svc.args(["--prefix", &prefix, "--scene"]).arg(scene).args([
        "--wait",
        "event",
        "--no-persist",
        "--pin",
        "0",
    ]);
    svc.stderr(std::fs::File::create(&svc_err)?);
    let mut svc = Proc::ready(svc, "solver-service")?;
    let started = Instant::now();
    let mut children = Hands(Vec::new());
    for h in &hands {
        let file = dir.join(format!("{script}-{chain}-{h}.txt"));
        let log = dir.join(format!("{script}-{chain}-{h}.err"));
        let child = Command::new(release_bin("hand")?)
            .args(["--prefix", &prefix, "run", "--builtin", script, "--hand", h])
            .args([
                "--chain",
                chain,
                "--rate",
                "0",
                "--quiet",
                "--turn-timeout",
                "300",
            ])
            .arg("--timings")
            .arg(&file)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log)?)
            .spawn()
            .context("start hand")?;
        children.0.push((child, file, log));
    }
    let mut row = Row {
        passes: Vec::new(),
        resolutions: None,
        refused: 0,
        knot: String::new(),
        seconds: 0.0,
    };
    for (child, file, log) in &mut children.0 {
        let status = loop {
            if let Some(s) = child.try_wait()? {
                break s;
            }
            if started.elapsed() > ROW_TIMEOUT {
                bail!("{script} on {chain}: a hand took longer than {ROW_TIMEOUT:?}");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        if !status.success() {
            let err = std::fs::read_to_string(&*log).unwrap_or_default();
            bail!("{script} on {chain}: a hand failed ({status}): {err}");
        }
        let file = &*file;
        let text = std::fs::read_to_string(file).with_context(|| file.display().to_string())?;
        for line in text.lines().filter(|l| !l.starts_with('#')) {
            let f: Vec<&str> = line.split_whitespace().collect();
            let [_, solve_us, status, _pull, passes] = f[..] else {
                bail!("{}: bad line {line:?}", file.display());
            };
            let ns = (solve_us.parse::<f64>()? * 1e3).round() as u64;
            row.passes.push((ns, passes.parse()?));
            if status != "ok" {
                row.refused += 1;
            }
        }
    }
    row.seconds = started.elapsed().as_secs_f64();
    let out = Command::new(release_bin("chainctl")?)
        .args(["--prefix", &prefix, "knot", chain, "--json"])
        .output()
        .context("chainctl knot")?;
    let text = String::from_utf8_lossy(&out.stdout);
    row.knot = text
        .split("\"knot\":\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .unwrap_or("?")
        .to_string();
    svc.stop();
    // The service's own count of the chain's resolutions, printed at shutdown.
    let err = std::fs::read_to_string(&svc_err).unwrap_or_default();
    row.resolutions = err
        .lines()
        .find(|l| l.contains(&format!("chain {chain}: contact resolution: ")))
        .map(str::to_string);
    Ok(row)
}

/// The rows of the held ropes' table: ropes with held joints whose passes creep (a built-in script
/// and its chain).
const HELD_ROWS: &[(&str, &str)] = &[
    ("square-held", "hands"),
    ("square-held", "hands-160"),
    ("square-held", "hands-320"),
    ("instrument-tie", "tie-160"),
    ("surgeons-knot", "tie"),
    ("surgeons-knot", "tie-160"),
];

/// The ways tried: `collision_together_after` (0: the passes alone; 2: the default) and
/// `collision_pushed_weight` (1: the default; 0.5 what `knots.toml`'s long held ropes set; 0.1).
const HELD_WAYS: &[(u32, f64)] = &[(0, 1.0), (0, 0.5), (2, 1.0), (2, 0.5), (2, 0.1)];

/// What the resolution of held ropes bought: `knots.toml` with every collision chain given each way
/// in turn (the scene's own settings of both keys taken out), the rows' scripts run on it as in the
/// first table.
fn held_ways(k0: usize, dir: &Path, knots: &Path) -> Result<()> {
    let text = std::fs::read_to_string(knots).context("read knots.toml")?;
    println!(
        "\n### Held ropes: the passes alone against contacts and lengths solved together\n\nThe held \
         ropes whose passes creep, with `collision_together_after` (0: the passes alone; 2, the \
         default: the joint projection once two passes have not parted the contacts) and \
         `collision_pushed_weight` (1, the default; `knots.toml` sets 0.5 on its 160- and 320-link \
         held ropes, the first table's rows) set on every chain of `knots.toml`, as in the first \
         table (µs; passes, resolutions and projections as in the first table):\n"
    );
    println!(
        "| script | chain | together after | weight | requests | refused | p50 µs | p99 µs | p99.9 µs \
         | max µs | passes p50 | over 1 ms | their passes p50 | long resolutions | stalled projections \
         | knot |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    let own: String = text
        .lines()
        .filter(|l| {
            !l.starts_with("collision_pushed_weight") && !l.starts_with("collision_together_after")
        })
        .flat_map(|l| [l, "\n"])
        .collect();
    let mut k = k0;
    for &(script, chain) in HELD_ROWS {
        for &(after, w) in HELD_WAYS {
            let scene = dir.join(format!("knots-held-{after}-{w}.toml"));
            let line = "collision = \"capsules\"\n";
            std::fs::write(
                &scene,
                own.replace(
                    line,
                    &format!(
                        "{line}collision_together_after = {after}\ncollision_pushed_weight = {w}\n"
                    ),
                ),
            )?;
            match run_row(script, chain, k, dir, &scene) {
                Ok(r) if !r.passes.is_empty() => {
                    println!(
                        "| {script} | {chain} | {after} | {w} | {} | {} | {} | {} |",
                        r.cells(),
                        r.pass_cells(),
                        r.resolution_cells(),
                        r.knot
                    );
                }
                Ok(_) => {
                    println!(
                        "| {script} | {chain} | {after} | {w} | 0 | – | – | – | – | – | – | – | – | – | – | – |"
                    )
                }
                Err(e) => {
                    eprintln!("contact bench: {e:#}");
                    println!(
                        "| {script} | {chain} | {after} | {w} | failed: {e} | | | | | | | | | | | |"
                    );
                }
            }
            k += 1;
        }
    }
    Ok(())
}

/// The scale curve: one service with a chain per resolution × collision, the overhand's head path
/// sent to each in turn, timed here.
fn scale(k: usize, dir: &Path) -> Result<()> {
    const SIZES: [usize; 4] = [40, 200, 1000, 10_000];
    let mut scene = String::from("budget = 100000000\n");
    for n in SIZES {
        for on in [false, true] {
            scene.push_str(&format!(
                "\n[[chain]]\nname = \"n{n}{}\"\nlinks = {n}\nlink_length = {}\naxis = [1.0, 0.0, 0.0]\n",
                if on { "-capsules" } else { "" },
                40.0 / n as f64
            ));
            if on {
                scene
                    .push_str("thickness = 0.2\ncollision = \"capsules\"\nmin_bend_radius = 1.5\n");
            }
        }
    }
    let file = dir.join("scale.toml");
    std::fs::write(&file, scene)?;
    let prefix = format!("contact_{}_{k}_", std::process::id());
    let mut svc = Command::new(release_bin("solver-service")?);
    svc.args(["--prefix", &prefix, "--scene"]).arg(&file).args([
        "--wait",
        "spin",
        "--no-persist",
        "--pin",
        "0",
    ]);
    let mut svc = Proc::ready(svc, "solver-service")?;
    shared::pin_current_thread(1).map_err(anyhow::Error::msg)?;
    let mut opts = clients::ConnectOptions::for_tool(&prefix, 10.0).map_err(anyhow::Error::msg)?;
    opts.wait = clients::Wait::Spin;
    opts.call_timeout = Duration::from_secs(60);
    let mut conn = clients::Connection::connect(opts)?;
    let script = Script::builtin("overhand-bend").context("built-in overhand-bend")?;
    let path = script.turn[0].targets([40.0, 0.0, 0.0], script.max_step);
    println!(
        "\n### The scale curve: round trip per move against resolution\n\nA 40-unit rope in 40 to 10,000 \
         links, the built-in `overhand-bend`'s head path ({} moves, no corner), capsule collision \
         (thickness 0.2) with the bend radius 1.5 of `knots.toml`'s `bend-*` ropes, or neither; \
         the round trip from this process's call to the response read, the client spinning on core 1 \
         and the service spinning on core 0; *solve* is the service's own time (`solve_ns`) (µs):\n",
        path.len()
    );
    println!(
        "| links | link length | collision and limits | p50 round trip | p99 | p99.9 | max | p50 solve | refused | knot |"
    );
    println!("|---:|---:|---|---:|---:|---:|---:|---:|---:|---|");
    for n in SIZES {
        for on in [false, true] {
            let name = format!("n{n}{}", if on { "-capsules" } else { "" });
            let id = conn.require_chain(&name)?;
            let (mut trips, mut solves, mut refused) = (Vec::new(), Vec::new(), 0usize);
            for t in &path {
                let mut h = shared::RequestHeader::new(shared::Command::Move, id);
                h.joint = shared::JOINT_HEAD;
                let called = Instant::now();
                let (status, solve_ns) =
                    conn.call_with(h, &[shared::Vec3::new(t[0], t[1], t[2])], |rh, _| {
                        (rh.status, rh.solve_ns)
                    })?;
                trips.push(called.elapsed().as_nanos() as u64);
                solves.push(solve_ns);
                refused += usize::from(status != 0);
            }
            trips.sort_unstable();
            solves.sort_unstable();
            let k = clients::hand::knot_of(&mut conn, id)?;
            println!(
                "| {n} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {refused} | {} |",
                40.0 / n as f64,
                if on {
                    "capsules, bend radius 1.5"
                } else {
                    "none"
                },
                pct(&trips, 0.5),
                pct(&trips, 0.99),
                pct(&trips, 0.999),
                pct(&trips, 1.0),
                pct(&solves, 0.5),
                k.kind.name()
            );
        }
    }
    drop(conn);
    svc.stop();
    Ok(())
}

fn pct(v: &[u64], p: f64) -> f64 {
    v[((v.len() - 1) as f64 * p).round() as usize] as f64 / 1e3
}

fn main() -> Result<()> {
    let only: Option<Vec<String>> = std::env::var("CONTACT_BENCH_ONLY")
        .ok()
        .map(|s| s.split(',').map(str::to_string).collect());
    let dir = tempfile::tempdir()?;
    let mut out = std::io::stdout();
    clients::latency_bench::noise(&mut out, 2000, 1.0)?;
    println!(
        "### Contact per request along every built-in knot's tying path\n\nThe service's own time per \
         request (`solve_ns`), capsule self-collision on the shipped `knots.toml` (rope thickness 0.2, \
         its holds, instruments, anchors, bend limits and budget; without `knot = true`: the knot's \
         name with every state is in the tighten bench), the service pinned to core 0, the \
         script's hands as fast as it answers; every move and instrument pose the hands sent, refused \
         ones and the halves of split moves included (µs). *Passes*: the collision resolution's \
         passes that pushed links apart, as each response reports them (`iterations`, summed over \
         its substeps): their median over all requests, the requests over 1 ms, and those \
         requests' median passes (where a slow request's time goes). *Long resolutions*: the \
         resolutions (one per substep) of 32 passes or more, and *stalled projections*: the joint \
         projections of a held rope that did not converge (the passes then went on alone), of all \
         its projections, as the service counts them (its line per chain at shutdown):\n"
    );
    println!(
        "| script | chain | links | what it has | requests | refused | p50 µs | p99 µs | p99.9 µs \
         | max µs | passes p50 | over 1 ms | their passes p50 | long resolutions | stalled projections \
         | knot | wall s |"
    );
    println!("|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|");
    // The shipped scene without `knot = true`: the knot's name with every state is the tighten
    // bench's to measure, not the contact's.
    let shipped = workspace().join("solver-service/scenes/knots.toml");
    let text = std::fs::read_to_string(&shipped).context("read knots.toml")?;
    let knots = dir.path().join("knots.toml");
    std::fs::write(
        &knots,
        text.lines()
            .filter(|l| l.trim() != "knot = true")
            .flat_map(|l| [l, "\n"])
            .collect::<String>(),
    )?;
    for (k, &(script, chain, links, what)) in ROWS.iter().enumerate() {
        if let Some(o) = &only
            && !o.iter().any(|x| x == script || x == chain)
        {
            continue;
        }
        match run_row(script, chain, k, dir.path(), &knots) {
            Ok(r) if !r.passes.is_empty() => {
                println!(
                    "| {script} | {chain} | {links} | {what} | {} | {} | {} | {} | {:.1} |",
                    r.cells(),
                    r.pass_cells(),
                    r.resolution_cells(),
                    r.knot,
                    r.seconds
                );
            }
            Ok(_) => println!(
                "| {script} | {chain} | {links} | {what} | 0 | – | – | – | – | – | – | – | – | – | – | – | – |"
            ),
            Err(e) => {
                eprintln!("contact bench: {e:#}");
                println!(
                    "| {script} | {chain} | {links} | {what} | failed: {e} | | | | | | | | | | | | |"
                );
            }
        }
    }
    if only.as_ref().is_none_or(|o| o.iter().any(|x| x == "held")) {
        held_ways(ROWS.len(), dir.path(), &knots)?;
    }
    if only.as_ref().is_none_or(|o| o.iter().any(|x| x == "scale")) {
        scale(ROWS.len() + HELD_ROWS.len() * HELD_WAYS.len(), dir.path())?;
    }
    Ok(())
}
