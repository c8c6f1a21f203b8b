//! A hand controller: grasps a joint and drives it through a script's turns, taking turns with the other
//! hands of the script (each its own process), recording what it sent; and the replay of recordings.
//!
//! Turn-taking runs over an iceoryx2 event service `tractrix/turns/<script name>`: when a hand finishes
//! turn `k` it notifies event id `k`; a hand whose turn is next waits for that id. Notifications reach
//! only listeners that exist, so a hand keeps re-announcing the last turn it finished while it waits,
//! and at the end each hand announces it is finished and waits for the others: hands may be started in
//! any order, seconds apart. Every wait has a deadline.

use crate::connection::{CallError, Connection, Pacer, Svc, count_refusal, ipc};
use anyhow::Context as _;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::prelude::*;
use knots::script::{InstrumentEnds, Joint, Script, parse_joint};
use serde::{Deserialize, Serialize};
use shared::{Command, JOINT_HEAD, PullStop, RequestHeader, Status, Vec3};
use std::io::Write;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

pub mod device;
mod lines;
mod replay;
pub use device::{DeviceOptions, DeviceReport, FEEL};
pub use lines::*;
pub use replay::*;

/// Event ids from this value on mean "hand number `id − FINISHED` is finished".
const FINISHED: usize = 220;

/// One request a hand sent, as recorded (one JSON line each).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Wall-clock time the request was sent, ns since the Unix epoch (orders two hands' records).
    pub t_ns: u64,
    pub hand: String,
    /// 0-based turn of the script.
    pub turn: u32,
    pub chain: String,
    /// Wire joint (`4294967295` = head).
    pub joint: u32,
    pub target: [f64; 3],
    pub request_id: u64,
    /// Status name (`ok`, `locked`, ...).
    pub status: String,
    /// State sequence number after the request.
    pub sequence: u64,
    /// CRC-32 of the returned joint positions (little-endian f64 x, y, z per joint): bit-for-bit check.
    pub digest: u32,
    /// The command: `move` (the default, and what older recordings hold), `grasp`, `release` or
    /// `instrument` (`joint` the instrument's index, `target` its centre, `axis` its axis).
    #[serde(default = "move_command", skip_serializing_if = "is_move")]
    pub command: String,
    /// An instrument's new axis direction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Sent with the pull flag (a tightening pull: as far as the rope lets).
    #[serde(default, skip_serializing_if = "is_false")]
    pub pull: bool,
    /// Sent with the drive flag (the needle driven along its arc).
    #[serde(default, skip_serializing_if = "is_false")]
    pub drive: bool,
    /// A needle's pose, sent with the pose flag: its rotation vector (the second point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[f64; 3]>,
}

fn is_false(b: &bool) -> bool {
    !*b
}

impl Record {
    /// Appends this record to a recording as one JSON line.
    fn append_to(&self, w: &mut impl Write) -> anyhow::Result<()> {
        serde_json::to_writer(&mut *w, self)?;
        w.write_all(b"\n")?;
        Ok(())
    }
}

fn move_command() -> String {
    "move".into()
}

fn is_move(c: &str) -> bool {
    c == "move"
}

/// What a hand did.
#[derive(Clone, Debug, Default)]
pub struct HandReport {
    pub requests: u64,
    pub ok: u64,
    pub locked: u64,
    /// Other refusals (status name, count).
    pub refused: Vec<(String, u64)>,
    /// Turns skipped because their path could not be made (a tuck that found no loop, a wrap round an
    /// instrument the chain does not have).
    pub skipped_turns: u64,
    /// Key frames: `(label, joints)`, kept when asked for ([`HandConfig::frames_per_turn`]).
    pub frames: Vec<(String, Vec<[f64; 3]>)>,
    /// Moves refused as over-budget and sent again as two halves (not counted in `requests`).
    pub splits: u64,
    /// Every move and instrument request sent, in order, the halves of a split move included.
    pub timings: Vec<Timing>,
    /// How each tightening pull of this hand ended ([`knots::script::Tighten`]).
    pub tightened: Vec<Tightened>,
    /// What a device saw of its samples (`HandConfig::device`; empty otherwise).
    pub device: DeviceReport,
}

/// How a tightening pull ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Tightened {
    /// The turn (1-based).
    pub turn: usize,
    /// Requests sent.
    pub steps: u32,
    /// How far the joint went.
    pub travel: f64,
    /// Why it stopped, after the last request (the service's [`PullStop`] when it stopped short):
    /// `taut` (the stretch from the joint to the next held joint is straight, or out of length),
    /// `jammed` (the contacts could not make way: the knot at the rope's thickness), `out-of-work`
    /// (resolving the contacts would have cost more than a request's work budget, request after
    /// request: the knot resists more than the budget resolves), `limit` (a joint limit),
    /// `stopped` (it went no further without stopping short, or had no direction) or `max-steps`.
    pub why: &'static str,
    /// The joint's pull after the last request.
    pub pull: f64,
}

