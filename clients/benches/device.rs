//! The device sweep (issue 68): the knots tied by hands played as haptic devices, inside the
//! service's default frame, at every resolution.
//!
//! `cargo bench -p clients --bench device` starts, for each row and each perturbed run, the release
//! `solver-service` on the shipped `knots.toml` (its default frame: 1 ms of work per request), pinned
//! to core 0 and waiting on events, and the script's `hand` processes in device mode (`hand run
//! --device`: sampled at 1 kHz at 10 units per second, each request the hand's position when the
//! previous answer came, never halved, repeated or retried, tremor on, held by the coupling's pull
//! while two rope thicknesses ahead of its joint; `--perturb SEED` changes the
//! turns, one seed per run). Per row: the runs whose knot is the script's and, for the two-strand
//! knots (square, granny, surgeon's), whose two strands cut at the stitch are each unknotted (as the
//! hand's `--identify` names them); the service's own
//! time per request (`solve_ns`, every request of every run) at p50, p99, p99.9 and max beside the
//! frame; and the proxy's lag (how far the moved joint was from the hand's position, each hand's
//! p50, p99 and max as it reports them: their median, and the largest p99 and max over the runs).
//! The machine's noise (sleep lateness and busy-loop gaps on each core, nothing of ours running)
//! is measured first and printed above the table.
//!
//! The binaries must be built first (`cargo build --release --bins`; `scripts/bench-report.sh` does).
//! `DEVICE_BENCH_RUNS` (default 16) sets the runs per row; `DEVICE_BENCH_LINKS=40,80` keeps the rows
//! of those resolutions; `DEVICE_BENCH_ONLY=square-held` those of the scripts named;
//! `DEVICE_BENCH_FRAME=4000` runs the service with that frame (`--frame`, link-steps) instead of its
//! default (16,000), to show what a frame buys; `DEVICE_BENCH_TIGHTEN=0.05` then tightens every
//! knot tied, the device hands pulling their ends at that many units per request (`hand run
//! --tighten`), and reports the knotted stretch against its ideal; `DEVICE_BENCH_FEEL=inf` plays the
//! hands without force feedback (`hand run --feel`, default 2 rope thicknesses: how far ahead of
//! its joint a hand gets before the coupling's pull holds it).

use anyhow::{Context, Result, bail};
use clients::latency_bench::nearest_rank_us;
use clients::process::{Proc, release_bin, workspace};
use knots::script::Script;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The scripts, the knot each ties, and the chain of `knots.toml` at each resolution.
const SCRIPTS: &[(&str, &str, [&str; 4])] = &[
    (
        "overhand-held",
        "trefoil",
        ["hands", "hands-80", "hands-160", "hands-320"],
    ),
    (
        "square-held",
        "square",
        ["hands", "hands-80", "hands-160", "hands-320"],
    ),
    (
        "granny-held",
        "granny",
        ["hands", "hands-80", "hands-160", "hands-320"],
    ),
    (
        "instrument-tie",
        "trefoil",
        ["tie", "tie-80", "tie-160", "tie-320"],
    ),
    (
        "surgeons-knot",
        "surgeons",
        ["tie", "tie-80", "tie-160", "tie-320"],
    ),
    (
        "instrument-square",
        "square",
        ["tie", "tie-80", "tie-160", "tie-320"],
    ),
];

/// The resolutions, in the order of [`SCRIPTS`]' chains.
const LINKS: [usize; 4] = [40, 80, 160, 320];

/// How long one run may take before it is abandoned.
const RUN_TIMEOUT: Duration = Duration::from_secs(600);

/// What one run gave: every request's `solve_ns`, the knot, whether each strand is unknotted, and
/// each hand's lag figures (p50, p99, max).
struct Run {
    solve_ns: Vec<u64>,
    knot: String,
    strands_unknotted: bool,
    lags: Vec<[f64; 3]>,
    /// The knotted stretch after tightening, in rope diameters (`hand --identify`'s line).
    stretch: Option<f64>,
    /// From the service's start to the last hand's end, seconds.
    seconds: f64,
}

