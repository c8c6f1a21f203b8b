//! The needle's pass with two hands, perturbed (issue 39): how often it succeeds and what a move costs.
//!
//! `cargo bench -p clients --bench stitch` runs, for each held suture of the shipped `stitch.toml`
//! (`suture-held-80`, `suture-held-160`), `STITCH_BENCH_RUNS` (default 16) runs of the built-in
//! `needle-pass-held` through the release `solver-service`: hand B (the forceps) holds the tail, hand A
//! (the driver) takes the needle's end into the tissue, under the incision and out and draws the
//! suture through, both hands perturbed as a person's (`hand run --perturb SEED`: sizes ±10 %,
//! directions ±0.05, waypoints moved by up to 0.1, a tremor of 0.02 on every step) and as fast as the
//! service answers (`--rate 0`). A run passes when both hands finish (a hand whose move is refused,
//! the rope too taut for it, goes on: the refused requests and the runs that had one are counted
//! apart) and the bench's own code finds, in the last state: two eyelets, both threaded, on the
//! tissue's top face (|z| < 1e-9)
//! on either side of the incision (x = 28); each eyelet on the rope to 1e-9 (its distance from the
//! nearest link's segment); every link its length to 1e-12; the tail where the forceps hold it (within
//! 0.2 of where the script puts it: the perturbed grip and tremor); and more than a unit of suture
//! before the entry. The service's own time per request (`solve_ns`) is pooled over the runs; the
//! machine's own noise is measured first.
//!
//! A second table is the instrument ties over a bite: the built-in `instrument-tie` and
//! `surgeons-knot` on the `stitch-tie` sutures of `stitch.toml` (40 and 80 links, the rope through an
//! entry and an exit eyelet where knots.toml's `tie` is anchored), with the scene's eyelet friction
//! and without it, unperturbed: the knot the service names at the end, the refusals, how far the
//! eyelets slid, and the time per request ([`ties`]).
//!
//! A third table is the whole stitch ([`whole`]): on `stitch-80` and `stitch-160`, the needle's pass
//! by one hand (`stitch-pass`, the tail free: the needle posed over the entry and driven through both
//! sides, its point cutting the holes) and then the surgeon's knot over the bite by two hands
//! (`surgeons-knot`), tightened (`--tighten 0.05`: each hand pulls its end until it stops), all three
//! hands perturbed with the run's seed, `STITCH_BENCH_RUNS` runs. A run succeeds when the service
//! names the surgeon's knot at the end and the bench's own code finds both eyelets threaded and on the
//! rope (to 1e-9). The wound: the eyelets' distance after the pass and at the end, measured by the
//! bench on the queried eyelets (the scene's tissue gives: `wound_margin` 0.5 either side of the
//! incision, so closed is 1.0 apart).
//!
//! `STITCH_BENCH_TABLES` keeps some of the tables (`pass`, `ties`, `whole`, comma-separated; all by
//! default). The binaries must be built first (`cargo build --release --bins`;
//! `scripts/bench-report.sh` does).

use anyhow::{Context, Result, bail};
use clients::process::{Proc, release_bin, workspace};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The held sutures: chain, links, link length.
const SUTURES: [(&str, usize, f64); 2] = [
    ("suture-held-80", 80, 0.25),
    ("suture-held-160", 160, 0.125),
];
/// Where the forceps hold their tails: where `stitch.toml` lays them, 0.3 toward the needle.
const TAIL: [f64; 3] = [20.0, -4.7, 2.0];
/// How long one run may take.
const RUN_TIMEOUT: Duration = Duration::from_secs(300);

/// One run: whether it passed (else why not), the tail before the entry, the service's times (ns) and
/// the refused requests.
struct Run {
    failure: Option<String>,
    tail: f64,
    solve: Vec<u64>,
    refused: usize,
    /// 1 when some request of the run was refused.
    refusals: usize,
}

