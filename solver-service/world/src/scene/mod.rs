//! Scenes: the chains a service instance holds, read from TOML and validated before anything is built.
//!
//! A scene is a list of `[[chain]]` tables. Each chain declares what it needs, and the service builds
//! nothing more: planar chains get planar (2D) state and math, f32 chains f32 state, and collision
//! structures exist only for chains that declare collision.
//!
//! | field | type | default | meaning |
//! |---|---|---|---|
//! | `name` | string, 1..=31 bytes | required | unique handle for clients |
//! | `kind` | `"free"` \| `"fixed-base"` | `"free"` | a rope or snake, or a manipulator whose joint 0 never moves |
//! | `space` | `"planar"` \| `"spatial"` | `"spatial"` | planar chains live in the z = 0 plane |
//! | `links` | integer, 1..=65536 | required unless `shape = "points"` | number of links |
//! | `link_length` / `link_lengths` | positive number / list of `links` numbers | required unless `shape = "points"` | link lengths |
//! | `base` | `[x, y]` or `[x, y, z]` | origin | position of joint 0 (the tail; the base of a manipulator) |
//! | `shape` | `"straight"` \| `"arc"` \| `"points"` | `"straight"` | initial shape |
//! | `axis` | vector | `[1, 0, 0]` | direction of a straight chain; start tangent of an arc |
//! | `radius`, `bend` | number, vector | –, `[0, 1, 0]` | arc radius (≥ half the longest link) and the side it bends to |
//! | `points` | list of `links + 1` points | – | explicit joints (`shape = "points"`); lengths come from them |
//! | `thickness` | number ≥ 0 | 0 | diameter, for collision and pictures |
//! | `collision` | `"none"` \| `"capsules"` \| `"paper-spheres"` | `"none"` | collision scheme (free chains only; see `tractrix::collision`) |
//! | `self_collision` | bool | `true` with a scheme | whether links collide with each other |
//! | `obstacles` | list of obstacle names | `[]` | the `[[obstacle]]`s this chain avoids (needs a scheme) |
//! | `instruments` | list of instrument names | `[]` | the `[[instrument]]`s that push this chain (needs a scheme) |
//! | `collision_iterations` | integer 1..=10000 | 64 | passes per substep before the chain is "locked" |
//! | `collision_tolerance` | number in (0, 1) | 0.01 | accepted penetration, fraction of the clearance |
//! | `collision_over_relaxation` | number in [1, 2) | 1.5 | each push as a multiple of its contact's depth: fewer passes on a jammed knot (BENCHMARKS.md, collision) |
//! | `collision_pushed_weight` | number in (0, 1] | 1 | ropes with held joints: how freely pushed joints move when the rope is relaxed to its lengths after a pass (1: like the others); smaller takes fewer passes but locks more moves (BENCHMARKS.md, contact) |
//! | `collision_together_after` | integer 0..=4096 | 2 | ropes with held joints: the passes after which a move's contacts and lengths are solved together (the joint projection; 0: the passes alone); not on ropes through eyelets (BENCHMARKS.md, contact) |
//! | `precision` | `"f64"` \| `"f32"` | `"f64"` | arithmetic and storage of the chain |
//! | `method` | `"tractrix"` \| `"paper"` \| `"ftl"` | `"tractrix"` | default single-link method |
//! | `substeps` / `max_step` | integer ≥ 1 / fraction of the shortest link | `substeps = 1` | default substep policy |
//! | `max_substeps` | integer ≥ 1 | 65536 | a move needing more substeps is refused |
//! | `strategy` | `"translate-back"` \| `"two-link"` \| `"pull-back"` | `"translate-back"` | fixed-base strategy (also of a free chain's held sides) |
//! | `tolerance` | number in (0, 0.1] | 1e-9 | fixed-base tolerance, fraction of the total length |
//! | `max_iterations` | integer 1..=100000 | 1000 (64 with joint limits) | fixed-base iteration limit |
//! | `hierarchy_after` | integer 0..=100000 | 16 | fixed-base iterations before Korein & Badler's reach hierarchy finishes (0: never; also of a free chain's held sides); smaller is faster and places more of the pose by the hierarchy (BENCHMARKS.md, "What joint limits cost") |
//! | `min_bend_radius` | positive length | – | a rope's bend radius: a cone `2·atan(L / 2R)` at each joint (`L` its shorter link) |
//! | `max_bend` / `max_bends` | degrees in [0, 180] / list of `links + 1` | – | a cone at every joint / per joint (the ends' entries are ignored) |
//! | `joint_range` / `joint_ranges` | `[lo, hi]` degrees / list of `links + 1` pairs | – | signed range of every joint / per joint; planar chains only |
//! | `eyelets` | list of points on the chain | `[]` | fixed points the rope slides through (free chains; docs/eyelets.md) |
//! | `tissue` | `[lo, hi]` box corners | – | a block the head pierces, making eyelets (free spatial chains); with collision, the rope stays out of it but where it passes through |
//! | `needle` | `[radius, angle°, thickness]` | – | a curved needle swaged to the head: an arc of that radius spanning that angle (at most 270°), drawn and pushed as capsules, carried rigidly with the head (needs `tissue` and collision) |
//! | `needle_bend` | direction | up (`[0, 0, 1]`; `[1, 0, 0]` for a vertical head link) | the way the needle first curves from the head link (made perpendicular to it): `[0, 0, -1]` lays it curving down, point toward tissue below, ready to be driven (`FLAG_DRIVE`) |
//! | `incision` | `[point, normal]` | – | the plane of the incision a stitch closes (needs `tissue` and `tissue_give`) |
//! | `tissue_give` | number > 0 | – | after a request whose pull stopped short, each threaded eyelet moves this much per unit of pull toward the incision (needs `incision`) |
//! | `wound_margin` | number ≥ 0 | 0 | how near the incision an eyelet may be drawn: the wound is closed when every eyelet is this far from it |
//! | `eyelet_friction` | number ≥ 0, or `inf` | 0 | 0: the rope slides freely through the eyelets; more: it sticks in them until the pulled side is taut; `inf`: it never slides |
//!
//! At most one of the limit fields (`tractrix::limits`): the angle at joint `j` is the turn from link
//! `j` to link `j + 1` (0 where the chain runs straight; counter-clockwise positive in the plane), the
//! two ends have none, and a fixed base's own angle is not limited. The initial pose must lie within
//! them. Without a limit field a chain has none and costs nothing more.
//!
//! Static obstacles are `[[obstacle]]` tables: `name`, `shape = "sphere"` (`center`, `radius`),
//! `"capsule"` (`a`, `b`, `radius`) or `"plane"` (`point`, `normal`: the free side). A chain lists the
//! ones it avoids; a planar chain's obstacles must lie in its plane.
//!
//! Instruments are `[[instrument]]` tables of the same form (spheres and capsules only): a needle
//! driver's jaws, a forceps tip, a post a hand carries. They start where the table puts them and move
//! when a client sends the `instrument` command with a new pose, pushing the chain that lists them. An
//! instrument belongs to one chain (its pose is part of that chain's state: journaled, snapshotted, put
//! back by `reset`); the chain's `instruments` list gives each its index on the wire. `follows = "head"`
//! (or `"tail"`, or a joint index) makes an instrument ride with that joint, as a needle driver rides
//! with the hand that holds the suture: a move of the joint carries the instrument along, pushing the
//! rest of the rope; the links within the instrument's reach of the joint are held by it and not tested
//! against it.
//!
//! A `[[bundle]]` is many free strands of equal links moved together by one request (hair, fur, a
//! bundle of sutures; see `shared`'s "Bundles"): its handle comes after the chains'. Its strands hang
//! straight from heads on a grid; it has no collision, no holds and no instruments.
//!
//! | field | type | default | meaning |
//! |---|---|---|---|
//! | `name` | string, 1..=31 bytes | required | unique among chains and bundles |
//! | `strands` | integer, 1..=131072 | required | number of strands |
//! | `links` | integer ≥ 1, strands × (links + 1) ≤ 2²⁰ | required | links per strand |
//! | `link_length` | positive number | required | every link's length |
//! | `origin` | vector | origin | the first strand's head |
//! | `spacing`, `columns` | positive number, integer | `link_length`, ⌈√strands⌉ | heads on a grid in z = const: strand `i` at `origin + spacing·(i mod columns, i div columns, 0)` |
//! | `hang` | vector | `[0, 0, -1]` | the direction each strand hangs from its head |
//! | `precision` | `"f64"` \| `"f32"` | `"f64"` | arithmetic and storage |
//! | `substeps` | integer ≥ 1 | 1 | default substeps of a move |
//! | `two_cores` | bool | `true` | sweep half the strands on a second thread when a move is large enough |
//!
//! Errors name the file, the line and the field; sizes are checked before anything is allocated.
//!
//! Three steps: `read` (TOML into raw tables that remember their spans), `validate` (raw tables into
//! [`ChainSpec`]s of kernel types) and `shapes` (initial joints).