impl std::fmt::Display for Tightened {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "tighten turn {}: {} after {} requests, {:.3} pulled, pull {:.3e}",
            self.turn, self.why, self.steps, self.travel, self.pull
        )
    }
}

/// One request's times.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// From the call to the response read, as the hand waits for it, µs.
    pub round_trip_us: f64,
    /// The service's own time for it (`solve_ns` of the response: from decoding to journaling).
    pub solve_ns: u64,
    /// Its status's name.
    pub status: &'static str,
    /// A tightening pull's request ([`knots::script::Tighten`]).
    pub pull: bool,
    /// The response's `iterations`: on a chain with collision handling, the resolution passes that
    /// pushed links apart (summed over substeps; for a locked move, those of the substep where it
    /// locked).
    pub passes: u32,
}

/// What the service says a request cost: its own time and its collision passes.
#[derive(Clone, Copy, Debug)]
struct Served {
    solve_ns: u64,
    passes: u32,
}

impl Served {
    fn of(rh: &shared::ResponseHeader) -> Served {
        Served {
            solve_ns: rh.solve_ns,
            passes: rh.iterations,
        }
    }
}

/// How deep a move refused as over-budget is split in halves (at most 2⁴ pieces).
const SPLITS: u32 = 4;

/// How many times the patient hand sends a target again that stopped short inside its frame (out
/// of work).
const PATIENT_RESENDS: u32 = 256;

/// How many answers in a row that bring the joint no nearer the patient hand waits through.
const PATIENT_STILL: u32 = 16;

impl HandReport {
    /// Keeps one request's times: its round trip (since `called`) and what the service said it cost
    /// (`solve_ns` and the collision passes); returns the status's name.
    fn time(&mut self, status: u32, called: Instant, served: Served) -> &'static str {
        let name = Status::from_u32(status).map_or("unknown", |s| s.name());
        self.timings.push(Timing {
            round_trip_us: called.elapsed().as_secs_f64() * 1e6,
            solve_ns: served.solve_ns,
            status: name,
            pull: false,
            passes: served.passes,
        });
        name
    }

    /// Marks the last request's times as a tightening pull's.
    fn pulled(&mut self) {
        if let Some(t) = self.timings.last_mut() {
            t.pull = true;
        }
    }

    /// Counts one request's answer by its status and keeps its times ([`HandReport::time`]);
    /// returns the status's name.
    fn tally(&mut self, status: u32, called: Instant, served: Served) -> &'static str {
        let name = self.time(status, called, served);
        self.requests += 1;
        match Status::from_u32(status) {
            Some(Status::Ok) => self.ok += 1,
            Some(Status::Locked) => self.locked += 1,
            _ => count_refusal(&mut self.refused, name),
        }
        name
    }
}

/// How a hand runs.
#[derive(Debug)]
pub struct HandConfig {
    pub hand: String,
    pub script: Script,
    /// Requests per second (0: as fast as the service answers).
    pub rate_hz: f64,
    /// Longest wait for another hand's turn.
    pub turn_timeout: Duration,
    /// Where to append the record of every request.
    pub record: Option<std::path::PathBuf>,
    /// Print progress to stderr.
    pub progress: bool,
    /// Key frames to keep per turn of this hand, evenly spaced, the last at the turn's end (0: none).
    pub frames_per_turn: usize,
    /// The seed of a perturbed run (0: none) and the tremor's amplitude: every target this hand sends
    /// is shaken by [`knots::script::Tremor`] (amplitude 0: not at all).
    pub tremor: (u64, f64),
    /// Play the script's moves as a haptic device does ([`device`]); `None`: a patient hand, which
    /// waits for every answer and halves a move over the service's budget. Tightening pulls and
    /// instrument turns are played by the patient hand either way.
    pub device: Option<DeviceOptions>,
}

/// A move's points in `buf`: the target, and a pose's rotation vector after it when there is one.
fn move_points(buf: &mut [Vec3; 2], to: [f64; 3], rotation: Option<[f64; 3]>) -> &[Vec3] {
    buf[0] = Vec3::new(to[0], to[1], to[2]);
    match rotation {
        Some(r) => {
            buf[1] = Vec3::new(r[0], r[1], r[2]);
            &buf[..]
        }
        None => &buf[..1],
    }
}