fn distance_to_segment(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> (f64, f64) {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let l2 = ab.iter().map(|x| x * x).sum::<f64>();
    let t = (ap.iter().zip(&ab).map(|(x, y)| x * y).sum::<f64>() / l2).clamp(0.0, 1.0);
    let d = (0..3)
        .map(|k| (a[k] + ab[k] * t - p[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    (d, t)
}

/// The service on `scene` and the hands of `script` on `chain` (hands `B` then `A`, with `extra`
/// arguments), as fast as it answers, each writing its request times: the service (still running, for
/// the caller to query), its prefix, every request's `solve_ns`, the refused requests, and why a hand
/// failed (a hand exits 1 when a request of it was refused, counted apart; anything else fails).
fn hands(
    scene: &Path,
    script: &str,
    chain: &str,
    extra: &[String],
    tag: &str,
    dir: &Path,
) -> Result<Ran> {
    let prefix = format!("stitch_{}_{tag}_", std::process::id());
    let mut svc = Command::new(release_bin("solver-service")?);
    svc.args(["--prefix", &prefix, "--scene"])
        .arg(scene)
        .args(["--wait", "event", "--no-persist"]);
    let svc = Proc::ready(svc, "solver-service")?;
    let started = Instant::now();
    let mut children = Vec::new();
    for h in ["B", "A"] {
        let file = dir.join(format!("{tag}-{h}.txt"));
        let child = Command::new(release_bin("hand")?)
            .args(["--prefix", &prefix, "run", "--builtin", script])
            .args(["--hand", h, "--chain", chain, "--rate", "0", "--quiet"])
            .args(["--turn-timeout", "120"])
            .args(extra)
            .arg("--timings")
            .arg(&file)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .context("start hand")?;
        children.push((child, file));
    }
    let (mut solve, mut refused_all, mut failure) = (Vec::new(), 0, None);
    for (child, file) in &mut children {
        let status = wait_for(child, started)?;
        let refused = timings(file, &mut solve)?;
        refused_all += refused;
        if !(status.success() || (status.code() == Some(1) && refused > 0)) {
            failure.get_or_insert(format!("a hand failed ({status})"));
        }
    }
    Ok(Ran {
        svc,
        prefix,
        solve,
        refused: refused_all,
        failure,
    })
}

/// What [`hands`] leaves: the service (still running), its prefix, every request's `solve_ns`, the
/// refused requests, and why a hand failed.
struct Ran {
    svc: Proc,
    prefix: String,
    solve: Vec<u64>,
    refused: usize,
    failure: Option<String>,
}

/// The chain's joints and eyelets as the service has them.
fn query(prefix: &str, chain: &str) -> Result<(Vec<[f64; 3]>, Vec<shared::EyeletState>)> {
    let mut conn = clients::Connection::connect(clients::ConnectOptions {
        prefix: prefix.to_string(),
        ..clients::ConnectOptions::default()
    })?;
    let id = conn.require_chain(chain)?;
    let r = conn.call(shared::RequestHeader::new(shared::Command::Query, id), &[])?;
    let parts = shared::Parts::of_response(&r.header, &r.payload);
    Ok((
        parts.joints.iter().map(|p| p.to_array()).collect(),
        parts.eyelet_states().collect(),
    ))
}

fn run(chain: &str, link: f64, seed: u64, dir: &Path) -> Result<Run> {
    let scene = workspace().join("solver-service/scenes/stitch.toml");
    let Ran {
        mut svc,
        prefix,
        solve,
        refused,
        failure,
    } = hands(
        &scene,
        "needle-pass-held",
        chain,
        &["--perturb".into(), seed.to_string()],
        &format!("{chain}-{seed}"),
        dir,
    )?;
    let mut out = Run {
        failure,
        tail: f64::NAN,
        solve,
        refused,
        refusals: usize::from(refused > 0),
    };
    // The last state, checked here.
    let (joints, eyelets) = query(&prefix, chain)?;
    svc.stop();
    let mut fail = |why: String| {
        out.failure.get_or_insert(why);
    };
    for (k, w) in joints.windows(2).enumerate() {
        let l = (0..3)
            .map(|i| (w[1][i] - w[0][i]).powi(2))
            .sum::<f64>()
            .sqrt();
        if (l - link).abs() > 1e-12 {
            fail(format!("link {k} is {l}"));
        }
    }
    if (0..3)
        .map(|i| (joints[0][i] - TAIL[i]).powi(2))
        .sum::<f64>()
        .sqrt()
        > 0.2
    {
        fail(format!("the tail is at {:?}", joints[0]));
    }
    let on_face = eyelets.len() == 2
        && eyelets.iter().all(|e| e.threaded && e.at.z.abs() < 1e-9)
        && (22.0..28.0).contains(&eyelets[0].at.x)
        && (28.0..34.0).contains(&eyelets[1].at.x);
    if !on_face {
        fail(format!("eyelets {eyelets:?}"));
    } else {
        for e in &eyelets {
            let p = e.at.to_array();
            let (d, _) = joints
                .windows(2)
                .map(|w| distance_to_segment(w[0], w[1], p))
                .fold((f64::INFINITY, 0.0), |a, b| if b.0 < a.0 { b } else { a });
            if d > 1e-9 {
                fail(format!("an eyelet {d:e} off the rope"));
            }
        }
        // The suture before the entry, along the rope.
        let p = eyelets[0].at.to_array();
        let (k, (_, t)) = joints
            .windows(2)
            .map(|w| distance_to_segment(w[0], w[1], p))
            .enumerate()
            .fold(
                (0, (f64::INFINITY, 0.0)),
                |a, b| if b.1.0 < a.1.0 { b } else { a },
            );
        out.tail = (k as f64 + t) * link;
        if out.tail <= 1.0 {
            fail(format!("only {:.2} of tail", out.tail));
        }
    }
    Ok(out)
}

/// The instrument ties over a bite: each built-in tie on each `stitch-tie` suture of `stitch.toml`,
/// with the scene's friction and without (the scene copied with `eyelet_friction = 0`), unperturbed:
/// the knot the service names at the end (`chainctl knot`), the refused requests, how far the bite's
/// eyelets slid along the rope (links, the bench's own reading of the eyelets' links before and
/// after), and the service's time per request.
fn ties(dir: &Path) -> Result<()> {
    let text = std::fs::read_to_string(workspace().join("solver-service/scenes/stitch.toml"))?;
    let frictionless = dir.join("stitch-frictionless.toml");
    std::fs::write(
        &frictionless,
        text.replace("eyelet_friction = 1.0", "eyelet_friction = 0.0"),
    )?;
    let shipped = workspace().join("solver-service/scenes/stitch.toml");
    println!(
        "\n| script | suture | links | eyelet friction | knot at the end | requests | refused | eyelets slid (links) | p50 µs | p99.9 µs | max µs |"
    );
    println!("|---|---|---:|---:|---|---:|---:|---|---:|---:|---:|");
    for script in ["instrument-tie", "surgeons-knot"] {
        for (chain, links) in [("stitch-tie", 40), ("stitch-tie-80", 80)] {
            for (friction, scene) in [("1", &shipped), ("0", &frictionless)] {
                let tag = format!("{script}-{chain}-{friction}");
                let row = (|| -> Result<String> {
                    let Ran {
                        mut svc,
                        prefix,
                        mut solve,
                        refused,
                        failure,
                    } = hands(scene, script, chain, &[], &tag, dir)?;
                    let (_, after) = query(&prefix, chain)?;
                    let out = Command::new(release_bin("chainctl")?)
                        .args(["--prefix", &prefix, "knot", chain, "--json"])
                        .output()
                        .context("chainctl knot")?;
                    svc.stop();
                    if let Some(f) = failure {
                        bail!("{f}");
                    }
                    let text = String::from_utf8_lossy(&out.stdout);
                    let knot = text
                        .split("\"knot\":\"")
                        .nth(1)
                        .and_then(|s| s.split('"').next())
                        .unwrap_or("?")
                        .to_string();
                    // The scene's eyelets lie on links these suture's joints put them (the bench's
                    // own: a straight rope along x from the origin).
                    let link_len = 40.0 / links as f64;
                    let slid: Vec<String> = after
                        .iter()
                        .map(|e| {
                            let start = (e.at.x / link_len).floor() as i64;
                            format!("{:+}", e.link as i64 - start)
                        })
                        .collect();
                    solve.sort_unstable();
                    Ok(format!(
                        "{knot} | {} | {refused} | {} | {:.1} | {:.1} | {:.1}",
                        solve.len(),
                        slid.join(", "),
                        pct(&solve, 0.5),
                        pct(&solve, 0.999),
                        pct(&solve, 1.0)
                    ))
                })()
                .unwrap_or_else(|e| format!("failed: {e} | | | | | | "));
                println!("| {script} | {chain} | {links} | {friction} | {row} |");
            }
        }
    }
    Ok(())
}

/// Waits for a hand process until [`RUN_TIMEOUT`] after `started` (then kills it: an error).
fn wait_for(child: &mut std::process::Child, started: Instant) -> Result<std::process::ExitStatus> {
    loop {
        if let Some(s) = child.try_wait()? {
            return Ok(s);
        }
        if started.elapsed() > RUN_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            bail!("a hand took longer than {RUN_TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A hand's `--timings` file: every request's `solve_ns` appended to `solve`; returns the refused.
fn timings(file: &Path, solve: &mut Vec<u64>) -> Result<usize> {
    let text = std::fs::read_to_string(file).unwrap_or_default();
    let mut refused = 0;
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let [_, solve_us, status, _pull, _passes] = f[..] else {
            bail!("{}: bad line {line:?}", file.display());
        };
        solve.push((solve_us.parse::<f64>()? * 1e3).round() as u64);
        if status != "ok" {
            refused += 1;
        }
    }
    Ok(refused)
}

/// One hand process's run on `prefix` (`--rate 0`, `--quiet`), its `solve_ns` in µs and status
/// appended from its timings; `Err` when it fails for another reason than refused moves.
fn one_hand(prefix: &str, args: &[&str], file: &Path, solve: &mut Vec<u64>) -> Result<usize> {
    let mut child = Command::new(release_bin("hand")?)
        .args(["--prefix", prefix, "run", "--rate", "0", "--quiet"])
        .args(["--turn-timeout", "120"])
        .args(args)
        .arg("--timings")
        .arg(file)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .context("start hand")?;
    let status = wait_for(&mut child, Instant::now())?;
    let refused = timings(file, solve)?;
    if !(status.success() || (status.code() == Some(1) && refused > 0)) {
        bail!("a hand failed ({status})");
    }
    Ok(refused)
}

/// The whole stitch on `stitch-80` and `stitch-160`, `runs` perturbed runs each (see the module
/// docs).
fn whole(runs: u64, dir: &Path) -> Result<()> {
    println!(
        "\n| suture | links | runs | surgeon's knot over the bite, tightened | eyelets apart after the pass, median | at the end, median | wound closed (1.0 apart) | runs with a refused request | refused | pass: requests | p50 µs | p99.9 µs | tie and tighten: requests | p50 µs | p99 µs | p99.9 µs | max µs |"
    );
    println!(
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for (chain, links) in [("stitch-80", 80), ("stitch-160", 160)] {
        whole_on(chain, links, runs, dir)?;
    }
    Ok(())
}

/// [`whole`]'s row of one suture.
fn whole_on(chain: &str, links: usize, runs: u64, dir: &Path) -> Result<()> {
    let scene = workspace().join("solver-service/scenes/stitch.toml");
    let (mut tied, mut with_refusals, mut refused) = (0, 0, 0);
    let (mut pass_solve, mut tie_solve) = (Vec::new(), Vec::new());
    // The eyelets' distance after the pass and at the end, of the runs that tied the knot.
    let (mut opened, mut ended, mut closed) = (Vec::new(), Vec::new(), 0);
    let gap = |e: &[shared::EyeletState]| {
        let (a, b) = (e[0].at.to_array(), e[1].at.to_array());
        (0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt()
    };
    for seed in 1..=runs {
        let outcome = (|| -> Result<Option<(f64, f64)>> {
            let prefix = format!("stitch_{}_whole_{links}_{seed}_", std::process::id());
            let mut svc = Command::new(release_bin("solver-service")?);
            svc.args(["--prefix", &prefix, "--scene"])
                .arg(&scene)
                .args(["--wait", "event", "--no-persist"]);
            let mut svc = Proc::ready(svc, "solver-service")?;
            let s = seed.to_string();
            let mut r = one_hand(
                &prefix,
                &[
                    "--builtin",
                    "stitch-pass",
                    "--chain",
                    chain,
                    "--perturb",
                    &s,
                ],
                &dir.join(format!("whole-{links}-{seed}-pass.txt")),
                &mut pass_solve,
            )?;
            let (_, passed) = query(&prefix, chain)?;
            if passed.len() != 2 {
                bail!("{} eyelets after the pass", passed.len());
            }
            let b = std::thread::scope(|scope| -> Result<usize> {
                let b = scope.spawn(|| {
                    let mut solve = Vec::new();
                    let r = one_hand(
                        &prefix,
                        &[
                            "--builtin",
                            "surgeons-knot",
                            "--hand",
                            "B",
                            "--chain",
                            chain,
                            "--perturb",
                            &s,
                            "--tighten",
                            "0.05",
                        ],
                        &dir.join(format!("whole-{links}-{seed}-B.txt")),
                        &mut solve,
                    );
                    r.map(|r| (r, solve))
                });
                r += one_hand(
                    &prefix,
                    &[
                        "--builtin",
                        "surgeons-knot",
                        "--hand",
                        "A",
                        "--chain",
                        chain,
                        "--perturb",
                        &s,
                        "--tighten",
                        "0.05",
                    ],
                    &dir.join(format!("whole-{links}-{seed}-A.txt")),
                    &mut tie_solve,
                )?;
                let (rb, solve) = b.join().map_err(|_| anyhow::anyhow!("hand B panicked"))??;
                tie_solve.extend(solve);
                Ok(rb)
            })?;
            r += b;
            refused += r;
            with_refusals += usize::from(r > 0);
            let (joints, eyelets) = query(&prefix, chain)?;
            let out = Command::new(release_bin("chainctl")?)
                .args(["--prefix", &prefix, "knot", chain, "--json"])
                .output()
                .context("chainctl knot")?;
            svc.stop();
            let knot = String::from_utf8_lossy(&out.stdout).contains("\"knot\":\"surgeons\"");
            // The bench's own check of the bite: both eyelets threaded, each on the rope.
            let on_rope = eyelets.len() == 2
                && eyelets.iter().all(|e| {
                    let p = e.at.to_array();
                    e.threaded
                        && joints
                            .windows(2)
                            .map(|w| distance_to_segment(w[0], w[1], p).0)
                            .fold(f64::INFINITY, f64::min)
                            < 1e-9
                });
            Ok((knot && on_rope).then(|| (gap(&passed), gap(&eyelets))))
        })();
        match outcome {
            Ok(Some((a, b))) => {
                tied += 1;
                opened.push(a);
                ended.push(b);
                closed += usize::from(b <= 1.0 + 1e-9);
            }
            Ok(None) => eprintln!(
                "stitch bench: the whole stitch on {chain}, seed {seed}: no surgeon's knot over the bite"
            ),
            Err(e) => eprintln!("stitch bench: the whole stitch on {chain}, seed {seed}: {e:#}"),
        }
    }
    pass_solve.sort_unstable();
    tie_solve.sort_unstable();
    if pass_solve.is_empty() || tie_solve.is_empty() || opened.is_empty() {
        println!(
            "| {chain} | {links} | {runs} | {tied} | – | – | – | – | – | – | – | – | – | – | – | – | – |"
        );
        return Ok(());
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "| {chain} | {links} | {runs} | {tied} | {:.3} | {:.3} | {closed} | {with_refusals} | {refused} | {} | {:.1} | {:.1} | {} | {:.1} | {:.1} | {:.1} | {:.1} |",
        median(&mut opened),
        median(&mut ended),
        pass_solve.len(),
        pct(&pass_solve, 0.5),
        pct(&pass_solve, 0.999),
        tie_solve.len(),
        pct(&tie_solve, 0.5),
        pct(&tie_solve, 0.99),
        pct(&tie_solve, 0.999),
        pct(&tie_solve, 1.0),
    );
    Ok(())
}

fn pct(v: &[u64], q: f64) -> f64 {
    v[((v.len() - 1) as f64 * q).round() as usize] as f64 / 1e3
}

fn main() -> Result<()> {
    let runs: u64 = std::env::var("STITCH_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&r| r > 0)
        .unwrap_or(16);
    let dir = tempfile::tempdir()?;
    // `STITCH_BENCH_TABLES=whole` (or `pass`, `ties`, comma-separated) keeps those tables.
    let tables = std::env::var("STITCH_BENCH_TABLES").unwrap_or_default();
    let wants = |t: &str| tables.is_empty() || tables.split(',').any(|x| x == t);
    clients::latency_bench::noise(&mut std::io::stdout(), 2000, 1.0)?;
    if wants("pass") {
        pass_table(runs, dir.path())?;
    }
    if wants("ties") {
        ties(dir.path())?;
    }
    if wants("whole") {
        whole(runs, dir.path())?;
    }
    Ok(())
}

/// The first table: the needle's pass with two hands, `runs` perturbed runs per held suture.
fn pass_table(runs: u64, dir: &Path) -> Result<()> {
    println!(
        "| suture | links | runs | passed | suture before the entry, median (units) | runs with a refused request | requests | refused | p50 µs | p99 µs | p99.9 µs | max µs |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (chain, links, link) in SUTURES {
        let (mut passed, mut tails, mut solve, mut refused) = (0, Vec::new(), Vec::new(), 0);
        let mut with_refusals = 0;
        for seed in 1..=runs {
            match run(chain, link, seed, dir) {
                Ok(r) => {
                    refused += r.refused;
                    with_refusals += r.refusals;
                    solve.extend(r.solve);
                    match r.failure {
                        None => {
                            passed += 1;
                            tails.push(r.tail);
                        }
                        Some(why) => eprintln!("stitch bench: {chain}, seed {seed}: {why}"),
                    }
                }
                Err(e) => eprintln!("stitch bench: {chain}, seed {seed}: {e:#}"),
            }
        }
        solve.sort_unstable();
        tails.sort_by(f64::total_cmp);
        let tail = tails.get(tails.len() / 2).copied().unwrap_or(f64::NAN);
        if solve.is_empty() {
            println!("| {chain} | {links} | {runs} | {passed} | – | – | 0 | – | – | – | – | – |");
            continue;
        }
        println!(
            "| {chain} | {links} | {runs} | {passed} | {tail:.2} | {with_refusals} | {} | {refused} | {:.1} | {:.1} | {:.1} | {:.1} |",
            solve.len(),
            pct(&solve, 0.5),
            pct(&solve, 0.99),
            pct(&solve, 0.999),
            pct(&solve, 1.0),
        );
    }
    Ok(())
}
