//! The client binaries as a user runs them (issue 4): `snake` crawls to the end of its curve, `reach`
//! runs both methods and plots them, `watch` writes every state as CSV and frames; and a hand driven into
//! an obstacle of a collision scene is refused as locked with the state unchanged.

use shared::{Command, RequestHeader, Vec3};
use std::io::Read;
use std::process::{Child, Command as Process, ExitStatus, Stdio};
use std::time::{Duration, Instant};
use tests::{Service, bin, unique_prefix};

const TOOL_TIMEOUT: Duration = Duration::from_secs(60);

fn default_service() -> Service {
    Service::start(&unique_prefix(), &["--wait", "event", "--no-persist"])
}

fn spawn(svc: &Service, tool: &str, args: &[&str]) -> Child {
    Process::new(bin(tool))
        .arg("--prefix")
        .arg(&svc.prefix)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("spawn {tool}: {e}"))
}

/// Waits for a child with a deadline; returns its status, stdout and stderr.
fn finish(mut child: Child, what: &str) -> (ExitStatus, String, String) {
    let deadline = Instant::now() + TOOL_TIMEOUT;
    // Drain the pipes on threads so a chatty child cannot block on a full pipe.
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let o = std::thread::spawn(move || {
        let mut s = String::new();
        out.read_to_string(&mut s).map(|_| s).unwrap_or_default()
    });
    let e = std::thread::spawn(move || {
        let mut s = String::new();
        err.read_to_string(&mut s).map(|_| s).unwrap_or_default()
    });
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("{what} did not finish within {TOOL_TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    (status, o.join().unwrap(), e.join().unwrap())
}

fn run(svc: &Service, tool: &str, args: &[&str]) -> String {
    let (st, out, err) = finish(spawn(svc, tool, args), tool);
    assert!(st.success(), "{tool} {args:?}: {st}\n{out}\n{err}");
    out
}

/// The number after `key` in `text` (`key` ends with a space or similar).
fn number_after(text: &str, key: &str) -> f64 {
    let at = text
        .find(key)
        .unwrap_or_else(|| panic!("{key:?} in {text}"))
        + key.len();
    let tail: String = text[at..]
        .chars()
        .take_while(|c| c.is_ascii_digit() || "+-.e".contains(*c))
        .collect();
    tail.parse()
        .unwrap_or_else(|_| panic!("a number after {key:?} in {text}"))
}

fn head_of(svc: &Service, chain: &str) -> Vec3 {
    let mut c = svc.connect();
    let id = c.find_chain(chain).unwrap().unwrap();
    let r = c.call(RequestHeader::new(Command::Query, id), &[]).unwrap();
    *r.joints().last().unwrap()
}

#[test]
fn snake_crawls_to_the_end_of_its_curve_keeping_its_links() {
    let svc = default_service();
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().display().to_string();
    let out = run(&svc, "snake", &["--quiet", "--svg", &svg, "--frames", "6"]);
    assert!(out.contains("240 moves, 240 ok"), "{out}");
    assert!(number_after(&out, "head error ") < 1e-12, "{out}");
    assert!(number_after(&out, "link length error ") < 1e-12, "{out}");
    // The head ends where the curve does: the point 60 units of arc along the crawl, computed here from
    // its formula (issue 15: before, from the binary's own `Curve::targets`). The scene's snake has its
    // head at (0, -50, 0) heading -y, so the crawl's side is -x and its up +z:
    //   c(t) = (0, -50, 0) + t (0, -1, 0) + 3 sin(2π t / 20) (-1, 0, 0) + 4 (1 - cos(2π t / 50)) (0, 0, 1).
    // The tool walks chords of dt = 0.02 of the curve, which fall short of the arc by about κ²d³/24
    // each: about 1e-4 over 60 units, bounded here by 1e-3.
    let tau = std::f64::consts::TAU;
    let curve = |t: f64| {
        [
            -3.0 * (tau * t / 20.0).sin(),
            -50.0 - t,
            4.0 * (1.0 - (tau * t / 50.0).cos()),
        ]
    };
    let speed = |t: f64| {
        let (x, z) = (
            -3.0 * tau / 20.0 * (tau * t / 20.0).cos(),
            4.0 * tau / 50.0 * (tau * t / 50.0).sin(),
        );
        (x * x + 1.0 + z * z).sqrt()
    };
    let (mut t, mut arc, h) = (0.0f64, 0.0f64, 1e-4);
    loop {
        // Simpson's rule on [t, t + h].
        let ds = h / 6.0 * (speed(t) + 4.0 * speed(t + h / 2.0) + speed(t + h));
        if arc + ds >= 60.0 {
            t += h * (60.0 - arc) / ds;
            break;
        }
        arc += ds;
        t += h;
    }
    let end = curve(t);
    let head = head_of(&svc, "snake");
    let d =
        ((head.x - end[0]).powi(2) + (head.y - end[1]).powi(2) + (head.z - end[2]).powi(2)).sqrt();
    assert!(d < 1e-3, "head {head:?}, curve end {end:?}: {d:e} apart");
    eprintln!("snake: head {d:.1e} from the curve's end computed from its formula");
    let pic = std::fs::read_to_string(dir.path().join("snake.svg")).unwrap();
    let panels = pic
        .lines()
        .filter(|l| l.trim().starts_with("after "))
        .count();
    assert_eq!(panels, 6, "six key frames");
}

/// The residuals of `reach`'s method rows, each checked within the tolerance (1e-9 of the 2-unit arm).
fn reach_residuals(out: &str) -> Vec<f64> {
    out.lines()
        .filter(|l| !l.contains('°'))
        .filter(|l| l.trim_start().starts_with("tractrix ") || l.contains("pseudo-inverse "))
        .map(|r| {
            let residual: f64 = r.split_whitespace().nth(2).unwrap().parse().unwrap();
            assert!(residual <= 2e-9, "{r}");
            residual
        })
        .collect()
}

#[test]
fn reach_runs_the_tractrix_and_the_pseudo_inverse_and_plots_both() {
    let svc = default_service();
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().display().to_string();
    let out = run(
        &svc,
        "reach",
        &[
            "--targets",
            "1.0,0.9 -0.8,1.2",
            "--steps",
            "4",
            "--svg",
            &svg,
        ],
    );
    for k in ["target 1 (1.0000, 0.9000)", "target 2 (-0.8000, 1.2000)"] {
        assert!(out.contains(k), "{out}");
    }
    // Every method row reports a residual within the tolerance (1e-9 of the 2-unit arm).
    assert_eq!(reach_residuals(&out).len(), 4, "{out}");
    // Ten joint rotations per method and target.
    let per_joint = out
        .lines()
        .filter(|l| l.contains(" °"))
        .map(|l| l.split('°').nth(1).unwrap().split_whitespace().count())
        .collect::<Vec<_>>();
    assert_eq!(per_joint, vec![10; 4], "{out}");
    // The service's arm is at the last target.
    let h = head_of(&svc, "arm");
    assert!((h.x + 0.8).hypot(h.y - 1.2) < 2e-9, "{h:?}");
    let fig7 = std::fs::read_to_string(dir.path().join("reach.svg")).unwrap();
    assert!(fig7.contains("<circle"), "joints are marked");
    let fig8 = std::fs::read_to_string(dir.path().join("rotations.svg")).unwrap();
    let texts: Vec<&str> = fig8.lines().map(str::trim).collect();
    assert!(texts.contains(&"tractrix") && texts.contains(&"pseudo-inverse"));
    // The orientation rows: both methods with the last link along (0, 1) at every step; both land,
    // and the service's arm ends with its last link pointing up (from the joints).
    let out = run(
        &svc,
        "reach",
        &["--targets", "0.9,0.7", "--steps", "2", "--direction", "0,1"],
    );
    assert!(
        out.contains("orientation goal: the last link along (0, 1)"),
        "{out}"
    );
    assert_eq!(reach_residuals(&out).len(), 2, "{out}");
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 2), &[]).unwrap();
    let j = q.joints();
    let (dx, dy) = (j[10].x - j[9].x, j[10].y - j[9].y);
    assert!(dx.abs() < 1e-12 && (dy - 0.2).abs() < 1e-12, "{dx} {dy}");
}

