//! Hand scripts: what a hand controller does, turn by turn.
//!
//! A script is a list of *turns*. Each turn belongs to one hand (`"A"`, `"B"`, ...), grasps one joint of
//! one chain and drives it through waypoints *relative to where that joint is when the turn starts* (a
//! turn cannot know where the previous turns left the rope). Hands run as separate processes and take
//! the turns in order: a hand waits until the turn before its own is done (`clients::hand`).
//!
//! ```toml
//! name = "square"          # names the turn-taking channel between the hands
//! max_step = 0.1           # longest hand motion per request (length units)
//! grasp = true             # hands hold their joints for the whole script (the default)
//!
//! [[turn]]
//! hand = "A"
//! chain = "reef"
//! joint = "tail"           # "head", "tail" or an index
//! throw = { handedness = "left", outward = [-1, 0, 0], scale = 0.8, exit = 30 }
//! waypoints = [[0, 0, 1]]  # after the throw, relative to the turn's start
//! ```
//!
//! A *throw* is one overhand throw: the grasped end traces an open trefoil, entered from where the end
//! is, heading `outward`, then leaves it by `exit` length units straight on. Traced by a free end of a
//! tractrix rope with collision handling, the rope follows the end like a snake and keeps the knot. A
//! `"left"` throw is a trefoil of negative writhe; `"right"` its mirror. Two throws of opposite
//! handedness in series make a square knot, of the same handedness a granny.
//!
//! A *wide loop* (`wide_loop = { outward = [1, 0, 0], side = [0, 1, 0], radius = 4.5, exit = 5.4 }`)
//! is the overhand the paper's coarse rope keeps: one loop wide enough to survive behind the hand
//! until the end is tucked through it ([`WideLoop`]; built-in `overhand-wide` on 40 unit links). On a
//! rope held at its other end the loop is *fed* (`feed = 1`): the hand draws back toward the hold by as
//! much circle as it has drawn, since a held rope cannot slide after it (built-in `overhand-anchored`);
//! `handedness = "left"` mirrors it.
//!
//! Some turns look at the rope before they move: a *tuck* (`tuck = { outward = [1, 0, 0], side =
//! [0, 1, 0] }`, [`Tuck`]) finds the loop nearest the hand's end in the rope's joints when its turn
//! starts and threads the end through it where it lies (after a wide loop with `tuck = false`, which
//! draws the circle only: built-in `overhands-held`, an overhand in each end of a rope held at both
//! ends); a *wrap* (`wrap = { instrument = 0, at = 3, radius = 1.1 }`, [`Wrap`]) winds the end
//! round one of the chain's instruments where the service reports it. A turn with `instrument = {
//! index = 0, tip = [0, 0, 0], axis = [1, 0, 1] }` ([`InstrumentMove`]) moves that instrument instead
//! of the joint: its tip to the joint (plus `tip`), its axis along `axis` (built-in `instrument-tie`,
//! hand B carrying the needle driver).
//!
//! Errors name the line and the field (the `toml` crate's spans).

use crate::vec3::{add, cross, dot, norm, scale, sub};
use serde::{Deserialize, Serialize};

/// Largest number of turns a script may have (turn numbers travel as event ids, at most 255).
pub const MAX_TURNS: usize = 200;
/// Largest number of waypoints of one turn.
pub const MAX_WAYPOINTS: usize = 100_000;

/// How much a person's hand departs from a script's sizes (relative): ±10 % ([`Script::perturb`]).
pub const HAND_SIZE: f64 = 0.10;
/// How much it departs from a script's directions, per component: ±0.05 ([`Script::perturb`]).
pub const HAND_DIRECTION: f64 = 0.05;
/// How far it puts a waypoint from where the script says: up to 0.1 units ([`Script::perturb`]).
pub const HAND_SHIFT: f64 = 0.1;
/// The tremor on every step: up to 0.02 units ([`Tremor`]).
pub const HAND_TREMOR: f64 = 0.02;

/// SplitMix64: a small seeded generator, the same on every platform (perturbed runs repeat).
#[derive(Clone, Debug)]
struct SplitMix(u64);