/// The knotted stretch an open knot of `knot` tightens to, in rope diameters: the trefoil's ideal
/// (about 10.1, Katritch et al. 1996; `docs/knots.md`), and twice it for the knots of two throws
/// (square, granny, surgeon's) until a better reference is measured.
fn ideal(knot: &str) -> f64 {
    match knot {
        "trefoil" => 10.1,
        _ => 20.2,
    }
}

/// The diameters of a "knotted stretch: ..., X diameters" line.
fn stretch_of(line: &str) -> Option<f64> {
    let rest = line.strip_prefix("knotted stretch: ")?;
    rest.rsplit(", ")
        .next()?
        .strip_suffix(" diameters")?
        .parse()
        .ok()
}

fn run_once(
    script: &str,
    chain: &str,
    seed: u64,
    dir: &Path,
    (scene, frame, tighten, feel): (&Path, Option<u64>, Option<f64>, Option<f64>),
) -> Result<Run> {
    let hands: Vec<String> = {
        let s = Script::builtin(script).context("no such built-in script")?;
        let mut h: Vec<String> = s.turn.iter().map(|t| t.hand.clone()).collect();
        h.sort();
        h.dedup();
        h
    };
    let prefix = format!("device_{}_{seed}_", std::process::id());
    let mut svc = Command::new(release_bin("solver-service")?);
    svc.args(["--prefix", &prefix, "--scene"]).arg(scene).args([
        "--wait",
        "event",
        "--no-persist",
        "--pin",
        "0",
    ]);
    if let Some(f) = frame {
        svc.args(["--frame", &f.to_string()]);
    }
    svc.stderr(Stdio::null());
    let mut svc = Proc::ready(svc, "solver-service")?;
    let started = Instant::now();
    let mut children = Vec::new();
    for (i, h) in hands.iter().enumerate() {
        let timings = dir.join(format!("{script}-{chain}-{seed}-{h}.txt"));
        let out = dir.join(format!("{script}-{chain}-{seed}-{h}.out"));
        let mut cmd = Command::new(release_bin("hand")?);
        cmd.args(["--prefix", &prefix, "run", "--builtin", script, "--hand", h])
            .args([
                "--chain",
                chain,
                "--device",
                "--quiet",
                "--turn-timeout",
                "300",
            ])
            .args(["--perturb", &seed.to_string()])
            .args(
                tighten
                    .map(|t| ["--tighten".to_string(), t.to_string()])
                    .into_iter()
                    .flatten(),
            )
            .args(
                feel.map(|f| ["--feel".to_string(), f.to_string()])
                    .into_iter()
                    .flatten(),
            )
            .arg("--timings")
            .arg(&timings)
            .stdout(std::fs::File::create(&out)?)
            .stderr(Stdio::null());
        // The last hand names the knot (it ends after the others' last turn).
        if i + 1 == hands.len() {
            cmd.args(["--identify", chain]);
        }
        children.push((cmd.spawn().context("start hand")?, timings, out));
    }
    let mut run = Run {
        solve_ns: Vec::new(),
        knot: "?".into(),
        strands_unknotted: false,
        lags: Vec::new(),
        stretch: None,
        seconds: 0.0,
    };
    for (child, timings, out) in &mut children {
        let status = loop {
            if let Some(s) = child.try_wait()? {
                break s;
            }
            if started.elapsed() > RUN_TIMEOUT {
                let _ = child.kill();
                bail!("{script} on {chain}, seed {seed}: a hand took longer than {RUN_TIMEOUT:?}");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        if !status.success() {
            bail!("{script} on {chain}, seed {seed}: a hand failed ({status})");
        }
        let text = std::fs::read_to_string(&*timings).context("timings")?;
        for line in text.lines().filter(|l| !l.starts_with('#')) {
            let f: Vec<&str> = line.split_whitespace().collect();
            if let [_, solve_us, ..] = f[..] {
                run.solve_ns
                    .push((solve_us.parse::<f64>()? * 1e3).round() as u64);
            }
        }
        let out = std::fs::read_to_string(&*out).unwrap_or_default();
        for l in out.lines() {
            if let Some(k) = l.strip_prefix("knot: ") {
                run.knot = k.split_whitespace().next().unwrap_or("?").to_string();
            }
            if let Some(d) = stretch_of(l) {
                run.stretch = Some(d);
            }
            if l.starts_with("strands cut at joint") {
                run.strands_unknotted = l.contains("each strand alone unknotted");
            }
            if l.contains(": device: ")
                && let Some(lag) = lag_of(l)
            {
                run.lags.push(lag);
            }
        }
    }
    run.seconds = started.elapsed().as_secs_f64();
    svc.stop();
    Ok(run)
}

/// The lag figures (p50, p99, max) of a hand's device line: "... lag behind the hand p50 X / p99
/// Y / max Z; ...".
fn lag_of(line: &str) -> Option<[f64; 3]> {
    let at = line.find("lag behind the hand p50 ")? + "lag behind the hand p50 ".len();
    let rest = &line[at..];
    let num = |s: &str| s.split([' ', ';']).next()?.parse::<f64>().ok();
    let p50 = num(rest)?;
    let p99 = num(rest.split("p99 ").nth(1)?)?;
    let max = num(rest.split("max ").nth(1)?)?;
    Some([p50, p99, max])
}

fn main() -> Result<()> {
    let runs: u64 = std::env::var("DEVICE_BENCH_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(16)
        .max(1);
    let links: Vec<usize> = std::env::var("DEVICE_BENCH_LINKS").map_or(LINKS.to_vec(), |v| {
        v.split(',').filter_map(|s| s.trim().parse().ok()).collect()
    });
    let only: Option<Vec<String>> = std::env::var("DEVICE_BENCH_ONLY")
        .ok()
        .map(|v| v.split(',').map(|s| s.trim().to_string()).collect());
    let frame: Option<u64> = std::env::var("DEVICE_BENCH_FRAME")
        .ok()
        .and_then(|v| v.parse().ok());
    let tighten: Option<f64> = std::env::var("DEVICE_BENCH_TIGHTEN")
        .ok()
        .and_then(|v| v.parse().ok());
    let feel: Option<f64> = std::env::var("DEVICE_BENCH_FEEL")
        .ok()
        .and_then(|v| v.parse().ok());
    let feel_text = match feel {
        Some(f) if f.is_infinite() => "without force feedback: each hand walks its path at its \
             speed whatever the rope does (`--feel inf`)"
            .to_string(),
        f => format!(
            "each hand held by the coupling's pull while more than {} rope thicknesses ahead of \
             its joint (`--feel`)",
            f.unwrap_or(clients::hand::FEEL)
        ),
    };
    let frame_text = frame.map_or(
        "the service's default frame (16,000 link-steps, 1 ms)".to_string(),
        |f| format!("a frame of {f} link-steps (`--frame {f}`; the default is 16,000, 1 ms)"),
    );
    let root = workspace();
    let scene = root.join("solver-service/scenes/knots.toml");
    let dir = tempfile::tempdir()?;
    // The machine's noise beside which the max column is read (as the contact bench prints it).
    clients::latency_bench::noise(&mut std::io::stdout(), 2000, 1.0)?;
    println!();
    let without = if feel.is_some_and(f64::is_infinite) {
        " without force feedback"
    } else {
        ""
    };
    match frame {
        Some(f) => println!("### The device sweep{without} at a frame of {f} link-steps\n"),
        None => println!("### The device sweep{without}\n"),
    }
    println!(
        "Both hands in device mode (1 kHz, 10 units/s, tremor on, never halved or retried), \
         {feel_text}, on `knots.toml` at {frame_text}, {runs} perturbed \
         runs per row (seeds 1..={runs}). *right knot*: the runs whose knot is the script's, for the \
         square, granny and surgeon's knots with each strand, cut at the stitch, unknotted. *solve*: the service's own time per request over every \
         request of every run (µs). *lag*: how far the moved joint was from the hand's position \
         (units; rope thickness 0.2): the median of the hands' p50, the largest p99 and max. \
         *tie s*: from the service's start to the last hand's end, the median run (seconds).{}\n",
        tighten.map_or(String::new(), |t| format!(
            " Then both hands tighten the knot as devices (`--tighten {t}`, every request of it \
             counted in *solve* and *lag*); *right knot* and *knots tied* are after it. \
             *stretch ÷ ideal*: the knotted stretch in rope diameters over the open knot's \
             ideal (trefoil 10.1, the knots of two throws twice that, 20.2), the median and the \
             largest over the runs with the right knot."
        ))
    );
    let extra = if tighten.is_some() {
        (" | stretch ÷ ideal p50 | max", "|---:|---:")
    } else {
        ("", "")
    };
    println!(
        "| script | chain | links | right knot | knots tied | requests | solve p50 µs | p99 | p99.9 | max \
         | lag p50 | lag p99 | lag max | tie s{} |",
        extra.0
    );
    println!(
        "|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:{}|",
        extra.1
    );
    for &(script, want, chains) in SCRIPTS {
        if only
            .as_ref()
            .is_some_and(|o| !o.iter().any(|s| s == script))
        {
            continue;
        }
        for (chain, n) in chains.iter().zip(LINKS) {
            if !links.contains(&n) {
                continue;
            }
            let mut solve = Vec::new();
            let (mut right, mut names) = (0, Vec::<String>::new());
            let mut lags: Vec<[f64; 3]> = Vec::new();
            let mut stretches: Vec<f64> = Vec::new();
            let mut seconds: Vec<f64> = Vec::new();
            for seed in 1..=runs {
                match run_once(
                    script,
                    chain,
                    seed,
                    dir.path(),
                    (&scene, frame, tighten, feel),
                ) {
                    Ok(r) => {
                        // Two-strand knots: each strand alone unknotted too (one throw, an
                        // overhand over the stitch, is in one strand).
                        let two = matches!(want, "square" | "granny" | "surgeons");
                        let good = r.knot == want && (r.strands_unknotted || !two);
                        right += usize::from(good);
                        if good && let Some(d) = r.stretch {
                            stretches.push(d / ideal(want));
                        }
                        names.push(r.knot);
                        seconds.push(r.seconds);
                        solve.extend(r.solve_ns);
                        lags.extend(r.lags);
                    }
                    Err(e) => names.push(format!("failed: {e}")),
                }
            }
            solve.sort_unstable();
            names.sort();
            let mut tally: Vec<(String, usize)> = Vec::new();
            for n in names {
                match tally.last_mut() {
                    Some((m, c)) if *m == n => *c += 1,
                    _ => tally.push((n, 1)),
                }
            }
            let tied = tally
                .iter()
                .map(|(n, c)| format!("{c} {n}"))
                .collect::<Vec<_>>()
                .join(", ");
            let mut p50: Vec<f64> = lags.iter().map(|l| l[0]).collect();
            p50.sort_by(f64::total_cmp);
            let worst = |i: usize| lags.iter().map(|l| l[i]).fold(f64::NAN, f64::max);
            stretches.sort_by(f64::total_cmp);
            seconds.sort_by(f64::total_cmp);
            let tie_s = seconds
                .get(seconds.len().saturating_sub(1) / 2)
                .copied()
                .unwrap_or(f64::NAN);
            let stretch = if tighten.is_none() {
                String::new()
            } else if stretches.is_empty() {
                " | – | –".to_string()
            } else {
                format!(
                    " | {:.2} | {:.2}",
                    stretches[(stretches.len() - 1) / 2],
                    stretches[stretches.len() - 1]
                )
            };
            println!(
                "| `{script}` | `{chain}` | {n} | {right} of {runs} | {tied} | {} | {:.0} | {:.0} | {:.0} | {:.0} | {:.3} | {:.3} | {:.3} | {tie_s:.0}{stretch} |",
                solve.len(),
                nearest_rank_us(&solve, 0.5),
                nearest_rank_us(&solve, 0.99),
                nearest_rank_us(&solve, 0.999),
                nearest_rank_us(&solve, 1.0),
                p50.get(p50.len().saturating_sub(1) / 2)
                    .copied()
                    .unwrap_or(f64::NAN),
                worst(1),
                worst(2)
            );
        }
    }
    Ok(())
}
