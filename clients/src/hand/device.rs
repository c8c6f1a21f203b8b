//! A hand played as a haptic device plays it (`hand run --device`): the turn's path walked at the
//! hand's speed and sampled at the device's rate, each request the hand's position at the first
//! sample after the previous answer arrived (a late answer skips the samples in between), never
//! halved or sent again, tremor on; at the end of the path the hand holds still, as a person waits,
//! until its joint is within a tolerance of where the hand is, or a timeout.
//!
//! The person feels the proxy: the held joint is the proxy of the hand, and the virtual coupling
//! pulls the hand toward it with a force that grows with the distance between them (the pull the
//! service reports). A person pushing with a bounded force gets no farther ahead of the joint
//! than [`DeviceOptions::feel`] rope thicknesses (that force over the coupling's stiffness): there
//! the hand stops advancing along its path, its tremor aside, until the joint catches up; it is
//! never sent back, and a sample is never repeated. A tightening turn pulls as a person does: the
//! hand moves away from the knot at its speed, held the same way, and stops when the rope stops the
//! joint there (taut, jammed: the pull the person feels) or the rope gives no direction.

use super::*;

/// How far ahead of its joint, in rope thicknesses, a device's hand gets before the coupling's pull
/// holds it (the default of [`DeviceOptions::feel`]).
pub const FEEL: f64 = 2.0;

/// How a device plays a hand's turns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceOptions {
    /// Samples per second, positive; `hand run --rate` (default 1000 with `--device`).
    pub rate_hz: f64,
    /// The hand's speed along its path, in length units per second, positive (default 10).
    pub speed: f64,
    /// At the end of a turn, how near (length units) the joint must come to the hand before the next
    /// turn starts (default 0.05).
    pub settle: f64,
    /// The longest a hand waits at the end of a turn for its joint (default 2 s); a turn that runs
    /// out of it is counted in [`DeviceReport::unsettled`].
    pub settle_timeout: Duration,
    /// How far ahead of its joint, in rope thicknesses, the hand gets before the coupling's pull
    /// holds it: positive, default [`FEEL`]; `f64::INFINITY` for a device without force feedback
    /// (the path walked at its speed whatever the rope does).
    pub feel: f64,
}

impl DeviceOptions {
    /// Whether a hand `lag` length units from its joint (`None`: not known yet) on a rope
    /// `thickness` thick moves on along its path: it does while within the feel.
    pub fn moves_on(&self, lag: Option<f64>, thickness: f64) -> bool {
        self.feel == f64::INFINITY || lag.is_none_or(|l| l.is_nan() || l <= self.feel * thickness)
    }
}

/// What the hand does on one sample of a device's path ([`Coupling::step`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hand {
    /// It moves on along its path; `pushed`: it has just begun to push through the coupling.
    Moves { pushed: bool },
    /// The coupling's pull holds it where it is.
    Held,
}

/// The person's side of the virtual coupling on a device's path: held while the joint is beyond
/// the feel; held longer than the settle timeout (the rope taut or jammed short of the path), the
/// person pushes on through the pull, at the hand's speed, until the joint is within the feel
/// again.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Coupling {
    pushing: bool,
}

impl Coupling {
    /// One sample: `within`, whether the joint is within the feel
    /// ([`DeviceOptions::moves_on`]); `held_for`, how long the hand has been held (`None`: it is
    /// not held); `timeout`, the settle timeout.
    pub fn step(&mut self, within: bool, held_for: Option<Duration>, timeout: Duration) -> Hand {
        if within {
            self.pushing = false;
            return Hand::Moves { pushed: false };
        }
        if self.pushing {
            return Hand::Moves { pushed: false };
        }
        if held_for.is_some_and(|h| h >= timeout) {
            self.pushing = true;
            return Hand::Moves { pushed: true };
        }
        Hand::Held
    }
}

/// What the device saw of its requests.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeviceReport {
    /// Samples sent.
    pub sent: u64,
    /// Samples skipped: ticks that passed while the device waited for an answer.
    pub skipped: u64,
    /// The proxy's lag of every sample answered with the rope's joints (a refused one is answered
    /// without them): how far the moved joint was from the hand's position (the target sent), in
    /// length units.
    pub lags: Vec<f64>,
    /// Turns whose joint did not come within [`DeviceOptions::settle`] of the hand in time.
    pub unsettled: u64,
    /// Ticks the hand spent held by the coupling ([`DeviceOptions::feel`]), not advancing.
    pub held: u64,
    /// Times a hand held longer than [`DeviceOptions::settle_timeout`] pushed on through the pull
    /// (on until its joint was within the feel again, [`Coupling`]).
    pub pushed: u64,
}