#[test]
fn watch_writes_every_state_as_csv_and_frames() {
    // Subscribers buffer more states than the 240 the snake makes: "every state" cannot depend on
    // how soon `watch` gets the CPU.
    let svc = Service::start(
        &unique_prefix(),
        &["--wait", "event", "--no-persist", "--state-buffer", "512"],
    );
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("states.csv");
    let frames = dir.path().join("frames");
    let (csv_s, frames_s) = (csv.display().to_string(), frames.display().to_string());
    let mut watch = spawn(
        &svc,
        "watch",
        &[
            "--chain",
            "snake",
            "--csv",
            &csv_s,
            "--svg",
            &frames_s,
            "--every",
            "40",
            "--count",
            "240",
            "--duration",
            "50",
        ],
    );
    // Wait until it listens, so no state is published before it subscribed.
    let rx = tests::stderr_lines(&mut watch);
    let line = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("watch listens");
    assert!(line.contains("listening"), "{line}");
    // 240 head moves at 2 kHz: 0.12 s.
    run(&svc, "snake", &["--quiet", "--rate", "2000"]);
    let deadline = Instant::now() + TOOL_TIMEOUT;
    let st = loop {
        if let Some(st) = watch.try_wait().unwrap() {
            break st;
        }
        assert!(Instant::now() < deadline, "watch did not stop");
        std::thread::sleep(Duration::from_millis(10));
    };
    assert!(st.success());
    // The pipe's reader thread forwards the last lines and ends with the pipe: wait for it.
    let mut summary: Vec<String> = Vec::new();
    while let Ok(l) = rx.recv_timeout(Duration::from_secs(10)) {
        summary.push(l);
    }
    assert!(
        summary
            .iter()
            .any(|l| l.contains("240 states, 6 SVG frames, 0 missed")),
        "{summary:?}"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("sequence,chain,command,request_id,joint,x,y,z")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 240 * 41, "41 joints per state");
    let seqs: Vec<u64> = rows
        .iter()
        .step_by(41)
        .map(|r| r[0].parse().unwrap())
        .collect();
    assert!(
        seqs.windows(2).all(|w| w[1] == w[0] + 1),
        "every state, in order"
    );
    // The last state read back bit for bit equals the service's.
    let mut c = svc.connect();
    let id = c.find_chain("snake").unwrap().unwrap();
    let q = c.call(RequestHeader::new(Command::Query, id), &[]).unwrap();
    for (row, p) in rows[rows.len() - 41..].iter().zip(q.joints()) {
        let v: Vec<f64> = row[5..8].iter().map(|x| x.parse().unwrap()).collect();
        assert_eq!(
            [v[0].to_bits(), v[1].to_bits(), v[2].to_bits()],
            [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
        );
    }
    let svgs = std::fs::read_dir(&frames).unwrap().count();
    assert_eq!(svgs, 6, "every 40th of 240 states");
}

/// A scene with a collision rope and a ball: the head driven into the ball cannot get there, so the
/// move stops short inside its frame (jammed), the head outside the ball and short of its target; a
/// move past the ball is served with contacts.
#[test]
fn a_hand_driven_into_an_obstacle_stops_short_outside_it() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("ball.toml");
    std::fs::write(
        &scene,
        r#"
[[chain]]
name = "rope"
links = 20
link_length = 0.5
axis = [1.0, 0.0, 0.0]
thickness = 0.2
collision = "capsules"
obstacles = ["ball"]

[[obstacle]]
name = "ball"
shape = "sphere"
center = [10.0, -3.0, 0.0]
radius = 1.0
"#,
    )
    .unwrap();
    let svc = Service::start(
        &unique_prefix(),
        &["--scene", scene.to_str().unwrap(), "--no-persist"],
    );
    let mut c = svc.connect();
    let r = c
        .call(
            RequestHeader::new(Command::Move, 0),
            &[Vec3::new(10.0, -3.0, 0.0)],
        )
        .unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    assert_eq!(
        r.header.pull_stop(),
        Some(shared::PullStop::Jammed),
        "{}",
        r.header.reason_str()
    );
    let out_of_ball = |p: &Vec3| {
        ((p.x - 10.0).powi(2) + (p.y + 3.0).powi(2) + p.z.powi(2)).sqrt() >= 1.1 * 0.99 - 1e-9
    };
    let joints = r.joints();
    assert!(joints.iter().all(out_of_ball), "a joint in the ball");
    let head = joints[joints.len() - 1];
    assert!(((head.x - 10.0).powi(2) + (head.y + 3.0).powi(2)).sqrt() > 1.0);
    // Sweeping the rope down past the ball: served, and no joint inside it.
    for k in 1..=40 {
        let y = -6.0 * k as f64 / 40.0;
        let r = c
            .call(
                RequestHeader::new(Command::Move, 0),
                &[Vec3::new(12.0, y, 0.0)],
            )
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        for p in r.joints() {
            let d = ((p.x - 10.0).powi(2) + (p.y + 3.0).powi(2) + p.z.powi(2)).sqrt();
            assert!(d >= 1.1 * 0.99 - 1e-9, "joint {p:?} in the ball");
        }
    }
}