/// CRC-32 of joint positions, as recorded.
pub fn digest(joints: &[Vec3]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    for p in joints {
        for c in p.to_array() {
            h.update(&c.to_le_bytes());
        }
    }
    h.finalize()
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

/// The turn-taking channel of one script.
struct Baton {
    notifier: Notifier<Svc>,
    listener: Listener<Svc>,
    seen: [bool; 256],
}

impl Baton {
    fn open(conn: &Connection, script: &str) -> Result<Baton, CallError> {
        let name = format!("tractrix/turns/{script}");
        let svc = conn
            .node()
            .service_builder(&name.as_str().try_into().map_err(ipc("turn service name"))?)
            .event()
            .open_or_create()
            .map_err(ipc("turn event service"))?;
        Ok(Baton {
            notifier: svc
                .notifier_builder()
                .create()
                .map_err(ipc("turn notifier"))?,
            listener: svc
                .listener_builder()
                .create()
                .map_err(ipc("turn listener"))?,
            seen: [false; 256],
        })
    }

    fn announce(&self, ids: &[usize]) {
        for &id in ids {
            let _ = self.notifier.notify_with_custom_event_id(EventId::new(id));
        }
    }

    /// Waits until every id in `want` has been seen, re-announcing `mine` every 20 ms.
    fn wait_all(
        &mut self,
        want: &[usize],
        mine: &[usize],
        timeout: Duration,
    ) -> Result<(), String> {
        let deadline = Instant::now() + timeout;
        loop {
            self.announce(mine);
            let seen = &mut self.seen;
            let _ = self.listener.timed_wait(
                |ev| {
                    if let Some(s) = seen.get_mut(ev.id.as_value()) {
                        *s = true;
                    }
                },
                Duration::from_millis(20),
            );
            if want.iter().all(|&w| self.seen[w]) {
                return Ok(());
            }
            if Instant::now() >= deadline {
                return Err(format!(
                    "waited {timeout:?} for the other hands (events {want:?})"
                ));
            }
        }
    }
}

/// Runs hand `cfg.hand` of `cfg.script` against a connected service.
pub fn run_hand(conn: &mut Connection, cfg: &HandConfig) -> anyhow::Result<HandReport> {
    let hands = cfg.script.hands();
    let me = hands.iter().position(|h| *h == cfg.hand).with_context(|| {
        format!(
            "hand {:?} has no turn in script {:?} (hands: {hands:?})",
            cfg.hand, cfg.script.name
        )
    })?;
    let mut baton = Baton::open(conn, &cfg.script.name)?;
    let mut record = match &cfg.record {
        Some(p) => Some(std::io::BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("create {}", p.display()))?,
        )),
        None => None,
    };
    let mut report = HandReport::default();
    // SIGINT and SIGTERM reach the node from here on (iceoryx2 installs its handler on the first wait).
    let _ = conn.node().wait(Duration::ZERO);
    let mut grips: Vec<(String, u32, u32)> = Vec::new();
    // The script says whether hands hold their joints: grasped before the first turn, released after
    // the last (also when interrupted by SIGINT or SIGTERM; a hand killed with `kill -9` leaves its
    // grasps, a clamp until `release`).
    if cfg.script.grasp {
        for turn in cfg.script.turn.iter().filter(|t| t.hand == cfg.hand) {
            let chain = conn.require_chain(&turn.chain)?;
            let joint = wire_joint(&turn.joint)?;
            if !grips.iter().any(|g| g.1 == chain && g.2 == joint) {
                grips.push((turn.chain.clone(), chain, joint));
            }
        }
        for (name, chain, joint) in &grips {
            hold(
                conn,
                Command::Grasp,
                name,
                *chain,
                *joint,
                &cfg.hand,
                &mut record,
            )?;
        }
    }
    // Every hand's grip is in place before anyone moves: a hand that started late would otherwise
    // find its end dragged by the first turns.
    let result = if cfg.script.grasp {
        wait_for_grips(conn, cfg)
    } else {
        Ok(())
    }
    .and_then(|()| drive(conn, cfg, me, &hands, &mut baton, &mut record, &mut report));
    // Let go whatever happened (a refused release is reported, the first error wins).
    let mut released = Ok(());
    for (name, chain, joint) in &grips {
        if let Err(e) = hold(
            conn,
            Command::Release,
            name,
            *chain,
            *joint,
            &cfg.hand,
            &mut record,
        ) {
            released = released.and(Err(e));
        }
    }
    result?;
    released?;
    if let Some(w) = &mut record {
        w.flush()?;
    }
    Ok(report)
}

/// Waits (up to the turn timeout) until every joint the script's hands drive is held.
fn wait_for_grips(conn: &mut Connection, cfg: &HandConfig) -> anyhow::Result<()> {
    let mut wanted: Vec<(u32, u32)> = Vec::new();
    for turn in &cfg.script.turn {
        let chain = conn.require_chain(&turn.chain)?;
        let joint = wire_joint(&turn.joint)?;
        if !wanted.contains(&(chain, joint)) {
            wanted.push((chain, joint));
        }
    }
    let deadline = std::time::Instant::now() + cfg.turn_timeout;
    loop {
        let mut missing = None;
        for &(chain, joint) in &wanted {
            let q = conn.call(RequestHeader::new(Command::Query, chain), &[])?;
            let index = if joint == shared::JOINT_HEAD {
                q.header.n_joints.saturating_sub(1)
            } else {
                joint
            };
            if !q.held().iter().any(|&(j, _)| j == index) {
                missing = Some((chain, index));
                break;
            }
        }
        let Some((chain, joint)) = missing else {
            return Ok(());
        };
        if std::time::Instant::now() > deadline {
            anyhow::bail!(
                "joint {joint} of chain {chain} was not grasped by its hand within {:?} (is every hand of \
                 script {:?} running?)",
                cfg.turn_timeout,
                cfg.script.name
            );
        }
        if shared::stop_requested(conn.node(), Duration::from_millis(5)) {
            anyhow::bail!("interrupted (SIGINT or SIGTERM)");
        }
    }
}

