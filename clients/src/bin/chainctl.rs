//! `chainctl`: one request to a running solver service, printed as text or JSON.
//!
//! ```text
//! chainctl describe
//! chainctl move rope --joint head --target 40,5,0 --substeps 8
//! chainctl path snake --path "0,-50,1 1,-50,2" --max-step 0.25
//! chainctl reach arm --target 1.0,0.9 --angles
//! chainctl query rope --json
//! chainctl reset rope
//! chainctl snapshot
//! chainctl grasp rope --joint tail      # held: moves elsewhere leave it where it is
//! chainctl release rope --joint tail
//! chainctl move rope --joint head --target 60,0,0 --pull   # as far as the rope lets; prints the pull
//! chainctl eyelet suture --joint 0 --target 10.5,2,0            # tissue moved: the rope goes with it
//! chainctl knot reef
//! ```
//!
//! Exit codes: 0 ok, 1 the service refused the request or could not be reached, 2 usage.

use anyhow::{Result, bail};
use clap::{Parser, ValueEnum};
use clients::{ConnectOptions, Connection, Wait};
use shared::text::{ChainRef, JointRef, TextRequest, TextResponse};
use shared::{Command, Precision, RequestHeader, WireMethod, WireStrategy};
use std::time::Duration;

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum Cmd {
    Move,
    Path,
    Reach,
    Query,
    Reset,
    Describe,
    Snapshot,
    /// Hold the joint where it is (a hand's grasp).
    Grasp,
    /// Let a grasped joint go.
    Release,
    /// Move an instrument of the chain (`--joint` = its index in the chain's `instruments` list) to
    /// `--target` (its centre), turned to `--axis` (capsules), pushing the chain.
    Instrument,
    /// Move an eyelet of the chain (`--joint` = its index in the scene's `eyelets`, default 0) to
    /// `--target`, carrying the rope's point at it (tissue that moves).
    Eyelet,
    /// Query the chain and name the knot tied in it (unknot, trefoil, square, granny, double-overhand, surgeons, other).
    Knot,
}

#[derive(Parser, Debug)]
#[command(version, about = "Send one request to a running solver-service")]
struct Args {
    /// What to do.
    command: Cmd,
    /// Chain name or index (describe without it lists every chain).
    chain: Option<String>,
    /// Joint: head, tail or an index (instrument: its index, default 0).
    #[arg(long, default_value = "head")]
    joint: String,
    /// Target point: x,y or x,y,z.
    #[arg(long, allow_hyphen_values = true)]
    target: Option<String>,
    /// An instrument's axis direction: x,y or x,y,z (capsules).
    #[arg(long, allow_hyphen_values = true)]
    axis: Option<String>,
    /// A pose move's rotation vector x,y,z (axis × angle, radians): a bundle's heads' (`--target` is
    /// then the translation), or, moving the head of a chain with a needle, the needle's from its own
    /// frame (it leaves the swage along R·x and curves toward R·y; `--target` is the swage).
    #[arg(long, allow_hyphen_values = true)]
    rotation: Option<String>,
    /// Reach: an orientation goal, the last link's direction x,y or x,y,z (`--target` is where the head
    /// goes).
    #[arg(long, allow_hyphen_values = true)]
    direction: Option<String>,
    /// Reach: a ball goal, the head within this distance of `--target` (no motion when it already is).
    #[arg(long)]
    within: Option<f64>,
    /// Reach: a box goal, its two corners "x,y x,y" or "x,y,z x,y,z" (smallest, largest), no `--target` (no
    /// motion when the head is already inside).
    #[arg(long = "box", value_name = "LO HI", allow_hyphen_values = true)]
    in_box: Option<String>,
    /// Path points: space-separated groups, each x,y or x,y,z.
    #[arg(long, allow_hyphen_values = true)]
    path: Option<String>,
    /// Path: follow the natural cubic spline through the joint and the points (C²) instead of
    /// straight segments.
    #[arg(long)]
    smooth: bool,
    /// Method (default: the chain's).
    #[arg(long, value_enum)]
    method: Option<WireMethod>,
    /// Precision (must match the chain's).
    #[arg(long, value_enum)]
    precision: Option<Precision>,
    /// Equal substeps per move (reach: per tractrix pass).
    #[arg(long)]
    substeps: Option<u32>,
    /// Longest substep as a fraction of the shortest link.
    #[arg(long)]
    max_step: Option<f64>,
    /// Reach strategy (default: the chain's).
    #[arg(long, value_enum)]
    strategy: Option<WireStrategy>,
    /// Reach tolerance (fraction of the chain's length).
    #[arg(long)]
    tolerance: Option<f64>,
    /// Reach iteration limit.
    #[arg(long)]
    max_iterations: Option<u32>,
    /// Also return joint rotations.
    #[arg(long)]
    angles: bool,
    /// Move, instrument: go as far toward the target as the rope lets, and print the rest as the
    /// pull (the tension a hand feels) instead of refusing.
    #[arg(long)]
    pull: bool,
    /// Move of the head of a chain with a needle: drive the needle along its own arc (its point cuts
    /// the holes the rope threads; docs/eyelets.md).
    #[arg(long)]
    drive: bool,
    /// Grasp, release, move, path, reset: take over other clients' grasps (refused `held` without).
    #[arg(long)]
    take_over: bool,
    /// Print the response as one JSON object.
    #[arg(long)]
    json: bool,
    /// iceoryx2 prefix of the service.
    #[arg(long, env = shared::PREFIX_ENV, default_value = shared::DEFAULT_PREFIX)]
    prefix: String,
    /// Seconds to wait for a service to appear (default: fail at once).
    #[arg(long, default_value_t = 0.0)]
    wait_for_service: f64,
    /// Seconds to wait for the response.
    #[arg(long, default_value_t = 5.0)]
    timeout: f64,
}