mod read;
mod shapes;
mod validate;

use nalgebra::Vector3;
use std::fmt;
use tractrix::collision::{CollisionOptions, Obstacle};
use tractrix::{JointLimits, LimitKind, MoveOptions, ReachOptions};

/// The scene served when no file is given: the paper's rope, snake and planar manipulator.
pub const DEFAULT_SCENE: &str = include_str!("../../../scenes/default.toml");
/// Name under which the default scene is reported in errors.
pub const DEFAULT_SCENE_NAME: &str = "<default scene>";
/// Largest scene file read (bytes).
pub const MAX_SCENE_BYTES: u64 = 16 << 20;
/// Largest `max_substeps` a scene may allow.
pub const MAX_SUBSTEPS_LIMIT: u32 = 1 << 20;
/// Most links all the chains of a scene may have together (about 100 MB of state and buffers): a
/// short file cannot make the service allocate gigabytes.
pub const MAX_SCENE_LINKS: usize = 1 << 20;
/// Most obstacles a scene may declare (each is tested against every link of the chains that list it).
pub const MAX_OBSTACLES: usize = 256;
/// Most instruments a scene may declare.
pub const MAX_INSTRUMENTS: usize = 64;
/// Most joints all the bundles of a scene may have together (48 MiB of f64 state).
pub const MAX_SCENE_BUNDLE_JOINTS: usize = 2 << 20;