/// Sends a grasp or a release and records it.
fn hold(
    conn: &mut Connection,
    command: Command,
    name: &str,
    chain: u32,
    joint: u32,
    hand: &str,
    record: &mut Option<std::io::BufWriter<std::fs::File>>,
) -> anyhow::Result<()> {
    let mut h = RequestHeader::new(command, chain);
    h.joint = joint;
    let sent = now_ns();
    let r = conn.call(h, &[])?;
    if !r.is_ok() {
        anyhow::bail!(
            "{} of joint {joint} of {name:?} refused: {}",
            command.name(),
            r.header.reason_str()
        );
    }
    if let Some(w) = record {
        let rec = Record {
            t_ns: sent,
            hand: hand.to_string(),
            turn: 0,
            chain: name.to_string(),
            joint,
            target: [0.0; 3],
            request_id: r.header.request_id,
            status: "ok".into(),
            sequence: r.header.sequence,
            digest: digest(r.joints()),
            command: command.name().into(),
            axis: None,
            pull: false,
            drive: false,
            rotation: None,
        };
        rec.append_to(w)?;
    }
    Ok(())
}

/// The turns of hand `me`, in order with the other hands'.
fn drive(
    conn: &mut Connection,
    cfg: &HandConfig,
    me: usize,
    hands: &[String],
    baton: &mut Baton,
    record: &mut Option<std::io::BufWriter<std::fs::File>>,
    report: &mut HandReport,
) -> anyhow::Result<()> {
    use anyhow::bail;
    let mut mine: Vec<usize> = Vec::new();
    // A device always shakes (a person's hand never holds a target exactly): unperturbed, its
    // tremor has seed 1.
    let seed = match (cfg.tremor.0, cfg.device) {
        (0, Some(_)) => 1,
        (seed, _) => seed,
    };
    let mut tremor =
        knots::script::Tremor::new(seed, &cfg.hand, if seed == 0 { 0.0 } else { cfg.tremor.1 });
    for (k, turn) in cfg.script.turn.iter().enumerate() {
        if turn.hand != cfg.hand {
            if k > 0 {
                baton
                    .wait_all(&[k - 1], &mine, cfg.turn_timeout)
                    .map_err(anyhow::Error::msg)?;
            }
            continue;
        }
        if k > 0 && cfg.script.turn[k - 1].hand != cfg.hand {
            baton
                .wait_all(&[k - 1], &mine, cfg.turn_timeout)
                .map_err(anyhow::Error::msg)?;
        }
        let chain = conn.require_chain(&turn.chain)?;
        let joint = wire_joint(&turn.joint)?;
        let q = conn.call(RequestHeader::new(Command::Query, chain), &[])?;
        let joints = q.joints();
        let idx = if joint == JOINT_HEAD {
            joints.len().saturating_sub(1)
        } else {
            joint as usize
        };
        if idx >= joints.len() {
            bail!("joint {} is not a joint of {:?}", turn.joint, turn.chain);
        }
        let rope: Vec<[f64; 3]> = joints.iter().map(|p| p.to_array()).collect();
        let instruments: Vec<InstrumentEnds> = q
            .instruments()
            .iter()
            .map(|i| (i.a.to_array(), i.b.to_array()))
            .collect();
        let mut hand = TurnRun {
            conn: &mut *conn,
            cfg,
            record: &mut *record,
            report: &mut *report,
            k,
            turn,
            chain,
        };
        if let Some(g) = &turn.tighten {
            hand.tighten(joint, idx, &rope, g, &mut tremor)?;
        } else if let Some(d) = &turn.drive {
            if joint != JOINT_HEAD && idx + 1 != rope.len() {
                bail!("turn {}: a drive moves the head, the needle's swage", k + 1);
            }
            let moves =
                knots::script::needle_arc(rope[idx], &instruments, d.angle, cfg.script.max_step)
                    .map_err(|e| anyhow::anyhow!("turn {}: drive: {e}", k + 1))?;
            let (targets, rotations): (Vec<_>, Vec<_>) = moves.into_iter().unzip();
            // A steady hand drives the needle (`FLAG_DRIVE`, the points alone: the service turns
            // it along its arc). A trembling one sends its poses instead: a trembling step driven
            // would turn the needle off its circle, and each such error would stay; posed, the
            // needle trembles with the hand and comes back to its circle.
            let (rotations, flags) = if tremor.is_steady() {
                (None, shared::FLAG_DRIVE)
            } else {
                (Some(rotations.as_slice()), shared::FLAG_POSE)
            };
            hand.moves(
                joint,
                rope[idx],
                &targets,
                rotations,
                &q,
                &mut tremor,
                flags,
            )?;
        } else if let Some(p) = &turn.pose {
            if joint != JOINT_HEAD && idx + 1 != rope.len() {
                bail!("turn {}: a pose moves the head, the needle's swage", k + 1);
            }
            let poses = turn
                .pose_moves(p, &rope, idx, &instruments, cfg.script.max_step)
                .map_err(|e| anyhow::anyhow!("turn {}: pose: {e}", k + 1))?;
            let (targets, rotations): (Vec<_>, Vec<_>) = poses.into_iter().unzip();
            hand.moves(
                joint,
                rope[idx],
                &targets,
                Some(&rotations),
                &q,
                &mut tremor,
                shared::FLAG_POSE,
            )?;
        } else if let Some(m) = &turn.instrument {
            let Some(now) = instruments.get(m.index as usize) else {
                bail!(
                    "turn {}: instrument {} of {:?} (it has {})",
                    k + 1,
                    m.index,
                    turn.chain,
                    instruments.len()
                );
            };
            hand.instrument(m.index, rope[idx], *now)?;
        } else {
            // A turn whose path cannot be made (a tuck that finds no loop in the rope, a wrap round
            // an instrument that is not there) is skipped, said on stderr and counted: the other
            // hands go on (the knot is then not tied, which the identification reports).
            let mut targets = match turn.targets_with(&rope, idx, &instruments, cfg.script.max_step)
            {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("hand {}: turn {} skipped: {e}", cfg.hand, k + 1);
                    hand.report.skipped_turns += 1;
                    Vec::new()
                }
            };
            if turn.draw.is_some() {
                // A draw goes on past its last waypoint, along its last step, at most the rope's
                // length (it stops at the tail: `moves`).
                let from = if targets.len() >= 2 {
                    targets[targets.len() - 2]
                } else {
                    rope[idx]
                };
                if let Some(&last) = targets.last() {
                    let d = knots::vec3::sub(last, from);
                    let n = knots::vec3::norm(d);
                    let rope_len: f64 =
                        rope.windows(2).map(|w| knots::vec3::dist(w[0], w[1])).sum();
                    if n > 0.0 && n.is_finite() {
                        let steps = (rope_len / n).ceil().min(1e6) as usize;
                        targets.extend(
                            (1..=steps)
                                .map(|i| knots::vec3::add(last, knots::vec3::scale(d, i as f64))),
                        );
                    }
                }
            }
            hand.moves(joint, rope[idx], &targets, None, &q, &mut tremor, 0)?;
        }
        if let Some(w) = record.as_mut() {
            w.flush()?;
        }
        mine.push(k);
        baton.announce(&mine);
    }
    mine.push(FINISHED + me);
    let everyone: Vec<usize> = (0..hands.len()).map(|i| FINISHED + i).collect();
    baton
        .wait_all(&everyone, &mine, cfg.turn_timeout)
        .map_err(anyhow::Error::msg)?;
    Ok(())
}

