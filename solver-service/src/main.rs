//! `solver-service`: serves a scene over iceoryx2 (the default), or applies a batch of requests to it.
//!
//! Exit codes: 0 ok, 1 failure (including refused batch requests), 2 usage or scene error.

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use shared::WaitMode;
use solver_service::batch::{Format, run_batch};
use solver_service::persist::JournalMode;
use solver_service::scene_file::load_scene;
use solver_service::serve::LoopOptions;
use solver_service::service::{Persistence, ServiceConfig, Solver, run, run_echo};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;
use world::World;
use world::scene::{Scene, SceneError, default_scene};

#[derive(Parser, Debug)]
#[command(
    version,
    about = "Tractrix solver service for ropes, snakes and hyper-redundant manipulators"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Cmd>,
    #[command(flatten)]
    serve: ServeArgs,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Apply a file of JSON-lines requests to the scene, without IPC, and write the resulting joints;
    /// snapshots and journal only with --state-dir (then --restore starts from them).
    Batch(BatchArgs),
    /// Validate the scene (--scene, or the embedded one) and print its chains.
    Check,
    /// Serve the same protocol over a Unix domain socket (the latency bench's comparison transport),
    /// one connection at a time; snapshots and journal only with --state-dir.
    Unix(UnixArgs),
    /// Serve the raw echo (the latency bench's baseline): the service's ports, serving loop and waits
    /// (--wait, --spin-us, --pin), no validation, no solving; every response carries --elements points.
    Echo(EchoArgs),
}

#[derive(Args, Debug)]
struct EchoArgs {
    /// Elements in every response (a chain of n links answers n + 1 joints).
    #[arg(long, default_value_t = 41, value_parser = clap::value_parser!(u32).range(1..=shared::MAX_RESPONSE_ELEMENTS as i64))]
    elements: u32,
}

#[derive(Args, Debug)]
struct UnixArgs {
    /// Socket path (created; an existing file is an error).
    #[arg(long)]
    socket: PathBuf,
    /// Exit after this many connections (default: serve forever).
    #[arg(long)]
    connections: Option<usize>,
}

#[derive(Args, Debug)]
struct ServeArgs {
    /// Scene file (TOML). Default: the embedded scene (rope, snake, planar arm of the paper).
    #[arg(long, global = true)]
    scene: Option<PathBuf>,
    /// iceoryx2 prefix isolating this instance and its clients.
    #[arg(long, global = true, env = shared::PREFIX_ENV, default_value = shared::DEFAULT_PREFIX)]
    prefix: String,
    /// How to wait for requests: spin (lowest latency, one core busy), event (sleeps), hybrid (sleeps,
    /// spins for --spin-us after each request).
    #[arg(long, global = true, value_enum, default_value_t = WaitMode::Hybrid)]
    wait: WaitMode,
    /// Hybrid mode: microseconds of spinning after the last request.
    #[arg(long, global = true, default_value_t = 2000)]
    spin_us: u64,
    /// Pin the serving thread to this CPU core.
    #[arg(long, global = true)]
    pin: Option<usize>,
    /// Directory of snapshots and the journal (default: $XDG_STATE_HOME/tractrix-solver/<prefix>).
    #[arg(long)]
    state_dir: Option<PathBuf>,
    /// Keep no snapshots and no journal.
    #[arg(long)]
    no_persist: bool,
    /// Journal: write (survives kill -9), fsync (survives power loss), off (snapshots only).
    #[arg(long, value_enum, default_value_t = JournalMode::Write)]
    journal: JournalMode,
    /// Start from the saved state (snapshot + journal) instead of the scene.
    #[arg(long)]
    restore: bool,
    /// With a damaged journal (or one missing): restore the state before the damage, keep the damaged
    /// files beside the new ones (damaged-<state>-*) and say what was dropped. Without it such a
    /// restore is refused and no file is touched.
    #[arg(long)]
    restore_from_damaged: bool,
    /// The frame: most work one request may cost, in link-steps (about 62 ns each here; collision
    /// work metered as it runs). A move, pull or instrument pose that cannot be finished inside it
    /// stops short where it got ("stopped short: work budget"); only a request whose size alone can
    /// never fit (a path of too many points, a reach of too many iterations) is refused
    /// over-budget. Default: the scene's `budget`, else 16000 (1 ms, a haptic device's sample).
    #[arg(long, alias = "frame", global = true, value_parser = clap::value_parser!(u64).range(1..))]
    budget: Option<u64>,
    /// Most work one pull may cost (a move or instrument pose with the pull flag), in link-steps,
    /// at most `--budget`: a haptic hand's pulls bounded in time while other moves keep the whole
    /// budget; a pull stops short at it ("work budget") and the next goes on from there. Default:
    /// the scene's `pull_budget`, else the budget.
    #[arg(long, global = true, value_parser = clap::value_parser!(u64).range(1..))]
    pull_budget: Option<u64>,
    /// Seconds between snapshots while the state changes (0: only on shutdown and on command).
    #[arg(long, default_value_t = 10.0)]
    snapshot_every: f64,
    /// States each subscriber of the state stream may buffer before it loses the oldest (a recorder
    /// that must miss nothing: up to 4096; shared memory grows with it, 16 subscribers × this × the
    /// largest chain's state).
    #[arg(long, default_value_t = shared::STATE_BUFFER as u32,
          value_parser = clap::value_parser!(u32).range(1..=shared::MAX_STATE_BUFFER as i64))]
    state_buffer: u32,
}

