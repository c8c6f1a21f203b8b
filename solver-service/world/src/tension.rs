//! What a hand holding the rope feels: the pull on every held joint and every instrument, and which
//! stretches between held joints are taut.
//!
//! The tractrix rope is inextensible and has no elasticity, so it has no tension of its own: a rope
//! pulled straight between two fixed points carries whatever force holds it, and the solver does not
//! know that force. What it knows is geometry, and the proxy is the one a haptic device uses anyway,
//! a **virtual coupling**: the hand is joined to the rope's joint by a spring. When a move is sent with
//! the pull flag (`FLAG_PULL`) and the rope cannot go all the way (the stretch to a held joint is
//! out of length, contact has jammed, a joint is at its limit), the joint goes as far toward the
//! target as it can and stops short; the **pull** is the vector from where the hand asked the joint to
//! be to where the rope let it be, `p = x − target`. A coupling of stiffness `k` (N/m) gives the force
//! on the hand, `F = k·p`: zero while the rope is slack (the joint reaches its target), growing with
//! the over-pull once it is taut, pointing back toward the rope. A haptic loop at 1 kHz sends the
//! hand's position every millisecond, so the pull is always that of the owner's last request.
//!
//! The pull travels along the rope: a held joint whose own request was not short feels the pull of
//! the held joint at the other end of its stretch when that stretch is taut (its chord shorter than
//! its rope by no more than [`taut_slack`] and the rounding of its links) or jammed (the other end stopped on contact or a joint limit),
//! and the other end's pull points into the stretch (the rope pulls back, not the hand pushing). It
//! feels the same magnitude, along the rope's first link from it into the stretch: an inextensible
//! rope without friction carries one tension along a stretch. An instrument that follows a joint feels
//! that joint's pull; an instrument posed with the pull flag feels its own (its centre, stopped short
//! of the asked centre).
//!
//! The payload carries one pull per held joint, then one per instrument (the wire's `n_pulls`), and
//! the held joint's third number says whether the stretch from it toward the head is taut.

pub use crate::command::Stop;
use crate::point::{Point, to_point};
use serde::{Deserialize, Serialize};
use tractrix::Chain;
use tractrix::collision::Obstacle;
use tractrix::math::{Embed3, Real, Vector};

/// Where a joint or an instrument was last asked to go, when it stopped short.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Asked {
    /// The held joint, or the instrument's index in the chain's list.
    pub at: usize,
    /// The target (an instrument: its centre).
    pub target: [f64; 3],
    /// Why it stopped short.
    pub stop: Stop,
}

/// The asked targets of a chain's held joints and instruments that stopped short, and the pulls they
/// give (recomputed after every change: a payload reads them without a pass over the chain).
#[derive(Debug, Clone, Default)]
pub struct Tension {
    pub(crate) joints: Vec<Asked>,
    pub(crate) instruments: Vec<Asked>,
    /// One per held joint (ascending), then one per instrument.
    pub(crate) pulls: Vec<Point>,
    /// One per held joint: the stretch from it to the next held joint toward the head is taut.
    pub(crate) taut: Vec<bool>,
}

impl Tension {
    /// Records the outcome of a move of held joint `joint` to `target`: short (`stop`) or not.
    pub(crate) fn joint_moved(&mut self, joint: usize, target: Point, stop: Option<Stop>) {
        self.joints.retain(|a| a.at != joint);
        if let Some(stop) = stop {
            self.joints.push(Asked {
                at: joint,
                target: target.into(),
                stop,
            });
        }
    }
    /// Records the outcome of a pose of instrument `index`.
    pub(crate) fn instrument_moved(&mut self, index: usize, centre: Point, stop: Option<Stop>) {
        self.instruments.retain(|a| a.at != index);
        if let Some(stop) = stop {
            self.instruments.push(Asked {
                at: index,
                target: centre.into(),
                stop,
            });
        }
    }
    /// Forgets joint `joint`'s asked target (released).
    pub(crate) fn released(&mut self, joint: usize) {
        self.joints.retain(|a| a.at != joint);
    }
    /// The asked targets (a snapshot), joints then instruments.
    pub fn asked(&self) -> (&[Asked], &[Asked]) {
        (&self.joints, &self.instruments)
    }
    /// Puts asked targets back (a restored snapshot).
    pub(crate) fn set_asked(&mut self, joints: Vec<Asked>, instruments: Vec<Asked>) {
        self.joints = joints;
        self.instruments = instruments;
    }
    /// The pulls, one per held joint then one per instrument.
    pub fn pulls(&self) -> &[Point] {
        &self.pulls
    }
    /// Whether the stretch from the `k`-th held joint to the next toward the head is taut.
    pub fn taut(&self, k: usize) -> bool {
        self.taut.get(k).copied().unwrap_or(false)
    }
}

