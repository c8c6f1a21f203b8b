//! Hand scripts: what a hand controller does, turn by turn.
//!
//! A script is a list of *turns*. Each turn belongs to one hand (`"A"`, `"B"`, ...), grasps one joint of
//! one chain and drives it through waypoints *relative to where that joint is when the turn starts* (a
//! turn cannot know where the previous turns left the rope). Hands run as separate processes and take
//! the turns in order: a hand waits until the turn before its own is done ([`crate::hand`]).
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

/// The needle among `instruments` (its capsules end to end from `swage`): the arc's points from the
/// swage, the circle's centre (the circumcentre of the swage, the first capsule's far end and the
/// point) and the normal of its plane (not unit).
fn needle_circle(swage: [f64; 3], instruments: &[InstrumentEnds]) -> Result<Circle, String> {
    use nalgebra::Vector3;
    let v = |p: [f64; 3]| Vector3::new(p[0], p[1], p[2]);
    let near = |p: Vector3<f64>, q: Vector3<f64>| (p - q).norm() <= 1e-9 * (1.0 + p.norm());
    // The needle: the capsules end to end from the swage.
    let mut arc = vec![v(swage)];
    while let Some((_, b)) = instruments
        .iter()
        .find(|(a, _)| near(v(*a), *arc.last().unwrap()))
    {
        arc.push(v(*b));
        if arc.len() > instruments.len() + 1 {
            break;
        }
    }
    if arc.len() < 3 {
        return Err("no needle of two capsules or more starts at the swage".into());
    }
    let (p0, p1, p2) = (arc[0], arc[1], arc[arc.len() - 1]);
    let (a, b) = (p1 - p0, p2 - p0);
    let n = a.cross(&b);
    if n.norm() <= 1e-12 || !n.norm().is_finite() {
        return Err("the needle is straight".into());
    }
    let centre = p0
        + (b.cross(&n) * a.norm_squared() + n.cross(&a) * b.norm_squared())
            / (2.0 * n.norm_squared());
    Ok((arc, centre, n))
}

/// The moves of a [`Drive`]: the swage at `swage` moved round the circle of the needle among
/// `instruments` (the capsules end to end from the swage) by `angle_deg`, in steps of at most
/// `max_step` along the circle, each with the needle's rotation vector there (its frame now turned
/// about the circle's axis as far as the swage: the pose a trembling hand's drive sends, `FLAG_POSE`;
/// a steady one sends the points alone with `FLAG_DRIVE`).
pub fn needle_arc(
    swage: [f64; 3],
    instruments: &[InstrumentEnds],
    angle_deg: f64,
    max_step: f64,
) -> Result<Vec<PoseMove>, String> {
    use nalgebra::{Unit, UnitQuaternion};
    let (arc, centre, n) = needle_circle(swage, instruments)?;
    if !(max_step > 0.0 && angle_deg.is_finite()) {
        return Err("the step or the angle is not usable".into());
    }
    let p0 = arc[0];
    let now = needle_frame(&arc, centre)?;
    let r = (p0 - centre).norm();
    let angle = angle_deg.to_radians();
    let steps = ((angle.abs() * r / max_step).ceil() as usize).clamp(1, 1 << 20);
    let axis = Unit::new_normalize(n);
    Ok((1..=steps)
        .map(|k| {
            let turn = UnitQuaternion::from_axis_angle(&axis, angle * k as f64 / steps as f64);
            let p = centre + turn * (p0 - centre);
            let q = (turn * now).scaled_axis();
            ([p.x, p.y, p.z], [q.x, q.y, q.z])
        })
        .collect())
}

/// The needle's frame from its arc's points and its circle's centre: x its tangent at the swage (the
/// first capsule's chord made perpendicular to the bend: the chord is turned half a capsule's angle
/// from the tangent), y its bend toward the centre.
fn needle_frame(
    arc: &[nalgebra::Vector3<f64>],
    centre: nalgebra::Vector3<f64>,
) -> Result<nalgebra::UnitQuaternion<f64>, String> {
    let bend = centre - arc[0];
    let chord = arc[1] - arc[0];
    frame(
        chord - bend * (chord.dot(&bend) / bend.norm_squared()),
        bend,
    )
}

/// The rotation whose x is along `t` and whose y along `b` made perpendicular to it.
fn frame(
    t: nalgebra::Vector3<f64>,
    b: nalgebra::Vector3<f64>,
) -> Result<nalgebra::UnitQuaternion<f64>, String> {
    let t = t.try_normalize(1e-12).ok_or("a zero tangent")?;
    let b = (b - t * b.dot(&t))
        .try_normalize(1e-12)
        .ok_or("a bend along the tangent")?;
    let m = nalgebra::Rotation3::from_basis_unchecked(&[t, b, t.cross(&b)]);
    Ok(nalgebra::UnitQuaternion::from_rotation_matrix(&m))
}

/// One move of a [`Pose`] turn: where the swage goes, and the needle's rotation vector.
pub type PoseMove = ([f64; 3], [f64; 3]);

/// The moves of a [`Pose`] turn: the needle among `instruments` (its capsules end to end from
/// `swage`) turned from its pose now to `pose` while its swage goes along the first `turning` points
/// of `path` (the turn's targets; empty: it stays), in equal steps, as many as those points and
/// enough that the needle's point moves at most `max_step` in each by the turn; then posed so along
/// the rest of the path. Each move: where the swage goes and the needle's rotation vector from its
/// own frame (it leaves the swage along x, curving toward y), as `FLAG_POSE` sends them.
pub fn needle_poses(
    swage: [f64; 3],
    instruments: &[InstrumentEnds],
    path: &[[f64; 3]],
    turning: usize,
    pose: &Pose,
    max_step: f64,
) -> Result<Vec<PoseMove>, String> {
    use nalgebra::Vector3;
    let (arc, centre, _) = needle_circle(swage, instruments)?;
    let v = |p: [f64; 3]| Vector3::new(p[0], p[1], p[2]);
    if max_step.is_nan()
        || max_step <= 0.0
        || !pose.tangent.iter().chain(&pose.bend).all(|c| c.is_finite())
    {
        return Err("the step or the pose is not usable".into());
    }
    let r = (arc[0] - centre).norm();
    let now = needle_frame(&arc, centre)?;
    let goal = frame(v(pose.tangent), v(pose.bend)).map_err(|e| format!("the pose: {e}"))?;
    // The point is at most twice the radius from the swage: a turn by θ moves it at most 2rθ.
    let (path, rest) = path.split_at(turning.min(path.len()));
    let turn = now.angle_to(&goal);
    let steps = ((2.0 * r * turn / max_step).ceil() as usize)
        .max(path.len())
        .clamp(1, 1 << 20);
    // The swage's place at fraction f of the path (its points equally spaced in f from the start).
    let pts: Vec<Vector3<f64>> = std::iter::once(arc[0])
        .chain(path.iter().map(|p| v(*p)))
        .collect();
    let along = |f: f64| {
        let x = f * (pts.len() - 1) as f64;
        let i = (x.floor() as usize).min(pts.len() - 1);
        let j = (i + 1).min(pts.len() - 1);
        pts[i] + (pts[j] - pts[i]) * (x - i as f64)
    };
    let posed = goal.scaled_axis();
    Ok((1..=steps)
        .map(|k| {
            let f = k as f64 / steps as f64;
            let p = along(f);
            let q = now.slerp(&goal, f).scaled_axis();
            ([p.x, p.y, p.z], [q.x, q.y, q.z])
        })
        .chain(rest.iter().map(|p| (*p, [posed.x, posed.y, posed.z])))
        .collect())
}

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
    2000
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