impl SplitMix {
    /// Uniform in `[lo, hi)`.
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        lo + (hi - lo) * (((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64)
    }

    /// Uniform in the ball of radius `r` (rejection from the cube).
    fn in_ball(&mut self, r: f64) -> [f64; 3] {
        loop {
            let v = [
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            ];
            if dot(v, v) <= 1.0 {
                return scale(v, r);
            }
        }
    }
}

/// A hand's tremor: every target it sends moved by a fresh random offset of length up to `amplitude`
/// (not accumulated: the hand stays on its path). Seeded by the run's seed and the hand's name, so a
/// perturbed run repeats and two hands do not shake alike.
#[derive(Clone, Debug)]
pub struct Tremor {
    rng: SplitMix,
    amplitude: f64,
}

impl Tremor {
    /// A tremor of up to `amplitude` units for hand `hand` of a run perturbed with `seed`.
    pub fn new(seed: u64, hand: &str, amplitude: f64) -> Tremor {
        let salt = hand.bytes().fold(0xCBF2_9CE4_8422_2325u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x100_0000_01B3)
        });
        Tremor {
            rng: SplitMix(seed ^ salt),
            amplitude: amplitude.max(0.0),
        }
    }

    /// Whether the hand does not shake (amplitude 0).
    pub fn is_steady(&self) -> bool {
        self.amplitude == 0.0
    }

    /// `p` as the shaking hand sends it.
    pub fn apply(&mut self, p: [f64; 3]) -> [f64; 3] {
        if self.amplitude == 0.0 {
            return p;
        }
        add(p, self.rng.in_ball(self.amplitude))
    }
}

/// A whole script.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Script {
    /// Name of the turn-taking channel (hands of one script must agree on it).
    pub name: String,
    /// Longest motion of the grasped joint per request.
    #[serde(default = "default_max_step")]
    pub max_step: f64,
    /// Whether each hand holds the joints it drives for the whole script (a `grasp` before its first
    /// turn, a `release` after its last), so that while one hand moves, the joints the other hands
    /// hold stay where they are. `false`: hands only push their joint along, the rest of the rope
    /// follows freely (the two-handed built-ins, whose throws need the rope to slide: see
    /// BENCHMARKS.md, knots).
    #[serde(default = "default_grasp")]
    pub grasp: bool,
    /// The turns, in order.
    pub turn: Vec<Turn>,
}

fn default_max_step() -> f64 {
    0.1
}

fn default_grasp() -> bool {
    true
}

/// One hand's turn.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Turn {
    pub hand: String,
    pub chain: String,
    /// `"head"`, `"tail"` or a joint index.
    pub joint: String,
    #[serde(default)]
    pub throw: Option<Throw>,
    /// One wide loop and a tuck (after the throw, if both are given).
    #[serde(default)]
    pub wide_loop: Option<WideLoop>,
    /// A tuck through the loop the rope has *now*, found in the rope's joints when the turn starts
    /// (after the wide loop, if both are given, and before the waypoints): the hand that watches
    /// where its loop lies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tuck: Option<Tuck>,
    /// The hand's end wound round one of the chain's instruments (where the instrument is when the
    /// turn starts), after the tuck and before the waypoints.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wrap: Option<Wrap>,
    /// The turn moves one of the chain's instruments instead of the joint (the hand that carries a
    /// needle driver); such a turn moves nothing else.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instrument: Option<InstrumentMove>,
    /// The turn pulls the joint away from the knot until the knot stops shrinking ([`Tighten`]);
    /// such a turn moves nothing else.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tighten: Option<Tighten>,
    /// The turn drives the chain's needle round its own circle ([`Drive`]); such a turn moves
    /// nothing else.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive: Option<Drive>,
    /// The turn poses the chain's needle as a hand turns the needle driver ([`Pose`]): the swage
    /// along the waypoints while the needle turns to the pose.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose: Option<Pose>,
    /// The turn draws the suture through the tissue until a tail of a given length is left
    /// ([`Draw`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub draw: Option<Draw>,
    /// Relative to the joint's position when the turn starts.
    #[serde(default)]
    pub waypoints: Vec<[f64; 3]>,
}

/// The suture drawn through the tissue until a tail of a given length is left, as a surgeon draws it
/// after the needle's pass: the joint goes along the turn's waypoints and on past the last one along
/// its direction (at most the rope's length farther), and the turn ends at the first accepted move
/// that leaves the rope before the first threaded eyelet (the tail, measured along the rope from the
/// chain's tail to the eyelet's point) at most `tail` long. Without a threaded eyelet it is a plain
/// turn. `hand run --tail` sets it on every such turn.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Draw {
    /// The tail's length, in the chain's units.
    pub tail: f64,
}