/// `watch` on a bundle: it subscribes to the bundles' stream, writes every state of the bundle (all
/// its strands, strand after strand, each tail first) as CSV rows that read back bit for bit as the
/// service's `query`, counts no gap, and draws a frame with one polyline per strand. The rope beside
/// the bundle is not watched. Link lengths are computed here.
#[test]
fn watch_writes_a_bundles_strands() {
    const STRANDS: usize = 20;
    const LINKS: usize = 6;
    const LEN: f64 = 0.25;
    const MOVES: usize = 5;
    let (svc, dir) = tests::service_on_scene(&format!(
        "[[chain]]\nname = \"rope\"\nlinks = 10\nlink_length = 1.0\n\n\
             [[bundle]]\nname = \"hair\"\nstrands = {STRANDS}\nlinks = {LINKS}\n\
             link_length = {LEN}\ncolumns = 5\nspacing = 0.5\norigin = [0.0, 0.0, 3.0]\n"
    ));
    let csv = dir.path().join("hair.csv");
    let frames = dir.path().join("frames");
    let (csv_s, frames_s) = (csv.display().to_string(), frames.display().to_string());
    let mut watch = spawn(
        &svc,
        "watch",
        &[
            "--chain",
            "hair",
            "--csv",
            &csv_s,
            "--svg",
            &frames_s,
            "--every",
            "5",
            "--count",
            &MOVES.to_string(),
            "--duration",
            "8",
        ],
    );
    let rx = tests::stderr_lines(&mut watch);
    let line = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("watch listens");
    assert!(line.contains("listening"), "{line}");
    let mut c = svc.connect();
    let hair = c.find_chain("hair").unwrap().expect("the bundle");
    let rope = c.find_chain("rope").unwrap().expect("the rope");
    let start = c
        .call(RequestHeader::new(Command::Query, hair), &[])
        .unwrap();
    let heads: Vec<Vec3> = start.joints().chunks(LINKS + 1).map(|s| s[LINKS]).collect();
    for m in 1..=MOVES {
        // A rope move between bundle moves: on the other stream, not watched.
        let r = c
            .call(
                RequestHeader::new(Command::Move, rope),
                &[Vec3::new(10.0, 0.3 * m as f64, 0.0)],
            )
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        let targets: Vec<Vec3> = heads
            .iter()
            .enumerate()
            .map(|(i, h)| {
                let a = 0.7 * (i + m) as f64;
                Vec3::new(
                    h.x + 0.2 * a.cos(),
                    h.y + 0.2 * a.sin(),
                    h.z + 0.05 * m as f64,
                )
            })
            .collect();
        let r = c
            .call(RequestHeader::new(Command::Move, hair), &targets)
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        // A viewer's pace: the bundles' stream buffers two samples per subscriber (megabytes each
        // for real hair), and `watch` counts what it could not keep up with as missed.
        std::thread::sleep(Duration::from_millis(100));
    }
    let deadline = Instant::now() + TOOL_TIMEOUT;
    let st = loop {
        if let Some(st) = watch.try_wait().unwrap() {
            break st;
        }
        assert!(Instant::now() < deadline, "watch did not stop");
        std::thread::sleep(Duration::from_millis(10));
    };
    let mut said: Vec<String> = Vec::new();
    while let Ok(l) = rx.recv_timeout(Duration::from_secs(10)) {
        said.push(l);
    }
    assert!(st.success(), "{said:?}");
    assert!(
        said.iter()
            .any(|l| l.contains(&format!("{MOVES} states, 1 SVG frames, 0 missed"))),
        "{said:?}"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let per_state = STRANDS * (LINKS + 1);
    assert_eq!(rows.len(), MOVES * per_state, "every joint of every strand");
    assert!(rows.iter().all(|r| r[1] == "hair"), "only the bundle");
    let seqs: Vec<u64> = rows
        .iter()
        .step_by(per_state)
        .map(|r| r[0].parse().unwrap())
        .collect();
    assert_eq!(
        seqs,
        (1..=MOVES as u64).collect::<Vec<_>>(),
        "the bundle's own count"
    );
    let point = |r: &Vec<&str>| -> [f64; 3] {
        let v: Vec<f64> = r[5..8].iter().map(|x| x.parse().unwrap()).collect();
        [v[0], v[1], v[2]]
    };
    for state in rows.chunks(per_state) {
        for strand in state.chunks(LINKS + 1) {
            for w in strand.windows(2) {
                let (a, b) = (point(&w[0]), point(&w[1]));
                let d =
                    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
                assert!((d - LEN).abs() <= 1e-12 * LEN, "a link of length {d}");
            }
        }
    }
    let q = c
        .call(RequestHeader::new(Command::Query, hair), &[])
        .unwrap();
    for (row, p) in rows[rows.len() - per_state..].iter().zip(q.joints()) {
        let v = point(row);
        assert_eq!(
            [v[0].to_bits(), v[1].to_bits(), v[2].to_bits()],
            [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
        );
    }
    let svg = std::fs::read_dir(&frames)
        .unwrap()
        .next()
        .expect("a frame")
        .unwrap()
        .path();
    let text = std::fs::read_to_string(svg).unwrap();
    // The frame draws a polyline segment per link: one per link of every strand, none joining the
    // tail of one strand to the head of the one before (one polyline of all joints would have
    // STRANDS·(LINKS + 1) − 1).
    assert_eq!(
        text.matches("<polyline").count(),
        STRANDS * LINKS,
        "a segment per link of every strand"
    );
}

/// Issue 37: a second service on a prefix another serves stops at once and says so, naming `--prefix`;
/// the first one keeps serving.
#[test]
fn a_second_service_on_a_taken_prefix_says_so_and_names_the_option() {
    let svc = default_service();
    let second = Process::new(bin("solver-service"))
        .args(["--prefix", &svc.prefix, "--no-persist"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (status, _, err) = finish(second, "a second solver-service");
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(
        err.contains("another solver-service already serves this prefix")
            && err.contains("--prefix"),
        "{err}"
    );
    let mut c = svc.connect();
    assert!(
        c.call(RequestHeader::new(Command::Query, 0), &[])
            .unwrap()
            .is_ok()
    );
}

/// Issue 37: a client asked for a chain the service does not have lists the chains it has and names
/// the shipped scene that declares the one asked for.
#[test]
fn a_missing_chain_is_named_with_the_scene_that_declares_it() {
    let svc = default_service();
    for (tool, args) in [
        (
            "hand",
            &[
                "run",
                "--builtin",
                "instrument-tie",
                "--hand",
                "A",
                "--quiet",
            ][..],
        ),
        ("chainctl", &["query", "tie"][..]),
    ] {
        let (status, _, err) = finish(spawn(&svc, tool, args), tool);
        assert!(!status.success(), "{tool}: {err}");
        assert!(
            err.contains("no chain \"tie\" (it has rope, snake, arm)")
                && err.contains("knots.toml declares it"),
            "{tool}: {err}"
        );
    }
}

/// Issue 37: a recorder that must miss nothing. The service is started with `--state-buffer 512`;
/// `watch` is stopped (SIGSTOP) while 300 moves are made, far more than the default buffer of 64;
/// resumed, it reads all 300 and 10 more, and says it missed none.
#[test]
fn watch_misses_nothing_beside_a_deep_state_buffer() {
    let svc = Service::start(
        &unique_prefix(),
        &["--wait", "event", "--no-persist", "--state-buffer", "512"],
    );
    let said = watch_stopped_while_moving(&svc, 300, 10, 310);
    assert!(
        said.iter()
            .any(|l| l.contains("310 states") && l.contains(" 0 missed")),
        "{said:?}"
    );
    assert!(
        !said.iter().any(|l| l.contains("missed states")),
        "{said:?}"
    );
}

/// Issue 37: a subscriber that falls behind is told exactly which states it missed. `watch` is stopped
/// (SIGSTOP) while 200 moves are made, so its buffer of 64 keeps the last 64; resumed, it reads them
/// (its `--count` is 64) and says it missed the first 136, as one range of sequence numbers. No move is
/// made after it resumes: more moves would race its wake-up (on a loaded machine it may sleep through
/// them, lose more and never reach its count).
#[test]
fn watch_names_the_states_it_missed() {
    let svc = default_service();
    let s0 = svc
        .connect()
        .call(RequestHeader::new(Command::Query, 0), &[])
        .unwrap()
        .header
        .sequence;
    let said = watch_stopped_while_moving(&svc, 200, 0, 64);
    let expected = format!(
        "watch: missed states (sequence numbers): {}-{}",
        s0 + 1,
        s0 + 136
    );
    assert!(said.iter().any(|l| l == &expected), "{said:?}");
    assert!(said.iter().any(|l| l.contains("136 missed")), "{said:?}");
}

/// Waits (up to 30 s) until every thread of the process `pid` is stopped (state `T` in
/// `/proc/PID/task/*/stat`, the field after the command's closing parenthesis).
fn wait_until_stopped(pid: u32) {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let tasks = std::fs::read_dir(format!("/proc/{pid}/task")).expect("the process's threads");
        let states: Vec<char> = tasks
            .flatten()
            .filter_map(|t| std::fs::read_to_string(t.path().join("stat")).ok())
            .filter_map(|stat| {
                let after = &stat[stat.rfind(')')? + 1..];
                after.trim_start().chars().next()
            })
            .collect();
        if !states.is_empty() && states.iter().all(|&c| c == 'T' || c == 't') {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "process {pid} not stopped after 30 s: thread states {states:?}"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// Starts `watch --count count` on the rope, stops it (SIGSTOP) while `stopped` moves of the rope's
/// head are made, continues it and makes `after` more; returns what `watch` wrote to its standard error
/// once it has finished (within [`TOOL_TIMEOUT`]).
fn watch_stopped_while_moving(
    svc: &Service,
    stopped: usize,
    after: usize,
    count: usize,
) -> Vec<String> {
    let mut c = svc.connect();
    let mut watch = Process::new(bin("watch"))
        .args(["--prefix", &svc.prefix, "--chain", "rope", "--count"])
        .arg(count.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let rx = tests::stderr_lines(&mut watch);
    let line = rx
        .recv_timeout(Duration::from_secs(30))
        .expect("watch listens");
    assert!(line.contains("listening"), "{line}");
    let signal = |sig: &str| {
        let st = Process::new("kill")
            .args([sig, &watch.id().to_string()])
            .status()
            .unwrap();
        assert!(st.success());
    };
    signal("-STOP");
    // `kill` returns once the signal is sent, not once every thread has stopped: on a busy machine the
    // reader thread read a few of the first states before it stopped.
    wait_until_stopped(watch.id());
    let mut mv = |i: usize| {
        let mut h = RequestHeader::new(Command::Move, 0);
        h.joint = shared::JOINT_HEAD;
        let a = i as f64 * 0.05;
        let r = c
            .call(h, &[Vec3::new(38.0 + a.cos(), a.sin(), 0.0)])
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
    };
    for i in 0..stopped {
        mv(i);
    }
    signal("-CONT");
    for i in stopped..stopped + after {
        mv(i);
    }
    let deadline = Instant::now() + TOOL_TIMEOUT;
    let status = loop {
        if let Some(st) = watch.try_wait().unwrap() {
            break st;
        }
        if Instant::now() > deadline {
            let _ = watch.kill();
            panic!("watch did not finish within {TOOL_TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    assert!(status.success());
    // The reader thread ends with the pipe: wait for its last lines.
    let mut said: Vec<String> = Vec::new();
    while let Ok(l) = rx.recv_timeout(Duration::from_secs(10)) {
        said.push(l);
    }
    said
}

/// `chainctl reach` with each of Korein & Badler's goals: `--box` moves the arm's head into the box,
/// `--within` around a head already inside moves nothing, `--direction` lays the last link along it;
/// `path --smooth` ends the rope's head on the last point. Every check from the joints, here.
#[test]
fn chainctl_reaches_goals_and_follows_a_smooth_path() {
    let svc = default_service();
    let chainctl = |args: &[&str]| run(&svc, "chainctl", args);
    chainctl(&["reach", "arm", "--box", "0.5,0.8 1.0,1.2"]);
    let h = head_of(&svc, "arm");
    assert!(
        (0.5..=1.0).contains(&h.x) && (0.8..=1.2).contains(&h.y),
        "{h:?}"
    );
    let target = format!("{},{}", h.x + 0.05, h.y);
    chainctl(&["reach", "arm", "--target", &target, "--within", "0.1"]);
    assert_eq!(head_of(&svc, "arm"), h, "a head inside the ball stays");
    chainctl(&[
        "reach",
        "arm",
        "--target",
        "-0.9,0.6",
        "--direction",
        "-1,0",
    ]);
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 2), &[]).unwrap();
    let j = q.joints();
    let (dx, dy) = (j[10].x - j[9].x, j[10].y - j[9].y);
    assert!((dx + 0.2).abs() < 1e-12 && dy.abs() < 1e-12, "{dx} {dy}");
    assert!((j[10].x + 0.9).hypot(j[10].y - 0.6) < 2e-9, "{:?}", j[10]);
    chainctl(&["path", "rope", "--smooth", "--path", "39,2,0 37,3,1 36,5,0"]);
    let h = head_of(&svc, "rope");
    assert!((h.x - 36.0).hypot(h.y - 5.0).hypot(h.z) < 1e-9, "{h:?}");
}

/// `chainctl move --pull` says why the stopped short: the rope's tail grasped, its head pulled
/// to (60, 0, 0), beyond its 40 units from the tail: the head stops 40
/// from the tail (computed here from the joints) and the answer says the rope is taut; a pull the
/// rope can make says nothing of the kind.
#[test]
fn chainctl_says_why_a_pull_stopped_short() {
    let svc = default_service();
    let chainctl = |args: &[&str]| run(&svc, "chainctl", args);
    chainctl(&["grasp", "rope", "--joint", "tail"]);
    let said = chainctl(&[
        "move", "rope", "--joint", "head", "--target", "38,5,0", "--pull",
    ]);
    assert!(!said.contains("stopped short"), "{said}");
    let said = chainctl(&[
        "move", "rope", "--joint", "head", "--target", "60,0,0", "--pull",
    ]);
    assert!(said.contains("  stopped short: taut"), "{said}");
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    let j = q.joints();
    let (t, h) = (j[0], j[j.len() - 1]);
    let reach = (h.x - t.x).hypot(h.y - t.y).hypot(h.z - t.z);
    assert!((reach - 40.0).abs() < 1e-6, "{reach}");
}

/// At shutdown the service prints, for each chain with collision handling whose contacts it
/// resolved, where that time went (resolutions, passes, joint projections): a rope held at its tail,
/// pushed by a post through `chainctl instrument`; the chain without collision gets no line.
#[test]
fn at_shutdown_the_service_says_where_each_chain_s_contact_time_went() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("post.toml");
    std::fs::write(
        &scene,
        "[[instrument]]\nname = \"post\"\nshape = \"capsule\"\na = [5.0, -0.5, -3.0]\n\
         b = [5.0, -0.5, 3.0]\nradius = 0.4\n\n[[chain]]\nname = \"rope\"\nlinks = 40\n\
         link_length = 0.5\nthickness = 0.2\ncollision = \"capsules\"\ninstruments = [\"post\"]\n\n\
         [[chain]]\nname = \"plain\"\nlinks = 4\nlink_length = 1.0\n",
    )
    .unwrap();
    let err_path = dir.path().join("service.err");
    let prefix = unique_prefix();
    let mut cmd = Process::new(bin("solver-service"));
    cmd.args([
        "--prefix",
        &prefix,
        "--wait",
        "event",
        "--no-persist",
        "--scene",
    ])
    .arg(&scene)
    .stderr(std::fs::File::create(&err_path).unwrap());
    let proc = clients::process::Proc::ready(cmd, "solver-service").unwrap();
    let mut svc = Service {
        ready_line: proc.ready_line.clone(),
        proc,
        prefix,
    };
    let chainctl = |args: &[&str]| run(&svc, "chainctl", args);
    chainctl(&["grasp", "rope", "--joint", "tail"]);
    for k in 1..=20 {
        let y = format!("5,{},0", -0.5 + 0.05 * f64::from(k));
        let _ = finish(
            spawn(
                &svc,
                "chainctl",
                &[
                    "instrument",
                    "rope",
                    "--joint",
                    "0",
                    "--target",
                    &y,
                    "--axis",
                    "0,0,1",
                ],
            ),
            "chainctl",
        );
    }
    svc.signal("INT");
    assert!(svc.wait_exit(Duration::from_secs(30)).success());
    let err = std::fs::read_to_string(&err_path).unwrap();
    let line = err
        .lines()
        .find(|l| l.contains("chain rope: contact resolution: "))
        .unwrap_or_else(|| panic!("no line for the rope in {err}"));
    assert!(number_after(line, "contact resolution: ") > 0.0, "{line}");
    assert!(number_after(line, "or more), ") > 0.0, "{line}");
    assert!(line.contains("joint projections: "), "{line}");
    assert!(!err.contains("chain plain:"), "{err}");
}