/// The rope before the first threaded eyelet of a response (along the rope from the chain's tail to
/// the eyelet's point), if one is threaded: the tail a draw turn leaves.
fn tail_before_eyelet(rh: &shared::ResponseHeader, pts: &[Vec3]) -> Option<f64> {
    let parts = shared::Parts::of_response(rh, pts);
    let e = parts.eyelet_states().find(|e| e.threaded)?;
    let (j, l) = (parts.joints, e.link as usize);
    if l + 1 >= j.len() {
        return None;
    }
    let d = |a: Vec3, b: Vec3| knots::vec3::dist(a.to_array(), b.to_array());
    Some(j[..=l].windows(2).map(|w| d(w[0], w[1])).sum::<f64>() + d(j[l], e.at))
}

/// One turn of a hand: its connection, configuration, recording and report, which turn it is (`k`) and
/// the chain it moves.
struct TurnRun<'a> {
    conn: &'a mut Connection,
    cfg: &'a HandConfig,
    record: &'a mut Option<std::io::BufWriter<std::fs::File>>,
    report: &'a mut HandReport,
    k: usize,
    turn: &'a knots::script::Turn,
    chain: u32,
}

impl TurnRun<'_> {
    /// Moves instrument `index` of the chain along the turn's poses from where it is (`now`), the
    /// joint it follows at `joint_at`.
    fn instrument(
        &mut self,
        index: u32,
        joint_at: [f64; 3],
        now: InstrumentEnds,
    ) -> anyhow::Result<()> {
        use anyhow::bail;
        let poses = self
            .turn
            .instrument_poses(joint_at, now, self.cfg.script.max_step);
        let pacer = Pacer::new(self.cfg.rate_hz);
        for (i, (centre, axis)) in poses.iter().enumerate() {
            pacer.wait(i);
            if self.conn.node().wait(Duration::ZERO).is_err() {
                bail!("interrupted (SIGINT or SIGTERM)");
            }
            let mut h = RequestHeader::new(Command::Instrument, self.chain);
            h.joint = index;
            let sent = now_ns();
            let called = Instant::now();
            let (status, seq, rid, dg, served) = self.conn.call_with(
                h,
                &[
                    Vec3::new(centre[0], centre[1], centre[2]),
                    Vec3::new(axis[0], axis[1], axis[2]),
                ],
                |rh, pts| {
                    let n = (rh.n_joints as usize).min(pts.len());
                    (
                        rh.status,
                        rh.sequence,
                        rh.request_id,
                        digest(&pts[..n]),
                        Served::of(rh),
                    )
                },
            )?;
            let name = self.report.tally(status, called, served);
            if let Some(w) = self.record.as_mut() {
                let r = Record {
                    t_ns: sent,
                    hand: self.cfg.hand.clone(),
                    turn: self.k as u32,
                    chain: self.turn.chain.clone(),
                    joint: index,
                    target: *centre,
                    request_id: rid,
                    status: name.to_string(),
                    sequence: seq,
                    digest: dg,
                    command: Command::Instrument.name().into(),
                    axis: Some(*axis),
                    pull: false,
                    drive: false,
                    rotation: None,
                };
                r.append_to(w)?;
            }
        }
        Ok(())
    }

    /// Records a move request when the hand records: sent at `t_ns`, of `joint` to `target` (with a
    /// pose's `rotation`) and `flags`, answered with request id, status name, sequence number and the
    /// joints' digest.
    #[allow(clippy::type_complexity)]
    fn record_move(
        &mut self,
        (t_ns, joint, target, rotation, flags): (u64, u32, [f64; 3], Option<[f64; 3]>, u32),
        (request_id, status, sequence, digest): (u64, &str, u64, u32),
    ) -> anyhow::Result<()> {
        let Some(w) = self.record.as_mut() else {
            return Ok(());
        };
        Record {
            t_ns,
            hand: self.cfg.hand.clone(),
            turn: self.k as u32,
            chain: self.turn.chain.clone(),
            joint,
            target,
            request_id,
            status: status.to_string(),
            sequence,
            digest,
            command: move_command(),
            axis: None,
            pull: false,
            drive: flags & shared::FLAG_DRIVE != 0,
            rotation,
        }
        .append_to(w)
    }

    /// Moves `joint` (at `start`, the rope as `q` answered) through `targets`, each shaken by the
    /// tremor and sent with `flags` (`FLAG_DRIVE` for a drive; `FLAG_POSE` for a pose, with the
    /// needle's rotation vector of each target in `rotations`); a move over the service's budget is
    /// split in halves, at most `SPLITS` deep.
    #[allow(clippy::too_many_arguments)]
    fn moves(
        &mut self,
        joint: u32,
        start: [f64; 3],
        targets: &[[f64; 3]],
        rotations: Option<&[[f64; 3]]>,
        q: &crate::Reply,
        tremor: &mut knots::script::Tremor,
        flags: u32,
    ) -> anyhow::Result<()> {
        use anyhow::bail;
        if let Some(d) = self.cfg.device {
            return self.device_moves(d, joint, start, targets, rotations, tremor, flags);
        }
        let every = (targets.len() / self.cfg.frames_per_turn.max(1)).max(1);
        if self.cfg.frames_per_turn > 0 && self.report.frames.is_empty() {
            let joints = q.joints().iter().map(|p| p.to_array()).collect();
            self.report
                .frames
                .push((format!("{}: start", self.turn.chain), joints));
        }
        let pacer = Pacer::new(self.cfg.rate_hz);
        // Where the joint is: the query's, then each accepted target (a refused move leaves it).
        let mut at = start;
        // The needle's rotation vector where the last accepted pose left it: a pose split in halves
        // turns it halfway in the first (the turn's first pose, wholly).
        let mut turned: Option<[f64; 3]> = None;
        let mut told_budget = false;
        let mut told_locked = false;
        // A draw turn that has left its tail ([`knots::script::Draw`]).
        let mut drawn = false;
        for (i, t) in targets.iter().enumerate() {
            if drawn {
                break;
            }
            let t = &tremor.apply(*t);
            pacer.wait(i);
            if self.conn.node().wait(Duration::ZERO).is_err() {
                bail!("interrupted (SIGINT or SIGTERM)");
            }
            let keep = self.cfg.frames_per_turn > 0
                && ((i + 1) % every == 0 || i + 1 == targets.len())
                && (i + 1) / every <= self.cfg.frames_per_turn;
            // A move refused as over-budget (more collision work than the service allows one
            // request) is sent again as two halves from where the joint is, each split again if it
            // must, at most `SPLITS` deep: the same path in smaller requests.
            let rotation = rotations.and_then(|r| r.get(i).copied());
            let mut pending = vec![(*t, rotation, 0u32)];
            // Requests of this target sent again after stopping short, those in a row that
            // brought the joint no nearer, and its least distance from it so far.
            let mut resent = (0u32, 0u32, f64::INFINITY);
            while let Some((t, rotation, depth)) = pending.pop() {
                let mut h = RequestHeader::new(Command::Move, self.chain);
                h.joint = joint;
                h.flags = flags;
                let sent = now_ns();
                let called = Instant::now();
                let last = pending.is_empty();
                let mut buf = [Vec3::default(); 2];
                let points = move_points(&mut buf, t, rotation);
                let draw = self.turn.draw;
                let (status, seq, rid, dg, frame, (reason, stopped_at, served, short), tail) =
                    self.conn.call_with(h, points, |rh, pts| {
                        let n = (rh.n_joints as usize).min(pts.len());
                        let frame: Option<Vec<[f64; 3]>> = (keep && last && rh.status == 0)
                            .then(|| pts[..n].iter().map(|p| p.to_array()).collect());
                        let tail = draw
                            .filter(|_| rh.status == 0)
                            .and_then(|_| tail_before_eyelet(rh, pts));
                        (
                            rh.status,
                            rh.sequence,
                            rh.request_id,
                            digest(&pts[..n]),
                            frame,
                            (
                                rh.reason_str(),
                                rh.substeps,
                                Served::of(rh),
                                (rh.pull_stop() == Some(PullStop::Work)).then_some(rh.residual),
                            ),
                            tail,
                        )
                    })?;
                if let (Some(d), Some(t)) = (draw, tail)
                    && t <= d.tail
                {
                    // The tail is left: the draw ends here (the rest of its path given up).
                    drawn = true;
                    pending.clear();
                }
                // Halves help unless the work ran out in the first substep (a piece does
                // fewer substeps); a rope jammed against itself spends every collision pass in
                // one substep whatever the move's length, and splitting only repeats that.
                let splittable = stopped_at != 1 && depth < SPLITS;
                if status == Status::OverBudget as u32 && !splittable {
                    // The rest of this target is given up, as after a lock.
                    pending.clear();
                    if !told_budget {
                        told_budget = true;
                        eprintln!(
                            "hand {}: turn {}: a move is over the service's work budget (said once \
                         per turn): {reason}",
                            self.cfg.hand,
                            self.k + 1
                        );
                    }
                }
                if status == Status::Locked as u32 && !told_locked && self.cfg.progress {
                    told_locked = true;
                    eprintln!(
                        "hand {}: turn {}: a move locked (said once per turn): {reason}",
                        self.cfg.hand,
                        self.k + 1
                    );
                }
                if status == Status::OverBudget as u32 && splittable {
                    self.report.splits += 1;
                    self.report.time(status, called, served);
                    let half = |a: [f64; 3], b: [f64; 3]| {
                        [
                            0.5 * (a[0] + b[0]),
                            0.5 * (a[1] + b[1]),
                            0.5 * (a[2] + b[2]),
                        ]
                    };
                    let mid = half(at, t);
                    // Close rotation vectors of one pose's steps: their mean is the rotation halfway.
                    let mid_rotation = rotation.map(|r| turned.map_or(r, |from| half(from, r)));
                    pending.push((t, rotation, depth + 1));
                    pending.push((mid, mid_rotation, depth + 1));
                } else {
                    let name = self.report.tally(status, called, served);
                    if status == Status::Ok as u32 {
                        at = t;
                        turned = rotation.or(turned);
                    }
                    self.record_move((sent, joint, t, rotation, flags), (rid, name, seq, dg))?;
                    // Stopped short inside its frame, out of work: a patient hand asks again from
                    // where the rope got (the service goes on with a resolution it kept), at most
                    // `PATIENT_RESENDS` times, and gives up after `PATIENT_STILL` answers in a row
                    // that brought the joint no nearer.
                    if let Some(left) = short {
                        let still = if left < resent.2 * (1.0 - 1e-6) {
                            0
                        } else {
                            resent.1 + 1
                        };
                        if resent.0 < PATIENT_RESENDS && still < PATIENT_STILL && !drawn {
                            resent = (resent.0 + 1, still, left.min(resent.2));
                            pending.push((t, rotation, depth));
                        }
                    }
                }
                if let Some(f) = frame {
                    let label = format!(
                        "hand {}, turn {}, move {}",
                        self.cfg.hand,
                        self.k + 1,
                        i + 1
                    );
                    self.report.frames.push((label, f));
                }
            }
            if self.cfg.progress && (i + 1) % 500 == 0 {
                eprintln!(
                    "hand {}: turn {}/{}: {}/{} requests, {} locked",
                    self.cfg.hand,
                    self.k + 1,
                    self.cfg.script.turn.len(),
                    i + 1,
                    targets.len(),
                    self.report.locked
                );
            }
        }
        Ok(())
    }
}