impl Script {
    /// Parses and checks a script; errors carry the line.
    pub fn parse(text: &str, file: &str) -> Result<Script, String> {
        let s: Script = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|sp| text[..sp.start.min(text.len())].matches('\n').count() + 1);
            match line {
                Some(l) => format!("{file}:{l}: {}", e.message().trim()),
                None => format!("{file}: {}", e.message().trim()),
            }
        })?;
        s.check().map_err(|m| format!("{file}: {m}"))?;
        Ok(s)
    }

    /// Checks sizes and numbers (a script from a file is outside input).
    pub fn check(&self) -> Result<(), String> {
        if self.turn.is_empty() || self.turn.len() > MAX_TURNS {
            return Err(format!(
                "a script has 1..={MAX_TURNS} turns, not {}",
                self.turn.len()
            ));
        }
        if !(self.max_step > 0.0 && self.max_step.is_finite()) {
            return Err(format!(
                "max_step {} is not a positive length",
                self.max_step
            ));
        }
        if self.name.is_empty()
            || self.name.len() > 64
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(format!(
                "name {:?}: 1..=64 letters, digits, - or _",
                self.name
            ));
        }
        for (k, t) in self.turn.iter().enumerate() {
            let at = |m: String| format!("turn {}: {m}", k + 1);
            if t.waypoints.len() > MAX_WAYPOINTS {
                return Err(at(format!("more than {MAX_WAYPOINTS} waypoints")));
            }
            if t.hand.is_empty() || t.hand.len() > 16 {
                return Err(at("hand: 1..=16 characters".into()));
            }
            parse_joint(&t.joint).map_err(at)?;
            if !t.waypoints.iter().flatten().all(|x| x.is_finite()) {
                return Err(at("a waypoint is not finite".into()));
            }
            if let Some(d) = &t.draw
                && !(d.tail >= 0.0 && d.tail <= 1e9)
            {
                return Err(at(format!("draw.tail {} is not in [0, 1e9]", d.tail)));
            }
            if let Some(th) = &t.throw {
                let n = norm(th.outward);
                if !(n > 0.0 && n.is_finite()) {
                    return Err(at("throw.outward must be a non-zero vector".into()));
                }
                if !(th.scale > 0.0 && th.scale.is_finite() && th.scale <= 1e6) {
                    return Err(at(format!("throw.scale {} is not in (0, 1e6]", th.scale)));
                }
                if !(th.exit >= 0.0 && th.exit.is_finite() && th.exit <= 1e9) {
                    return Err(at(format!("throw.exit {} is not in [0, 1e9]", th.exit)));
                }
            }
            if let Some(k) = &t.tuck {
                if loop_frame(k.outward, k.side).is_none() {
                    return Err(at(
                        "tuck.outward and tuck.side must be finite, non-zero and not parallel"
                            .into(),
                    ));
                }
                if !(k.clearance > 0.0 && k.clearance <= 1e6) {
                    return Err(at(format!(
                        "tuck.clearance {} is not in (0, 1e6]",
                        k.clearance
                    )));
                }
                if !(k.exit >= 0.0 && k.exit <= 1e9) {
                    return Err(at(format!("tuck.exit {} is not in [0, 1e9]", k.exit)));
                }
            }
            if let Some(w) = &t.wrap {
                if !(w.radius > 0.0 && w.radius.is_finite() && w.radius <= 1e6) {
                    return Err(at(format!("wrap.radius {} is not in (0, 1e6]", w.radius)));
                }
                if !(w.turns > 0.0 && w.turns <= 100.0) {
                    return Err(at(format!("wrap.turns {} is not in (0, 100]", w.turns)));
                }
                if !(w.at.is_finite()
                    && w.at.abs() <= 1e6
                    && w.pitch.is_finite()
                    && w.pitch.abs() <= 1e6)
                {
                    return Err(at(
                        "wrap.at and wrap.pitch must be finite, at most 1e6".into()
                    ));
                }
            }
            if let Some(m) = &t.instrument {
                let n = norm(m.axis);
                if !(m.tip.iter().all(|c| c.is_finite() && c.abs() <= 1e9)
                    && n > 0.0
                    && n.is_finite())
                {
                    return Err(at(
                        "instrument.tip must be finite and instrument.axis finite and non-zero"
                            .into(),
                    ));
                }
                if t.throw.is_some()
                    || t.wide_loop.is_some()
                    || t.tuck.is_some()
                    || t.wrap.is_some()
                    || !t.waypoints.is_empty()
                {
                    return Err(at(
                        "a turn that moves an instrument moves nothing else".into()
                    ));
                }
            }
            if let Some(g) = &t.tighten {
                if !(g.speed > 0.0 && g.speed.is_finite() && g.speed <= 1e6) {
                    return Err(at(format!("tighten.speed {} is not in (0, 1e6]", g.speed)));
                }
                if !(1..=10_000).contains(&g.stall) || g.max_steps as usize > MAX_WAYPOINTS {
                    return Err(at(format!(
                        "tighten.stall must be in 1..=10000 and tighten.max_steps at most \
                         {MAX_WAYPOINTS}"
                    )));
                }
                if t.throw.is_some()
                    || t.wide_loop.is_some()
                    || t.tuck.is_some()
                    || t.wrap.is_some()
                    || t.instrument.is_some()
                    || !t.waypoints.is_empty()
                {
                    return Err(at("a turn that tightens moves nothing else".into()));
                }
            }
            if let Some(l) = &t.wide_loop {
                if loop_frame(l.outward, l.side).is_none() {
                    return Err(at(
                        "wide_loop.outward and wide_loop.side must be finite, non-zero and not parallel"
                            .into(),
                    ));
                }
                if !(l.radius > 0.0 && l.radius.is_finite() && l.radius <= 1e6) {
                    return Err(at(format!(
                        "wide_loop.radius {} is not in (0, 1e6]",
                        l.radius
                    )));
                }
                if !(l.exit >= 0.0 && l.exit.is_finite() && l.exit <= 1e9) {
                    return Err(at(format!("wide_loop.exit {} is not in [0, 1e9]", l.exit)));
                }
                if !(l.feed.is_finite() && (0.0..=10.0).contains(&l.feed)) {
                    return Err(at(format!("wide_loop.feed {} is not in [0, 10]", l.feed)));
                }
            }
        }
        Ok(())
    }

    /// Perturbs the script as a person's hand departs from it (issue 34's magnitudes, [`HAND_SIZE`],
    /// [`HAND_DIRECTION`], [`HAND_SHIFT`]): each throw's, wide loop's and wrap's size by up to ±10 %,
    /// each component of a direction by up to ±0.05, an exit by up to ±1 unit (kept ≥ 0), and every
    /// waypoint, a wrap's place along its instrument and an instrument's tip by a random offset of
    /// length up to 0.1 units (half the knot ropes' thickness). The tremor on every step is the hand's
    /// ([`Tremor`]). One seed gives one script, so the hands of a script agree when each perturbs it
    /// with the same seed; seed 0 leaves it as it is.
    pub fn perturb(&mut self, seed: u64) {
        if seed == 0 {
            return;
        }
        let mut rng = SplitMix(seed);
        let size = |rng: &mut SplitMix| rng.range(1.0 - HAND_SIZE, 1.0 + HAND_SIZE);
        let turn = |rng: &mut SplitMix, v: &mut [f64; 3]| {
            for c in v {
                *c += rng.range(-HAND_DIRECTION, HAND_DIRECTION);
            }
        };
        let exit = |rng: &mut SplitMix, e: f64| (e + rng.range(-1.0, 1.0)).max(0.0);
        for t in &mut self.turn {
            if let Some(th) = &mut t.throw {
                th.scale *= size(&mut rng);
                turn(&mut rng, &mut th.outward);
                th.exit = exit(&mut rng, th.exit);
            }
            if let Some(l) = &mut t.wide_loop {
                l.radius *= size(&mut rng);
                turn(&mut rng, &mut l.outward);
                l.exit = exit(&mut rng, l.exit);
            }
            if let Some(w) = &mut t.wrap {
                w.radius *= size(&mut rng);
                w.at += rng.range(-HAND_SHIFT, HAND_SHIFT);
            }
            if let Some(m) = &mut t.instrument {
                m.tip = add(m.tip, rng.in_ball(HAND_SHIFT));
            }
            if let Some(k) = &mut t.tuck {
                turn(&mut rng, &mut k.outward);
                k.exit = exit(&mut rng, k.exit);
            }
            for w in &mut t.waypoints {
                *w = add(*w, rng.in_ball(HAND_SHIFT));
            }
        }
    }

    /// The script with every draw turn ([`Draw`]) leaving a tail of `tail` (`hand run --tail`).
    pub fn with_tail(mut self, tail: f64) -> Script {
        for t in self.turn.iter_mut().filter(|t| t.draw.is_some()) {
            t.draw = Some(Draw { tail });
        }
        self
    }

    /// The script followed by a tightening phase (`hand run --tighten SPEED`): every hand pulls the
    /// rope's end it holds away from the knot ([`Tighten`]) in turn, in the order of the hands, twice
    /// round (the first round cinches the knot, the second finds whether the other end's pull left
    /// room). An end is a chain's tail or head some turn of the hand drives; hands that drive neither
    /// (a hand that only carries an instrument) do not pull.
    pub fn with_tighten(mut self, speed: f64) -> Script {
        let mut ends: Vec<(String, String, String)> = Vec::new();
        for t in &self.turn {
            let end = t.joint == "tail" || t.joint == "head" || t.joint == "0";
            let key = (t.hand.clone(), t.chain.clone(), t.joint.clone());
            if end && t.instrument.is_none() && !ends.contains(&key) {
                ends.push(key);
            }
        }
        for _ in 0..2 {
            for (hand, chain, joint) in &ends {
                if self.turn.len() >= MAX_TURNS {
                    break;
                }
                self.turn.push(Turn {
                    hand: hand.clone(),
                    chain: chain.clone(),
                    joint: joint.clone(),
                    throw: None,
                    wide_loop: None,
                    tuck: None,
                    wrap: None,
                    instrument: None,
                    tighten: Some(Tighten::at(speed)),
                    drive: None,
                    pose: None,
                    draw: None,
                    waypoints: Vec::new(),
                });
            }
        }
        self
    }

    /// The hands of the script, in order of first appearance.
    pub fn hands(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for t in &self.turn {
            if !out.contains(&t.hand) {
                out.push(t.hand.clone());
            }
        }
        out
    }

    /// A built-in script by name (see [`BUILTINS`]).
    pub fn builtin(name: &str) -> Option<Script> {
        let throw = |h, outward: [f64; 3], exit| Throw {
            handedness: h,
            outward,
            scale: 0.8,
            exit,
            lobe: false,
        };
        let two_hands = |second| Script {
            name: name.into(),
            max_step: 0.05,
            // The throws need the rope to slide through the other end's hand: with both ends
            // held, none of them ties (BENCHMARKS.md, knots).
            grasp: false,
            turn: vec![
                // A throws at the tail end and walks on far enough that B's pull, which drags the
                // rope toward B, does not bring the tail back through A's knot.
                turn(
                    "A",
                    "reef",
                    "tail",
                    Some(throw(Handedness::Left, [-1.0, 0.0, 0.0], 30.0)),
                    vec![],
                ),
                turn(
                    "B",
                    "reef",
                    "head",
                    Some(throw(second, [1.0, 0.0, 0.0], 0.0)),
                    vec![],
                ),
            ],
        };
        match name {
            "overhand" => Some(Script {
                name: name.into(),
                max_step: 0.1,
                grasp: true,
                turn: vec![turn(
                    "A",
                    "overhand",
                    "head",
                    Some(Throw {
                        handedness: Handedness::Left,
                        outward: [1.0, 0.0, 0.0],
                        scale: 0.9,
                        // The rope slides through the knot after the head: walking on 12 units
                        // brings the knot near the middle of the 40-unit rope.
                        exit: 12.0,
                        lobe: false,
                    }),
                    vec![],
                )],
            }),
            // A suture with a bend radius (chains `bend-80`, `bend-160`, `bend-320` of knots.toml: 40
            // units, R_min 1.5): the head draws the trefoil entered at a lobe, a path with no corner
            // (tightest bend about 1.55 units), then walks on 3 units. One script for every resolution
            // from 80 links on (BENCHMARKS.md, "Knots over resolution and bend radius").
            "overhand-bend" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: vec![turn(
                    "A",
                    "bend-80",
                    "head",
                    Some(Throw {
                        handedness: Handedness::Left,
                        outward: [1.0, 0.0, 0.0],
                        scale: 1.2,
                        exit: 3.0,
                        lobe: true,
                    }),
                    vec![],
                )],
            }),
            // The paper's rope (40 unit links, free): one wide loop and a tuck, heading away from the
            // rope along +x with the loop on the +y side.
            "overhand-wide" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: vec![Turn {
                    wide_loop: Some(WideLoop {
                        outward: [1.0, 0.0, 0.0],
                        side: [0.0, 1.0, 0.0],
                        radius: default_loop_radius(),
                        exit: default_loop_exit(),
                        feed: 0.0,
                        handedness: Handedness::Right,
                        tuck: true,
                    }),
                    ..turn("A", "paper", "head", None, vec![])
                }],
            }),
            "square" => Some(two_hands(Handedness::Right)),
            "granny" => Some(two_hands(Handedness::Left)),
            // The tail held (by the scene or a second hand), the rope hanging in a U from it to the
            // hand, both ends pointing up (+y): the head throws upward, away from the rope, and walks
            // on, then sideways.
            "overhand-u" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: vec![
                    turn(
                        "A",
                        "rope",
                        "head",
                        Some(Throw {
                            handedness: Handedness::Left,
                            outward: [0.0, 1.0, 0.0],
                            scale: 0.9,
                            exit: 6.0,
                            lobe: false,
                        }),
                        vec![],
                    ),
                    turn("A", "rope", "head", None, vec![[4.0, 0.0, 0.0]]),
                ],
            }),
            // The paper's rope with its tail anchored by the scene (chain `suture`): the head's hand
            // draws the wide loop feeding rope toward the anchor, tucks, then pulls the knot snug
            // back along the rope (tuned to unit links).
            "overhand-anchored" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: vec![
                    Turn {
                        wide_loop: Some(held_loop()),
                        ..turn("A", "suture", "head", None, vec![])
                    },
                    turn("A", "suture", "head", None, vec![[-HELD_PULL, 0.0, 0.0]]),
                ],
            }),
            // The overhand with both ends held, tied by hand round B's finger (chain `hands`): the
            // first throw of `square-held`, one script at every resolution.
            "overhand-held" => Some(instrument_tie(name, "hands", 1.0)),
            "overhands-held" => Some(overhands_held(name, Handedness::Left)),
            // The two-handed knots tied round each other: B's finger takes the driver's part.
            "square-held" => Some(two_throw_tie(name, "hands", 1.0, Handedness::Left)),
            "granny-held" => Some(two_throw_tie(name, "hands", 1.0, Handedness::Right)),
            "instrument-tie" => Some(instrument_tie(name, "tie", 1.0)),
            "surgeons-tie" => Some(instrument_tie(name, "tie", 2.0)),
            "surgeons-knot" => Some(two_throw_tie(name, "tie", 2.0, Handedness::Left)),
            "instrument-square" => Some(two_throw_tie(name, "tie", 1.0, Handedness::Left)),
            "instrument-granny" => Some(two_throw_tie(name, "tie", 1.0, Handedness::Right)),
            "square-u" => Some(two_hands_u(name, Handedness::Right)),
            "granny-u" => Some(two_hands_u(name, Handedness::Left)),
            "wave" => Some(Script {
                name: name.into(),
                max_step: 0.1,
                grasp: true,
                turn: vec![turn(
                    "A",
                    "rope",
                    "head",
                    None,
                    vec![
                        [2.0, 3.0, 0.0],
                        [4.0, -3.0, 1.0],
                        [6.0, 3.0, -1.0],
                        [8.0, 0.0, 0.0],
                    ],
                )],
            }),
            // The needle's pass of a stitch (chain `suture-80` of `stitch.toml`, the head the
            // needle's end): down into the tissue 4.5 before the head's start, under the incision
            // (x = 28) 2.2 deep, up and out 11.5 on, then drawing the suture through until about 4
            // units of tail are left before the entry. Where the head
            // goes in and comes out the service makes the entry and exit eyelets. Not grasped: the
            // head is the moved joint; nothing else holds the suture.
            "needle-pass" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: false,
                turn: vec![turn(
                    "A",
                    "suture-80",
                    "head",
                    None,
                    vec![
                        [3.0, 0.0, -1.0],
                        [4.5, 0.0, -2.8],
                        [6.0, 0.0, -3.8],
                        [8.0, 0.0, -4.2],
                        [10.0, 0.0, -3.8],
                        [11.5, 0.0, -2.8],
                        [12.5, 0.0, -1.0],
                        [14.0, 0.0, 0.5],
                        [17.0, 0.0, 2.0],
                    ],
                )],
            }),
            // The pass with two hands (chain `suture-held-80` of `stitch.toml`, laid across the
            // table from (20, -5, 2) along y): the forceps (hand B) hold the tail where it lies, the
            // driver (hand A) holds the head and swings it round the forceps to beside the bite
            // (sideways, then on, the suture following like a snake: moved back along its own line,
            // a tractrix rope is pushed end on and piles up), loads the needle and drives it through
            // both sides of x = 28 as `stitch-pass` does, then draws the suture through both eyelets
            // toward the held tail.
            "needle-pass-held" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: [
                    // A little toward the needle (a grip perturbed by up to 0.1 stays within the
                    // rope's reach: the suture lies straight between the hands).
                    vec![turn(
                        "B",
                        "suture-held-80",
                        "tail",
                        None,
                        vec![[0.0, 0.3, 0.0]],
                    )],
                    // Round the forceps to beside the bite, arriving from +y (the suture trailing
                    // sideways, out of the needle's way), then loaded and driven through both sides
                    // of x = 28 (the needle's radius 0.5: its circle centred 0.05 above the top at
                    // x = 28, its point 0.22 above it when loaded), then the suture drawn through,
                    // up and on along +x.
                    loaded_and_driven(
                        "suture-held-80",
                        vec![
                            [3.0, -1.0, 0.0],
                            [6.0, -3.0, 0.0],
                            [8.383, -7.0, 0.0],
                            [8.383, -12.0, -0.5],
                            [8.383, -13.5, -1.3],
                        ],
                        [0.0, -1.5, -0.3286],
                        vec![[0.5, 0.0, 0.8], [4.5, 0.0, 1.7]],
                        None,
                    ),
                ]
                .concat(),
            }),
            // The needle driven round its own circle (chain `needle-drive-80` of `stitch.toml`: 10
            // units of suture in 80 links, its needle of radius 1 and 120° laid curving down, its
            // point just above the tissue): the driver turns the needle 250° (its point goes in,
            // under and out, cutting the two holes; the swage follows it through them, and the
            // suture threads them), then draws the suture up and back through both holes.
            "needle-drive" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: false,
                turn: vec![
                    Turn {
                        drive: Some(Drive { angle: 250.0 }),
                        ..turn("A", "needle-drive-80", "head", None, vec![])
                    },
                    turn(
                        "A",
                        "needle-drive-80",
                        "head",
                        None,
                        vec![[-0.3, 0.0, 1.0], [-1.0, 0.0, 2.0], [-2.5, 0.0, 2.5]],
                    ),
                ],
            }),
            // The needle's pass of the whole stitch (chain `stitch-80` or `stitch-160` of
            // `stitch.toml`, laid along +x from x = -25 to the needle's swage at x = 15, half a unit
            // above the tissue; the needle, radius 0.7 and 120°, curving up from the head link), as
            // a surgeon loads and drives a curved needle: the driver swings the swage aside (to
            // y = 1.5) and over the bite; lifts it, turning the needle (a pose turn) to arch over the
            // entry, high enough that its point cannot reach the tissue while it turns; then brings
            // it down into the plane y = 0, its point at 160° of a circle centred 0.05 above the
            // tissue's top at x = 15.95 and the suture hanging from the swage sideways, out of the
            // needle's way. The driver then drives it 345° round that circle: its point cuts the
            // entry (x ≈ 15.25) and the exit (≈ 16.65) either side of the incision at x = 15.9, the
            // swage follows it through both and the suture threads them. Then the suture is drawn
            // on along +x and up until the tail before the entry, free, is [`STITCH_TAIL`] long
            // (`hand run --tail` sets another). Not grasped: the
            // tail must slide toward the entry. The point starts 0.29 above the tissue, room for a
            // person's hand (`--perturb`) to set the swage 0.2 lower.
            "stitch-pass" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: false,
                turn: loaded_and_driven(
                    "stitch-80",
                    vec![[0.0, 1.5, 0.1], [1.4862, 1.5, 0.2]],
                    [0.0, -1.5, -0.2],
                    vec![[0.66, 0.0, 0.85], [23.31, 0.0, 1.85]],
                    Some(STITCH_TAIL),
                ),
            }),
            _ => None,
        }
    }
}