/// A scene error: where and what.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The file (or [`DEFAULT_SCENE_NAME`]).
    pub file: String,
    /// 1-based line (0 when the error concerns the whole file).
    pub line: usize,
    /// What is wrong, naming the chain and the field.
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "{}:{}: {}", self.file, self.line, self.message)
        } else {
            write!(f, "{}: {}", self.file, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

/// What a chain is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ChainKind {
    /// A rope, suture or snake: every joint free.
    Free,
    /// A manipulator whose joint 0 is fixed.
    FixedBase,
}

/// The arithmetic and storage of a chain or bundle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Precision {
    /// Double precision.
    F64,
    /// Single precision.
    F32,
}

/// One chain of a validated scene, everything resolved into the kernel's types.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainSpec {
    /// Line of its `links` (or `points`) field in the scene file (errors found after validation point
    /// there).
    pub links_line: usize,
    /// Unique handle for clients (1..=31 bytes).
    pub name: String,
    /// Free (rope, snake) or fixed base (manipulator).
    pub kind: ChainKind,
    /// 2 (planar, z = 0) or 3.
    pub dims: u32,
    /// `F64` or `F32`: the chain's arithmetic and storage.
    pub precision: Precision,
    /// Initial joint positions, tail first (z = 0 for planar chains).
    pub points: Vec<Vector3<f64>>,
    /// Link lengths, positive.
    pub lengths: Vec<f64>,
    /// Sum of the link lengths.
    pub total_length: f64,
    /// The shortest link (the unit of `max_step`).
    pub shortest: f64,
    /// Largest coordinate a target of this chain may have ([`crate::sizes::max_coordinate`]).
    pub max_coordinate: f64,
    /// Diameter, for collision and pictures.
    pub thickness: f64,
    /// Collision handling, only when the chain declares a scheme.
    pub collision: Option<CollisionSpec>,
    /// Default method and substeps of a move, and the substep limit.
    pub moves: MoveOptions<f64>,
    /// Default strategy, tolerance (fraction of the total length) and iteration limit of a reach.
    pub reach: ReachOptions<f64>,
    /// Joints held from the start and never released (`anchors`: a suture's end in tissue, a rope tied
    /// to a ring), ascending; free chains only.
    pub anchors: Vec<u32>,
    /// Joint limits, only when the chain declares them.
    pub limits: Option<LimitSpec>,
    /// Fixed points the chain passes through from the start, the rope sliding through each
    /// (`eyelets`: free chains without instruments; [`tractrix::eyelet`]), in order along
    /// the rope, each with the link through it.
    pub eyelets: Vec<(Vector3<f64>, usize)>,
    /// A block of tissue the chain's head pierces (`tissue = [[lo], [hi]]`, an axis-aligned box):
    /// where the head goes in or out through its surface an eyelet is made, on the link there. With
    /// collision it is also an obstacle the rope stays out of, but where it passes through.
    pub tissue: Option<(Vector3<f64>, Vector3<f64>)>,
    /// Whether its knot is named with every answer and state (`knot = true`: free spatial chains;
    /// [`knots::Namer`]).
    pub knot: bool,
    /// Friction at its eyelets (`eyelet_friction`, ≥ 0; 0 slides freely, more sticks the rope in
    /// them until the pulled side is taut: [`tractrix::eyelet::EyeletWorkspace::with_friction`]).
    pub eyelet_friction: f64,
    /// Tissue that gives (`incision`, `tissue_give`, `wound_margin`): the wound the stitch closes.
    pub wound: Option<Wound>,
    /// A curved needle swaged to the head (`needle = [radius, angle°, thickness]`): its capsules are
    /// the chain's last instruments ([`crate::needle`]).
    pub needle: Option<crate::needle::Needle>,
}