impl TurnRun<'_> {
    /// A tightening pull of `joint` (index `idx`, the rope as `rope`): see [`knots::script::Tighten`].
    fn tighten(
        &mut self,
        joint: u32,
        idx: usize,
        rope: &[[f64; 3]],
        g: &knots::script::Tighten,
        tremor: &mut knots::script::Tremor,
    ) -> anyhow::Result<()> {
        use knots::vec3::{add, norm, scale, sub};
        let d = self
            .conn
            .call(RequestHeader::new(Command::Describe, self.chain), &[])?;
        let thickness = d.header.thickness;
        if let Some(dev) = self.cfg.device {
            let out = self.device_tighten(dev, (joint, idx), rope, (g, thickness), tremor)?;
            if self.cfg.progress {
                eprintln!("hand {}: {out}", self.cfg.hand);
            }
            self.report.tightened.push(out);
            return Ok(());
        }
        let mut rope = rope.to_vec();
        let start = rope[idx];
        let mut still = 0;
        let mut waiting = 0;
        let mut out = Tightened {
            turn: self.k + 1,
            steps: 0,
            travel: 0.0,
            why: "max-steps",
            pull: 0.0,
        };
        let pacer = Pacer::new(self.cfg.rate_hz);
        // A pull over the service's work budget is sent again shorter (halved, at most `SPLITS`
        // times in a row), as a move is split: the knot under a long pull needs more contact work.
        let mut speed = g.speed;
        for i in 0..g.max_steps {
            pacer.wait(i as usize);
            if self.conn.node().wait(Duration::ZERO).is_err() {
                anyhow::bail!("interrupted (SIGINT or SIGTERM)");
            }
            let at = rope[idx];
            let Some(away) = knots::contact::away_from_knot(&rope, idx, thickness) else {
                out.why = "stopped";
                break;
            };
            let target = tremor.apply(add(at, scale(away, speed)));
            let mut h = RequestHeader::new(Command::Move, self.chain);
            h.joint = joint;
            h.flags = shared::FLAG_PULL;
            let sent = now_ns();
            let called = Instant::now();
            let (status, seq, rid, dg, joints, (pull, taut, served, stop)) = self.conn.call_with(
                h,
                &[Vec3::new(target[0], target[1], target[2])],
                |rh, pts| {
                    let parts = shared::Parts::of_response(rh, pts);
                    let j = idx as u32;
                    let k = parts.held_joints().position(|(q, _)| q == j);
                    let taut: Vec<bool> = parts.taut().collect();
                    let pull = k
                        .and_then(|k| parts.pulls.get(k))
                        .map_or(0.0, |p| norm(p.to_array()));
                    let t = k.is_some_and(|k| taut[k] || (k > 0 && taut[k - 1]));
                    (
                        rh.status,
                        rh.sequence,
                        rh.request_id,
                        digest(parts.joints),
                        parts
                            .joints
                            .iter()
                            .map(|p| p.to_array())
                            .collect::<Vec<_>>(),
                        (pull, t, Served::of(rh), rh.pull_stop()),
                    )
                },
            )?;
            out.steps = i + 1;
            if status == Status::OverBudget as u32 && speed > g.speed / f64::from(1 << SPLITS) {
                self.report.splits += 1;
                self.report.time(status, called, served);
                self.report.pulled();
                speed *= 0.5;
                continue;
            }
            let name = self.report.tally(status, called, served);
            self.report.pulled();
            if let Some(w) = self.record.as_mut() {
                Record {
                    t_ns: sent,
                    hand: self.cfg.hand.clone(),
                    turn: self.k as u32,
                    chain: self.turn.chain.clone(),
                    joint,
                    target,
                    request_id: rid,
                    status: name.to_string(),
                    sequence: seq,
                    digest: dg,
                    command: move_command(),
                    axis: None,
                    pull: true,
                    drive: false,
                    rotation: None,
                }
                .append_to(w)?;
            }
            if status != Status::Ok as u32 {
                out.why = "stopped";
                break;
            }
            speed = (speed * 2.0).min(g.speed);
            let moved = norm(sub(joints[idx], at));
            rope = joints;
            out.pull = pull;
            out.travel = norm(sub(rope[idx], start));
            // A pull answered out of work has its resolution kept by the service, which goes on
            // with it when the same pull is asked again: it is not yet stopped (up to
            // [`knots::script::PULL_WAITS`] such answers in a row).
            let waits = moved < 0.1 * speed && stop == Some(PullStop::Work);
            waiting = if waits { waiting + 1 } else { 0 };
            still = if moved >= 0.1 * speed {
                0
            } else if waits && waiting <= knots::script::PULL_WAITS {
                still
            } else {
                still + 1
            };
            if still >= g.stall {
                out.why = if taut { "taut" } else { why_of(stop) };
                break;
            }
        }
        if self.cfg.progress {
            eprintln!("hand {}: {out}", self.cfg.hand);
        }
        self.report.tightened.push(out);
        Ok(())
    }
}

/// How a tightening pull ended, as [`Tightened::why`] says it, from why its last request stopped
/// short (`None`: it did not).
fn why_of(stop: Option<PullStop>) -> &'static str {
    match stop {
        Some(PullStop::Taut) => "taut",
        Some(PullStop::Jammed) => "jammed",
        Some(PullStop::Limit) => "limit",
        Some(PullStop::Work) => "out-of-work",
        None => "stopped",
    }
}

/// A script's joint as the wire's joint field (the head: [`shared::JOINT_HEAD`]).
fn wire_joint(s: &str) -> anyhow::Result<u32> {
    Ok(match parse_joint(s).map_err(anyhow::Error::msg)? {
        Joint::Head => shared::JOINT_HEAD,
        Joint::Index(i) => i,
    })
}