/// A turn of `hand` moving `joint` of `chain` through a throw (if any), then `waypoints`; nothing
/// else (set the other fields on it: `Turn { wrap, ..turn(..) }`).
pub fn turn(
    hand: &str,
    chain: &str,
    joint: &str,
    throw: Option<Throw>,
    waypoints: Vec<[f64; 3]>,
) -> Turn {
    Turn {
        hand: hand.into(),
        chain: chain.into(),
        joint: joint.into(),
        throw,
        wide_loop: None,
        tuck: None,
        wrap: None,
        instrument: None,
        tighten: None,
        drive: None,
        pose: None,
        draw: None,
        waypoints,
    }
}

/// One hand's needle pass (hand A, the chain's head): along `approach` to beside the bite (the
/// suture trailing sideways from the swage, out of the needle's way); then a pose turn that lifts the
/// swage (0.8 up, 0.3 toward the bite's plane) turning the needle to [`LOADED`], high enough that its
/// point cannot reach the tissue while it turns, and brings it `down` (from where the approach
/// ended) onto its circle, the point 0.2 or more above the tissue; then a drive of 345° round that
/// circle (the point cuts the entry and the exit, the swage follows it through both); then the
/// suture drawn through along `draw`, until a tail of `tail` is left if given ([`Draw`]). One pose
/// turn, not two: a perturbed hand's waypoint errors add up turn by turn.
fn loaded_and_driven(
    chain: &str,
    approach: Vec<[f64; 3]>,
    down: [f64; 3],
    draw: Vec<[f64; 3]>,
    tail: Option<f64>,
) -> Vec<Turn> {
    vec![
        turn("A", chain, "head", None, approach),
        Turn {
            pose: Some(LOADED),
            ..turn("A", chain, "head", None, vec![[0.0, -0.3, 0.8], down])
        },
        Turn {
            drive: Some(Drive { angle: 345.0 }),
            ..turn("A", chain, "head", None, vec![])
        },
        Turn {
            draw: tail.map(|tail| Draw { tail }),
            ..turn("A", chain, "head", None, draw)
        },
    ]
}

/// The tail the whole stitch's pass leaves before the entry (units): about as long as
/// `stitch-tie-80`'s, so that its instrument tie follows.
pub const STITCH_TAIL: f64 = 15.25;

/// A curved needle loaded for a bite along +x under a tissue's top, in the plane y = const: its swage
/// at 40° of its circle (seen from −y, angles from +x toward +z), leaving it toward the top of the
/// circle and curving toward its centre, so that its point (120° on, at 160°) leads it down into the
/// tissue on the −x side when it is driven ([`Drive`]).
const LOADED: Pose = Pose {
    tangent: [-0.642_787_610, 0.0, 0.766_044_443],
    bend: [-0.766_044_443, 0.0, -0.642_787_610],
};

/// The wide loop of the held overhand on the paper's rope, straight along +x and held at its tail: a
/// loop of radius 4 (on unit links a smaller one does not survive the tuck; BENCHMARKS.md, knots),
/// the rope fed toward the hold as the circle is drawn.
fn held_loop() -> WideLoop {
    WideLoop {
        outward: [1.0, 0.0, 0.0],
        side: [0.0, 1.0, 0.0],
        radius: 4.0,
        exit: 2.0,
        feed: 1.0,
        handedness: Handedness::Right,
        tuck: true,
    }
}

/// How far the held overhand's hand pulls back along the rope after the tuck: the knot snug, before
/// it jams (a jammed knot locks the hand's moves).
const HELD_PULL: f64 = 8.0;

/// Two overhands in series on the paper's rope (built-in `overhands-held`, chain `paper`: 40 unit
/// links, straight along +x), each tied by one hand in its own end, each end held by its hand for the
/// whole script (A the tail, B the head), the hands moving alternately (six alternations). The whole
/// rope has the square knot's type (a connected sum of two mirror trefoils), but the strands do not
/// hold each other: a cut between the knots leaves a trefoil in each half (issue 34); the reef and
/// the granny tied round each other are the built-ins `square-held` and `granny-held`. A first gives
/// the rope slack: its end 4 units toward B, dipping aside and up on the way (the rope between the knots would otherwise be taut after B's throw, and A's circle
/// would drag B's knot until it jammed; a move straight along a straight rope only pushes it along,
/// so the hand goes round). Each throw is a fed loop of radius 2 drawn by one hand (the circle only)
/// and a tuck that watches the rope ([`Tuck`]: the end threaded through the loop where it lies); B
/// throws first (a right trefoil), then A (`second`: `Left` mirrors it, a square knot; `Right`, a
/// granny); then each hand pulls its end back along the rope by one unit, twice, in turn.
pub fn overhands_held(name: &str, second: Handedness) -> Script {
    let hand = |h: &str| {
        turn(
            h,
            "paper",
            if h == "A" { "tail" } else { "head" },
            None,
            vec![],
        )
    };
    // Each hand heads away from the rope (B along +x, A along −x), the loop on the +y side.
    let outward = |h: &str| [if h == "A" { -1.0 } else { 1.0 }, 0.0, 0.0];
    let handedness = |h: &str| {
        if h == "A" { second } else { Handedness::Right }
    };
    let circle = |h: &str| Turn {
        wide_loop: Some(WideLoop {
            outward: outward(h),
            side: [0.0, 1.0, 0.0],
            radius: HELD_TWO_RADIUS,
            exit: 0.0,
            feed: 1.0,
            handedness: handedness(h),
            tuck: false,
        }),
        ..hand(h)
    };
    let tuck = |h: &str| Turn {
        tuck: Some(Tuck {
            outward: outward(h),
            side: [0.0, 1.0, 0.0],
            clearance: default_tuck_clearance(),
            exit: 2.0,
            handedness: handedness(h),
        }),
        ..hand(h)
    };
    let pull = |h: &str| Turn {
        waypoints: vec![[-outward(h)[0], 0.0, 0.0]],
        ..hand(h)
    };
    Script {
        name: name.into(),
        max_step: 0.05,
        grasp: true,
        turn: vec![
            Turn {
                waypoints: vec![[4.0, -2.0, 0.5], [4.0, 0.0, 0.0]],
                ..hand("A")
            },
            circle("B"),
            tuck("B"),
            circle("A"),
            tuck("A"),
            pull("B"),
            pull("A"),
            pull("B"),
            pull("A"),
        ],
    }
}