#[derive(Args, Debug)]
struct BatchArgs {
    /// Requests, one JSON object per line ('-' for stdin).
    #[arg(long)]
    requests: PathBuf,
    /// Output file ('-' for stdout).
    #[arg(long, default_value = "-")]
    out: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::JsonLines)]
    format: Format,
}

fn scene(path: &Option<PathBuf>) -> Result<Scene> {
    match path {
        Some(p) => Ok(load_scene(p)?),
        None => Ok(default_scene()),
    }
}

fn state_dir(prefix: &str) -> PathBuf {
    let base = std::env::var_os("XDG_STATE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state")))
        .unwrap_or_else(|| PathBuf::from("."));
    base.join("tractrix-solver").join(prefix)
}

fn serve_config(a: &ServeArgs) -> Result<ServiceConfig> {
    if !(a.snapshot_every.is_finite() && a.snapshot_every >= 0.0) {
        bail!("--snapshot-every must be a number of seconds ≥ 0");
    }
    if (a.restore || a.restore_from_damaged) && a.no_persist {
        bail!("--restore needs persistence; drop --no-persist");
    }
    shared::iceoryx_config(&a.prefix).map_err(anyhow::Error::msg)?;
    Ok(ServiceConfig {
        prefix: a.prefix.clone(),
        wait: a.wait.with_budget(Duration::from_micros(a.spin_us)),
        pin: a.pin,
        persistence: (!a.no_persist).then(|| {
            persistence(
                a,
                a.state_dir.clone().unwrap_or_else(|| state_dir(&a.prefix)),
            )
        }),
        state_buffer: a.state_buffer as usize,
    })
}

/// Snapshots and journal in `dir`, as the options say.
fn persistence(a: &ServeArgs, dir: PathBuf) -> Persistence {
    Persistence {
        dir,
        journal: a.journal,
        restore: a.restore || a.restore_from_damaged,
        from_damaged: a.restore_from_damaged,
        snapshot_every: Duration::from_secs_f64(a.snapshot_every),
    }
}

