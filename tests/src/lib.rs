//! Support for the end-to-end tests: the real binaries as processes (through the clients' one process
//! harness, [`clients::process`]), each test with its own iceoryx2 prefix and state directory, every
//! wait with a deadline, every child killed and reaped on drop.

use clients::process::Proc;
use clients::{ConnectOptions, Connection, Wait};
use iceoryx2::prelude::local;
use solver_service::serve::{LoopOptions, ServerPorts, serve};
use solver_service::service::Solver;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::sync::atomic::{AtomicU32, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;
use world::World;
use world::scene::{Scene, default_scene};

pub use clients::process::START_TIMEOUT;

pub mod knot_check;

/// A prefix no other test (or test run) uses.
pub fn unique_prefix() -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!(
        "tt{}_{}_",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    )
}

/// Whether the system tool `tool` (a program on the PATH) or library (`lib…` in `ldconfig -p`) is here.
pub fn system_has(tool: &str) -> bool {
    let probe = if tool.starts_with("lib") {
        // ldconfig lives in /sbin, which a normal user's PATH may not have.
        format!("PATH=\"$PATH:/sbin:/usr/sbin\" ldconfig -p | grep -q {tool}")
    } else {
        format!("command -v {tool}")
    };
    std::process::Command::new("sh")
        .args(["-c", &probe])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// For a test that needs system packages (`scripts/system-packages.sh` installs them, as root or with
/// sudo): `true` when every one of `needs` is here. Otherwise the test is skipped with one line on
/// stderr, except under `CI=true`, where nothing may be skipped and the test fails.
pub fn system_packages(test: &str, needs: &[&str]) -> bool {
    let missing: Vec<&str> = needs.iter().copied().filter(|t| !system_has(t)).collect();
    if missing.is_empty() {
        return true;
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{test}: {} missing, and CI=true skips nothing: run scripts/system-packages.sh as root",
        missing.join(", ")
    );
    skip(&format!(
        "{test}: {} missing (scripts/system-packages.sh installs them as root or with sudo)",
        missing.join(", ")
    ));
    false
}

/// The environment variable naming the file where skipped tests add their line (`scripts/test.sh`
/// sets it and prints the file after the tests: cargo shows no output of a test that passed).
pub const SKIPS_ENV: &str = "TRACTRIX_TEST_SKIPS";

/// Says that a test (or part of one) is skipped and why: one line on stderr, and one in the file
/// [`SKIPS_ENV`] names, for the test command's summary.
pub fn skip(why: &str) {
    eprintln!("skipped {why}");
    if let Some(path) = std::env::var_os(SKIPS_ENV) {
        use std::io::Write;
        if let Ok(mut f) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
        {
            let _ = writeln!(f, "skipped {why}");
        }
    }
}

/// Runs `cargo ARGS` (the cargo that runs the tests) and fails the test if the build fails: for what a
/// test needs and the runner may not have built.
pub fn cargo_build(args: &[&str]) {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let ok = Command::new(cargo)
        .arg("build")
        .args(args)
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "cargo build {} failed", args.join(" "));
}

/// The lines a child writes to its standard error, as they come (read on a thread, so the child never
/// blocks on a full pipe); the child must have been spawned with `stderr(Stdio::piped())`.
pub fn stderr_lines(child: &mut std::process::Child) -> std::sync::mpsc::Receiver<String> {
    use std::io::BufRead;
    let err = child.stderr.take().expect("stderr piped");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for l in std::io::BufReader::new(err).lines().map_while(Result::ok) {
            let _ = tx.send(l);
        }
    });
    rx
}

/// Path of a workspace binary, built on demand if the test runner did not build it.
/// A scene of one rope, `suture`: 40 unit links straight along x from the origin, threaded through the
/// eyelets [`SUTURE_EYELETS`]; and a service started on it (its scene file in the returned folder).
pub const SUTURE_EYELETS: [[f64; 3]; 2] = [[10.5, 0.0, 0.0], [25.5, 0.0, 0.0]];
/// The block of tissue of the same scene (its corners), under the rope between the eyelets: the
/// describe carries it, the viewers draw it.
pub const SUTURE_TISSUE: ([f64; 3], [f64; 3]) = ([12.0, -3.0, -4.0], [24.0, 3.0, -1.0]);