/// The radius of each throw's loop in the two-handed held knots: two loops and their tucks fit in 40
/// units (BENCHMARKS.md, knots: a fed loop of radius 4, which the drawn tuck needs on unit links,
/// takes more than half the rope).
const HELD_TWO_RADIUS: f64 = 2.0;

/// The radius of the instrument ties' coils round the driver's jaws (a capsule of radius 0.8): the
/// rope (0.1 from its axis to its surface) lies on the jaws with a thickness of play, so the driver
/// holds the coil open until the tail is drawn through it, whatever the rope's resolution. A loose coil
/// (radius 2.2, the first choice) kept its loop only on unit links: cut into 80 links the rope left
/// the jaws and untied (BENCHMARKS.md, "Knots through the service at every resolution").
const WRAP_RADIUS: f64 = 1.1;

/// Where the surgeon's double wrap starts (units from the driver's tip) and how far it advances toward
/// the tip per turn. On the frictionless jaws the rope just behind the winding hand slides along the
/// driver toward the tip, farther the finer the rope (after one turn started 4 from the tip, the
/// rope on the jaws reached 3.3 from the tip at 80 links, 0.9 at 160). Wound 0.6 per turn from 4
/// units, the first turn slid past the place of the second, the lead-in crossed over the coil, and
/// the tail drawn through it tied 5₂ instead of the double overhand 5₁ at 160 and 320 links, in every
/// run (BENCHMARKS.md, "Knot success through the service"). Started 10 from the tip and advancing
/// 4.5 per turn, each turn is laid nearer the tip than the last one slid to, at every resolution
/// from 40 to 320 links (perturbation seeds 1 to 5, tried as scripts before this was built in).
const DOUBLE_WRAP_AT: f64 = 10.0;
const DOUBLE_WRAP_PITCH: f64 = -4.5;

/// A turn of the instrument tie on chain `tie` through `waypoints`: hand A moves the head (the long
/// end), hand B the tail (the short end, in the driver's jaws).
fn tie_turn(chain: &str, h: &str, waypoints: Vec<[f64; 3]>) -> Turn {
    turn(
        h,
        chain,
        if h == "A" { "head" } else { "tail" },
        None,
        waypoints,
    )
}

/// The instrument tie of surgery on chain `tie` of `knots.toml` (the paper's rope stitched in at joint
/// 16, the needle driver `driver` riding with the tail): hand B holds the short end's tail in the
/// driver's jaws, lays the short end in a U and then turns the driver's axis along +x, its tip on the
/// tail, so that the short end's last 3 units trail straight behind the tip; hand A holds the long
/// end (the head), brings it over the stitch to the far side of the driver, level with it, and winds
/// it round the driver's jaws 4 units from the tip (the double wrap from 10, [`DOUBLE_WRAP_AT`]), the
/// coil progressing toward the tip (its lead-in on the side the tail leaves by); B pulls the tail along the driver's axis through the coil (the
/// driver riding with it, the coil sliding off its tip onto the tail); then the hands draw their ends
/// out of the knot, which tightens between them (eight turns, five changes of hand). Turning the
/// driver after the U is laid keeps its body off the short end (turned first, it lay along the
/// straight rope and B's first moves were locked). `wraps` is how many times A winds the long end
/// round the driver: 1 (built-in `instrument-tie`, a half knot: the trefoil), or the surgeon's 2
/// (built-in `surgeons-tie`: the double overhand, 5₁).
fn instrument_tie(name: &str, chain: &str, wraps: f64) -> Script {
    let hand = |h: &str, w| tie_turn(chain, h, w);
    let axis = [1.0, 0.0, 0.0];
    Script {
        name: name.into(),
        max_step: 0.05,
        grasp: true,
        turn: vec![
            // The short end laid in a U, its last 3 units straight behind the tip along the axis.
            hand(
                "B",
                vec![
                    [3.0, -4.0, 1.0],
                    [7.0, -2.0, 3.0],
                    [7.0, 0.0, 3.0],
                    [10.0, 0.0, 3.0],
                ],
            ),
            // Then the driver's tip to the tail (it rode there with the tail), its axis along +x.
            Turn {
                instrument: Some(InstrumentMove {
                    index: 0,
                    tip: [0.0; 3],
                    axis,
                }),
                ..hand("B", vec![])
            },
            // The long end over the stitch to the far side of the driver, level with the coil.
            hand("A", vec![[-12.0, 3.0, 2.0], [-26.0, 2.2, 3.0]]),
            Turn {
                wrap: Some(Wrap {
                    instrument: 0,
                    at: if wraps > 1.0 { DOUBLE_WRAP_AT } else { 4.0 },
                    radius: WRAP_RADIUS,
                    turns: wraps,
                    pitch: if wraps > 1.0 { DOUBLE_WRAP_PITCH } else { -0.6 },
                    handedness: Handedness::Right,
                }),
                ..hand("A", vec![])
            },
            // The tail pulled through the coil along the driver's axis.
            hand("B", vec![scale(axis, 10.0)]),
            // Both ends drawn out of the knot, which tightens between them.
            hand("A", vec![[-6.0, 3.0, -3.0]]),
            hand("B", vec![[3.0, 0.0, 1.0]]),
            hand("A", vec![[-6.0, 0.0, 0.0]]),
        ],
    }
}

/// Two throws by instrument tie on `chain` (`tie`, or `hands`, where B's finger is the instrument):
/// the first throw of [`instrument_tie`] with `wraps` turns round the driver, then a single throw,
/// also by the driver, wound `second`-handed: left, the other way, with 2 wraps the surgeon's knot
/// (built-in `surgeons-knot`: the double overhand, then the single throw), with 1 the square knot
/// (built-ins `instrument-square`, and `square-held` by hand); right, the same way, the granny
/// (`instrument-granny`, `granny-held`). B draws the tail out a little more (the first throw
/// tightens), lifts it and carries it back over the knot to the long end's side, turns the driver to
/// point away from the knot (through the vertical, so that its body sweeps no rope), and lowers it;
/// the short end now runs from the knot straight into the driver's tip. A brings the long end up
/// beside the driver from beyond the coil's place and winds it once round the jaws, 3 units from the
/// tip, left-handed (the first throw's wrap seen in a mirror across the knot: the second throw the
/// other way, as the surgeon's and the square knot have it), or right-handed for the granny, one
/// and a half turns (A comes from the side a left-handed turn starts on: one right-handed turn from
/// there ended short of the short end and the second throw was lost, a trefoil in every run tried at
/// 40, 80 and 160 links); B pulls the tail through along the driver; the hands draw their ends
/// apart. Eighteen turns, ten changes of hand.
fn two_throw_tie(name: &str, chain: &str, wraps: f64, second: Handedness) -> Script {
    let mut script = instrument_tie(name, chain, wraps);
    let hand = |h: &str, w| tie_turn(chain, h, w);
    let turn_driver = |axis| Turn {
        instrument: Some(InstrumentMove {
            index: 0,
            tip: [0.0; 3],
            axis,
        }),
        ..hand("B", vec![])
    };
    script.turn.extend([
        hand("B", vec![[4.0, 0.0, -2.0]]),
        hand("B", vec![[0.0, 0.0, 4.0], [-14.0, 0.0, 4.0]]),
        turn_driver([0.0, 0.0, 1.0]),
        turn_driver([-1.0, 0.0, 0.0]),
        hand("B", vec![[0.0, 0.0, -3.0]]),
        hand("A", vec![[5.0, -0.7, 2.0], [11.0, -1.5, 3.0]]),
        Turn {
            wrap: Some(Wrap {
                instrument: 0,
                at: 3.0,
                radius: WRAP_RADIUS,
                turns: if second == Handedness::Left { 1.0 } else { 1.5 },
                pitch: -0.6,
                handedness: second,
            }),
            ..hand("A", vec![])
        },
        hand("B", vec![[-5.0, 0.0, 0.0]]),
        hand("A", vec![[6.0, 0.0, 0.0]]),
        hand("B", vec![[-3.0, 0.0, 0.0]]),
    ]);
    script
}