/// Batch mode and the Unix socket persist only into a `--state-dir` given (a batch beside a running
/// service must not take its state directory): then as the service does, restore included.
fn door_persistence(a: &ServeArgs, door: &str) -> Result<Option<Persistence>> {
    if !(a.snapshot_every.is_finite() && a.snapshot_every >= 0.0) {
        bail!("--snapshot-every must be a number of seconds ≥ 0");
    }
    match (&a.state_dir, a.no_persist) {
        (Some(dir), false) => Ok(Some(persistence(a, dir.clone()))),
        _ if a.restore || a.restore_from_damaged => {
            bail!("{door}: --restore needs --state-dir DIR (and no --no-persist)")
        }
        _ => Ok(None),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match real_main(cli) {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!("solver-service: {e:#}");
            if e.downcast_ref::<world::scene::SceneError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// Prints a line a script or a test waits for, flushed at once.
fn ready(msg: &str) {
    println!("{msg}");
    let _ = std::io::stdout().flush();
}

/// The scene's chains with the budget set: every check a start makes (the scene's validation, building
/// every chain, and every chain's `describe` within the budget), for `check` and for every door.
fn world(a: &ServeArgs) -> Result<World> {
    let sc = scene(&a.scene)?;
    let file = a
        .scene
        .as_ref()
        .map_or(world::scene::DEFAULT_SCENE_NAME.to_string(), |p| {
            p.display().to_string()
        });
    let mut set = World::new(&sc).map_err(|e| SceneError {
        file: file.clone(),
        line: 0,
        message: e.to_string(),
    })?;
    set.set_budget(
        a.budget
            .or(sc.budget)
            .unwrap_or(world::chains::DEFAULT_BUDGET),
    );
    set.set_pull_budget(a.pull_budget.or(sc.pull_budget));
    if let Some((line, message)) = set.unservable() {
        return Err(SceneError {
            file,
            line,
            message,
        }
        .into());
    }
    Ok(set)
}

fn real_main(cli: Cli) -> Result<u8> {
    match cli.command {
        None => {
            let cfg = serve_config(&cli.serve)?;
            let set = world(&cli.serve)?;
            run(&cfg, set, ready).map_err(anyhow::Error::msg)?;
            Ok(0)
        }
        Some(Cmd::Echo(e)) => {
            let a = &cli.serve;
            shared::iceoryx_config(&a.prefix).map_err(anyhow::Error::msg)?;
            let opts = LoopOptions {
                wait: a.wait.with_budget(Duration::from_micros(a.spin_us)),
                stop: None,
            };
            run_echo(&a.prefix, e.elements, &opts, a.pin, ready)?;
            Ok(0)
        }
        Some(Cmd::Check) => {
            let set = world(&cli.serve)?;
            for c in set.specs() {
                println!(
                    "{}: {:?}, {}D, {} links, total length {}, {:?}",
                    c.name,
                    c.kind,
                    c.dims,
                    c.lengths.len(),
                    c.total_length,
                    c.precision
                );
            }
            Ok(0)
        }
        Some(Cmd::Unix(u)) => {
            let set = world(&cli.serve)?;
            if let Some(core) = cli.serve.pin {
                shared::pin_current_thread(core).map_err(anyhow::Error::msg)?;
            }
            let persist = door_persistence(&cli.serve, "unix")?;
            let (mut solver, restored) = Solver::open(set, persist.as_ref())?;
            let listener = std::os::unix::net::UnixListener::bind(&u.socket)
                .with_context(|| format!("bind {}", u.socket.display()))?;
            println!(
                "solver-service ready: {} chains, unix socket {}{restored}",
                solver.set().len(),
                u.socket.display()
            );
            let _ = std::io::stdout().flush();
            solver_service::unix_socket::serve(&listener, &mut solver, u.connections)?;
            let _ = std::fs::remove_file(&u.socket);
            solver.close()?;
            Ok(0)
        }
        Some(Cmd::Batch(b)) => {
            let format = b.format;
            let set = world(&cli.serve)?;
            let source = b.requests.display().to_string();
            let mut input: Box<dyn std::io::BufRead> = if source == "-" {
                Box::new(std::io::stdin().lock())
            } else {
                Box::new(std::io::BufReader::new(
                    std::fs::File::open(&b.requests).with_context(|| source.clone())?,
                ))
            };
            let mut out: Box<dyn Write> = if b.out.as_os_str() == "-" {
                Box::new(std::io::BufWriter::new(std::io::stdout().lock()))
            } else {
                Box::new(std::io::BufWriter::new(
                    std::fs::File::create(&b.out).with_context(|| b.out.display().to_string())?,
                ))
            };
            let persist = door_persistence(&cli.serve, "batch")?;
            let (mut solver, _) = Solver::open(set, persist.as_ref())?;
            let s = run_batch(&mut solver, &mut input, &mut out, format, &source)?;
            out.flush()?;
            if persist.is_some() {
                solver.close()?;
            }
            eprintln!("{} requests, {} refused", s.requests, s.failed);
            Ok(if s.failed > 0 { 1 } else { 0 })
        }
    }
}