/// The command-line name of an option value (the text form takes the same names).
fn name(v: impl ValueEnum) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_default()
}

fn point(s: &str) -> Result<Vec<f64>> {
    let v: Result<Vec<f64>, _> = s.split(',').map(|x| x.trim().parse::<f64>()).collect();
    match v {
        Ok(v) if (2..=3).contains(&v.len()) => Ok(v),
        _ => bail!("{s:?} is not a point x,y[,z]"),
    }
}

fn main() -> std::process::ExitCode {
    clients::cli::main("chainctl", || run(Args::parse()))
}

fn print(r: &TextResponse, json: bool) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string(r)?);
        return Ok(());
    }
    if r.status != "ok" {
        println!("{} {}: {} ({})", r.command, r.chain, r.status, r.reason);
        return Ok(());
    }
    if r.command == "snapshot" {
        println!("snapshot written at state {}", r.sequence);
        return Ok(());
    }
    // The name comes with `describe` only.
    let name = if r.name.is_empty() {
        String::new()
    } else {
        format!(" {:?}", r.name)
    };
    println!(
        "{} chain {}{name}: ok, state {}, {} substeps, {} iterations, residual {:.3e}, solved in {} ns",
        r.command, r.chain, r.sequence, r.substeps, r.iterations, r.residual, r.solve_ns
    );
    for (i, j) in r.joints.iter().enumerate() {
        println!(
            "  joint {i:>5}: {:>14.9} {:>14.9} {:>14.9}",
            j[0], j[1], j[2]
        );
    }
    for (i, a) in r.angles.iter().enumerate() {
        println!(
            "  rot   {i:>5}: {:>14.9} {:>14.9} {:>14.9}",
            a[0], a[1], a[2]
        );
    }
    if !r.held.is_empty() {
        let held: Vec<String> = r
            .held
            .iter()
            .map(|h| format!("{}{}", h.joint, if h.anchor { " (anchor)" } else { "" }))
            .collect();
        println!("  held: {}", held.join(", "));
        for h in r.held.iter().filter(|h| h.taut) {
            println!("  taut: from joint {} to the next held joint", h.joint);
        }
    }
    for (k, e) in r.eyelets.iter().enumerate() {
        if e.threaded {
            println!(
                "  eyelet {k} at ({:.6}, {:.6}, {:.6}): link {}",
                e.at[0], e.at[1], e.at[2], e.link
            );
        } else {
            println!("  eyelet {k}: left");
        }
    }
    if let Some([lo, hi]) = r.tissue {
        println!(
            "  tissue: from ({:.6}, {:.6}, {:.6}) to ({:.6}, {:.6}, {:.6})",
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
        );
    }
    if !r.knot.is_empty() {
        println!("  knot: {}", r.knot);
    }
    // An ok pull that stopped short says why (`shared::PullStop`).
    if !r.reason.is_empty() {
        println!("  {}", r.reason);
    }
    let pulls = r
        .held
        .iter()
        .map(|h| (format!("joint {}", h.joint), h.pull))
        .chain(
            r.instrument_pulls
                .iter()
                .enumerate()
                .map(|(i, p)| (format!("instrument {i}"), *p)),
        );
    for (what, p) in pulls.filter(|(_, p)| *p != [0.0; 3]) {
        let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        println!(
            "  pull on {what}: {n:.6} toward ({:.6}, {:.6}, {:.6})",
            p[0] / n,
            p[1] / n,
            p[2] / n
        );
    }
    Ok(())
}

