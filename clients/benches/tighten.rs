//! How tight the built-in knots get (issue 38): each knot tied by its `hand` processes through the
//! service, then tightened by the same hands (`hand run --tighten 0.05`: each hand pulls the end it
//! holds away from the knot with the pull flag until it stops, twice round), and the knotted stretch
//! measured at the end.
//!
//! `cargo bench -p clients --bench tighten` starts, for each row, the release `solver-service` on the
//! shipped `knots.toml` (its ropes 0.2 thick, its holds, instruments, anchors and work budget) with a
//! deep state buffer, a `watch --crossings` that checks every published state against the one before
//! (the swept-volume check, `knots::check::crossings_between`: no link through another), and the
//! script's hands. The table gives the knot named at the end (the service's identification), the
//! knotted stretch (the shortest run of joints that, closed far away by itself, is still the knot:
//! `knots::knotted_stretch`) in rope diameters, against the ideal length the issue names
//! (the open trefoil about 10.1 diameters, Pieranski, Przybyl & Stasiak 2001; square and granny at most
//! 28.5 by the composite bound of Cantarella, LaPointe & Rawdon; none for the surgeon's knot), how each
//! tightening pull ended (`taut`, `jammed`, `out-of-work`: see docs/tension.md), the crossings `watch` found in the
//! states it read, and the row's time. Rows that fail to tie say so.
//!
//! The binaries must be built first (`cargo build --release --bins`; `scripts/bench-report.sh` does).
//! `TIGHTEN_BENCH_ONLY=square-held,tie-160` keeps the rows whose script or chain is named.

use anyhow::{Context, Result, bail};
use clients::process::{Proc, release_bin, workspace};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The rows: a built-in script, the chain of `knots.toml`, its links, the knot it ties and that
/// knot's ideal length in diameters (open trefoil; the composite bound for square and granny).
const ROWS: &[(&str, &str, usize, &str, Option<f64>)] = &[
    (
        "instrument-tie",
        "tie",
        40,
        "trefoil (overhand)",
        Some(10.1),
    ),
    (
        "instrument-tie",
        "tie-160",
        160,
        "trefoil (overhand)",
        Some(10.1),
    ),
    (
        "instrument-tie",
        "tie-320",
        320,
        "trefoil (overhand)",
        Some(10.1),
    ),
    ("square-held", "hands", 40, "square", Some(28.5)),
    ("square-held", "hands-160", 160, "square", Some(28.5)),
    ("square-held", "hands-320", 320, "square", Some(28.5)),
    ("granny-held", "hands-160", 160, "granny", Some(28.5)),
    ("granny-held", "hands-320", 320, "granny", Some(28.5)),
    ("surgeons-knot", "tie", 40, "surgeon's", None),
    ("surgeons-knot", "tie-160", 160, "surgeon's", None),
    ("surgeons-knot", "tie-320", 320, "surgeon's", None),
];

/// How long one row may take before it is abandoned.
const ROW_TIMEOUT: Duration = Duration::from_secs(900);

/// Children killed and reaped when the row ends.
struct Children(Vec<std::process::Child>);

impl Drop for Children {
    fn drop(&mut self) {
        for c in &mut self.0 {
            if matches!(c.try_wait(), Ok(None)) {
                let _ = c.kill();
                let _ = c.wait();
            }
        }
    }
}

struct Row {
    knot: String,
    stretch: Option<f64>,
    pulls: Vec<String>,
    crossings: String,
    seconds: f64,
    /// `watch --name-knots`'s line for the chain (`clients::naming::Naming`).
    naming: Option<String>,
    /// The service's own time (`solve_ns`, µs) of every tightening pull's request, and of every
    /// request, both hands' (`hand run --timings`), sorted.
    pull_us: Vec<f64>,
    all_us: Vec<f64>,
    /// Requests the service refused (both hands).
    refused: usize,
}

/// The budget table's rows, each run at these work budgets (link-steps per request; `None`: the
/// scene's, 2,000,000).
const BUDGET_ROWS: &[(&str, &str, usize, &str, Option<f64>)] = &[
    ("square-held", "hands-160", 160, "square", Some(28.5)),
    ("square-held", "hands-320", 320, "square", Some(28.5)),
    ("surgeons-knot", "tie-160", 160, "surgeons", None),
];
/// Each as (`--budget`, `--pull-budget`): the whole request's budget cut, then the pulls' alone.
const BUDGETS: &[(Option<u64>, Option<u64>)] = &[
    (Some(50_000), None),
    (Some(200_000), None),
    (None, None),
    (None, Some(200_000)),
    (None, Some(50_000)),
];