/// A service on the scene of [`SUTURE_EYELETS`] (the folder holds its scene file: keep it while the
/// service runs).
pub fn suture_service() -> (Service, tempfile::TempDir) {
    let points: Vec<String> = SUTURE_EYELETS
        .iter()
        .map(|p| format!("[{}, {}, {}]", p[0], p[1], p[2]))
        .collect();
    service_on_scene(&format!(
        "[[chain]]\nname = \"suture\"\nlinks = 40\nlink_length = 1.0\neyelets = [{}]\n\
         tissue = [{:?}, {:?}]\n",
        points.join(", "),
        SUTURE_TISSUE.0,
        SUTURE_TISSUE.1
    ))
}

/// A service (no persistence, event waits) on a scene given as text, written to `scene.toml` in the
/// returned folder (keep it while the service runs; the test may put its own files there too).
pub fn service_on_scene(text: &str) -> (Service, tempfile::TempDir) {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, text).expect("write the scene");
    let svc = Service::start(
        &unique_prefix(),
        &[
            "--scene",
            scene.to_str().expect("a UTF-8 path"),
            "--no-persist",
            "--wait",
            "event",
        ],
    );
    (svc, dir)
}

/// The nearest link of the rope through `joints` to the point `p`: its index, the distance, and how
/// far along the link the nearest point lies (the tests' own geometry, not the service's).
pub fn nearest_link(joints: &[shared::Vec3], p: [f64; 3]) -> (usize, f64, f64) {
    let mut best = (0, f64::INFINITY, 0.0);
    for k in 0..joints.len().saturating_sub(1) {
        let (a, b) = (joints[k].to_array(), joints[k + 1].to_array());
        let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
        let l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
        let t = ((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / l2).clamp(0.0, 1.0);
        let e = [ap[0] - ab[0] * t, ap[1] - ab[1] * t, ap[2] - ab[2] * t];
        let d = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        if d < best.1 {
            best = (k, d, t * l2.sqrt());
        }
    }
    best
}

/// Waits (300 s at most) for a `hand` process whose stdout is piped to finish successfully and
/// returns what it printed (its output is small: `--quiet` or a report).
pub fn hand_output(mut child: std::process::Child) -> String {
    let deadline = std::time::Instant::now() + Duration::from_secs(300);
    loop {
        if let Some(st) = child.try_wait().expect("wait for the hand") {
            let mut out = String::new();
            if let Some(o) = child.stdout.as_mut() {
                std::io::Read::read_to_string(o, &mut out).expect("read the hand's output");
            }
            assert!(st.success(), "hand failed: {st}\n{out}");
            return out;
        }
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("a hand did not finish within 300 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

pub fn bin(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let dir = exe
        .parent()
        .and_then(Path::parent)
        .expect("target/<profile>/deps")
        .to_path_buf();
    let path = dir.join(name);
    if !path.exists() {
        static BUILD: std::sync::Once = std::sync::Once::new();
        BUILD.call_once(|| {
            // The workspace's binaries, as scripts/test.sh builds them (`-p` would resolve other
            // features for the dependencies and build them again).
            cargo_build(&["--bins", "--profile", "test"])
        });
    }
    assert!(path.exists(), "{} missing", path.display());
    path
}

/// A running solver-service, killed and reaped on drop.
#[derive(Debug)]
pub struct Service {
    /// The process.
    pub proc: Proc,
    /// Its iceoryx2 prefix.
    pub prefix: String,
    /// The line it printed when ready.
    pub ready_line: String,
}

impl Service {
    /// Starts the service with `args` (plus `--prefix`) and waits for its ready line.
    pub fn start(prefix: &str, args: &[&str]) -> Service {
        let mut cmd = Command::new(bin("solver-service"));
        cmd.arg("--prefix").arg(prefix).args(args);
        let proc = Proc::ready(cmd, "solver-service").unwrap_or_else(|e| panic!("{e:#}"));
        Service {
            ready_line: proc.ready_line.clone(),
            proc,
            prefix: prefix.to_string(),
        }
    }

    /// The process id.
    pub fn id(&self) -> u32 {
        self.proc.child.id()
    }

    /// A connection that spins (tests run two at a time on two cores: at most one spinner each).
    pub fn connect(&self) -> Connection {
        self.connect_with(Wait::Hybrid(Duration::from_micros(50)))
    }

    /// A connection that waits as told.
    pub fn connect_with(&self, wait: Wait) -> Connection {
        Connection::connect(ConnectOptions {
            prefix: self.prefix.clone(),
            wait,
            connect_timeout: Duration::from_secs(5),
            call_timeout: Duration::from_secs(10),
            // Room for oversized requests, so the tests can see the service refuse them.
            max_request_points: 2 * shared::MAX_PATH_POINTS as usize,
        })
        .expect("connect to the service")
    }

    /// Sends a signal with the system's `kill`.
    pub fn signal(&self, sig: &str) {
        self.proc.signal(sig).unwrap_or_else(|e| panic!("{e:#}"));
    }

    /// Waits for the process to exit, at most `timeout`.
    pub fn wait_exit(&mut self, timeout: Duration) -> ExitStatus {
        self.proc
            .wait_exit(timeout)
            .unwrap_or_else(|e| panic!("{e:#}"))
    }

    /// `kill -9` and reap, then remove what the dead service left in shared memory (its segments are
    /// reserved, real memory: a restart under the same prefix would clean them, the tests restart
    /// under new ones).
    pub fn kill9(mut self) {
        self.proc.kill9();
        remove_dead(&self.prefix);
    }
}

/// Removes the resources of the dead processes of `prefix` (as a service starting there would).
pub fn remove_dead(prefix: &str) {
    use iceoryx2::prelude::*;
    let Ok(cfg) = shared::iceoryx_config(prefix) else {
        return;
    };
    let _ = Node::<ipc::Service>::list(&cfg, |state| {
        if let NodeState::Dead(view) = state {
            let _ = view.try_remove_stale_resources();
        }
        CallbackProgression::Continue
    });
}

/// The service's serving loop and solver on the default scene (no persistence) in a thread of the test
/// process, over iceoryx2's `local` service: for the tests of what a request does (errors, the state
/// stream), which need no process of their own. Stopped and joined on drop.
#[derive(Debug)]
pub struct InProcess {
    /// Its iceoryx2 prefix.
    pub prefix: String,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<(), String>>>,
    /// Request points a connection is sized for (the largest bundle's strands at least).
    max_points: usize,
}

impl InProcess {
    /// Serves the default scene in event mode until dropped.
    pub fn start() -> InProcess {
        Self::start_scene(default_scene())
    }

    /// Serves `scene` in event mode until dropped.
    pub fn start_scene(scene: Scene) -> InProcess {
        let max_points = scene
            .bundles
            .iter()
            .map(|b| b.strands as usize)
            .fold(2 * shared::MAX_PATH_POINTS as usize, usize::max);
        let prefix = unique_prefix();
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let thread = {
            let (prefix, stop) = (prefix.clone(), stop.clone());
            std::thread::spawn(move || -> Result<(), String> {
                let set = World::new(&scene).map_err(|e| e.to_string())?;
                let iox = shared::iceoryx_config(&prefix)?;
                let (elements, joints) = set.response_sizes();
                let (ports, _) = ServerPorts::<local::Service>::open(
                    &iox,
                    "tractrix-solver-in-process",
                    elements,
                    Some(joints),
                    shared::STATE_BUFFER,
                    set.bundle_stream_size(),
                )
                .map_err(|e| e.to_string())?;
                let mut solver = Solver::new(set, None, Duration::ZERO);
                let _ = tx.send(());
                let opts = LoopOptions {
                    stop: Some(stop),
                    ..LoopOptions::default()
                };
                serve(&ports, &mut solver, &opts).map_err(|e| e.to_string())
            })
        };
        rx.recv_timeout(START_TIMEOUT)
            .expect("the in-process service got ready");
        InProcess {
            prefix,
            stop,
            thread: Some(thread),
            max_points,
        }
    }

    /// A connection from this process (at most one spinning thread per core: it sleeps after 50 µs).
    pub fn connect(&self) -> Connection<local::Service> {
        Connection::open(ConnectOptions {
            prefix: self.prefix.clone(),
            wait: Wait::Hybrid(Duration::from_micros(50)),
            connect_timeout: Duration::from_secs(5),
            call_timeout: Duration::from_secs(10),
            max_request_points: self.max_points,
        })
        .expect("connect to the in-process service")
    }
}

impl Drop for InProcess {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let r = t.join();
            if !std::thread::panicking() {
                assert!(
                    matches!(r, Ok(Ok(()))),
                    "the in-process service ended badly: {r:?}"
                );
            }
        }
    }
}