impl DeviceReport {
    /// The lag at quantile `q` in `[0, 1]` (nearest rank); `None` without samples.
    pub fn lag(&self, q: f64) -> Option<f64> {
        let mut v = self.lags.clone();
        v.sort_by(f64::total_cmp);
        let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len().max(1)) - 1;
        v.get(k).copied()
    }
}

/// A turn's path as a device walks it: its start and targets joined by straight segments.
#[derive(Clone, Debug, PartialEq)]
pub struct DevicePath {
    points: Vec<[f64; 3]>,
    /// Length along the path at each point.
    along: Vec<f64>,
}

impl DevicePath {
    /// The path from `start` through `targets`.
    pub fn new(start: [f64; 3], targets: &[[f64; 3]]) -> Self {
        let mut points = Vec::with_capacity(targets.len() + 1);
        points.push(start);
        points.extend_from_slice(targets);
        let mut along = Vec::with_capacity(points.len());
        let mut s = 0.0;
        along.push(s);
        for w in points.windows(2) {
            s += knots::vec3::dist(w[0], w[1]);
            along.push(s);
        }
        DevicePath { points, along }
    }

    /// The path's length.
    pub fn length(&self) -> f64 {
        self.along[self.along.len() - 1]
    }

    /// The point `s` along the path (clamped to its ends), and the index of the target that ends the
    /// segment it lies on (0 for the start).
    pub fn at(&self, s: f64) -> ([f64; 3], usize) {
        let last = self.points.len() - 1;
        if s.is_nan() || s <= 0.0 || last == 0 {
            return (self.points[0], 0);
        }
        if s >= self.length() {
            return (self.points[last], last - 1);
        }
        // The first point at or beyond `s`.
        let k = self.along.partition_point(|&a| a < s).clamp(1, last);
        let (a, b) = (self.along[k - 1], self.along[k]);
        let t = if b > a { (s - a) / (b - a) } else { 1.0 };
        (
            knots::vec3::lerp(self.points[k - 1], self.points[k], t),
            k - 1,
        )
    }
}

/// The tick a device samples next when an answer arrived `elapsed` seconds after the turn began, the
/// last tick sent being `last`: the first tick of `rate_hz` at or after the answer, and at least the
/// one after `last` (a late answer skips the ticks in between; an early one waits for the next).
pub fn next_tick(elapsed: f64, rate_hz: f64, last: u64) -> u64 {
    let due = (elapsed * rate_hz).ceil();
    let due = if due.is_finite() && due > 0.0 {
        due.min(u64::MAX as f64) as u64
    } else {
        0
    };
    due.max(last.saturating_add(1))
}

impl TurnRun<'_> {
    /// [`TurnRun::moves`] as a device plays it ([`DeviceOptions`]): `joint` (at `start`) along the
    /// path through `targets`, each sample shaken by the tremor and sent with `flags` (and the
    /// rotation of the target its segment ends at, for a pose); a refused sample is counted and the
    /// device goes on from where the rope is. A draw turn ends when its tail is left.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn device_moves(
        &mut self,
        d: DeviceOptions,
        joint: u32,
        start: [f64; 3],
        targets: &[[f64; 3]],
        rotations: Option<&[[f64; 3]]>,
        tremor: &mut knots::script::Tremor,
        flags: u32,
    ) -> anyhow::Result<()> {
        let path = DevicePath::new(start, targets);
        let thickness = if d.feel.is_finite() {
            let r = self
                .conn
                .call(RequestHeader::new(Command::Describe, self.chain), &[])?;
            r.header.thickness
        } else {
            0.0
        };
        let t0 = Instant::now();
        let mut tick = 0u64;
        // How far along its path the hand is, and the proxy's lag at the last answer with joints.
        let mut along = 0.0f64;
        let mut felt: Option<f64> = None;
        let mut held_since: Option<Instant> = None;
        let mut coupling = Coupling::default();
        let mut settling: Option<Instant> = None;
        loop {
            if self.conn.node().wait(Duration::ZERO).is_err() {
                anyhow::bail!("interrupted (SIGINT or SIGTERM)");
            }
            let next = next_tick(t0.elapsed().as_secs_f64(), d.rate_hz, tick);
            self.report.device.skipped += next - tick - 1;
            let within = d.moves_on(felt, thickness);
            let held_for = held_since.map(|h: Instant| h.elapsed());
            match coupling.step(within, held_for, d.settle_timeout) {
                Hand::Moves { pushed } => {
                    along += d.speed * (next - tick) as f64 / d.rate_hz;
                    self.report.device.pushed += u64::from(pushed);
                    held_since = None;
                }
                Hand::Held => {
                    self.report.device.held += next - tick;
                    held_since.get_or_insert_with(Instant::now);
                }
            }
            tick = next;
            let due = t0 + Duration::from_secs_f64(tick as f64 / d.rate_hz);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
            let (at, k) = path.at(along);
            let t = tremor.apply(at);
            let rotation = rotations.and_then(|r| r.get(k).copied());
            let mut h = RequestHeader::new(Command::Move, self.chain);
            h.joint = joint;
            h.flags = flags;
            let mut buf = [Vec3::default(); 2];
            let points = move_points(&mut buf, t, rotation);
            let draw = self.turn.draw;
            let sent = now_ns();
            let called = Instant::now();
            let (status, seq, rid, dg, served, reached, tail) =
                self.conn.call_with(h, points, |rh, pts| {
                    let n = (rh.n_joints as usize).min(pts.len());
                    let j = if joint == shared::JOINT_HEAD {
                        n.saturating_sub(1)
                    } else {
                        joint as usize
                    };
                    let tail = draw
                        .filter(|_| rh.status == 0)
                        .and_then(|_| tail_before_eyelet(rh, pts));
                    (
                        rh.status,
                        rh.sequence,
                        rh.request_id,
                        digest(&pts[..n]),
                        Served::of(rh),
                        pts[..n].get(j).map(|p| p.to_array()),
                        tail,
                    )
                })?;
            let name = self.report.tally(status, called, served);
            self.report.device.sent += 1;
            self.record_move((sent, joint, t, rotation, flags), (rid, name, seq, dg))?;
            let lag = reached.map(|r| knots::vec3::dist(r, t));
            if let Some(lag) = lag {
                self.report.device.lags.push(lag);
                felt = Some(lag);
            }
            if let (Some(dr), Some(tl)) = (draw, tail)
                && tl <= dr.tail
            {
                return Ok(()); // the tail is left: the draw ends here
            }
            if along < path.length() {
                continue;
            }
            // At the end of the path the hand holds still (its tremor aside) until the joint is
            // there.
            let since = *settling.get_or_insert_with(Instant::now);
            if lag.is_some_and(|l| l <= d.settle) {
                return Ok(());
            }
            if since.elapsed() >= d.settle_timeout {
                self.report.device.unsettled += 1;
                if self.cfg.progress {
                    eprintln!(
                        "hand {}: turn {}: the joint did not come within {} of the hand in {:?}",
                        self.cfg.hand,
                        self.k + 1,
                        d.settle,
                        d.settle_timeout
                    );
                }
                return Ok(());
            }
        }
    }
}