fn run(a: Args) -> Result<u8> {
    if !(a.timeout.is_finite()
        && a.timeout > 0.0
        && a.wait_for_service.is_finite()
        && a.wait_for_service >= 0.0)
    {
        bail!("--timeout must be positive and --wait-for-service non-negative");
    }
    let mut conn = Connection::connect(ConnectOptions {
        prefix: a.prefix.clone(),
        wait: Wait::Spin,
        connect_timeout: Duration::from_secs_f64(a.wait_for_service),
        call_timeout: Duration::from_secs_f64(a.timeout),
        ..ConnectOptions::default()
    })?;
    if a.command == Cmd::Describe && a.chain.is_none() {
        let first = conn.call(RequestHeader::new(Command::Describe, 0), &[])?;
        let n = first.header.n_chains;
        for c in 0..n {
            let r = conn.call(RequestHeader::new(Command::Describe, c), &[])?;
            let h = &r.header;
            if a.json {
                println!(
                    "{}",
                    serde_json::to_string(&TextResponse::from_wire(h, &r.payload))?
                );
            } else {
                let strands = if h.kind == shared::ChainKind::Bundle as u32 {
                    format!(" of {} strands", h.n_joints / (h.n_links + 1).max(1))
                } else {
                    String::new()
                };
                let limits = shared::text::limits_text(h.limits, h.limit_value);
                let limits = if limits.is_empty() {
                    String::new()
                } else {
                    format!(", limits: {limits}")
                };
                println!(
                    "{c}: {:?} {} {}D, {} links{strands}, length {}, thickness {}, precision {}, method {}{limits}",
                    h.name_str(),
                    match shared::ChainKind::try_from(h.kind) {
                        Ok(shared::ChainKind::FixedBase) => "fixed-base",
                        Ok(shared::ChainKind::Bundle) => "bundle",
                        _ => "free",
                    },
                    h.dims,
                    h.n_links,
                    short(h.total_length),
                    short(h.thickness),
                    if h.precision == 2 { "f32" } else { "f64" },
                    shared::text::method_name(h.method)
                );
            }
        }
        return Ok(0);
    }
    let chain = match a.chain.as_deref() {
        None if a.command == Cmd::Snapshot => None,
        None => bail!("which chain? (chainctl describe lists them)"),
        Some(s) => Some(match s.parse::<u32>() {
            Ok(i) => ChainRef::Index(i),
            Err(_) => ChainRef::Index(conn.require_chain(s)?),
        }),
    };
    if a.command == Cmd::Knot {
        let Some(ChainRef::Index(id)) = chain else {
            bail!("which chain?");
        };
        let k = clients::hand::knot_of(&mut conn, id)?;
        let series = clients::hand::series_of(&mut conn, id, &k)?;
        if a.json {
            let series_json = match &series {
                None => String::new(),
                Some(None) => ",\"in_series\":null".to_string(),
                Some(Some(s)) => format!(
                    ",\"in_series\":{{\"cut\":{},\"first\":\"{}\",\"second\":\"{}\"}}",
                    s.cut,
                    s.first.kind.name(),
                    s.second.kind.name()
                ),
            };
            println!(
                "{{\"knot\":\"{}\",\"closures_agreeing\":{},\"closures\":{},\"crossings\":{},\"writhe\":{},\"determinant\":{}{series_json}}}",
                k.kind.name(),
                k.agreeing,
                k.closures,
                k.crossings,
                k.writhe,
                k.determinant
            );
        } else {
            println!("{}", clients::hand::knot_line(&k));
            if let Some(s) = &series {
                println!("{}", clients::hand::series_line(s));
            }
        }
        return Ok(0);
    }
    let req = TextRequest {
        cmd: format!("{:?}", a.command).to_lowercase(),
        chain,
        joint: Some(match a.joint.parse::<u32>() {
            Ok(i) => JointRef::Index(i),
            // An instrument by default: the chain's first.
            Err(_) if matches!(a.command, Cmd::Instrument | Cmd::Eyelet) && a.joint == "head" => {
                JointRef::Index(0)
            }
            Err(_) => JointRef::Named(a.joint.clone()),
        }),
        target: a.target.as_deref().map(point).transpose()?,
        axis: a.axis.as_deref().map(point).transpose()?,
        rotation: a.rotation.as_deref().map(point).transpose()?,
        direction: a.direction.as_deref().map(point).transpose()?,
        within: a.within,
        in_box: a
            .in_box
            .as_deref()
            .map(|p| p.split_whitespace().map(point).collect::<Result<Vec<_>>>())
            .transpose()?,
        path: a
            .path
            .as_deref()
            .map(|p| p.split_whitespace().map(point).collect::<Result<Vec<_>>>())
            .transpose()?,
        method: a.method.map(name),
        precision: a.precision.map(name),
        substeps: a.substeps,
        max_step: a.max_step,
        strategy: a.strategy.map(name),
        tolerance: a.tolerance,
        max_iterations: a.max_iterations,
        angles: a.angles,
        take_over: a.take_over,
        smooth: a.smooth,
        pull: a.pull,
        drive: a.drive,
        request_id: None,
    };
    let (header, points) = req.to_wire(&|_| None).map_err(anyhow::Error::msg)?;
    let r = conn.call(header, &points)?;
    print(&TextResponse::from_wire(&r.header, &r.payload), a.json)?;
    Ok(if r.is_ok() { 0 } else { 1 })
}

/// A length as a person reads it: 13 significant digits, so that the sum of ten links of 0.2 prints as
/// 2, not 1.9999999999999998.
fn short(x: f64) -> String {
    let rounded: f64 = format!("{x:.12e}").parse().unwrap_or(x);
    format!("{rounded}")
}