/// The needle driven round its own circle, as a needle driver turns a curved needle through tissue:
/// the head (the needle's swage) moved along the circle the needle's capsules lie on when the turn
/// starts, `angle` degrees onward (the way its point leads), in steps of the script's `max_step`,
/// every move sent with the drive flag (`FLAG_DRIVE`: the needle goes along its arc, its point cuts
/// the holes the rope then threads; docs/eyelets.md). A trembling hand (`--perturb`) sends each
/// step's pose instead (`FLAG_POSE`: the swage shaken by the tremor, the needle turned as far round
/// its circle as the step): driven, a trembling step would turn the needle off its circle for good.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Drive {
    /// Degrees round the circle.
    pub angle: f64,
}

/// The needle posed as a hand turns the needle driver it holds (a 6-DOF stylus): the swage (the head)
/// moved to the turn's first waypoint while the needle turns from its pose when the turn starts to
/// the one given here, in equal steps that move the swage and the needle's point at most the script's
/// `max_step` each, then along the other waypoints with the needle so posed; every move sent with the
/// pose flag (`FLAG_POSE`: the needle set on its pose,
/// its point cutting holes where it crosses the tissue's surface; docs/eyelets.md).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// The way the needle leaves its swage.
    pub tangent: [f64; 3],
    /// The way it curves (made perpendicular to `tangent`).
    pub bend: [f64; 3],
}

/// A needle's arc points from its swage, its circle's centre and its plane's normal (not unit).
type Circle = (
    Vec<nalgebra::Vector3<f64>>,
    nalgebra::Vector3<f64>,
    nalgebra::Vector3<f64>,
);

/// A tightening pull, as hands cinch a knot: the hand pulls its joint away from the knot, `speed`
/// length units per request, every request sent with the pull flag (`FLAG_PULL`: the joint goes as
/// far as the rope lets it, the rest is its pull; docs/tension.md), until the joint has stopped
/// (moved less than a tenth of `speed`) for `stall` requests in a row: the rope between the hands is
/// taut or the knot has jammed. A request answered out of work (`PullStop::Work`: the service keeps
/// the pull's contact resolution and goes on with it when the same pull is asked again) does not
/// count, up to [`PULL_WAITS`] in a row. "Away from the knot" is away from the centre of the rope's contacts
/// (the joints of links within two thicknesses of a link three or more along the rope), recomputed
/// from every response; along the rope's last link outward when nothing touches. At most `max_steps`
/// requests.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tighten {
    /// Length units per request.
    #[serde(default = "default_tighten_speed")]
    pub speed: f64,
    /// Requests in a row that barely move the joint before the pull stops.
    #[serde(default = "default_tighten_stall")]
    pub stall: u32,
    /// Most requests.
    #[serde(default = "default_tighten_steps")]
    pub max_steps: u32,
}

/// Requests in a row answered out of work that a tightening pull waits through before they count
/// as stopped: the service finishes or locks a kept resolution within its pass limit, so this only
/// bounds a service that would not.
pub const PULL_WAITS: u32 = 64;

fn default_tighten_speed() -> f64 {
    0.05
}

fn default_tighten_stall() -> u32 {
    8
}

fn default_tighten_steps() -> u32 {
    8000
}

impl Tighten {
    /// A pull at `speed` units per request with the default stall count and step limit.
    pub fn at(speed: f64) -> Tighten {
        Tighten {
            speed,
            stall: default_tighten_stall(),
            max_steps: default_tighten_steps(),
        }
    }
}

/// One overhand throw (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Throw {
    pub handedness: Handedness,
    /// Direction the throw heads in (normalised here).
    pub outward: [f64; 3],
    /// Size of the trefoil: the path is `28.8 × scale` long.
    #[serde(default = "default_scale")]
    pub scale: f64,
    /// Straight run after the knot, along `outward`.
    #[serde(default)]
    pub exit: f64,
    /// Enter the trefoil at a lobe's tip, where its tangent runs out of the knot, turned so that the
    /// tangent points along `outward`; leave along the tangent at the lobe's other side, `exit` units
    /// on. The path has no corner, so a rope with a bend radius at most the path's tightest bend
    /// (about 1.29 × `scale`) can follow it (BENCHMARKS.md, "Knots over resolution and bend radius").
    /// The default enters at the trefoil's point nearest the hand and turns away at the end.
    #[serde(default, skip_serializing_if = "is_false")]
    pub lobe: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
}