/// The two-handed knots on a rope hanging in a U between the hands (A the tail, B the head), each
/// hand holding its end throughout; six alternating turns: A throws (upward, away from the rope), B
/// pulls its side out, A pulls back, B throws (`second`: mirrored for the square), A pulls, B pulls.
fn two_hands_u(name: &str, second: Handedness) -> Script {
    let throw = |handedness| Throw {
        handedness,
        outward: [0.0, 1.0, 0.0],
        scale: 0.45,
        exit: 3.0,
        lobe: false,
    };
    let turn = |hand: &str, throw: Option<Throw>, waypoints: Vec<[f64; 3]>| {
        turn(
            hand,
            "rope",
            if hand == "A" { "tail" } else { "head" },
            throw,
            waypoints,
        )
    };
    Script {
        name: name.into(),
        max_step: 0.05,
        grasp: true,
        turn: vec![
            turn("A", Some(throw(Handedness::Left)), vec![]),
            turn("B", None, vec![[3.0, 0.0, 0.0]]),
            turn("A", None, vec![[-3.0, 0.0, 0.0]]),
            turn("B", Some(throw(second)), vec![]),
            turn("A", None, vec![[-2.0, 0.0, 0.0]]),
            turn("B", None, vec![[2.0, 0.0, 0.0]]),
        ],
    }
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

/// `"head"`, `"tail"` or an index, as the wire's joint field.
pub fn parse_joint(s: &str) -> Result<u32, String> {
    match s {
        "head" => Ok(shared::JOINT_HEAD),
        "tail" => Ok(0),
        n => n
            .parse::<u32>()
            .map_err(|_| format!("joint {n:?}: expected head, tail or an index")),
    }
}

impl Turn {
    /// The absolute targets of this turn for a joint starting at `start`, split so that no request
    /// moves the joint more than `max_step`.
    pub fn targets(&self, start: [f64; 3], max_step: f64) -> Vec<[f64; 3]> {
        self.corners(start, None)
            .map(|c| densify(start, &c, max_step))
            .unwrap_or_default()
    }

    /// The absolute targets of this turn for its joint `joint` of the rope `joints` as the turn
    /// starts, split so that no request moves the joint more than `max_step`. A [`Tuck`] is aimed at
    /// the loop the rope has; an error when it has none, or when `joint` is not a joint of it.
    pub fn targets_on(
        &self,
        joints: &[[f64; 3]],
        joint: usize,
        max_step: f64,
    ) -> Result<Vec<[f64; 3]>, String> {
        self.targets_with(joints, joint, &[], max_step)
    }

    /// [`Turn::targets_on`] with the chain's instruments where they are (a [`Wrap`] needs them).
    pub fn targets_with(
        &self,
        joints: &[[f64; 3]],
        joint: usize,
        instruments: &[InstrumentEnds],
        max_step: f64,
    ) -> Result<Vec<[f64; 3]>, String> {
        let start = *joints
            .get(joint)
            .ok_or_else(|| format!("joint {joint} is not a joint of the rope"))?;
        let mut corners = self.corners(start, Some((joints, joint)))?;
        if let Some(w) = &self.wrap {
            let ends = instruments.get(w.instrument as usize).ok_or_else(|| {
                format!(
                    "wrap: instrument {} (the chain has {})",
                    w.instrument,
                    instruments.len()
                )
            })?;
            let k = corners.len() - self.waypoints.len();
            let from = if k > 0 { corners[k - 1] } else { start };
            let wound = wrap_path(from, *ends, w)?;
            corners.splice(k..k, wound);
        }
        Ok(densify(start, &corners, max_step))
    }

    /// The moves of this turn's [`Pose`] for its joint `joint` of the rope `joints` (the needle's
    /// swage, the head): the needle turned to the pose while the swage goes to the first waypoint,
    /// then kept so along the rest ([`needle_poses`]).
    pub fn pose_moves(
        &self,
        pose: &Pose,
        joints: &[[f64; 3]],
        joint: usize,
        instruments: &[InstrumentEnds],
        max_step: f64,
    ) -> Result<Vec<PoseMove>, String> {
        let path = self.targets_with(joints, joint, instruments, max_step)?;
        let start = joints[joint];
        let turning = self.waypoints.first().map_or(path.len(), |w| {
            densify(start, &[add(start, *w)], max_step).len()
        });
        needle_poses(start, instruments, &path, turning, pose, max_step)
    }

    /// The poses (centre, axis direction) an [`InstrumentMove`] turn sends, from the instrument's
    /// ends now, for the turn's joint at `joint_at`: steps that move no point of the instrument more
    /// than `max_step`.
    pub fn instrument_poses(
        &self,
        joint_at: [f64; 3],
        now: InstrumentEnds,
        max_step: f64,
    ) -> Vec<([f64; 3], [f64; 3])> {
        let Some(m) = &self.instrument else {
            return Vec::new();
        };
        let (a, b) = now;
        let len = norm(sub(b, a));
        let d0 = if len > 0.0 {
            scale(sub(b, a), 1.0 / len)
        } else {
            scale(m.axis, 1.0 / norm(m.axis))
        };
        let d1 = scale(m.axis, 1.0 / norm(m.axis));
        let c0 = add(a, scale(d0, 0.5 * len));
        let tip = add(joint_at, m.tip);
        let c1 = add(tip, scale(d1, 0.5 * len));
        // The farthest any point travels: the centre's distance plus the axis end's sweep.
        let angle = dot(d0, d1).clamp(-1.0, 1.0).acos();
        let travel = norm(sub(c1, c0)) + 0.5 * len * angle;
        let k = (travel / max_step).ceil().clamp(1.0, 1e7) as usize;
        (1..=k)
            .map(|i| {
                let t = i as f64 / k as f64;
                let c = add(c0, scale(sub(c1, c0), t));
                let d = add(scale(d0, 1.0 - t), scale(d1, t));
                let n = norm(d);
                // Opposite axes: turn about any axis across them.
                let d = if n > 1e-9 {
                    scale(d, 1.0 / n)
                } else {
                    let across = cross(
                        d0,
                        if d0[0].abs() < 0.9 {
                            [1.0, 0.0, 0.0]
                        } else {
                            [0.0, 1.0, 0.0]
                        },
                    );
                    scale(across, 1.0 / norm(across))
                };
                (c, d)
            })
            .collect()
    }

    /// The corners of the turn's path; a tuck needs the rope.
    fn corners(
        &self,
        start: [f64; 3],
        rope: Option<(&[[f64; 3]], usize)>,
    ) -> Result<Vec<[f64; 3]>, String> {
        let mut corners: Vec<[f64; 3]> = Vec::new();
        if let Some(th) = &self.throw {
            corners.extend(throw_path(start, th));
        }
        if let Some(l) = &self.wide_loop {
            let from = corners.last().copied().unwrap_or(start);
            corners.extend(loop_path(from, l));
        }
        if let Some(t) = &self.tuck {
            let (joints, joint) = rope.ok_or("a tuck needs the rope's joints")?;
            corners.extend(tuck_path(joints, joint, t)?);
        }
        corners.extend(self.waypoints.iter().map(|w| add(start, *w)));
        Ok(corners)
    }
}

/// The corners of a throw's path (400 points on the trefoil, then the exit).
fn throw_path(start: [f64; 3], th: &Throw) -> Vec<[f64; 3]> {
    if th.lobe {
        return lobe_path(start, th);
    }
    let [u, v, w] = throw_frame(th.outward);
    let mirror = if th.handedness == Handedness::Right {
        -1.0
    } else {
        1.0
    };
    let n = 400;
    let local: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            [
                (t.sin() + 2.0 * (2.0 * t).sin()) * th.scale,
                (t.cos() - 2.0 * (2.0 * t).cos()) * th.scale,
                -(3.0 * t).sin() * th.scale * mirror,
            ]
        })
        .collect();
    // Enter at the trefoil's point nearest the hand (least along its x axis), one unit ahead.
    let c = (0..n)
        .min_by(|&i, &j| local[i][0].total_cmp(&local[j][0]))
        .expect("points");
    let world = |p: [f64; 3]| {
        let q = [
            p[0] - local[c][0] + 1.0,
            p[1] - local[c][1],
            p[2] - local[c][2],
        ];
        add(
            start,
            add(add(scale(u, q[0]), scale(v, q[1])), scale(w, q[2])),
        )
    };
    let mut out: Vec<[f64; 3]> = (1..=n).map(|k| world(local[(c + k) % n])).collect();
    let last = *out.last().expect("points");
    let away = add(last, add(scale(u, 3.0), scale(v, -3.0)));
    out.push(away);
    if th.exit > 0.0 {
        out.push(add(away, scale(u, th.exit)));
    }
    out
}

/// A throw's right-handed unit frame (u, v, u × v), u along `outward`: a rotation, so the trefoil's
/// handedness is kept whatever the outward direction.
fn throw_frame(outward: [f64; 3]) -> [[f64; 3]; 3] {
    let u = scale(outward, 1.0 / norm(outward));
    let helper = if u[2].abs() < 0.9 {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let v = {
        let c = cross(helper, u);
        scale(c, 1.0 / norm(c))
    };
    [u, v, cross(u, v)]
}

/// A [`Throw`] with `lobe`: the trefoil from just past one lobe's tip round to just before it
/// (parameter π + 0.2 to 3π − 0.2), turned so that the entering tangent points along `outward`, one
/// unit ahead of the hand, then `exit` units on along the leaving tangent.
fn lobe_path(start: [f64; 3], th: &Throw) -> Vec<[f64; 3]> {
    let mirror = if th.handedness == Handedness::Right {
        -1.0
    } else {
        1.0
    };
    let at = |t: f64| {
        [
            (t.sin() + 2.0 * (2.0 * t).sin()) * th.scale,
            (t.cos() - 2.0 * (2.0 * t).cos()) * th.scale,
            -(3.0 * t).sin() * th.scale * mirror,
        ]
    };
    let tangent = |t: f64| {
        let d = sub(at(t + 1e-6), at(t - 1e-6));
        scale(d, 1.0 / norm(d))
    };
    let pi = std::f64::consts::PI;
    let (t0, t1) = (pi + 0.2, 3.0 * pi - 0.2);
    // The local frame (T, N, B) at the entry, T the tangent, onto the world's (u, w, −v): a rotation.
    let t_local = tangent(t0);
    let up = [0.0, 0.0, 1.0];
    let n_local = {
        let n = sub(up, scale(t_local, dot(up, t_local)));
        scale(n, 1.0 / norm(n))
    };
    let b_local = cross(t_local, n_local);
    let [u, v, w] = throw_frame(th.outward);
    let origin = at(t0);
    let world = |p: [f64; 3]| {
        let q = sub(p, origin);
        let local = [dot(q, t_local) + 1.0, dot(q, n_local), dot(q, b_local)];
        add(
            start,
            add(
                add(scale(u, local[0]), scale(w, local[1])),
                scale(v, -local[2]),
            ),
        )
    };
    let n = 400;
    let mut out: Vec<[f64; 3]> = (0..=n)
        .map(|k| world(at(t0 + (t1 - t0) * k as f64 / n as f64)))
        .collect();
    if th.exit > 0.0 {
        let last = *out.last().expect("points");
        let dir = sub(world(add(at(t1), tangent(t1))), world(at(t1)));
        out.push(add(last, scale(dir, th.exit)));
    }
    out
}

/// The unit frame of a wide loop: along `outward`, across it toward `side`, and their cross product.
fn loop_frame(outward: [f64; 3], side: [f64; 3]) -> Option<[[f64; 3]; 3]> {
    let n = norm(outward);
    if !(n > 0.0 && n.is_finite() && side.iter().all(|c| c.is_finite())) {
        return None;
    }
    let u = scale(outward, 1.0 / n);
    let across = add(side, scale(u, -dot(side, u)));
    let m = norm(across);
    let tiny = 1e-9 * norm(side).max(f64::MIN_POSITIVE);
    if !(m.is_finite() && m > tiny) {
        return None;
    }
    let v = scale(across, 1.0 / m);
    Some([u, v, cross(u, v)])
}

/// A wide loop's path in its own frame (along `outward`, across toward `side`, up), from its
/// origin: a Catmull-Rom curve through the loop's 24 points and the tuck's, eight corners per span
/// (the circle is the first 24 spans), mirrored for a left loop.
fn loop_local(l: &WideLoop) -> Vec<[f64; 3]> {
    let r = l.radius;
    // The circle about (0, r) entered at its near point, rising one unit over the last 30 % to
    // cross the rope it laid; then under the far side, up through the loop, over the near side, and
    // the pull.
    let mut pts: Vec<[f64; 3]> = vec![[0.0; 3]];
    let n = LOOP_POINTS;
    for k in 1..=n {
        let a = -std::f64::consts::FRAC_PI_2 + std::f64::consts::TAU * k as f64 / n as f64;
        let rise = 0.7 * n as f64;
        let z = if (k as f64) < rise {
            0.0
        } else {
            (k as f64 - rise) / (n as f64 - rise)
        };
        pts.push([r * a.cos(), r + r * a.sin(), z]);
    }
    if l.tuck {
        pts.extend(tuck_local(r, l.exit));
    }
    // The mirror knot: every crossing the other way up.
    if l.handedness == Handedness::Left {
        for p in &mut pts {
            p[2] = -p[2];
        }
    }
    catmull_rom(&pts)
}

/// The drawn tuck in a loop's frame (the loop a circle of radius `r` about `(0, r)`, entered and
/// closed at the origin): on past the crossing, under the far side, up through the middle, over the
/// near side, and `exit` on.
fn tuck_local(r: f64, exit: f64) -> [[f64; 3]; 8] {
    [
        [0.6 * r, -0.4 * r, 0.3],
        [1.3 * r, 0.1 * r, -1.0],
        [1.1 * r, 0.5 * r, -1.0],
        [0.2 * r, r, -1.0],
        [-0.2 * r, r, 0.0],
        [-0.5 * r, r, 1.0],
        [-1.3 * r, r, 1.0],
        [-1.3 * r - exit, r, 1.0],
    ]
}

/// A Catmull-Rom curve through `pts` (the ends repeated), eight samples per span.
fn catmull_rom(pts: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let at = |i: isize| pts[i.clamp(0, pts.len() as isize - 1) as usize];
    let mut out = Vec::new();
    for i in 0..pts.len() as isize - 1 {
        let (p0, p1, p2, p3) = (at(i - 1), at(i), at(i + 1), at(i + 2));
        for j in 1..=8 {
            let t = j as f64 / 8.0;
            let (t2, t3) = (t * t, t * t * t);
            let c = |d: usize| {
                0.5 * (2.0 * p1[d]
                    + (p2[d] - p0[d]) * t
                    + (2.0 * p0[d] - 5.0 * p1[d] + 4.0 * p2[d] - p3[d]) * t2
                    + (3.0 * p1[d] - p0[d] - 3.0 * p2[d] + p3[d]) * t3)
            };
            out.push([c(0), c(1), c(2)]);
        }
    }
    out
}

/// The corners of a [`Wrap`] from `from` round the instrument with ends `(a, b)`.
fn wrap_path(from: [f64; 3], (a, b): InstrumentEnds, w: &Wrap) -> Result<Vec<[f64; 3]>, String> {
    let axis = sub(b, a);
    let len = norm(axis);
    if !(len > 0.0 && len.is_finite()) {
        return Err("wrap: the instrument has no axis (a sphere)".into());
    }
    let u = scale(axis, 1.0 / len);
    let centre = add(a, scale(u, w.at));
    // Start at the circle's point nearest the hand; if the hand is on the axis, anywhere.
    let off = sub(from, centre);
    let across = sub(off, scale(u, dot(off, u)));
    let e1 = if norm(across) > 1e-9 {
        scale(across, 1.0 / norm(across))
    } else {
        let c = cross(
            u,
            if u[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            },
        );
        scale(c, 1.0 / norm(c))
    };
    let sign = if w.handedness == Handedness::Right {
        1.0
    } else {
        -1.0
    };
    let e2 = scale(cross(u, e1), sign);
    let per_turn = 48.0;
    let n = (w.turns * per_turn).ceil().max(1.0) as usize;
    Ok((0..=n)
        .map(|k| {
            let f = w.turns * k as f64 / n as f64;
            let t = std::f64::consts::TAU * f;
            add(
                centre,
                add(
                    add(scale(e1, w.radius * t.cos()), scale(e2, w.radius * t.sin())),
                    scale(u, w.pitch * f),
                ),
            )
        })
        .collect())
}

/// Points of a wide loop's circle.
const LOOP_POINTS: usize = 24;

/// How many joints from the hand's end a tuck looks at for its loop. The search compares segment
/// pairs (quadratic in what it walks), so on a long chain it stays near the end: a hand's loop lies
/// within a few loops' worth of rope of its end, and the knot ropes are a few hundred links at most.
pub const LOOP_SEARCH_JOINTS: usize = 1024;

/// The loop nearest the end `joint` (0 or the last) of the rope `joints`, seen along `w` in the frame
/// `(u, v, w)`: walking from the end (at most [`LOOP_SEARCH_JOINTS`] joints), the first stretch of
/// rope whose projection comes back across the rope walked before it (at least four links and twice
/// `min_span` across, so that a kink is no loop). Returns the loop's joints.
fn find_loop(
    joints: &[[f64; 3]],
    joint: usize,
    [u, v, _]: [[f64; 3]; 3],
    min_span: f64,
    reach: f64,
) -> Option<Vec<[f64; 3]>> {
    let n = joints.len();
    if n < 6 || (joint != 0 && joint != n - 1) {
        return None;
    }
    let walk: Vec<[f64; 3]> = if joint == 0 {
        joints.iter().take(LOOP_SEARCH_JOINTS).copied().collect()
    } else {
        joints
            .iter()
            .rev()
            .take(LOOP_SEARCH_JOINTS)
            .copied()
            .collect()
    };
    let n = walk.len();
    let mut flat: Vec<[f64; 2]> = walk.iter().map(|p| [dot(*p, u), dot(*p, v)]).collect();
    // The end's link reaches half a link past the end: a hand that closed its loop right above the
    // rope it crosses (the circle drawn to where it began) crosses it there.
    flat[0] = [
        1.5 * flat[0][0] - 0.5 * flat[1][0],
        1.5 * flat[0][1] - 0.5 * flat[1][1],
    ];
    let spread_ok = |ring: &[[f64; 3]]| {
        let spread = |d: [f64; 3]| {
            let xs = ring.iter().map(|p| dot(*p, d));
            xs.clone().fold(f64::MIN, f64::max) - xs.fold(f64::MAX, f64::min)
        };
        spread(u).min(spread(v)) >= 2.0 * min_span
    };
    // Segment a (walk[a]..walk[a + 1]) against the later segments b ≥ a + 4.
    for a in 0..n - 1 {
        for b in a + 4..n - 1 {
            if segments_cross(flat[a], flat[a + 1], flat[b], flat[b + 1])
                && spread_ok(&walk[a + 1..=b])
            {
                return Some(walk[a + 1..=b].to_vec());
            }
        }
    }
    // No crossing: the end's own link may have closed the loop short of the rope it headed for,
    // by up to `reach` (a hand's aim is no better); the nearest such approach closes it.
    (4..n - 1)
        .map(|b| {
            (
                segment_distance_2d(flat[0], flat[1], flat[b], flat[b + 1]),
                b,
            )
        })
        .filter(|&(d, b)| d < reach && spread_ok(&walk[1..=b]))
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, b)| walk[1..=b].to_vec())
}

