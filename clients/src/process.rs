//! The one process harness, for the end-to-end tests and the latency bench: a child process whose stdout
//! is read line by line on a thread, started until it prints its ready line, signalled with the
//! system's `kill`, and terminated (SIGTERM, then SIGKILL) and reaped on drop. Every wait has a deadline.

use anyhow::{Context, Result, bail};
use std::io::{BufRead, BufReader};
use std::process::{Child, ChildStdout, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// How long a server may take to print its ready line (a loaded CI machine, a cold page cache).
pub const START_TIMEOUT: Duration = Duration::from_secs(30);

/// A running child process.
#[derive(Debug)]
pub struct Proc {
    /// The child (its stdout is taken; read [`Proc::lines`]).
    pub child: Child,
    /// What it is, for messages.
    pub what: String,
    /// The ready line it printed.
    pub ready_line: String,
    /// Its later stdout lines.
    pub lines: mpsc::Receiver<String>,
}

impl Proc {
    /// Spawns `cmd` with a piped stdout and waits at most [`START_TIMEOUT`] for a line containing
    /// "ready".
    pub fn ready(cmd: Command, what: &str) -> Result<Proc> {
        let (child, out) = spawn_piped(cmd, what)?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut p = Proc {
            child,
            what: what.to_string(),
            ready_line: String::new(),
            lines: rx,
        };
        match p.lines.recv_timeout(START_TIMEOUT) {
            Ok(l) if l.contains("ready") => {
                p.ready_line = l;
                Ok(p)
            }
            Ok(l) => bail!("{what} said {l:?} instead of getting ready"),
            // Its stdout closed: it has exited (or is exiting) without a ready line.
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                match p.wait_exit(Duration::from_secs(5)) {
                    Ok(status) => bail!("{what} exited with {status} before getting ready"),
                    Err(_) => bail!("{what} closed its stdout without getting ready"),
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {
                bail!("{what} did not get ready within {START_TIMEOUT:?}")
            }
        }
    }

    /// Sends a signal (`TERM`, `INT`, `KILL` ...) with the system's `kill` (no unsafe code here).
    pub fn signal(&self, sig: &str) -> Result<()> {
        let ok = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(self.child.id().to_string())
            .status()
            .context("run kill")?
            .success();
        if !ok {
            bail!("kill -{sig} {} failed", self.what);
        }
        Ok(())
    }

    /// Waits at most `timeout` for the process to exit.
    pub fn wait_exit(&mut self, timeout: Duration) -> Result<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.child.try_wait()? {
                return Ok(s);
            }
            if Instant::now() >= deadline {
                bail!("{} did not exit within {timeout:?}", self.what);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// SIGTERM, then SIGKILL after 5 s; reaped either way.
    pub fn stop(&mut self) {
        if let Ok(Some(_)) = self.child.try_wait() {
            return;
        }
        let _ = self.signal("TERM");
        if self.wait_exit(Duration::from_secs(5)).is_ok() {
            return;
        }
        eprintln!("{} ignored SIGTERM; killing it", self.what);
        self.kill9();
    }

    /// `kill -9` and reap.
    pub fn kill9(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Spawns `cmd` with its stdout piped to this process (stderr inherited).
fn spawn_piped(mut cmd: Command, what: &str) -> Result<(Child, ChildStdout)> {
    // Its stderr as `cmd` says (inherited unless the caller sent it elsewhere).
    let mut child = cmd
        .stdout(Stdio::piped())
        .spawn()
        .with_context(|| format!("start {what}"))?;
    let out = child.stdout.take().context("piped stdout")?;
    Ok((child, out))
}

/// Runs a process to its end (deadline `timeout`) and returns its last stdout line.
pub fn output_line(cmd: Command, what: &str, timeout: Duration) -> Result<String> {
    let (mut child, out) = spawn_piped(cmd, what)?;
    let reader = std::thread::spawn(move || {
        BufReader::new(out)
            .lines()
            .map_while(Result::ok)
            .last()
            .unwrap_or_default()
    });
    let deadline = Instant::now() + timeout;
    let status = loop {
        if let Some(s) = child.try_wait()? {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            bail!("{what} did not finish within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let line = reader.join().unwrap_or_default();
    if !status.success() {
        bail!("{what} failed ({status})");
    }
    Ok(line)
}

/// The workspace's root, for benches and tools run from the source tree.
pub fn workspace() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A release binary of the workspace (`target/release/NAME`, or under `CARGO_TARGET_DIR`); an error
/// that names the build command when it is missing.
pub fn release_bin(name: &str) -> Result<std::path::PathBuf> {
    let dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| workspace().join("target"));
    let p = dir.join("release").join(name);
    if !p.exists() {
        bail!(
            "{} is missing: build the binaries first (cargo build --release --bins)",
            p.display()
        );
    }
    Ok(p)
}