/// Tissue that gives: the plane of the incision the stitch closes, and how the eyelets are drawn
/// toward it. After a request whose pull stopped short (the rope taut or its knot jammed), each
/// threaded eyelet moves toward the plane, along its normal, by `give` times the pull's length, no
/// nearer the plane than `margin`: the tissue flows under the suture's pull, as a dashpot does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wound {
    /// A point of the incision's plane.
    pub point: Vector3<f64>,
    /// Its unit normal.
    pub normal: Vector3<f64>,
    /// How far an eyelet moves per unit of blocked pull, each request (`tissue_give`, > 0).
    pub give: f64,
    /// How near the plane an eyelet may come (`wound_margin`, ≥ 0): the wound is closed when
    /// every eyelet is this far from it.
    pub margin: f64,
}

/// A chain's joint limits as its scene declares them, in radians, one entry per joint (the ends'
/// unlimited).
#[derive(Debug, Clone, PartialEq)]
pub struct LimitSpec {
    /// Cones (spatial or planar) or signed ranges (planar).
    pub kind: LimitKind,
    /// Lower bounds (`−hi` for cones).
    pub lo: Vec<f64>,
    /// Upper bounds (a cone's half-angle).
    pub hi: Vec<f64>,
    /// The bend radius the cones came from, when they did.
    pub min_bend_radius: Option<f64>,
}