/// Distance between two segments of the plane (they do not cross).
fn segment_distance_2d(p: [f64; 2], q: [f64; 2], r: [f64; 2], s: [f64; 2]) -> f64 {
    let point = |x: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        let d = [b[0] - a[0], b[1] - a[1]];
        let l2 = d[0] * d[0] + d[1] * d[1];
        let t = if l2 > 0.0 {
            (((x[0] - a[0]) * d[0] + (x[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        ((x[0] - a[0] - t * d[0]).powi(2) + (x[1] - a[1] - t * d[1]).powi(2)).sqrt()
    };
    point(p, r, s)
        .min(point(q, r, s))
        .min(point(r, p, q))
        .min(point(s, p, q))
}

/// Whether two segments of the plane cross (proper crossings only).
fn segments_cross(p: [f64; 2], q: [f64; 2], r: [f64; 2], s: [f64; 2]) -> bool {
    let orient = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    let (d1, d2) = (orient(r, s, p), orient(r, s, q));
    let (d3, d4) = (orient(p, q, r), orient(p, q, s));
    d1 * d2 < 0.0 && d3 * d4 < 0.0
}

/// The corners of a tuck (see [`Tuck`]) through the loop nearest the end `joint` of `joints`.
fn tuck_path(joints: &[[f64; 3]], joint: usize, t: &Tuck) -> Result<Vec<[f64; 3]>, String> {
    let frame = loop_frame(t.outward, t.side)
        .ok_or("tuck.outward and tuck.side must be finite, non-zero and not parallel")?;
    let [u, v, w] = frame;
    let ring = find_loop(joints, joint, frame, t.clearance.min(1.0), t.clearance)
        .ok_or("no loop to tuck through: the rope does not cross itself near the hand's end")?;
    let k = ring.len() as f64;
    let c = scale(ring.iter().fold([0.0; 3], |a, p| add(a, *p)), 1.0 / k);
    let along = |d: [f64; 3]| ring.iter().map(move |p| dot(add(*p, scale(c, -1.0)), d));
    let far = along(u).fold(f64::MIN, f64::max);
    let near = -along(u).fold(f64::MAX, f64::min);
    let bottom = -along(v).fold(f64::MAX, f64::min);
    let rho = ring
        .iter()
        .map(|p| {
            let d = add(*p, scale(c, -1.0));
            (dot(d, u).powi(2) + dot(d, v).powi(2)).sqrt()
        })
        .sum::<f64>()
        / k;
    let (d, e) = (t.clearance, t.exit);
    let up = if t.handedness == Handedness::Left {
        -1.0
    } else {
        1.0
    };
    let local = [
        [0.6 * rho, -bottom - 0.4 * rho, 0.3 * d],
        [far + d, -bottom + 0.1 * rho, -d],
        [far + 0.5 * d, -0.5 * rho, -d],
        [0.2 * rho, 0.0, -d],
        [-0.2 * rho, 0.0, 0.0],
        [-0.5 * rho, 0.0, d],
        [-near - d, 0.0, d],
        [-near - d - e, 0.0, d],
    ];
    Ok(local
        .iter()
        .map(|p| {
            add(
                c,
                add(add(scale(u, p[0]), scale(v, p[1])), scale(w, up * p[2])),
            )
        })
        .collect())
}

/// The corners of a wide loop's path (see [`WideLoop`]) from `start`, fed back along `outward` by
/// `feed` times the circle drawn so far.
fn loop_path(start: [f64; 3], l: &WideLoop) -> Vec<[f64; 3]> {
    let Some([u, v, w]) = loop_frame(l.outward, l.side) else {
        return Vec::new();
    };
    let local = loop_local(l);
    let circle = LOOP_POINTS * 8;
    let mut out: Vec<[f64; 3]> = local
        .iter()
        .map(|p| {
            add(
                start,
                add(add(scale(u, p[0]), scale(v, p[1])), scale(w, p[2])),
            )
        })
        .collect();
    if l.feed > 0.0 {
        let (mut drawn, mut prev) = (0.0, start);
        for (k, p) in out.iter_mut().enumerate() {
            if k < circle {
                drawn += norm([p[0] - prev[0], p[1] - prev[1], p[2] - prev[2]]);
                prev = *p;
            }
            *p = add(*p, scale(u, -l.feed * drawn));
        }
    }
    out
}

fn densify(start: [f64; 3], corners: &[[f64; 3]], max_step: f64) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    let mut prev = start;
    for &p in corners {
        let d = [p[0] - prev[0], p[1] - prev[1], p[2] - prev[2]];
        let k = (norm(d) / max_step).ceil().clamp(1.0, 1e7) as usize;
        for i in 1..=k {
            out.push(add(prev, scale(d, i as f64 / k as f64)));
        }
        prev = p;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_draw_turn_s_tail_is_set_by_with_tail_and_checked() {
        let base = Script::builtin("stitch-pass").unwrap();
        let draws = |s: &Script| s.turn.iter().filter_map(|t| t.draw).collect::<Vec<_>>();
        assert_eq!(draws(&base), vec![Draw { tail: STITCH_TAIL }]);
        let ten = base.clone().with_tail(10.0);
        assert_eq!(draws(&ten), vec![Draw { tail: 10.0 }]);
        assert!(ten.check().is_ok());
        // Only draw turns take it: a script without one is unchanged.
        let square = Script::builtin("square").unwrap();
        assert_eq!(square.clone().with_tail(3.0), square);
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let e = base.clone().with_tail(bad).check().unwrap_err();
            assert!(e.contains("draw.tail"), "{e}");
        }
        // In TOML it is `draw = { tail = L }` on the turn.
        let text = toml::to_string(&ten).unwrap();
        assert_eq!(Script::parse(&text, "ten").unwrap(), ten);
        assert!(text.contains("[turn.draw]\ntail = 10.0"), "{text}");
    }

    #[test]
    fn a_perturbation_is_small_repeatable_and_off_at_seed_zero() {
        let base = Script::builtin("square").unwrap();
        let mut zero = base.clone();
        zero.perturb(0);
        assert_eq!(zero, base);
        let (mut a, mut b, mut c) = (base.clone(), base.clone(), base.clone());
        a.perturb(7);
        b.perturb(7);
        c.perturb(8);
        assert_eq!(a, b, "one seed, one script: the hands agree");
        assert_ne!(a, c);
        assert_ne!(a, base);
        for (p, q) in a.turn.iter().zip(&base.turn) {
            if let (Some(t), Some(u)) = (p.throw, q.throw) {
                assert!((t.scale / u.scale - 1.0).abs() <= 0.10);
                for k in 0..3 {
                    assert!((t.outward[k] - u.outward[k]).abs() <= 0.05);
                }
                assert!(t.exit >= 0.0 && (t.exit - u.exit).abs() <= 1.0);
            }
            for (w, v) in p.waypoints.iter().zip(&q.waypoints) {
                let d =
                    ((w[0] - v[0]).powi(2) + (w[1] - v[1]).powi(2) + (w[2] - v[2]).powi(2)).sqrt();
                assert!(d <= 0.1, "a waypoint moved by {d}");
            }
        }
        a.check().unwrap();
    }

    #[test]
    fn a_tremor_is_bounded_repeatable_and_differs_between_hands() {
        let shake = |seed, hand: &str, amp| {
            let mut t = Tremor::new(seed, hand, amp);
            (0..1000)
                .map(|_| t.apply([1.0, 2.0, 3.0]))
                .collect::<Vec<_>>()
        };
        let a = shake(5, "A", 0.02);
        assert_eq!(a, shake(5, "A", 0.02));
        assert_ne!(a, shake(5, "B", 0.02));
        let mut largest = 0f64;
        for p in &a {
            let d = ((p[0] - 1.0).powi(2) + (p[1] - 2.0).powi(2) + (p[2] - 3.0).powi(2)).sqrt();
            assert!(d <= 0.02, "moved by {d}");
            largest = largest.max(d);
        }
        // Uniform in the ball: among 1000 draws some reach its outer tenth.
        assert!(largest > 0.018, "largest offset {largest}");
        assert!(shake(5, "A", 0.0).iter().all(|p| *p == [1.0, 2.0, 3.0]));
    }

    #[test]
    fn builtins_round_trip_through_toml() {
        for name in BUILTINS {
            let s = Script::builtin(name).unwrap();
            s.check().unwrap();
            let text = toml::to_string(&s).unwrap();
            assert_eq!(Script::parse(&text, "x").unwrap(), s);
        }
    }

    #[test]
    fn bad_scripts_name_the_line_and_field() {
        let e = Script::parse(
            "name = \"a\"\n[[turn]]\nhand = \"A\"\nchain = \"r\"\njoint = \"elbow\"\n",
            "s.toml",
        )
        .unwrap_err();
        assert!(e.contains("joint \"elbow\""), "{e}");
        let e = Script::parse(
            "name = \"a\"\n[[turn]]\nhand = \"A\"\nchain = 3\njoint = \"head\"\n",
            "s.toml",
        )
        .unwrap_err();
        assert!(e.starts_with("s.toml:4:"), "{e}");
        let e = Script::parse("name = \"a\"\nmax_step = -1\n[[turn]]\nhand = \"A\"\nchain = \"r\"\njoint = \"head\"\n", "s")
            .unwrap_err();
        assert!(e.contains("max_step"), "{e}");
    }

    #[test]
    fn a_fed_loop_walks_back_by_its_circle_and_a_left_loop_is_the_mirror() {
        let script = |extra: &str| {
            Script::parse(
                &format!(
                    "name = \"w\"\n[[turn]]\nhand = \"A\"\nchain = \"paper\"\njoint = \"head\"\nwide_loop = {{ outward = [1, 0, 0], side = [0, 1, 0], radius = 4{extra} }}\n"
                ),
                "w.toml",
            )
            .unwrap()
            .turn[0]
                .targets([40.0, 0.0, 0.0], 0.05)
        };
        let plain = script("");
        // Fed: the first step stays put along the rope (the hand draws back as much as it heads
        // out), and the tuck is the plain one moved back along -x by the circle's length, which
        // lies between the circle's and the circle's plus its rise of one unit.
        let fed = script(", feed = 1");
        assert!(fed[0][0] < 40.0 + 1e-3, "{:?}", fed[0]);
        let (a, b) = (plain.last().unwrap(), fed.last().unwrap());
        let back = a[0] - b[0];
        let circle = std::f64::consts::TAU * 4.0;
        assert!((circle..circle + 1.0).contains(&back), "{back}");
        assert!((a[1] - b[1]).abs() < 1e-9 && (a[2] - b[2]).abs() < 1e-9);
        // Left: every point of the right (default) loop with its height (along outward × side)
        // the other way.
        let left = script(", handedness = \"left\"");
        assert_eq!(left.len(), plain.len());
        for (l, r) in left.iter().zip(&plain) {
            assert!((l[0] - r[0]).abs() < 1e-9 && (l[1] - r[1]).abs() < 1e-9);
            assert!((l[2] + r[2]).abs() < 1e-9, "{l:?} {r:?}");
        }
        let bad = Script::parse(
            "name = \"w\"\n[[turn]]\nhand = \"A\"\nchain = \"paper\"\njoint = \"head\"\nwide_loop = { outward = [1, 0, 0], side = [0, 1, 0], feed = -1 }\n",
            "w.toml",
        )
        .unwrap_err();
        assert!(
            bad.contains("wide_loop.feed") && bad.contains("turn 1"),
            "{bad}"
        );
    }

    #[test]
    fn a_wide_loop_needs_a_side_across_its_direction_and_keeps_the_step() {
        let text = |side: &str| {
            format!(
                "name = \"w\"\n[[turn]]\nhand = \"A\"\nchain = \"paper\"\njoint = \"head\"\nwide_loop = {{ outward = [1, 0, 0], side = {side} }}\n"
            )
        };
        let e = Script::parse(&text("[2, 0, 0]"), "w.toml").unwrap_err();
        assert!(e.contains("not parallel"), "{e}");
        let s = Script::parse(&text("[0.5, 1, 0]"), "w.toml").unwrap();
        let l = s.turn[0].wide_loop.unwrap();
        assert_eq!((l.radius, l.exit), (4.5, 5.4));
        let p = s.turn[0].targets([0.0; 3], 0.05);
        let mut prev = [0.0; 3];
        for q in &p {
            let d = norm([q[0] - prev[0], q[1] - prev[1], q[2] - prev[2]]);
            assert!(d <= 0.05 + 1e-12, "{d}");
            prev = *q;
        }
        // The loop lies on the +y side (its far side two radii out), rises one unit to cross, dips
        // one under, and the pull ends 1.3 radii + exit back along -x, level with the loop's centre.
        let ys = p.iter().map(|q| q[1]);
        assert!(ys.clone().fold(f64::MIN, f64::max) > 8.0);
        assert!(ys.fold(f64::MAX, f64::min) > -3.0);
        let zs = p.iter().map(|q| q[2]);
        assert!(zs.clone().fold(f64::MIN, f64::max) > 0.99);
        assert!(zs.fold(f64::MAX, f64::min) < -0.99);
        let end = *p.last().unwrap();
        assert!(
            (end[0] + 1.3 * 4.5 + 5.4).abs() < 1e-9 && (end[1] - 4.5).abs() < 1e-9,
            "{end:?}"
        );
    }

    /// A rope written here: straight along +x from the origin to (20, 0, 0), then a circle of radius
    /// `r` about (20, r) drawn counter-clockwise from its bottom, rising to `z = 1` over its last
    /// quarter, its end `back` short of the bottom (in unit-ish links).
    fn looped_rope(r: f64, back: f64) -> Vec<[f64; 3]> {
        let mut p: Vec<[f64; 3]> = (0..=20).map(|k| [k as f64, 0.0, 0.0]).collect();
        let m = 40;
        for k in 1..=m {
            let a = (std::f64::consts::TAU - back / r) * k as f64 / m as f64;
            let z = (4.0 * k as f64 / m as f64 - 3.0).max(0.0);
            p.push([20.0 + r * a.sin(), r - r * a.cos(), z]);
        }
        p
    }

    #[test]
    fn a_tuck_finds_the_loop_where_it_lies_and_threads_it() {
        let tuck = Tuck {
            outward: [1.0, 0.0, 0.0],
            side: [0.0, 1.0, 0.0],
            clearance: 1.0,
            exit: 2.0,
            handedness: Handedness::Right,
        };
        let turn = Turn {
            tuck: Some(tuck),
            ..turn("B", "paper", "head", None, vec![])
        };
        // The end closes the loop just past the rope it crosses (a proper crossing), or 0.4 short of
        // it (closed within the clearance): either way the loop of radius 3 about (20, 3) is found.
        for back in [-0.3, 0.4] {
            let rope = looped_rope(3.0, back);
            let head = rope.len() - 1;
            let p = turn.targets_on(&rope, head, 0.05).unwrap();
            let mut prev = rope[head];
            for q in &p {
                assert!(norm([q[0] - prev[0], q[1] - prev[1], q[2] - prev[2]]) <= 0.05 + 1e-12);
                prev = *q;
            }
            // Under the far side (x beyond 23, below the loop), up through the middle (near
            // (20, 3) and rising), over the near side (x short of 17, above), then 2 on along −x.
            assert!(p.iter().any(|q| q[0] > 23.5 && q[2] < -0.5), "back {back}");
            let through = p
                .iter()
                .filter(|q| (q[0] - 20.0).abs() < 1.0 && (q[1] - 3.0).abs() < 1.0)
                .map(|q| q[2]);
            let (lo, hi) = through.fold((f64::MAX, f64::MIN), |(a, b), z| (a.min(z), b.max(z)));
            assert!(lo < -0.5 && hi > 0.5, "back {back}: {lo} {hi}");
            let end = p.last().unwrap();
            assert!(end[0] < 15.5 && end[2] > 0.5, "back {back}: {end:?}");
            // The left tuck is the same path the other way up.
            let left = Turn {
                tuck: Some(Tuck {
                    handedness: Handedness::Left,
                    ..tuck
                }),
                ..turn.clone()
            };
            let q = left.targets_on(&rope, head, 0.05).unwrap();
            assert!(q.iter().any(|x| x[0] > 23.5 && x[2] > 0.5), "back {back}");
            assert!(
                q.iter().all(|x| !(x[0] > 23.5 && x[2] < -0.5)),
                "back {back}"
            );
            let end = q.last().unwrap();
            assert!(end[0] < 15.5 && end[2] < -0.5, "back {back}: {end:?}");
        }
        // A straight rope has no loop: the turn is refused; so is a joint that is not an end.
        let straight: Vec<[f64; 3]> = (0..=40).map(|k| [k as f64, 0.0, 0.0]).collect();
        let e = turn.targets_on(&straight, 40, 0.05).unwrap_err();
        assert!(e.contains("no loop"), "{e}");
        assert!(turn.targets_on(&looped_rope(3.0, -0.3), 20, 0.05).is_err());
        assert!(turn.targets_on(&straight, 41, 0.05).is_err());
        // A circle whose end stops farther from the rope than the clearance (2.3 above it) is no
        // loop yet.
        let open = looped_rope(3.0, 4.0);
        assert!(turn.targets_on(&open, 60, 0.05).is_err());
    }

    #[test]
    fn a_tuck_on_a_long_chain_looks_only_near_the_hand() {
        let turn = Turn {
            tuck: Some(Tuck {
                outward: [1.0, 0.0, 0.0],
                side: [0.0, 1.0, 0.0],
                clearance: 1.0,
                exit: 2.0,
                handedness: Handedness::Right,
            }),
            ..super::turn("B", "long", "head", None, vec![])
        };
        // 65 536 joints leading in along −x, then the loop at the head: found.
        let lead: Vec<[f64; 3]> = (0..65_536)
            .map(|k| [k as f64 - 65_536.0, 0.0, 0.0])
            .collect();
        let rope: Vec<[f64; 3]> = lead.iter().copied().chain(looped_rope(3.0, -0.3)).collect();
        assert!(turn.targets_on(&rope, rope.len() - 1, 0.05).is_ok());
        // The same loop followed by more straight rope than the search walks (going on from the
        // loop's end, away from it): seen from that end, no loop.
        let mut far = looped_rope(3.0, -0.3);
        let from = *far.last().unwrap();
        far.extend((1..=LOOP_SEARCH_JOINTS).map(|k| [from[0] - k as f64, from[1], 5.0]));
        let e = turn.targets_on(&far, far.len() - 1, 0.05).unwrap_err();
        assert!(e.contains("no loop"), "{e}");
    }

    #[test]
    fn a_wrap_winds_round_the_instrument_where_it_is_and_an_instrument_turn_steps_its_pose() {
        let tie = Script::builtin("instrument-tie").unwrap();
        let wrap = tie.turn.iter().find(|t| t.wrap.is_some()).unwrap().clone();
        let w = wrap.wrap.unwrap();
        // A driver along +z from (1, 2, 0): the hand's end at (10, 2, 3) starts the circle on the
        // +x side, `at` up from the tip, winds once counter-clockwise seen along +z, advancing along
        // the axis by the pitch (negative: toward the tip).
        let rope: Vec<[f64; 3]> = (0..=10).map(|k| [k as f64, 2.0, 3.0]).collect();
        let driver = ([1.0, 2.0, 0.0], [1.0, 2.0, 14.0]);
        let p = wrap.targets_with(&rope, 10, &[driver], 0.05).unwrap();
        let mut prev = rope[10];
        for q in &p {
            assert!(norm(sub(*q, prev)) <= 0.05 + 1e-12);
            prev = *q;
        }
        let on_circle: Vec<&[f64; 3]> = p
            .iter()
            .filter(|q| ((q[0] - 1.0).hypot(q[1] - 2.0) - w.radius).abs() < 1e-9)
            .collect();
        assert!(on_circle.len() > 40, "{}", on_circle.len());
        let first = on_circle[0];
        assert!((first[0] - (1.0 + w.radius)).abs() < 1e-9 && (first[2] - w.at).abs() < 1e-9);
        let last = p.last().unwrap();
        assert!((last[0] - first[0]).abs() < 1e-9 && (last[2] - w.at - w.pitch).abs() < 1e-9);
        // Counter-clockwise about +z: a quarter of the way round the circle is on the +y side.
        let quarter = on_circle[on_circle.len() / 4];
        assert!(quarter[1] > 2.0 + 0.9 * w.radius, "{quarter:?}");
        // No instrument, or a sphere: refused.
        assert!(wrap.targets_with(&rope, 10, &[], 0.05).is_err());
        let ball = ([1.0, 2.0, 0.0], [1.0, 2.0, 0.0]);
        assert!(wrap.targets_with(&rope, 10, &[ball], 0.05).is_err());

        // The driver carried from where the scene parks it to the tail: its tip ends on the joint,
        // its axis along the script's, and no step moves any point more than the step.
        let carry = tie.turn.iter().find(|t| t.instrument.is_some()).unwrap();
        let m = carry.instrument.unwrap();
        let park = (
            [0.0, -6.0, 0.0],
            [7.0 * 2f64.sqrt(), -6.0, 7.0 * 2f64.sqrt()],
        );
        let tail = [0.5, 0.0, 0.0];
        let poses = carry.instrument_poses(tail, park, 0.05);
        let half = 7.0;
        let ends = |(c, d): ([f64; 3], [f64; 3])| (sub(c, scale(d, half)), add(c, scale(d, half)));
        let mut prev = park;
        for pose in &poses {
            assert!((norm(pose.1) - 1.0).abs() < 1e-12);
            let (a, b) = ends(*pose);
            assert!(norm(sub(a, prev.0)) <= 0.05 + 1e-9 && norm(sub(b, prev.1)) <= 0.05 + 1e-9);
            prev = (a, b);
        }
        let (a, _) = ends(*poses.last().unwrap());
        assert!(norm(sub(a, add(tail, m.tip))) < 1e-9);
        let axis = poses.last().unwrap().1;
        let want = scale(m.axis, 1.0 / norm(m.axis));
        assert!(norm(sub(axis, want)) < 1e-12);

        // An instrument turn moves nothing else; bad numbers name the field.
        let bad = |extra: &str| {
            Script::parse(
                &format!(
                    "name = \"i\"\n[[turn]]\nhand = \"B\"\nchain = \"tie\"\njoint = \"tail\"\n{extra}\n"
                ),
                "i.toml",
            )
            .unwrap_err()
        };
        let e = bad("waypoints = [[1, 0, 0]]\ninstrument = { index = 0, tip = [0, 0, 0] }");
        assert!(e.contains("moves nothing else"), "{e}");
        let e = bad("instrument = { index = 0, tip = [0, 0, 0], axis = [0, 0, 0] }");
        assert!(e.contains("instrument.axis"), "{e}");
        let e = bad("tuck = { outward = [1, 0, 0], side = [2, 0, 0] }");
        assert!(e.contains("tuck.outward"), "{e}");
        let e = bad("wrap = { instrument = 0, at = 3, radius = -1 }");
        assert!(e.contains("wrap.radius"), "{e}");
        let e = bad("wrap = { instrument = 0, at = 3, radius = 1, turns = 1000 }");
        assert!(e.contains("wrap.turns"), "{e}");
    }

    #[test]
    fn targets_start_next_to_the_hand_and_respect_the_step() {
        let t = &Script::builtin("square").unwrap().turn[0];
        let start = [0.0, 0.0, 0.0];
        let p = t.targets(start, 0.05);
        let mut prev = start;
        for q in &p {
            let d = norm([q[0] - prev[0], q[1] - prev[1], q[2] - prev[2]]);
            assert!(d <= 0.05 + 1e-12, "{d}");
            prev = *q;
        }
        // Heads outward (−x) and ends 30 further on.
        assert!(p.last().unwrap()[0] < -30.0);
    }

    /// A pose turn's moves, checked by the test's own arc and Rodrigues' formula: a needle of radius 1
    /// and 120° in four capsules, swaged at the origin along +x curving toward +z, turned to leave
    /// along −x curving toward +y while its swage goes 1 along +y. The last move is the pose asked for
    /// (its frame's x the tangent and y the bend, to 1e-12), the swage ends where the path does, and
    /// no point of the needle moves more than the step (plus the swage's own) between moves.
    /// A point of the unit-radius arc swaged at `c`, leaving along `t`, curving toward `b`, `phi` on.
    fn arc(c: [f64; 3], t: [f64; 3], b: [f64; 3], phi: f64) -> [f64; 3] {
        let (s, k) = (phi.sin(), phi.cos());
        [0, 1, 2].map(|i| c[i] + b[i] + t[i] * s - b[i] * k)
    }

    /// Rodrigues' formula: `v` turned by the rotation vector `r`.
    fn rodrigues(r: [f64; 3], v: [f64; 3]) -> [f64; 3] {
        let a = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        if a == 0.0 {
            return v;
        }
        let k = r.map(|c| c / a);
        let dot = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
        let cross = [
            k[1] * v[2] - k[2] * v[1],
            k[2] * v[0] - k[0] * v[2],
            k[0] * v[1] - k[1] * v[0],
        ];
        [0, 1, 2].map(|i| v[i] * a.cos() + cross[i] * a.sin() + k[i] * dot * (1.0 - a.cos()))
    }

    /// A unit-radius needle of 120° in four capsules swaged at the origin along +x, curving toward
    /// +z.
    fn test_needle() -> Vec<InstrumentEnds> {
        let ends: Vec<[f64; 3]> = (0..=4)
            .map(|k| {
                arc(
                    [0.0; 3],
                    [1.0, 0.0, 0.0],
                    [0.0, 0.0, 1.0],
                    120f64.to_radians() * k as f64 / 4.0,
                )
            })
            .collect();
        ends.windows(2).map(|w| (w[0], w[1])).collect()
    }

    /// A drive's moves: each swage on the needle's circle (centre (0, 0, 1), radius 1, in y = 0) and
    /// each pose's frame (by the test's Rodrigues formula) tangent there, curving toward the centre,
    /// to 1e-12; the swage goes the way the point leads (+x first); the steps at most `max_step`.
    #[test]
    fn a_drive_s_poses_keep_the_needle_on_its_circle() {
        let moves = needle_arc([0.0; 3], &test_needle(), 90.0, 0.05).unwrap();
        assert_eq!(
            moves.len(),
            (std::f64::consts::FRAC_PI_2 / 0.05).ceil() as usize
        );
        let mut before = [0.0; 3];
        for (k, (p, r)) in moves.iter().enumerate() {
            let to_centre = [-p[0], -p[1], 1.0 - p[2]];
            let off = (to_centre.iter().map(|c| c * c).sum::<f64>().sqrt() - 1.0).abs();
            assert!(off < 1e-12 && p[1].abs() < 1e-12, "move {k}: {p:?}");
            let (t, b) = (
                rodrigues(*r, [1.0, 0.0, 0.0]),
                rodrigues(*r, [0.0, 1.0, 0.0]),
            );
            for i in 0..3 {
                assert!((b[i] - to_centre[i]).abs() < 1e-12, "move {k}: bend {b:?}");
            }
            let dot: f64 = (0..3).map(|i| t[i] * to_centre[i]).sum();
            assert!(dot.abs() < 1e-12, "move {k}: tangent {t:?}");
            let step = (0..3)
                .map(|i| (p[i] - before[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(step <= 0.05 + 1e-12, "move {k}: a step of {step}");
            before = *p;
        }
        assert!(moves[0].0[0] > 0.0, "the swage went back: {:?}", moves[0].0);
        let last = moves.last().unwrap().0;
        assert!((last[0] - 1.0).abs() < 1e-12 && (last[2] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_pose_turn_turns_the_needle_to_its_pose_in_small_steps() {
        let (x, z) = ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        let caps = test_needle();
        let path: Vec<[f64; 3]> = (1..=20).map(|k| [0.0, k as f64 * 0.05, 0.0]).collect();
        let pose = Pose {
            tangent: [-1.0, 0.0, 0.0],
            bend: [0.0, 1.0, 0.0],
        };
        let moves = needle_poses([0.0; 3], &caps, &path, path.len(), &pose, 0.05).unwrap();
        let (last_at, last_r) = *moves.last().unwrap();
        let close = |a: [f64; 3], b: [f64; 3], tol: f64| (0..3).all(|i| (a[i] - b[i]).abs() < tol);
        assert!(
            close(rodrigues(last_r, x), pose.tangent, 1e-12),
            "{last_r:?}"
        );
        assert!(close(rodrigues(last_r, [0.0, 1.0, 0.0]), pose.bend, 1e-12));
        assert!(close(last_at, [0.0, 1.0, 0.0], 1e-12), "{last_at:?}");
        // The needle's ends at each move (at the start: its frame is x, z).
        let needle = |at: [f64; 3], t: [f64; 3], b: [f64; 3]| -> Vec<[f64; 3]> {
            (0..=4)
                .map(|k| arc(at, t, b, 120f64.to_radians() * k as f64 / 4.0))
                .collect()
        };
        let mut before = needle([0.0; 3], x, z);
        let mut at_before = [0.0; 3];
        // A half turn about the bisector of the two frames: the point's path is 2rθ at most.
        assert!(
            moves.len() >= (2.0 * std::f64::consts::PI / 0.05) as usize,
            "{}",
            moves.len()
        );
        for (at, r) in &moves {
            let now = needle(*at, rodrigues(*r, x), rodrigues(*r, [0.0, 1.0, 0.0]));
            let swage = (0..3)
                .map(|i| (at[i] - at_before[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            for (p, q) in now.iter().zip(&before) {
                let d = (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>().sqrt();
                assert!(d <= 0.05 + swage + 1e-9, "a needle end moved {d}");
            }
            before = now;
            at_before = *at;
        }
    }
}