fn default_scale() -> f64 {
    0.9
}

/// Chirality of a throw.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Handedness {
    Left,
    Right,
}

/// An overhand tied as one wide loop and a tuck, the form the paper's coarse rope can keep: a loop
/// survives behind the hand over a length of rope that grows with the square of its radius and falls
/// with the link length (BENCHMARKS.md, knots), so on unit links the loop must be wide. The hand heads
/// `outward`, draws a circle of `radius` on the `side` it is given (crossing over the rope it laid as
/// it closes the circle, one unit above), dives under the loop's far side, comes up through the loop
/// and leaves over its near side, then pulls `exit` units back along `outward`. The rope must be free
/// to slide after the hand: the knot takes about a loop and a half of rope.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WideLoop {
    /// Direction the hand heads in as it starts the loop (normalised here).
    pub outward: [f64; 3],
    /// The side the loop lies on (its part across `outward`, normalised); the crossings are along
    /// `outward × side`.
    pub side: [f64; 3],
    /// Radius of the loop.
    #[serde(default = "default_loop_radius")]
    pub radius: f64,
    /// Pull after the tuck, back along `outward`.
    #[serde(default = "default_loop_exit")]
    pub exit: f64,
    /// Rope fed toward the hold while the circle is drawn: the hand moves back along `outward` by
    /// `feed` times the length of circle drawn so far, then draws the tuck where the loop lies. A rope
    /// held at its other end cannot slide after the hand as a free one does, so a hand that did not
    /// feed would pull the whole rope, loop included, toward the hold; 1 on a held rope that starts
    /// straight along `outward`, 0 (the default) on a free rope.
    #[serde(default)]
    pub feed: f64,
    /// Chirality of the knot: `"right"` (the default) a trefoil of positive writhe, `"left"` its
    /// mirror (every crossing the other way up), as for throws.
    #[serde(default = "default_loop_handedness")]
    pub handedness: Handedness,
    /// Whether the turn ends with the drawn tuck and pull (the default) or with the circle, for a
    /// [`Tuck`] (a later turn) to thread the loop where it then lies.
    #[serde(default = "default_true", skip_serializing_if = "is_true")]
    pub tuck: bool,
}

fn default_true() -> bool {
    true
}

fn is_true(b: &bool) -> bool {
    *b
}

/// A tuck that watches the rope: when its turn starts, the hand finds the loop nearest its end in the
/// rope's joints (seen along `outward × side`: walking from the end, the first stretch of rope that
/// comes back across itself) and threads the end through it where it lies, as the drawn tuck of a
/// [`WideLoop`] does where the loop was drawn: under the loop's far side (along `outward`), up
/// through its middle, over its near side, then `exit` units on along −`outward`. On a tractrix rope
/// the loop a hand draws does not stay where it was drawn (it is dragged and shrinks as the rope
/// follows the hand, by amounts that depend on the link length: BENCHMARKS.md, knots), so a tuck aimed
/// at the drawn loop misses it on some ropes. No loop in the rope: the turn is refused
/// ([`Turn::targets_on`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tuck {
    /// The loop's frame, as the [`WideLoop`]'s that drew it: the far side lies along `outward`.
    pub outward: [f64; 3],
    /// Across `outward`, toward the loop.
    pub side: [f64; 3],
    /// How far the end passes beyond the loop's rim and above and below its plane.
    #[serde(default = "default_tuck_clearance")]
    pub clearance: f64,
    /// Pull after the tuck, back along `outward`.
    #[serde(default = "default_loop_exit")]
    pub exit: f64,
    /// The knot's chirality, as the loop's: `"left"` passes under and over the other way up.
    #[serde(default = "default_loop_handedness")]
    pub handedness: Handedness,
}