impl LimitSpec {
    /// The kernel's limits in the chain's scalar (validated when the scene was read).
    pub fn kernel<T: tractrix::Real>(&self) -> Result<JointLimits<T>, tractrix::LimitError> {
        let conv = |v: &[f64]| v.iter().map(|&a| T::lit(a)).collect::<Vec<T>>();
        match self.kind {
            LimitKind::Cone => JointLimits::cones(&conv(&self.hi)),
            LimitKind::Range => JointLimits::ranges(&conv(&self.lo), &conv(&self.hi)),
        }
    }
}

/// A chain's collision handling as its scene declares it.
#[derive(Debug, Clone, PartialEq)]
pub struct CollisionSpec {
    /// Scheme, self-collision, thickness, passes and tolerance.
    pub options: CollisionOptions<f64>,
    /// The static obstacles this chain avoids.
    pub obstacles: Vec<Obstacle<f64, 3>>,
    /// The instruments that push this chain, by name, at their starting poses (wire index = position).
    pub instruments: Vec<(String, Obstacle<f64, 3>)>,
    /// For each instrument, the joint it follows, if any (a hand's grasp).
    pub follows: Vec<Option<u32>>,
}

/// One bundle of a validated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct BundleSpec {
    /// Line of its `links` field in the scene file (errors found after validation point there).
    pub links_line: usize,
    /// Unique handle for clients (1..=31 bytes).
    pub name: String,
    /// Number of strands.
    pub strands: u32,
    /// Links per strand.
    pub links: u32,
    /// Every link's length.
    pub link_length: f64,
    /// `F64` or `F32`.
    pub precision: Precision,
    /// The strands' heads in the scene (the reference of a pose move), strand order.
    pub heads: Vec<Vector3<f64>>,
    /// Unit direction each strand hangs from its head.
    pub hang: Vector3<f64>,
    /// Default substeps of a move.
    pub substeps: u32,
    /// Whether a large move may use a second thread.
    pub two_cores: bool,
    /// Largest coordinate a target may have ([`crate::sizes::max_coordinate`]).
    pub max_coordinate: f64,
}

impl BundleSpec {
    /// Most substeps a move of the bundle may ask for.
    pub fn max_substeps(&self) -> u32 {
        MAX_SUBSTEPS_LIMIT
    }

    /// Joints of all strands: strands × (links + 1).
    pub fn joints(&self) -> usize {
        self.strands as usize * (self.links as usize + 1)
    }
}

/// A validated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The chains, in declaration order (their index is the wire's chain handle).
    pub chains: Vec<ChainSpec>,
    /// The bundles, in declaration order (handle = number of chains + index).
    pub bundles: Vec<BundleSpec>,
    /// The work one request may cost, in link-steps, when the scene says (top-level `budget`): a
    /// scene whose ropes need more collision work per move than the default (fine ropes with many
    /// collision passes) says so itself; `--budget` overrides it.
    pub budget: Option<u64>,
    /// The work one pull may cost (a move or an instrument pose with the pull flag), in link-steps,
    /// when the scene says (top-level `pull_budget`; never more than the request's budget): a haptic
    /// hand's pulls bounded in time while the tie's moves keep the whole budget. A pull's tries stop
    /// short at it (`work budget`), and the next pull goes on from there.
    pub pull_budget: Option<u64>,
}

/// The embedded default scene.
pub fn default_scene() -> Scene {
    parse_scene(DEFAULT_SCENE, DEFAULT_SCENE_NAME).expect("the embedded default scene is valid")
}

