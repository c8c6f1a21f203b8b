//! Support for the end-to-end tests: the real binaries as processes, each test with its own iceoryx2
//! prefix and state directory, every wait with a deadline, every child killed and reaped on drop.

use clients::{ClientWait, ConnectOptions, Connection};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// How long a service may take to start (a loaded CI machine, a cold page cache).
pub const START_TIMEOUT: Duration = Duration::from_secs(30);

/// A prefix no other test (or test run) uses.
pub fn unique_prefix() -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!(
        "tt{}_{}_",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    )
}

/// Path of a workspace binary, built on demand if the test runner did not build it.
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
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            let status = Command::new(cargo)
                .args([
                    "build",
                    "--bins",
                    "-p",
                    "solver-service",
                    "-p",
                    "clients",
                    "--profile",
                    "test",
                ])
                .status()
                .expect("run cargo build");
            assert!(status.success(), "building the binaries failed");
        });
    }
    assert!(path.exists(), "{} missing", path.display());
    path
}

/// A running solver-service, killed and reaped on drop.
#[derive(Debug)]
pub struct Service {
    pub child: Child,
    pub prefix: String,
    pub ready_line: String,
}

impl Service {
    /// Starts the service with `args` (plus `--prefix`) and waits for its ready line.
    pub fn start(prefix: &str, args: &[&str]) -> Service {
        let mut child = Command::new(bin("solver-service"))
            .arg("--prefix")
            .arg(prefix)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn solver-service");
        let stdout = child.stdout.take().expect("stdout");
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let ready_line = match rx.recv_timeout(START_TIMEOUT) {
            Ok(l) => l,
            Err(e) => {
                let _ = child.kill();
                let _ = child.wait();
                panic!("solver-service did not get ready within {START_TIMEOUT:?}: {e}");
            }
        };
        assert!(ready_line.contains("ready"), "{ready_line}");
        Service {
            child,
            prefix: prefix.to_string(),
            ready_line,
        }
    }

    /// A connection that spins (tests run two at a time on two cores: at most one spinner each).
    pub fn connect(&self) -> Connection {
        self.connect_with(ClientWait::Hybrid(Duration::from_micros(50)))
    }

    pub fn connect_with(&self, wait: ClientWait) -> Connection {
        Connection::connect(ConnectOptions {
            prefix: self.prefix.clone(),
            wait,
            connect_timeout: Duration::from_secs(5),
            call_timeout: Duration::from_secs(10),
            // Room for oversized requests, so the tests can see the service refuse them.
            max_request_points: 2 * protocol::MAX_PATH_POINTS as usize,
        })
        .expect("connect to the service")
    }

    /// Sends a signal with the system's `kill` (no unsafe code here).
    pub fn signal(&self, sig: &str) {
        let ok = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(self.child.id().to_string())
            .status()
            .expect("run kill")
            .success();
        assert!(ok, "kill -{sig} failed");
    }

    /// Waits for the process to exit, at most `timeout`.
    pub fn wait_exit(&mut self, timeout: Duration) -> ExitStatus {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.child.try_wait().expect("try_wait") {
                return s;
            }
            assert!(
                Instant::now() < deadline,
                "the service did not exit within {timeout:?}"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// `kill -9` and reap.
    pub fn kill9(mut self) {
        let _ = self.child.kill();
        let _ = self.wait_exit(Duration::from_secs(10));
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}