/// The rounding of a stretch of `links` links, relative to its length: `64 ε` per link.
fn rounding<T: Real>(links: usize) -> f64 {
    T::EPSILON.to_f64() * 64.0 * links as f64
}

/// How much shorter than its rope a stretch's chord may be and still count as taut, besides the
/// rounding of its links (`64 ε` per link): eight times the chain's fixed-base tolerance (scene
/// `tolerance`, a fraction of the total length) of its total length, since a pull stops a few
/// tolerances inside the length it cannot pass (default: `8e-9` of the total length).
pub fn taut_slack(tolerance: f64, total_length: f64) -> f64 {
    8.0 * tolerance * total_length
}

/// The unit vector of `v`, or zero.
fn unit(v: Point) -> Point {
    let n = v.norm();
    if n > 0.0 && n.is_finite() {
        v / n
    } else {
        Point::zeros()
    }
}

impl Tension {
    /// Recomputes the pulls and taut flags from the asked targets and `c` as it is now, with its
    /// instruments' poses, the joint each follows, the rope's length to each joint (`prefix`) and
    /// how much shorter than its rope a taut stretch may be ([`taut_slack`]). O(held joints +
    /// instruments); no allocation once warm.
    pub(crate) fn refresh<T: Real, const D: usize>(
        &mut self,
        c: &Chain<T, D>,
        instruments: &[Obstacle<T, D>],
        follows: &[Option<usize>],
        prefix: &[f64],
        taut_slack: f64,
    ) where
        Vector<T, D>: Embed3<T>,
    {
        let t = self;
        t.pulls.clear();
        t.taut.clear();
        let n_held = c.held().len();
        let links = c.links();
        let at = |k: usize| c.held_state(k).map(|(j, s)| (j, to_point(&s.value())));
        // Own pulls first (x − target), then what taut or jammed stretches carry.
        for k in 0..n_held {
            let Some((j, x)) = at(k) else { break };
            let own = t
                .joints
                .iter()
                .find(|a| a.at == j)
                .map_or(Point::zeros(), |a| x - Point::from(a.target));
            t.pulls.push(own);
            let taut = match at(k + 1) {
                Some((j2, x2)) => {
                    let rope = prefix[j2] - prefix[j];
                    let slack = taut_slack + rope * rounding::<T>(j2 - j);
                    (x2 - x).norm() >= rope - slack
                }
                None => false,
            };
            t.taut.push(taut);
        }
        // The rope's direction at held joint j into the stretch toward `toward` (a higher or lower
        // held joint).
        let into = |j: usize, toward_head: bool| -> Point {
            let l = if toward_head {
                links.get(j).map(|l| to_point(l))
            } else {
                j.checked_sub(1)
                    .and_then(|i| links.get(i))
                    .map(|l| -to_point(l))
            };
            unit(l.unwrap_or_else(Point::zeros))
        };
        for k in 0..n_held {
            if t.pulls[k] != Point::zeros() {
                continue;
            }
            let Some((j, _)) = at(k) else { break };
            let mut carried = Point::zeros();
            for (nb, toward_head) in [(k.checked_sub(1), false), (Some(k + 1), true)] {
                let Some(nb) = nb.filter(|&nb| nb < n_held) else {
                    continue;
                };
                let Some((jn, _)) = at(nb) else { continue };
                let p = t.pulls[nb];
                if p == Point::zeros() {
                    continue;
                }
                let stretch = if toward_head { k } else { nb };
                let jammed = t
                    .joints
                    .iter()
                    .find(|a| a.at == jn)
                    .is_some_and(|a| a.stop != Stop::Reach);
                // The neighbour's rope pulls it back into this stretch.
                let back = p.dot(&into(jn, !toward_head)) > 0.0;
                if (t.taut[stretch] || jammed) && back {
                    carried += into(j, toward_head) * p.norm();
                }
            }
            t.pulls[k] = carried;
        }
        // Instruments: the pull of the joint they follow, or their own.
        for (i, o) in instruments.iter().enumerate() {
            let p = match follows.get(i).copied().flatten() {
                Some(j) => (0..n_held)
                    .find(|&k| at(k).is_some_and(|(jk, _)| jk == j))
                    .map_or(Point::zeros(), |k| t.pulls[k]),
                None => t
                    .instruments
                    .iter()
                    .find(|a| a.at == i)
                    .map_or(Point::zeros(), |a| {
                        let centre = match *o {
                            Obstacle::Sphere { center, .. } => to_point(&center),
                            Obstacle::Capsule { a, b, .. } => (to_point(&a) + to_point(&b)) * 0.5,
                            Obstacle::HalfSpace { .. } | Obstacle::Block { .. } => Point::zeros(),
                        };
                        centre - Point::from(a.target)
                    }),
            };
            t.pulls.push(p);
        }
    }
}