/// A hand's `--timings` file: each request's `solve_ns` in µs into `all`, and into `pulls` too for
/// a tightening pull's; returns the refused requests.
fn read_timings(file: &Path, pulls: &mut Vec<f64>, all: &mut Vec<f64>) -> Result<usize> {
    let text = std::fs::read_to_string(file).with_context(|| file.display().to_string())?;
    let mut refused = 0;
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let [_, solve_us, status, pull, _passes] = f[..] else {
            bail!("{}: bad line {line:?}", file.display());
        };
        let us: f64 = solve_us.parse()?;
        all.push(us);
        if pull == "1" {
            pulls.push(us);
        }
        refused += usize::from(status != "ok");
    }
    Ok(refused)
}

/// The value at quantile `q` of sorted `v` (nearest rank), formatted; "—" when empty.
fn quantile(v: &[f64], q: f64) -> String {
    if v.is_empty() {
        return "—".into();
    }
    let i = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    format!("{:.0}", v[i])
}

/// Waits for a hand. `refusals_ok`: a hand that exits 1 (some requests refused, as over-budget
/// moves still over it after the hand's halvings) counts as done.
fn wait(
    c: &mut std::process::Child,
    started: Instant,
    what: &str,
    refusals_ok: bool,
) -> Result<()> {
    loop {
        if let Some(s) = c.try_wait()? {
            let refused_only = refusals_ok && s.code() == Some(1);
            if !s.success() && !refused_only {
                bail!("{what} failed ({s})");
            }
            return Ok(());
        }
        if started.elapsed() > ROW_TIMEOUT {
            bail!("{what} took longer than {ROW_TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn run_row(
    script: &str,
    chain: &str,
    k: usize,
    dir: &Path,
    (budget, pull_budget): (Option<u64>, Option<u64>),
) -> Result<Row> {
    let prefix = format!("tighten_{}_{k}_", std::process::id());
    let scene = workspace().join("solver-service/scenes/knots.toml");
    let mut svc = Command::new(release_bin("solver-service")?);
    svc.args(["--prefix", &prefix, "--scene"])
        .arg(&scene)
        .args(["--wait", "event", "--no-persist", "--state-buffer", "4096"]);
    if let Some(b) = budget {
        svc.args(["--budget", &b.to_string()]);
    }
    if let Some(b) = pull_budget {
        svc.args(["--pull-budget", &b.to_string()]);
    }
    let mut svc = Proc::ready(svc, "solver-service")?;
    let started = Instant::now();
    let watch_log = dir.join(format!("{script}-{chain}-watch.err"));
    let mut children = Children(Vec::new());
    children.0.push(
        Command::new(release_bin("watch")?)
            .args([
                "--prefix",
                &prefix,
                "--chain",
                chain,
                "--crossings",
                "--name-knots",
            ])
            .args(["--duration", "1800"])
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&watch_log)?)
            .spawn()
            .context("start watch")?,
    );
    // `watch` is listening once it said so.
    let t0 = Instant::now();
    while !std::fs::read_to_string(&watch_log)
        .unwrap_or_default()
        .contains("listening")
    {
        if t0.elapsed() > Duration::from_secs(30) {
            bail!("watch did not start");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let timings = |h: &str| dir.join(format!("{script}-{chain}-{k}-{h}.us"));
    let hand = |h: &str, extra: &[&str]| -> Result<std::process::Child> {
        Command::new(release_bin("hand")?)
            .args(["--prefix", &prefix, "run", "--builtin", script, "--hand", h])
            .args(["--chain", chain, "--quiet", "--turn-timeout", "300"])
            .args(["--tighten", "0.05"])
            .arg("--timings")
            .arg(timings(h))
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .context("start hand")
    };
    let mut b = hand("B", &[])?;
    let mut a = hand("A", &["--identify", chain])?;
    let cut = budget.is_some() || pull_budget.is_some();
    wait(&mut b, started, "hand B", cut)?;
    wait(&mut a, started, "hand A", cut)?;
    let read = |c: &mut std::process::Child| {
        let mut s = String::new();
        if let Some(o) = c.stdout.as_mut() {
            let _ = std::io::Read::read_to_string(o, &mut s);
        }
        s
    };
    let out = format!("{}{}", read(&mut a), read(&mut b));
    let seconds = started.elapsed().as_secs_f64();
    // Let `watch` read what is left, then stop it (SIGINT) and read its count.
    std::thread::sleep(Duration::from_secs(2));
    let pid = children.0[0].id();
    let _ = Command::new("kill")
        .args(["-INT", &pid.to_string()])
        .status();
    let _ = children.0[0].wait();
    let watched = std::fs::read_to_string(&watch_log).unwrap_or_default();
    let crossings = watched
        .lines()
        .find_map(|l| l.strip_prefix("watch: crossings: "))
        .and_then(|l| l.split(';').next())
        .unwrap_or("?")
        .to_string();
    let naming = watched
        .lines()
        .find_map(|l| l.strip_prefix(&format!("watch: knot names of {chain}: ")))
        .map(str::to_string);
    let knot = out
        .lines()
        .find_map(|l| l.strip_prefix("knot: "))
        .and_then(|l| l.split_whitespace().next())
        .unwrap_or("?")
        .to_string();
    let stretch = out
        .lines()
        .find(|l| l.starts_with("knotted stretch:"))
        .and_then(|l| l.rsplit(", ").next())
        .and_then(|l| l.split_whitespace().next())
        .and_then(|x| x.parse().ok());
    let pulls = out
        .lines()
        .filter_map(|l| l.split(": tighten turn ").nth(1))
        .filter_map(|l| l.split(": ").nth(1))
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .collect();
    svc.stop();
    let (mut pull_us, mut all_us, mut refused) = (Vec::new(), Vec::new(), 0);
    for h in ["A", "B"] {
        refused += read_timings(&timings(h), &mut pull_us, &mut all_us)?;
    }
    pull_us.sort_by(f64::total_cmp);
    all_us.sort_by(f64::total_cmp);
    Ok(Row {
        knot,
        stretch,
        pulls,
        crossings,
        seconds,
        naming,
        pull_us,
        all_us,
        refused,
    })
}

/// How a row's pulls ended, counted: "2 out-of-work, 2 taut".
fn ended(pulls: &[String]) -> String {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for p in pulls {
        match counts.iter_mut().find(|c| c.0 == p) {
            Some(c) => c.1 += 1,
            None => counts.push((p, 1)),
        }
    }
    let out: Vec<String> = counts.iter().map(|(p, n)| format!("{n} {p}")).collect();
    out.join(", ")
}

/// The work budget against how tight the knot gets and what a tightening request costs: the rows of
/// [`BUDGET_ROWS`] at each of [`BUDGETS`], side by side in one run.
fn budget_table(only: &[String], dir: &Path) -> Result<()> {
    let rows: Vec<_> = BUDGET_ROWS
        .iter()
        .filter(|(script, chain, ..)| {
            only.is_empty() || only.iter().any(|o| o == script || o == chain)
        })
        .collect();
    if rows.is_empty() {
        return Ok(());
    }
    println!(
        "\nThe work budget (the service's `--budget`, link-steps per request; knots.toml's is \
         2,000,000), and a pull's alone (`--pull-budget`), against how tight the knot gets: the \
         same tie and tightening at each budget, side by side in one run. A pull's tries stop short at the budget (`out-of-work`), and the \
         next request goes on from where it stopped, so a smaller budget bounds each request's time \
         and the knot tightens over more requests; over-budget moves of the tie are split by the \
         hands. *tightening requests*: both hands' pulls with the pull flag; the service's own time \
         (`solve_ns`); *every request*: the tie's too.\n"
    );
    println!(
        "| script | chain | links | work budget / a pull's (link-steps) | knot at the end | knotted stretch (rope diameters) | stretch ÷ ideal | how the pulls ended | tightening requests | their µs: p50 | p99 | p99.9 | max | every request's µs: p99.9 | max | requests refused (over the budget after the hand's halvings) |"
    );
    println!("|---|---|---:|---:|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (k, &&(script, chain, links, want, ideal)) in rows.iter().enumerate() {
        for &budgets in BUDGETS {
            let b = match budgets {
                (Some(b), _) => format!("{b} / the same"),
                (None, Some(p)) => format!("2,000,000 (the scene's) / {p}"),
                (None, None) => "2,000,000 (the scene's) / the same".to_string(),
            };
            match run_row(script, chain, 100 + k, dir, budgets) {
                Ok(r) => {
                    let stretch = r.stretch.map_or("—".into(), |s| format!("{s:.1}"));
                    // Against the ideal only when the script's knot is still there.
                    let ratio = match (ideal, r.stretch) {
                        (Some(i), Some(s)) if r.knot == want => format!("{:.2}", s / i),
                        _ => "—".into(),
                    };
                    let knot = if r.knot == want {
                        r.knot.clone()
                    } else {
                        format!("{} (not the script's)", r.knot)
                    };
                    println!(
                        "| `{script}` | `{chain}` | {links} | {b} | {knot} | {stretch} | {ratio} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                        ended(&r.pulls),
                        r.pull_us.len(),
                        quantile(&r.pull_us, 0.5),
                        quantile(&r.pull_us, 0.99),
                        quantile(&r.pull_us, 0.999),
                        quantile(&r.pull_us, 1.0),
                        quantile(&r.all_us, 0.999),
                        quantile(&r.all_us, 1.0),
                        r.refused,
                    );
                }
                Err(e) => println!(
                    "| `{script}` | `{chain}` | {links} | {b} | failed: {} | — | — | — | — | — | — | — | — | — | — | — |",
                    format!("{e:#}").replace('|', "/")
                ),
            }
        }
    }
    Ok(())
}

/// The numbers of a `clients::naming::Naming` line, in its order: states, joints, p50, p99, p99.9,
/// max, evaluated, agreeing, sampled, then the least over the passes: p99.9, max, new diagrams' max.
fn naming_numbers(line: &str) -> Vec<f64> {
    line.split(|c: char| c.is_whitespace() || c == ';')
        .filter_map(|w| w.parse::<f64>().ok())
        .collect()
}

fn main() -> Result<()> {
    let only: Vec<String> = std::env::var("TIGHTEN_BENCH_ONLY")
        .ok()
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_default();
    let dir = tempfile::tempdir()?;
    let mut names: Vec<String> = Vec::new();
    // The machine's own noise beside the times below (a busy core's interruptions are the first
    // pass's tail in the naming table).
    clients::latency_bench::noise(&mut std::io::stdout(), 2000, 1.0)?;
    println!();
    println!(
        "| script | chain | links | the script's knot | knot at the end (named by the service) | knotted stretch (rope diameters) | ideal (diameters) | stretch ÷ ideal | how the pulls ended | tightening requests, the service's µs: p50 / p99.9 / max | crossings between consecutive states (swept-volume check) | seconds (tie and tighten) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (k, &(script, chain, links, knot, ideal)) in ROWS.iter().enumerate() {
        if !only.is_empty() && !only.iter().any(|o| o == script || o == chain) {
            continue;
        }
        match run_row(script, chain, k, dir.path(), (None, None)) {
            Ok(r) => {
                let stretch = r.stretch.map_or("—".into(), |s| format!("{s:.1}"));
                let (ideal_s, ratio) = match (ideal, r.stretch) {
                    (Some(i), Some(s)) => (format!("{i}"), format!("{:.2}", s / i)),
                    (Some(i), None) => (format!("{i}"), "—".into()),
                    (None, _) => ("—".into(), "—".into()),
                };
                println!(
                    "| `{script}` | `{chain}` | {links} | {knot} | {} | {stretch} | {ideal_s} | {ratio} | {} | {} / {} / {} | {} | {:.0} |",
                    r.knot,
                    ended(&r.pulls),
                    quantile(&r.pull_us, 0.5),
                    quantile(&r.pull_us, 0.999),
                    quantile(&r.pull_us, 1.0),
                    r.crossings,
                    r.seconds
                );
                let aim = match links {
                    40 => "≤ 20",
                    320 => "≤ 200",
                    _ => "—",
                };
                names.push(match r.naming.as_deref().map(naming_numbers).as_deref() {
                    Some(&[states, _, p50, p99, p999, max, evaluated, agreeing, sampled, l999, lmax, newmax]) => format!(
                        "| `{script}` | `{chain}` | {links} | {states:.0} | {p50:.1} | {p99:.1} | {p999:.1} | {max:.1} | {l999:.1} | {lmax:.1} | {aim} | {evaluated:.0} ({:.1} %) | {newmax:.1} | {agreeing:.0} of {sampled:.0} |",
                        100.0 * evaluated / states.max(1.0)
                    ),
                    _ => format!(
                        "| `{script}` | `{chain}` | {links} | no line from watch: {:?} | — | — | — | — | — | — | {aim} | — | — | — |",
                        r.naming
                    ),
                });
            }
            Err(e) => println!(
                "| `{script}` | `{chain}` | {links} | {knot} | failed: {} | — | — | — | — | — | — | — |",
                format!("{e:#}").replace('|', "/")
            ),
        }
    }
    if !names.is_empty() {
        println!(
            "\nThe knot's name with every state: every state `watch` read in the rows above, named in order by \
             one `knots::Namer` after the row (the service and hands stopped), each call timed. \
             *new diagrams*: states whose reduced diagram the namer had not seen among its last 64, so \
             its Jones polynomial was computed; *agrees with identify*: of 100 states spread over the \
             row and the last, those the six-closure `identify` names the same. The states are named \
             three times over, each time by a new namer (the same calls): the first four time \
             columns are the first pass, as a scene would see it; *least of three* takes each \
             state's shortest time of the three, the work without the machine's interruptions (a \
             busy core here loses tens of µs now and then: the noise tables of \"Contact inside a \
             haptic frame\"); *new diagram's longest* is the longest such time among the new diagrams.\n"
        );
        println!(
            "| script | chain | links | states named | µs per state, p50 | p99 | p99.9 | max | p99.9, least of three | max, least of three | aim (µs) | new diagrams | new diagram's longest, least of three (µs) | agrees with identify |"
        );
        println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|");
        for n in names {
            println!("{n}");
        }
    }
    budget_table(&only, dir.path())
}