impl TurnRun<'_> {
    /// A tightening pull of `joint` (index `idx`, the rope as `rope`, `thickness` thick) as a device
    /// plays it ([`FEEL`]): at most `g.max_steps` samples, each sent with the pull flag.
    pub(super) fn device_tighten(
        &mut self,
        d: DeviceOptions,
        (joint, idx): (u32, usize),
        rope: &[[f64; 3]],
        (g, thickness): (&knots::script::Tighten, f64),
        tremor: &mut knots::script::Tremor,
    ) -> anyhow::Result<Tightened> {
        use knots::vec3::{add, dist, norm, scale, sub};
        let mut rope = rope.to_vec();
        let start = rope[idx];
        let mut hand = start;
        let mut out = Tightened {
            turn: self.k + 1,
            steps: 0,
            travel: 0.0,
            why: "max-steps",
            pull: 0.0,
        };
        let began = Instant::now();
        let mut tick = 0u64;
        let mut still = 0u32;
        for i in 0..g.max_steps {
            let next = next_tick(began.elapsed().as_secs_f64(), d.rate_hz, tick);
            let moved = if i == 0 { 1 } else { next - tick };
            self.report.device.skipped += moved.saturating_sub(1);
            tick = next;
            let due = began + Duration::from_secs_f64(tick as f64 / d.rate_hz);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
            let Some(away) = knots::contact::away_from_knot(&rope, idx, thickness) else {
                out.why = "stopped";
                break;
            };
            // Ahead of its joint by the feel, the hand is held by the coupling (the drag of a knot
            // the service resolves over several frames); else it moves on at its speed.
            if d.moves_on(Some(dist(hand, rope[idx])), thickness) {
                hand = add(hand, scale(away, d.speed * moved as f64 / d.rate_hz));
            } else {
                self.report.device.held += moved;
            }
            let t = tremor.apply(hand);
            let mut h = RequestHeader::new(Command::Move, self.chain);
            h.joint = joint;
            h.flags = shared::FLAG_PULL;
            let sent = now_ns();
            let called = Instant::now();
            let (status, seq, rid, dg, served, joints, stop) =
                self.conn
                    .call_with(h, &[Vec3::new(t[0], t[1], t[2])], |rh, pts| {
                        let n = (rh.n_joints as usize).min(pts.len());
                        (
                            rh.status,
                            rh.sequence,
                            rh.request_id,
                            digest(&pts[..n]),
                            Served::of(rh),
                            pts[..n].iter().map(|p| p.to_array()).collect::<Vec<_>>(),
                            rh.pull_stop(),
                        )
                    })?;
            let name = self.report.tally(status, called, served);
            self.report.pulled();
            self.report.device.sent += 1;
            self.record_move(
                (sent, joint, t, None, shared::FLAG_PULL),
                (rid, name, seq, dg),
            )?;
            out.steps = i + 1;
            if status != Status::Ok as u32 || joints.len() <= idx {
                out.why = "stopped";
                break;
            }
            let before = rope[idx];
            rope = joints;
            let lag = dist(rope[idx], t);
            self.report.device.lags.push(lag);
            out.pull = lag;
            out.travel = norm(sub(rope[idx], start));
            // The person feels the knot: the rope stops the joint (taut, jammed, a limit) with the
            // hand the feel ahead, and the hand stops pulling. Out of work, the joint is only
            // behind: the hand waits for it (stopping after [`PULL_WAITS`] answers without it
            // moving).
            still = if dist(rope[idx], before) < 1e-3 * thickness {
                still + 1
            } else {
                0
            };
            let resists =
                !d.moves_on(Some(lag), thickness) && stop.is_some_and(|s| s != PullStop::Work);
            if resists || still > knots::script::PULL_WAITS {
                out.why = why_of(stop);
                break;
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_late_answer_skips_the_ticks_it_missed_and_an_early_one_waits() {
        // At 1 kHz: an answer 0.2 ms after tick 3 was sent is followed by tick 4; one 3.5 ms late
        // by tick 7 (4, 5 and 6 skipped); one exactly on a tick by that tick.
        assert_eq!(next_tick(0.0032, 1000.0, 3), 4);
        assert_eq!(next_tick(0.0065, 1000.0, 3), 7);
        assert_eq!(next_tick(0.005, 1000.0, 3), 5);
        assert_eq!(next_tick(0.0, 1000.0, 0), 1);
        assert_eq!(next_tick(f64::NAN, 1000.0, 9), 10);
    }

    #[test]
    fn the_path_is_walked_by_length_and_held_at_its_end() {
        let p = DevicePath::new([0.0; 3], &[[1.0, 0.0, 0.0], [1.0, 2.0, 0.0]]);
        assert_eq!(p.length(), 3.0);
        assert_eq!(p.at(-1.0), ([0.0; 3], 0));
        assert_eq!(p.at(0.5), ([0.5, 0.0, 0.0], 0));
        assert_eq!(p.at(1.0), ([1.0, 0.0, 0.0], 0));
        assert_eq!(p.at(2.0), ([1.0, 1.0, 0.0], 1));
        assert_eq!(p.at(9.0), ([1.0, 2.0, 0.0], 1));
    }

    #[test]
    fn the_hand_moves_on_within_the_feel_and_is_held_beyond_it() {
        let d = DeviceOptions {
            rate_hz: 1000.0,
            speed: 10.0,
            settle: 0.05,
            settle_timeout: Duration::from_secs(2),
            feel: 2.0,
        };
        // A rope 0.2 thick: held beyond 0.4 units ahead of its joint.
        assert!(d.moves_on(None, 0.2));
        assert!(d.moves_on(Some(0.4), 0.2));
        assert!(!d.moves_on(Some(0.41), 0.2));
        let open = DeviceOptions {
            feel: f64::INFINITY,
            ..d
        };
        assert!(open.moves_on(Some(1e9), 0.0));
    }

    #[test]
    fn a_hand_held_past_the_timeout_pushes_on_until_its_joint_is_within_the_feel() {
        let t = Duration::from_secs(2);
        let mut c = Coupling::default();
        assert_eq!(c.step(true, None, t), Hand::Moves { pushed: false });
        assert_eq!(c.step(false, None, t), Hand::Held);
        assert_eq!(c.step(false, Some(Duration::from_secs(1)), t), Hand::Held);
        assert_eq!(c.step(false, Some(t), t), Hand::Moves { pushed: true });
        // Pushing, it keeps moving on every sample though it is no longer held, not one sample
        // per timeout.
        for _ in 0..100 {
            assert_eq!(c.step(false, None, t), Hand::Moves { pushed: false });
        }
        // The joint within the feel again, the coupling holds it next time it is beyond.
        assert_eq!(c.step(true, None, t), Hand::Moves { pushed: false });
        assert_eq!(c.step(false, None, t), Hand::Held);
    }

    #[test]
    fn lag_quantiles_are_nearest_rank() {
        let r = DeviceReport {
            lags: vec![0.3, 0.1, 0.2, 0.4],
            ..DeviceReport::default()
        };
        assert_eq!(r.lag(0.5), Some(0.2));
        assert_eq!(r.lag(1.0), Some(0.4));
        assert_eq!(r.lag(0.0), Some(0.1));
        assert_eq!(DeviceReport::default().lag(0.5), None);
    }
}