/// Parses and validates scene text; `file` names it in errors.
pub fn parse_scene(text: &str, file: &str) -> Result<Scene, SceneError> {
    validate::scene(read::read(text, file)?, text, file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_scene_is_the_papers() {
        let s = default_scene();
        let names: Vec<_> = s.chains.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["rope", "snake", "arm"]);
        assert_eq!(s.chains[0].lengths, vec![1.0; 40]);
        assert_eq!(s.chains[2].kind, ChainKind::FixedBase);
        assert_eq!(s.chains[2].dims, 2);
        assert_eq!(s.chains[2].lengths, vec![0.2; 10]);
    }

    #[test]
    fn hierarchy_after_reaches_the_reach_and_the_held_sides() {
        let text = "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = 1.0\nhierarchy_after = 4\n";
        let s = parse_scene(text, "t.toml").unwrap();
        assert_eq!(s.chains[0].reach.hierarchy_after, 4);
        assert_eq!(s.chains[0].moves.held.hierarchy_after, 4);
        let s = parse_scene(
            "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = 1.0\n",
            "t.toml",
        )
        .unwrap();
        assert_eq!(
            s.chains[0].reach.hierarchy_after, 16,
            "the kernel's default"
        );
    }

    #[test]
    fn a_bundle_hangs_from_a_grid() {
        let s = parse_scene(
            "[[bundle]]\nname = \"hair\"\nstrands = 10\nlinks = 3\nlink_length = 0.5\ncolumns = 4\nspacing = 2.0\norigin = [1, 1, 1]\n",
            "t.toml",
        )
        .unwrap();
        assert!(s.chains.is_empty());
        let b = &s.bundles[0];
        assert_eq!((b.strands, b.links, b.joints()), (10, 3, 40));
        assert_eq!(b.heads[5], Vector3::new(3.0, 3.0, 1.0));
        assert_eq!(b.hang, -Vector3::z());
    }

    #[test]
    fn an_arc_has_chords_of_the_link_lengths() {
        let s = parse_scene(
            "[[chain]]\nname = \"a\"\nlinks = 12\nlink_length = 0.5\nshape = \"arc\"\nradius = 2.0\n",
            "t.toml",
        )
        .unwrap();
        let p = &s.chains[0].points;
        for w in p.windows(2) {
            assert!(((w[1] - w[0]).norm() - 0.5).abs() < 1e-12);
        }
        for q in p {
            assert!(((q - Vector3::new(0.0, 2.0, 0.0)).norm() - 2.0).abs() < 1e-12);
        }
    }

    /// Each bad scene names the line and the field, and huge sizes are refused before allocation.
    #[test]
    fn errors_name_file_line_and_field() {
        let cases: &[(&str, usize, &str)] = &[
            (
                "[[chain]]\nname = \"a\"\nlinks = 1000000000\nlink_length = 1.0\n",
                3,
                "`links`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = -1.0\n",
                4,
                "`link_length`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = nan\n",
                4,
                "`link_length`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = \"four\"\nlink_length = 1.0\n",
                3,
                "links",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlinkk_length = 1.0\n",
                4,
                "linkk_length",
            ),
            ("[[chain]]\nname = \"a\"\nlink_length = 1.0\n", 2, "`links`"),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = 1.0\n\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\n",
                7,
                "twice",
            ),
            (
                "[[chain]]\nname = \"a\"\nspace = \"planar\"\nlinks = 2\nlink_length = 1.0\nbase = [0, 0, 1]\n",
                6,
                "`base`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nmethod = \"magic\"\n",
                5,
                "`method`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\ncollision = \"self\"\n",
                5,
                "`collision`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\ncollision = \"capsules\"\n",
                5,
                "`thickness`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nobstacles = [\"post\"]\n",
                5,
                "`obstacles`: needs `collision",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\nobstacles = [\"post\"]\n",
                7,
                "no [[obstacle]] is named \"post\"",
            ),
            (
                "[[chain]]\nname = \"a\"\nkind = \"fixed-base\"\nlinks = 2\nlink_length = 1.0\ncollision = \"paper-spheres\"\n",
                6,
                "free chains",
            ),
            (
                "[[obstacle]]\nname = \"b\"\nshape = \"sphere\"\ncenter = [0, 0]\nradius = -1\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\n",
                5,
                "obstacle \"b\": field `radius`",
            ),
            (
                "[[instrument]]\nname = \"t\"\nshape = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\n",
                3,
                "instrument \"t\": field `shape`: an instrument is a sphere or a capsule",
            ),
            (
                "[[instrument]]\nname = \"d\"\nshape = \"sphere\"\ncenter = [0, 1, 0]\nradius = 0.5\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ninstruments = [\"d\"]\n[[chain]]\nname = \"b\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ninstruments = [\"d\"]\n",
                19,
                "already pushes chain \"a\"",
            ),
            (
                "[[instrument]]\nname = \"d\"\nshape = \"sphere\"\ncenter = [0, 1, 0]\nradius = 0.5\nfollows = \"7\"\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ninstruments = [\"d\"]\n",
                6,
                "field `follows`: \"7\" is not",
            ),
            (
                "[[obstacle]]\nname = \"p\"\nshape = \"sphere\"\ncenter = [0, 1, 0]\nradius = 0.5\nfollows = \"head\"\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\n",
                6,
                "obstacles stay where they are",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ninstruments = [\"x\"]\n",
                7,
                "no [[instrument]] is named \"x\"",
            ),
            (
                "[[instrument]]\nname = \"d\"\nshape = \"sphere\"\ncenter = [0, 1, 0]\nradius = 0.5\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\ninstruments = [\"d\"]\n",
                10,
                "`instruments`: needs `collision",
            ),
            (
                "[[obstacle]]\nname = \"t\"\nshape = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n[[chain]]\nname = \"a\"\nspace = \"planar\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\nobstacles = [\"t\"]\n",
                13,
                "not in the planar chain's plane",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ncollision_tolerance = 1.5\n",
                7,
                "`collision_tolerance`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ncollision_over_relaxation = 2.0\n",
                7,
                "`collision_over_relaxation`: 2 is not in [1, 2)",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ncollision_pushed_weight = 0.0\n",
                7,
                "`collision_pushed_weight`: 0 is not in (0, 1]",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ncollision_together_after = 5000\n",
                7,
                "`collision_together_after`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\ncollision_together_after = 2\n",
                5,
                "`collision_together_after`: needs `collision",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\ncollision_over_relaxation = 1.2\n",
                5,
                "`collision_over_relaxation`: needs `collision",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nsubsteps = 0\n",
                5,
                "`substeps`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1e308\nbase = [1e308, 0, 0]\n",
                2,
                "overflow",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nbase = [0, 5e9, 0]\n",
                5,
                "`base`: a joint lies 5e9",
            ),
            (
                "[[chain]]\nname = \"a\"\nprecision = \"f32\"\nlinks = 8000\nlink_length = 1.0\n",
                2,
                "2^12 in f32",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 0.0\n",
                4,
                "`link_length`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 0\nlink_length = 1.0\n",
                3,
                "`links`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = -4\nlink_length = 1.0\n",
                3,
                "`links`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = \"thick\"\n",
                5,
                "thickness",
            ),
            ("[[chain]]\nlinks = 2\nlink_length = 1.0\n", 1, "name"),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nlink_length = 2.0\n",
                5,
                "duplicate",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 3\nlink_lengths = [1.0, 2.0]\n",
                4,
                "2 lengths for 3 links",
            ),
            ("[[chain]]\nname = \"a\"\nlinks = 2\n[[chain\n", 4, ""),
            // Issue 35: links the chain's arithmetic cannot carry (a square that over- or underflows).
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_lengths = [1.7e308, 1.0]\n",
                4,
                "`link_lengths`: link 0",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = 5e-324\n",
                4,
                "`link_length`: link 0",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = 1.0\nshape = \"arc\"\nradius = 1e308\n",
                6,
                "`radius`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nprecision = \"f32\"\nlink_length = 1e300\n",
                5,
                "inf between its joints): f32",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nprecision = \"f32\"\nlink_length = 1e-30\n",
                5,
                "f32 carries",
            ),
        ];
        for (text, line, field) in cases {
            let e = parse_scene(text, "bad.toml").expect_err(text);
            assert_eq!(e.file, "bad.toml");
            assert_eq!(e.line, *line, "{e}");
            assert!(e.message.contains(field), "{e} should mention {field}");
        }
        let empty = parse_scene("", "empty.toml").unwrap_err();
        assert!(empty.message.contains("no [[chain]]"));
        // The scene's budget: a positive count of link-steps, bounded.
        let chain = "[[chain]]\nname = \"c\"\nlinks = 2\nlink_length = 1.0\n";
        for field in ["budget", "pull_budget"] {
            for bad in ["0", "-5", "2000000000000"] {
                let text = format!("# budget\n{field} = {bad}\n{chain}");
                let e = parse_scene(&text, "bad.toml").expect_err(&text);
                assert_eq!(e.line, 2, "{e}");
                assert!(e.message.contains(&format!("field `{field}`")), "{e}");
            }
            let e = parse_scene(&format!("{field} = 1.5\n{chain}"), "bad.toml").unwrap_err();
            assert_eq!(e.line, 1, "{e}");
        }
        let ok = parse_scene(&format!("budget = 123456\n{chain}"), "ok.toml").unwrap();
        assert_eq!((ok.budget, ok.pull_budget), (Some(123_456), None));
        let ok = parse_scene(&format!("pull_budget = 5000\n{chain}"), "ok.toml").unwrap();
        assert_eq!((ok.budget, ok.pull_budget), (None, Some(5000)));
        assert_eq!(parse_scene(chain, "ok.toml").unwrap().budget, None);
        let bundles: &[(&str, usize, &str)] = &[
            (
                "[[bundle]]\nname = \"h\"\nstrands = 0\nlinks = 2\nlink_length = 1.0\n",
                3,
                "bundle \"h\": field `strands`",
            ),
            (
                "[[bundle]]\nname = \"h\"\nstrands = 100000\nlinks = 20\nlink_length = 1.0\n",
                4,
                "at most 1048576",
            ),
            (
                "[[bundle]]\nname = \"h\"\nstrands = 10\nlink_length = 1.0\n",
                2,
                "field `links`: missing",
            ),
            (
                "[[bundle]]\nname = \"h\"\nstrands = 10\nlinks = 2\nlink_length = 1.0\nhang = [0, 0, 0]\n",
                6,
                "field `hang`",
            ),
            (
                "[[chain]]\nname = \"h\"\nlinks = 2\nlink_length = 1.0\n[[bundle]]\nname = \"h\"\nstrands = 10\nlinks = 2\nlink_length = 1.0\n",
                6,
                "declared twice",
            ),
            (
                "[[bundle]]\nname = \"h\"\nstrands = 10\nlinks = 2\nlink_length = 1.0\nprecision = \"f16\"\n",
                6,
                "field `precision`",
            ),
            (
                "[[bundle]]\nname = \"h\"\nstrands = 10\nlinks = 2\nlink_length = 1.0\ncolour = 3\n",
                6,
                "colour",
            ),
        ];
        for (text, line, field) in bundles {
            let e = parse_scene(text, "bad.toml").expect_err(text);
            assert_eq!(e.line, *line, "{e}");
            assert!(e.message.contains(field), "{e} should mention {field}");
        }
    }

    /// Many chains at the per-chain maximum: the total is bounded, and the error names the chain that
    /// crosses it (its `links` line), before its successors are built.
    #[test]
    fn the_scene_total_of_links_is_bounded() {
        let text: String = (0..40)
            .map(|i| format!("[[chain]]\nname = \"c{i}\"\nlinks = 65536\nlink_length = 1.0\n"))
            .collect();
        let e = parse_scene(&text, "big.toml").unwrap_err();
        // Chain 16 (the 17th) crosses 2^20; each chain takes 4 lines, `links` is the third.
        assert_eq!(e.line, 16 * 4 + 3, "{e}");
        assert!(e.message.contains("chain \"c16\": field `links`"), "{e}");
        assert!(e.message.contains("at most 1048576"), "{e}");
        // 16 such chains are fine.
        let ok: String = text
            .lines()
            .take(16 * 4)
            .map(|l| format!("{l}\n"))
            .collect();
        assert_eq!(parse_scene(&ok, "ok.toml").unwrap().chains.len(), 16);
    }
}