/// The hand's end wound round an instrument's axis (a capsule: the axis from its tip, the scene's end
/// `a`, to its end `b`): from where the end is, straight to the nearest point of a circle of `radius`
/// about the axis `at` units from the tip, then `turns` times round it (`"right"`: counter-clockwise
/// seen from the tip, looking along the axis), advancing `pitch` along the axis per turn so that the
/// turns lie side by side (a negative pitch winds toward the tip). Where the instrument is is read
/// from the service when the turn starts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wrap {
    /// The instrument's index in the chain's `instruments` list.
    pub instrument: u32,
    /// Distance of the first turn from the tip, along the axis.
    pub at: f64,
    /// Radius of the turns about the axis.
    pub radius: f64,
    #[serde(default = "default_wrap_turns")]
    pub turns: f64,
    #[serde(default)]
    pub pitch: f64,
    #[serde(default = "default_loop_handedness")]
    pub handedness: Handedness,
}

fn default_wrap_turns() -> f64 {
    1.0
}

/// One of the chain's instruments moved to a new pose: its tip (the scene's end `a` of a capsule, the
/// centre of a sphere) to `tip`, relative to the turn's joint when the turn starts, and a capsule's axis
/// to point from the tip along `axis`. The hand moves it in steps that move no point of it more than
/// the script's `max_step` (the centre on a straight line, the axis turning at an even rate).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstrumentMove {
    /// The instrument's index in the chain's `instruments` list.
    pub index: u32,
    /// Where the tip goes, relative to the turn's joint.
    pub tip: [f64; 3],
    /// The direction from the tip to the other end (a capsule's).
    #[serde(default = "default_instrument_axis")]
    pub axis: [f64; 3],
}

fn default_instrument_axis() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

/// An instrument's pose as the service reports it: the axis ends `a` (the tip) and `b` (equal for a
/// sphere).
pub type InstrumentEnds = ([f64; 3], [f64; 3]);

fn default_tuck_clearance() -> f64 {
    1.0
}

fn default_loop_handedness() -> Handedness {
    Handedness::Right
}

fn default_loop_radius() -> f64 {
    4.5
}

fn default_loop_exit() -> f64 {
    5.4
}

/// Names accepted by [`Script::builtin`]. The `-u` scripts start from a rope hanging in a U (see
/// BENCHMARKS.md, knots): `overhand-u` with the tail held, `square-u` and `granny-u` with one hand on
/// each end. `overhand-wide` ties the overhand on the paper's rope (chain `paper` of `knots.toml`: 40
/// unit links) with one wide loop; `overhand-anchored` with the tail anchored by the scene (chain
/// `suture`), and `overhand-held` with both ends held, by hand round B's finger (chain `hands`, the
/// first throw of `square-held`);
/// `overhands-held` ties an overhand in each end of it, each hand in its own end, both ends held
/// throughout (two knots in series: the square knot's type, not a reef). `square-held` and
/// `granny-held` tie the two-handed knots round each other (chain `hands`: the long end wound round
/// B's finger, B's end drawn through), `instrument-granny` the granny by instrument tie.
/// `needle-pass` takes a suture's needle through tissue and out (chain `suture-80` of `stitch.toml`);
/// `needle-drive` drives a needle round its own circle through it (chain `needle-drive-80`).
pub const BUILTINS: &[&str] = &[
    "overhand",
    "overhand-wide",
    "overhand-bend",
    "overhand-held",
    "overhand-anchored",
    "square",
    "granny",
    "wave",
    "overhand-u",
    "square-u",
    "granny-u",
    "square-held",
    "granny-held",
    "overhands-held",
    "instrument-tie",
    "surgeons-tie",
    "surgeons-knot",
    "instrument-square",
    "instrument-granny",
    "needle-pass",
    "needle-pass-held",
    "needle-drive",
    "stitch-pass",
];

/// A turn's joint: the chain's head (whatever its length) or an index from its tail (0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Joint {
    /// The head: the last joint, however many links the chain has.
    Head,
    /// A joint by index, 0 = the tail.
    Index(u32),
}

/// `"head"`, `"tail"` (index 0) or an index.
pub fn parse_joint(s: &str) -> Result<Joint, String> {
    match s {
        "head" => Ok(Joint::Head),
        "tail" => Ok(Joint::Index(0)),
        n => n
            .parse::<u32>()
            .map(Joint::Index)
            .map_err(|_| format!("joint {n:?}: expected head, tail or an index")),
    }
}

mod builtin;
mod load;
mod needle;
mod paths;
#[cfg(test)]
mod tests;

pub use builtin::*;
pub use needle::*;
use paths::*;
