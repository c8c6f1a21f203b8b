//! The wire protocol of the tractrix solver service: payload types, their byte layout, service names and
//! limits. Every process that talks to the service (the Rust clients, the Python client, C and C++ code)
//! mirrors exactly what this crate declares.
//!
//! # Services
//!
//! All names are relative to the iceoryx2 prefix of the instance (`--prefix` or the environment variable
//! [`PREFIX_ENV`]; processes only see each other with the same prefix).
//!
//! | service | pattern | types | purpose |
//! |---|---|---|---|
//! | [`SERVICE_COMMAND`] | request-response, one server | request: user header [`RequestHeader`], payload slice of [`Vec3`] (targets); response: user header [`ResponseHeader`], payload slice of [`Vec3`] (joints, then joint rotations) | every command |
//! | [`SERVICE_STATE`] | publish-subscribe | user header [`StateHeader`], payload slice of [`Vec3`] (joints, held joints, instruments) | every accepted change, in order |
//! | [`SERVICE_BUNDLE_STATE`] | publish-subscribe | user header [`StateHeader`], payload slice of [`Vec3`] (all joints of one bundle) | every accepted change of a bundle; created only for a scene with bundles |
//! | [`SERVICE_WAKE_SERVER`] | event | – | a client notifies it after sending, so a server in `event`/`hybrid` mode wakes |
//! | [`SERVICE_WAKE_CLIENT`] | event | – | the server notifies the listener whose id a request carries in [`RequestHeader::client_listener`] |
//!
//! A client that busy-polls its response leaves `client_listener` at zero and needs no event service. A
//! client that sleeps creates a listener on [`SERVICE_WAKE_CLIENT`] and puts the listener's 128-bit id in
//! `client_listener` (low 64 bits first). Every client should notify [`SERVICE_WAKE_SERVER`] after sending
//! unless it knows the server spins.
//!
//! # One command
//!
//! 1. Loan a request slice of `n` [`Vec3`]: `n = 1` for [`Command::Move`] and [`Command::Reach`], `1..=`
//!    [`MAX_PATH_POINTS`] for [`Command::Path`], `0` for the others.
//! 2. Fill the [`RequestHeader`] (zero it first: zero means "the chain's default" for every option).
//! 3. Send, notify, and receive one response. Its [`ResponseHeader::status`] is a [`Status`]; on error
//!    [`ResponseHeader::reason`] says what was wrong and the chain is unchanged (when ok it is empty,
//!    but for a pull that stopped short, where it says why: [`PullStop`]). The payload holds
//!    `n_joints` joint positions (tail first, joint 0 = tail, joint `n_joints - 1` = head) followed by
//!    `n_angles` joint rotations as rotation vectors (axis × angle in radians; for a planar chain `(0, 0,
//!    θ)`), then `n_held` held joints (anchors of the scene and grasps of clients), one element each:
//!    `x` the joint's index, `y` 1 for an anchor and 0 for a grasp, `z` 1 when the stretch of rope from
//!    it to the next held joint toward the head is taut (straight to within its length's rounding),
//!    else 0, then `n_instruments`
//!    instruments of the chain (in the scene's order), three elements each ([`InstrumentPose`]): the
//!    two ends of the axis (equal for a sphere), then `(radius, 0 for a sphere or 1 for a capsule, 0)`,
//!    then `n_pulls` pulls, one per held joint and then one per instrument: the vector from where its
//!    owner last asked it to be to where the rope let it be (zero when slack; with a virtual coupling
//!    of stiffness `k` the force on the hand is `k` times it; [`FLAG_PULL`]), then `n_eyelets`
//!    eyelets the chain passes through (the scene's, in order along the rope), two elements each
//!    ([`EyeletState`]): the point, then `(link through it, 1 while threaded or 0 once the rope has
//!    left it, 0)`, then, in a [`Command::Describe`] of a chain with tissue, `n_tissue` (1) blocks of
//!    tissue, two elements each ([`TISSUE_ELEMENTS`]): the block's corners `lo` and `hi`.
//!    A chain without instruments has `n_instruments = 0`. An error response carries no elements. The chain's description (name, kind, sizes, defaults) comes with [`Command::Describe`]
//!    only.
//!
//! # Bundles
//!
//! A scene's `[[bundle]]`s (many free strands of equal links: hair, fur, a bundle of sutures) take the
//! handles after its chains (`n_chains` counts both; [`Command::Describe`] says [`ChainKind::Bundle`],
//! `n_links` per strand, `n_joints` = strands × (`n_links` + 1)). A bundle answers four commands:
//!
//! * [`Command::Move`], `joint` = [`JOINT_HEAD`]: every strand's head to its own target (one point per
//!   strand, in strand order), or with [`FLAG_POSE`] all heads by one rigid motion (two points). Only the
//!   closed-form tractrix (`method` 0 or 1) and fixed substeps (`substep_mode` 0 or 1).
//! * [`Command::Query`], [`Command::Describe`], [`Command::Reset`].
//!
//! Every other command is refused ([`Status::WrongChainKind`]). The response carries all joints, strand
//! after strand, each tail first; a change is published on [`SERVICE_BUNDLE_STATE`], not
//! [`SERVICE_STATE`]. A client sending per-strand targets sizes its request port for them (the Rust
//! client's `max_request_points`). Bundles are not persisted: the response's and the bundle stream's
//! `sequence` counts the bundle's own changes since the service started, and a restarted service
//! starts its bundles from the scene.
//!
//! Size limits: a bundle has at most [`MAX_BUNDLE_STRANDS`] strands and [`MAX_BUNDLE_JOINTS`] joints
//! (24 MiB per sample). The service sizes its response and bundle-stream ports from the scene, so a
//! scene without bundles pays nothing; the bundle stream buffers [`BUNDLE_STATE_BUFFER`] samples per
//! subscriber for at most [`MAX_BUNDLE_SUBSCRIBERS`] subscribers.
//!
//! # Byte layout
//!
//! Little-endian x86-64 / aarch64, natural alignment, no implicit padding (every gap is a named `reserved`
//! field that must be zero). The table is checked against the Rust types by a unit test, and each row by a
//! compile-time `offset_of!` assertion.
//!
//! <!-- layout-table-start -->
//! | type | field | offset | C type |
//! |---|---|---|---|
//! | Vec3 (24 B, align 8) | x | 0 | double |
//! | | y | 8 | double |
//! | | z | 16 | double |
//! | RequestHeader (96 B, align 8) | command | 0 | uint32_t |
//! | | chain | 4 | uint32_t |
//! | | joint | 8 | uint32_t |
//! | | method | 12 | uint32_t |
//! | | precision | 16 | uint32_t |
//! | | substep_mode | 20 | uint32_t |
//! | | substeps | 24 | uint32_t |
//! | | strategy | 28 | uint32_t |
//! | | max_iterations | 32 | uint32_t |
//! | | flags | 36 | uint32_t |
//! | | client_listener | 40 | `uint64_t[2]` |
//! | | request_id | 56 | uint64_t |
//! | | max_step | 64 | double |
//! | | tolerance | 72 | double |
//! | | reserved | 80 | `uint64_t[2]` |
//! | ResponseHeader (288 B, align 8) | status | 0 | uint32_t |
//! | | command | 4 | uint32_t |
//! | | chain | 8 | uint32_t |
//! | | n_joints | 12 | uint32_t |
//! | | n_angles | 16 | uint32_t |
//! | | iterations | 20 | uint32_t |
//! | | substeps | 24 | uint32_t |
//! | | paper_fallbacks | 28 | uint32_t |
//! | | sequence | 32 | uint64_t |
//! | | request_id | 40 | uint64_t |
//! | | solve_ns | 48 | uint64_t |
//! | | residual | 56 | double |
//! | | n_chains | 64 | uint32_t |
//! | | kind | 68 | uint32_t |
//! | | dims | 72 | uint32_t |
//! | | n_links | 76 | uint32_t |
//! | | precision | 80 | uint32_t |
//! | | method | 84 | uint32_t |
//! | | collision | 88 | uint32_t |
//! | | substep_mode | 92 | uint32_t |
//! | | substeps_default | 96 | uint32_t |
//! | | n_held | 100 | uint32_t |
//! | | max_step | 104 | double |
//! | | total_length | 112 | double |
//! | | thickness | 120 | double |
//! | | name | 128 | `uint8_t[32]` |
//! | | reason | 160 | `uint8_t[96]` |
//! | | n_instruments | 256 | uint32_t |
//! | | limits | 260 | uint32_t |
//! | | limit_value | 264 | double |
//! | | n_pulls | 272 | uint32_t |
//! | | knot | 276 | uint32_t |
//! | | n_eyelets | 280 | uint32_t |
//! | | n_tissue | 284 | uint32_t |
//! | StateHeader (48 B, align 8) | sequence | 0 | uint64_t |
//! | | chain | 8 | uint32_t |
//! | | n_joints | 12 | uint32_t |
//! | | command | 16 | uint32_t |
//! | | n_held | 20 | uint32_t |
//! | | request_id | 24 | uint64_t |
//! | | n_instruments | 32 | uint32_t |
//! | | n_pulls | 36 | uint32_t |
//! | | knot | 40 | uint32_t |
//! | | n_eyelets | 44 | uint32_t |
//! <!-- layout-table-end -->
//!
//! Service names carry no version on purpose: a peer of another protocol version finds the service and
//! is refused at `open` because the type names differ (iceoryx2's `IncompatibleRequestOrResponseType`),
//! so it can say why instead of reading garbage or timing out. Type names: `tractrix.v2.Vec3`, `tractrix.v2.RequestHeader`,
//! `tractrix.v2.ResponseHeader`, `tractrix.v2.StateHeader`.
//!
//! Versions: v1 had no instruments in payloads and no reserved tail in the response and state headers;
//! v2 adds `n_instruments` (and the instruments' elements) and zeroed `reserved` words for later fields;
//! `limits` and `limit_value` (a describe's joint limits, [`LIMITS_NONE`] and the rest) took three of
//! them within v2 (a v2 peer that does not know them reads zeros: no limits), `n_pulls` one more
//! in each header (a v2 peer that does not know it reads the pulls as trailing elements it ignores),
//! `knot` one more in each (a v2 peer that does not know it reads zero: not asked), and `n_eyelets`
//! one more in each (the state header's last: its next field needs a v3).
//!
//! # Enumerations (all `uint32_t`)
//!
//! * [`Command`]: 1 move, 2 path, 3 reach, 4 query, 5 reset, 6 describe, 7 snapshot, 8 grasp, 9
//!   release, 10 instrument, 11 eyelet.
//! * [`Status`]: 0 ok, then one value per error (see the type).
//! * `joint`: the joint index, 0 = tail; [`JOINT_HEAD`] (`0xFFFFFFFF`) = the head whatever the length.
//! * `method` ([`WireMethod`]): 0 chain default, 1 closed-form tractrix, 2 the paper's form, 3
//!   follow-the-leader.
//! * `precision` ([`Precision`]): 0 chain's, 1 f64, 2 f32 (must match the chain's declared precision).
//! * `substep_mode` ([`SubstepMode`]): 0 chain default, 1 `substeps` equal substeps, 2 no substep longer
//!   than `max_step` × the chain's shortest link.
//! * `strategy` ([`WireStrategy`]): 0 default (translate back), 1 translate back, 2 tractrix + two-link,
//!   3 pull-back (tractrix, then a tractrix pass pulling the base end back).
//! * `flags`: bit 0 [`FLAG_ANGLES`] (reach and query: append joint rotations), bit 1 [`FLAG_POSE`] (a
//!   bundle's move by one rigid motion of its heads; a needle's pose with a move of its swage), bit 2 [`FLAG_TAKE_OVER`] (grasp, release, move,
//!   path, reset: take over another client's grasps), bit 3 [`FLAG_ORIENT`], bit 4 [`FLAG_IN_BOX`],
//!   bit 5 [`FLAG_IN_BALL`] (reach goals), bit 6 [`FLAG_SMOOTH`] (path), bit 7 [`FLAG_PULL`] (move and
//!   instrument: as far as the rope lets, the rest reported as the pull), bit 8 [`FLAG_DRIVE`] (a
//!   move of the head of a chain with a needle: the needle driven along its arc, its point making the
//!   holes).
//! * `kind` ([`ChainKind`]): 0 free (rope, snake), 1 fixed base, 2 bundle. `collision`: bit 0 self, bit 1 obstacles.

use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};

pub mod iox;
pub use iox::{
    IOX_ROOT_BASE, iceoryx_config, iceoryx_config_file, iceoryx_root, iceoryx_root_problem,
    service_name, stop_requested,
};
pub mod text;
mod wait;
pub use wait::{Wait, WaitMode, pin_current_thread};
mod layout;
pub mod unix_frame;
pub use layout::{FieldLayout, TypeLayout, WIRE_TYPES};

/// Most held joints (anchors and grasps) one chain may have; a grasp beyond is refused.
pub const MAX_HELD: u32 = 64;

/// Most grasps one client may own on one chain, so that one client cannot take all [`MAX_HELD`] slots.
pub const MAX_GRASPS_PER_CLIENT: u32 = 16;

/// Most instruments a scene may declare (so at most this many on one chain).
pub const MAX_INSTRUMENTS: u32 = 64;
/// Elements per instrument in a payload (see [`InstrumentPose`]).
pub const INSTRUMENT_ELEMENTS: u32 = 3;
/// Most eyelets one chain passes through (scene `eyelets`).
pub const MAX_EYELETS: u32 = 64;
/// Elements of one eyelet in a payload ([`EyeletState`]): its point, then `(link, 1 threaded / 0
/// left, 0)`.
pub const EYELET_ELEMENTS: u32 = 2;
/// Elements of a chain's block of tissue in a describe's payload (scene `tissue`): its corners `lo`
/// and `hi`.
pub const TISSUE_ELEMENTS: u32 = 2;

/// Protocol version; it is part of every type name.
pub const PROTOCOL_VERSION: u32 = 2;
/// Request-response service of every command.
pub const SERVICE_COMMAND: &str = "tractrix/command";
/// Publish-subscribe stream of accepted states.
pub const SERVICE_STATE: &str = "tractrix/state";
/// Event service a client notifies after sending a request.
pub const SERVICE_WAKE_SERVER: &str = "tractrix/wake-server";
/// Event service through which the server wakes a waiting client.
pub const SERVICE_WAKE_CLIENT: &str = "tractrix/wake-client";
/// Publish-subscribe stream of the bundles' accepted states (only for a scene with bundles).
pub const SERVICE_BUNDLE_STATE: &str = "tractrix/bundle-state";
/// Samples a subscriber of [`SERVICE_STATE`] may buffer unless the service is started with a deeper
/// buffer (`solver-service --state-buffer N`): a subscriber that falls further behind loses the oldest
/// and sees a gap in the sequence numbers.
pub const STATE_BUFFER: usize = 64;
/// The deepest state buffer a service may offer (`--state-buffer`): 4096 samples, seconds of two
/// hands at full speed.
pub const MAX_STATE_BUFFER: usize = 4096;
/// Samples a subscriber of [`SERVICE_BUNDLE_STATE`] buffers (a bundle's sample is megabytes: the
/// stream keeps the newest few, not a history).
pub const BUNDLE_STATE_BUFFER: usize = 2;
/// Most subscribers of [`SERVICE_BUNDLE_STATE`].
pub const MAX_BUNDLE_SUBSCRIBERS: usize = 4;
/// Environment variable holding the iceoryx2 prefix that isolates one instance (and its clients).
pub const PREFIX_ENV: &str = "TRACTRIX_IOX_PREFIX";
/// Default iceoryx2 prefix.
pub const DEFAULT_PREFIX: &str = "tractrix_";

/// Most links in one chain. Bounds scenes, snapshots and the response memory (24 B per joint).
pub const MAX_LINKS: u32 = 65_536;
/// Most elements in a response: joints, one rotation per link, held joints, instruments, pulls and
/// eyelets.
pub const MAX_RESPONSE_ELEMENTS: u32 = 2 * MAX_LINKS
    + 1
    + 2 * MAX_HELD
    + (INSTRUMENT_ELEMENTS + 1) * MAX_INSTRUMENTS
    + EYELET_ELEMENTS * MAX_EYELETS
    + TISSUE_ELEMENTS;
/// Most points in one [`Command::Path`] request.
pub const MAX_PATH_POINTS: u32 = 4096;
/// Most chains in one scene.
pub const MAX_CHAINS: u32 = 256;

/// How far from the origin, in shortest links, a free chain's target may lie on any axis: 2³² links in
/// f64 and 2¹² in f32. Beyond it the spacing of floating-point numbers exceeds 2⁻²⁰ of a link (f64) or
/// 2⁻¹¹ (f32), and joint positions there can no longer carry the link lengths; such targets are
/// refused with [`Status::TooFar`]. A 1-unit link in f64 may be moved 4.3·10⁹ units from the origin.
pub fn max_coordinate(shortest_link: f64, f32_chain: bool) -> f64 {
    shortest_link * if f32_chain { 4096.0 } else { 4_294_967_296.0 }
}

/// Most concurrent client ports (each running client binary takes one).
pub const MAX_CLIENTS: usize = 16;
/// Bytes of a chain name (UTF-8, NUL-padded; a name fills at most `NAME_LEN - 1` bytes).
pub const NAME_LEN: usize = 32;
/// Bytes of an error reason (UTF-8, NUL-padded).
pub const REASON_LEN: usize = 96;
/// `joint` value meaning "the head", whatever the chain's length.
pub const JOINT_HEAD: u32 = u32::MAX;
/// Flag: append joint rotations to the response.
pub const FLAG_ANGLES: u32 = 1;
/// Flag (a move of a bundle): the two points are one rigid motion of the strands' heads, a translation
/// `t` then a rotation vector `r` (axis × angle, radians): strand `i`'s head goes to `R(r)·h0_i + t`,
/// `h0_i` its head in the scene. Without the flag a bundle's move carries one target per strand.
///
/// (A move of the head of a chain with a needle): the needle's pose, as a 6-DOF stylus holding a
/// needle driver sets it: two points, where the swage (the head) goes, then a rotation vector `r`
/// (axis × angle, radians) from the needle's own frame to the world's: the needle leaves its swage
/// along `R(r)·x` and curves toward `R(r)·y` (its arc in the plane of the two, its centre at
/// `swage + radius·R(r)·y`). The rope follows the head as in any move; the needle is set on its new
/// pose, pushing the rope as instruments do, and where its point crosses the tissue's surface it
/// makes a hole as a driven needle's point does ([`FLAG_DRIVE`]). Not with [`FLAG_DRIVE`] or
/// [`FLAG_PULL`].
pub const FLAG_POSE: u32 = 2;
/// Flag (grasp, release, move, path, reset of a free chain): take over the grasps of other clients that
/// the request touches (without it such a request is refused with [`Status::Held`]). Anchors are the
/// scene's and are never taken over.
pub const FLAG_TAKE_OVER: u32 = 4;
/// Flag (reach): an orientation goal, two points: where the head goes, then the direction of the last
/// link (any non-zero length). The rest of the chain reaches the last link's base joint.
pub const FLAG_ORIENT: u32 = 8;
/// Flag (reach): a box goal, two points, the corners of smallest and largest coordinates: the head
/// anywhere inside (no motion when it already is).
pub const FLAG_IN_BOX: u32 = 16;
/// Flag (reach): a ball goal, two points, the centre then `(radius, 0, 0)`: the head within the radius
/// of the centre (no motion when it already is).
pub const FLAG_IN_BALL: u32 = 32;
/// Flag (path): follow the natural cubic spline through the joint and the points (C² everywhere, Korein
/// & Badler's smooth key frames) instead of straight segments; each segment is sampled into as many
/// points as it has substeps.
pub const FLAG_SMOOTH: u32 = 64;
/// Move (one target) and instrument: pull. A move the rope cannot make in full (a held side out of
/// length, contact jammed, a joint limit) goes as far toward the target as it can instead of being
/// refused, and the rest is the joint's (or instrument's) pull in the payload (`n_pulls`): the
/// tension a haptic hand feels, docs/tension.md. An ok response of a pull that stopped short says
/// why in its `reason` ([`PullStop`]); one that made the whole move leaves it empty.
pub const FLAG_PULL: u32 = 128;

/// Why a pull ([`FLAG_PULL`]) stopped short of its target: the `reason` of its ok response is
/// [`PullStop::reason`] (empty when the whole move was made), read back by [`PullStop::of`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PullStop {
    /// The rope is taut: the stretch to a held joint (or an eyelet) is out of length.
    Taut,
    /// Contact could not make way: the knot or the instrument jammed at the rope's thickness (the
    /// contact resolution met its passes' limit or locked).
    Jammed,
    /// A joint would have gone beyond its limit.
    Limit,
    /// Resolving the contacts would have cost more than the request's work budget: the knot resists
    /// more than one request can resolve (the same pull asked again, from the same state, goes on
    /// from the resolution this one kept).
    Work,
}

impl PullStop {
    /// Every kind, in the wire's order.
    pub const ALL: [PullStop; 4] = [
        PullStop::Taut,
        PullStop::Jammed,
        PullStop::Limit,
        PullStop::Work,
    ];

    /// The `reason` text of an ok response whose pull stopped short this way.
    pub const fn reason(self) -> &'static str {
        match self {
            PullStop::Taut => "stopped short: taut",
            PullStop::Jammed => "stopped short: jammed",
            PullStop::Limit => "stopped short: joint limit",
            PullStop::Work => "stopped short: work budget",
        }
    }

    /// Why the pull of an ok response stopped short, from its `reason`; `None` when it made the whole
    /// move (or the reason is not a pull's).
    pub fn of(reason: &str) -> Option<PullStop> {
        PullStop::of_field(reason.as_bytes())
    }

    /// [`PullStop::of`] on the NUL-padded field itself (no copy: the hand and the C library read it
    /// from every pull's response).
    pub fn of_field(field: &[u8]) -> Option<PullStop> {
        let end = field.iter().position(|&b| b == 0).unwrap_or(field.len());
        PullStop::ALL
            .into_iter()
            .find(|p| p.reason().as_bytes() == &field[..end])
    }
}
/// Move of a chain's head (one target) when the chain carries a needle: the needle is *driven*, as a
/// needle driver drives a curved needle through tissue: instead of turning with the head link, it
/// goes along the circular arc from its swage to the target that leaves the swage along the needle's
/// own direction (a target on the needle's circle turns it about its centre, so its point, body and
/// swage all pass where the point went), and where its point crosses the tissue's surface it makes a
/// hole (an eyelet the rope has not yet threaded) that the rope then threads (docs/eyelets.md).
pub const FLAG_DRIVE: u32 = 256;

/// Most joints (strands × (links + 1)) of one bundle: 24 MiB per state sample in `Vec3`s.
pub const MAX_BUNDLE_JOINTS: u32 = 1 << 20;
/// Most strands in a bundle (so a move's targets fit one request of [`MAX_BUNDLE_STRANDS`] points).
pub const MAX_BUNDLE_STRANDS: u32 = 1 << 17;
/// Collision bit: the chain avoids itself.
pub const COLLISION_SELF: u32 = 1;
/// Collision bit: the chain avoids the scene's obstacles.
pub const COLLISION_OBSTACLES: u32 = 2;
/// Collision bit: the chain uses the paper's bounding spheres (section 4.2) instead of capsules.
pub const COLLISION_PAPER_SPHERES: u32 = 4;

/// The prefix from the environment ([`PREFIX_ENV`]) or the default.
pub fn prefix_from_env() -> String {
    std::env::var(PREFIX_ENV).unwrap_or_else(|_| DEFAULT_PREFIX.to_string())
}

/// A point or vector in metres (or the scene's unit). Planar chains use `z = 0`.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize, Deserialize, Pod, Zeroable,
)]
#[repr(C)]
#[type_name("tractrix.v2.Vec3")]
pub struct Vec3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl Vec3 {
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Vec3 { x, y, z }
    }
    pub const fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
    pub const fn from_array(a: [f64; 3]) -> Self {
        Vec3::new(a[0], a[1], a[2])
    }
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
}

/// The one place where wire points meet nalgebra (the kernel's and the scenes' vectors).
impl From<Vec3> for nalgebra::Vector3<f64> {
    fn from(v: Vec3) -> Self {
        nalgebra::Vector3::new(v.x, v.y, v.z)
    }
}

impl From<nalgebra::Vector3<f64>> for Vec3 {
    fn from(v: nalgebra::Vector3<f64>) -> Self {
        Vec3::new(v.x, v.y, v.z)
    }
}

/// A command (see the crate docs for the payload each takes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Command {
    /// Move `joint` to the one target point.
    Move = 1,
    /// Move `joint` through the target points in order.
    Path = 2,
    /// Fixed-base chain: bring the head to the target, base fixed.
    Reach = 3,
    /// Current joints (and rotations with [`FLAG_ANGLES`]).
    Query = 4,
    /// Back to the scene's initial state.
    Reset = 5,
    /// The chain's description in the header, and its joints.
    Describe = 6,
    /// Write a snapshot now (chain ignored; no joints returned).
    Snapshot = 7,
    /// Hold `joint` where it is (a hand's grasp): moves of other joints leave it in place, and the rope
    /// between it and a moved joint is solved as a fixed-base chain. Free chains only.
    Grasp = 8,
    /// Let `joint` go (a grasp; the scene's anchors are not released).
    Release = 9,
    /// Move instrument `joint` of the chain (its index in the chain's `instruments` list) to a new pose,
    /// pushing the chain out of its way: payload `[centre]` for a sphere, `[centre, axis direction]`
    /// for a capsule. A push the rope cannot give way to is `Locked` and changes nothing.
    Instrument = 10,
    /// Move eyelet `joint` of the chain (its index in the scene's `eyelets`) to the one point: tissue
    /// that a simulator moves. The rope's point at the eyelet goes with it (the link through it is
    /// carried), the rope on each side follows; an eyelet the rope has left just moves.
    Eyelet = 11,
}

impl Command {
    pub fn name(self) -> &'static str {
        match self {
            Command::Move => "move",
            Command::Path => "path",
            Command::Reach => "reach",
            Command::Query => "query",
            Command::Reset => "reset",
            Command::Describe => "describe",
            Command::Snapshot => "snapshot",
            Command::Grasp => "grasp",
            Command::Release => "release",
            Command::Instrument => "instrument",
            Command::Eyelet => "eyelet",
        }
    }
    /// Whether an accepted command of this kind changes the state (and is journaled and published).
    pub fn changes_state(self) -> bool {
        matches!(
            self,
            Command::Move
                | Command::Path
                | Command::Reach
                | Command::Reset
                | Command::Grasp
                | Command::Release
                | Command::Instrument
                | Command::Eyelet
        )
    }
}

/// Outcome of a command. Every error leaves the state unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Status {
    Ok = 0,
    /// `command` is not a known [`Command`].
    UnknownCommand = 1,
    /// `chain` is not a chain of the scene.
    UnknownChain = 2,
    /// `joint` is past the head.
    JointOutOfRange = 3,
    /// A target or option is NaN or infinite.
    NonFinite = 4,
    /// An option is out of range (method, precision, substeps, tolerance, flags, reserved fields ...).
    BadOption = 5,
    /// The number of target points does not fit the command.
    BadPointCount = 6,
    /// A fixed-base target lies outside the workspace.
    Unreachable = 7,
    /// A fixed-base reach hit its iteration limit.
    NotConverged = 8,
    /// The move would need more substeps than the service allows.
    TooManySubsteps = 9,
    /// The command does not apply to this chain (reach on a free chain, move on a fixed-base chain ...).
    WrongChainKind = 10,
    /// A planar chain got a target off its plane (`z != 0`).
    OffPlane = 11,
    /// A snapshot or journal write failed; the command was not applied.
    PersistenceFailed = 12,
    /// The response could not be written (too large for the service's memory).
    Internal = 13,
    /// Collision handling could not keep the links apart (the chain is "locked", section 4.2): the
    /// move was refused. Pulling a knot tight ends this way.
    Locked = 14,
    /// A free chain's target lies so far from the origin that joint positions there cannot hold the
    /// link lengths: beyond [`max_coordinate`] shortest links from the origin on any axis.
    TooFar = 15,
    /// The request would take more work than the service's budget per request (links × substeps ×
    /// points, or links × substeps × iterations for a reach; `solver-service --budget`): refused before
    /// anything runs, the estimate in the reason, so that one client cannot hold the serving thread.
    OverBudget = 16,
    /// A move would leave a joint beyond the chain's joint limits where the solve could not steer them
    /// (a held side, a collision pass, the closing two-link solution): refused, the state unchanged. A
    /// free move never is: its links are turned back into their limits as it runs.
    JointLimit = 17,
    /// The joint is held by another client's grasp (release, move or reset without [`FLAG_TAKE_OVER`];
    /// the reason names the owner), or is an anchor of the scene, which no client moves or releases.
    Held = 18,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::UnknownCommand => "unknown-command",
            Status::UnknownChain => "unknown-chain",
            Status::JointOutOfRange => "joint-out-of-range",
            Status::NonFinite => "non-finite",
            Status::BadOption => "bad-option",
            Status::BadPointCount => "bad-point-count",
            Status::Unreachable => "unreachable",
            Status::NotConverged => "not-converged",
            Status::TooManySubsteps => "too-many-substeps",
            Status::WrongChainKind => "wrong-chain-kind",
            Status::OffPlane => "off-plane",
            Status::PersistenceFailed => "persistence-failed",
            Status::Internal => "internal",
            Status::Locked => "locked",
            Status::TooFar => "too-far",
            Status::OverBudget => "over-budget",
            Status::JointLimit => "joint-limit",
            Status::Held => "held",
        }
    }
}

/// Single-link method on the wire (0 = the chain's default). On command lines: `tractrix`, `paper`,
/// `ftl`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[repr(u32)]
pub enum WireMethod {
    #[cfg_attr(feature = "clap", value(skip))]
    Default = 0,
    Tractrix = 1,
    Paper = 2,
    #[cfg_attr(feature = "clap", value(name = "ftl"))]
    FollowTheLeader = 3,
}

/// Arithmetic of a chain on the wire (0 = the chain's).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[repr(u32)]
pub enum Precision {
    #[cfg_attr(feature = "clap", value(skip))]
    Default = 0,
    F64 = 1,
    F32 = 2,
}

/// Substep policy on the wire (0 = the chain's default).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum SubstepMode {
    Default = 0,
    /// `substeps` equal substeps.
    Fixed = 1,
    /// No substep longer than `max_step` × the shortest link.
    MaxStep = 2,
}

/// Fixed-base strategy on the wire (0 = translate back).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[repr(u32)]
pub enum WireStrategy {
    #[cfg_attr(feature = "clap", value(skip))]
    Default = 0,
    TranslateBack = 1,
    #[cfg_attr(feature = "clap", value(name = "two-link"))]
    TractrixTwoLink = 2,
    /// Tractrix to the target, then a tractrix pass pulling the base end back to the base.
    #[cfg_attr(feature = "clap", value(name = "pull-back"))]
    PullBack = 3,
}

/// What a chain is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum ChainKind {
    /// A rope, suture or snake: every joint free.
    Free = 0,
    /// A manipulator whose joint 0 is fixed.
    FixedBase = 1,
    /// A bundle of free strands of equal links (hair, fur, sutures) moved together: a scene's
    /// `[[bundle]]`. Its joints are the strands' joints, strand after strand, each tail first.
    Bundle = 2,
}

macro_rules! wire_enum_from_u32 {
    ($($t:ident { $($v:ident),* })*) => {$(
        impl $t {
            /// Every value, in wire order.
            pub const ALL: [$t; [$($t::$v),*].len()] = [$($t::$v),*];
            /// The value for a wire number, `None` if unknown.
            pub fn from_u32(v: u32) -> Option<Self> {
                Self::ALL.into_iter().find(|x| *x as u32 == v)
            }
        }
        impl TryFrom<u32> for $t {
            /// The unknown wire number.
            type Error = u32;
            fn try_from(v: u32) -> Result<Self, u32> {
                Self::from_u32(v).ok_or(v)
            }
        }
    )*};
}
wire_enum_from_u32! {
    Command { Move, Path, Reach, Query, Reset, Describe, Snapshot, Grasp, Release, Instrument,
              Eyelet }
    Status { Ok, UnknownCommand, UnknownChain, JointOutOfRange, NonFinite, BadOption, BadPointCount,
             Unreachable, NotConverged, TooManySubsteps, WrongChainKind, OffPlane, PersistenceFailed,
             Internal, Locked, TooFar, OverBudget, JointLimit, Held }
    WireMethod { Default, Tractrix, Paper, FollowTheLeader }
    Precision { Default, F64, F32 }
    SubstepMode { Default, Fixed, MaxStep }
    WireStrategy { Default, TranslateBack, TractrixTwoLink, PullBack }
    ChainKind { Free, FixedBase, Bundle }
}

/// The request's user header. Zero every field you do not set: zero means "default".
#[derive(
    Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize, Deserialize, Pod, Zeroable,
)]
#[repr(C)]
#[type_name("tractrix.v2.RequestHeader")]
pub struct RequestHeader {
    /// A [`Command`].
    pub command: u32,
    /// Chain handle: its index in the scene (see [`Command::Describe`]).
    pub chain: u32,
    /// Joint to move: 0 = tail, [`JOINT_HEAD`] = head.
    pub joint: u32,
    /// A [`WireMethod`].
    pub method: u32,
    /// A [`Precision`].
    pub precision: u32,
    /// A [`SubstepMode`].
    pub substep_mode: u32,
    /// Substeps with [`SubstepMode::Fixed`] (≥ 1); for reach, substeps of each tractrix pass (0 = 1).
    pub substeps: u32,
    /// A [`WireStrategy`] (reach).
    pub strategy: u32,
    /// Reach iteration limit (0 = the default, 1000).
    pub max_iterations: u32,
    /// Bit set of `FLAG_*`.
    pub flags: u32,
    /// Id of the client's listener on [`SERVICE_WAKE_CLIENT`] (low 64 bits, high 64 bits); zero if the
    /// client polls.
    pub client_listener: [u64; 2],
    /// The client's own tag, echoed in the response and on the state stream.
    pub request_id: u64,
    /// With [`SubstepMode::MaxStep`]: the longest substep as a fraction of the shortest link (> 0).
    pub max_step: f64,
    /// Reach tolerance as a fraction of the chain's total length (0 = default 1e-9).
    pub tolerance: f64,
    /// Must be zero.
    pub reserved: [u64; 2],
}

impl RequestHeader {
    /// A header for `command` on `chain`, every option at its default.
    pub fn new(command: Command, chain: u32) -> Self {
        RequestHeader {
            command: command as u32,
            chain,
            joint: JOINT_HEAD,
            ..Default::default()
        }
    }
    /// The listener id as one number.
    pub fn listener_id(&self) -> u128 {
        (self.client_listener[0] as u128) | ((self.client_listener[1] as u128) << 64)
    }
    /// Stores a listener id.
    pub fn set_listener_id(&mut self, id: u128) {
        self.client_listener = [id as u64, (id >> 64) as u64];
    }
}

/// The response's user header. The description fields, from `n_chains`' neighbour `kind` through `name`
/// (`kind`, `dims`, `n_links`, `precision`, `method`, `collision`, `substep_mode`, `substeps_default`,
/// `max_step`, `total_length`, `thickness`, `name`), are filled by [`Command::Describe`] only; every
/// other response leaves them zero (a chain of `n` links answers `n + 1` joints).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("tractrix.v2.ResponseHeader")]
pub struct ResponseHeader {
    /// A [`Status`].
    pub status: u32,
    /// The request's command, echoed.
    pub command: u32,
    /// The request's chain, echoed.
    pub chain: u32,
    /// Joint positions in the payload (tail first).
    pub n_joints: u32,
    /// Joint rotations after the positions.
    pub n_angles: u32,
    /// Reach iterations, or for a move on a chain with collision handling, the resolution passes that
    /// pushed links apart (summed over substeps; for a move refused as `locked`, those of the
    /// substep where it locked).
    pub iterations: u32,
    /// Substeps taken (all points of a path); for a move refused as `locked` or `over-budget` by
    /// collision handling, the substep (1-based, of its segment) where it stopped.
    pub substeps: u32,
    /// Link steps where the paper's form was undefined and the closed form stood in.
    pub paper_fallbacks: u32,
    /// Sequence number of the state this response reflects (the state stream's counter).
    pub sequence: u64,
    /// The request's `request_id`, echoed.
    pub request_id: u64,
    /// Time spent solving, in nanoseconds (validation, kernel, journal).
    pub solve_ns: u64,
    /// Reach: final head-target distance; move and path: head-target distance after the move (0 unless
    /// a collision response moved the head); on `Unreachable`, the distance to the workspace.
    pub residual: f64,
    /// Chains in the scene.
    pub n_chains: u32,
    /// The chain's [`ChainKind`].
    pub kind: u32,
    /// 2 (planar, in the z = 0 plane) or 3.
    pub dims: u32,
    /// Links of the chain.
    pub n_links: u32,
    /// The chain's [`Precision`] (1 f64, 2 f32).
    pub precision: u32,
    /// The chain's default [`WireMethod`].
    pub method: u32,
    /// The chain's collision bits.
    pub collision: u32,
    /// The chain's default [`SubstepMode`] (1 or 2).
    pub substep_mode: u32,
    /// The chain's default substep count (mode 1).
    pub substeps_default: u32,
    /// Held joints after the joints and rotations (every response that carries joints).
    pub n_held: u32,
    /// The chain's default max step (mode 2).
    pub max_step: f64,
    /// Sum of the link lengths.
    pub total_length: f64,
    /// Thickness (diameter) of the chain.
    pub thickness: f64,
    /// Chain name, UTF-8, NUL-padded.
    pub name: [u8; NAME_LEN],
    /// Why the command failed, UTF-8, NUL-padded (empty when ok, but for a pull that stopped short:
    /// why, [`PullStop::reason`]).
    pub reason: [u8; REASON_LEN],
    /// Instruments after the held joints, [`INSTRUMENT_ELEMENTS`] elements each (every response that
    /// carries joints, for a chain whose scene gives it instruments).
    pub n_instruments: u32,
    /// `describe`: the chain's joint limits, [`LIMITS_NONE`], [`LIMITS_BEND_RADIUS`],
    /// [`LIMITS_CONE`], [`LIMITS_CONES`] or [`LIMITS_RANGES`]; 0 in other responses.
    pub limits: u32,
    /// `describe`: the bend radius (a length) for [`LIMITS_BEND_RADIUS`], the cone's angle (radians)
    /// for [`LIMITS_CONE`], the widest cone for [`LIMITS_CONES`], the widest range's width for
    /// [`LIMITS_RANGES`]; 0 otherwise.
    pub limit_value: f64,
    /// Pulls after the instruments: one per held joint, then one per instrument (`n_held +
    /// n_instruments`; every response that carries held joints or instruments). Each is the vector
    /// from where that joint's or instrument's owner last asked it to be to where the rope let it be:
    /// zero while the rope is slack ([`FLAG_PULL`], docs/tension.md).
    pub n_pulls: u32,
    /// The knot of the chain after the request, for a chain whose scene asks for it (`knot = true`):
    /// [`KNOT_UNKNOT`] and the rest ([`knot_name`]); [`KNOT_NOT_ASKED`] (0) otherwise.
    pub knot: u32,
    /// Eyelets after the pulls ([`EYELET_ELEMENTS`] elements each), for a chain whose scene has
    /// them.
    pub n_eyelets: u32,
    /// `describe`: 1 when the chain has a block of tissue (scene `tissue`), its two corners after the
    /// eyelets ([`TISSUE_ELEMENTS`]); 0 otherwise and in every other response. (It was `reserved`,
    /// always zero, before: the layout is unchanged.)
    pub n_tissue: u32,
}

/// [`ResponseHeader::knot`] and [`StateHeader::knot`]: the chain's scene does not ask for its knot.
pub const KNOT_NOT_ASKED: u32 = 0;
/// No knot.
pub const KNOT_UNKNOT: u32 = 1;
/// The overhand knot (the trefoil), either hand.
pub const KNOT_TREFOIL: u32 = 2;
/// The square (reef) knot.
pub const KNOT_SQUARE: u32 = 3;
/// The granny knot.
pub const KNOT_GRANNY: u32 = 4;
/// The double overhand knot (5₁), the surgeon's first throw.
pub const KNOT_DOUBLE_OVERHAND: u32 = 5;
/// The surgeon's knot.
pub const KNOT_SURGEONS: u32 = 6;
/// Any other knot (or a diagram too large to name at this rate).
pub const KNOT_OTHER: u32 = 7;

/// The name of a [`ResponseHeader::knot`] or [`StateHeader::knot`] code, as the tools print it
/// (`None` for [`KNOT_NOT_ASKED`] and unknown codes).
pub fn knot_name(code: u32) -> Option<&'static str> {
    const NAMES: [&str; 7] = [
        "unknot",
        "trefoil",
        "square",
        "granny",
        "double-overhand",
        "surgeons",
        "other",
    ];
    NAMES.get((code as usize).checked_sub(1)?).copied()
}

/// A describe's [`ResponseHeader::limits`]: the chain has no joint limits.
pub const LIMITS_NONE: u32 = 0;
/// A rope's minimum bend radius, as a cone at each joint (`limit_value`: the radius).
pub const LIMITS_BEND_RADIUS: u32 = 1;
/// One cone at every joint (`limit_value`: its angle in radians).
pub const LIMITS_CONE: u32 = 2;
/// A cone per joint (`limit_value`: the widest, radians).
pub const LIMITS_CONES: u32 = 3;
/// Signed revolute ranges of a planar chain (`limit_value`: the widest range's width, radians).
pub const LIMITS_RANGES: u32 = 4;

impl Default for ResponseHeader {
    fn default() -> Self {
        ResponseHeader {
            status: 0,
            command: 0,
            chain: 0,
            n_joints: 0,
            n_angles: 0,
            iterations: 0,
            substeps: 0,
            paper_fallbacks: 0,
            sequence: 0,
            request_id: 0,
            solve_ns: 0,
            residual: 0.0,
            n_chains: 0,
            kind: 0,
            dims: 0,
            n_links: 0,
            precision: 0,
            method: 0,
            collision: 0,
            substep_mode: 0,
            substeps_default: 0,
            n_held: 0,
            max_step: 0.0,
            total_length: 0.0,
            thickness: 0.0,
            name: [0; NAME_LEN],
            reason: [0; REASON_LEN],
            n_instruments: 0,
            limits: 0,
            limit_value: 0.0,
            n_pulls: 0,
            knot: 0,
            n_eyelets: 0,
            n_tissue: 0,
        }
    }
}

impl ResponseHeader {
    /// The status, or `None` for a number this version does not know.
    pub fn status(&self) -> Option<Status> {
        Status::from_u32(self.status)
    }
    /// The chain name as text (up to the first NUL; invalid UTF-8 is replaced).
    pub fn name_str(&self) -> String {
        c_string(&self.name)
    }
    /// The reason as text.
    pub fn reason_str(&self) -> String {
        c_string(&self.reason)
    }
    /// Why the pull of an ok response stopped short ([`FLAG_PULL`]); `None` when it made the whole
    /// move, or the response is not ok.
    pub fn pull_stop(&self) -> Option<PullStop> {
        if self.status != Status::Ok as u32 {
            return None;
        }
        PullStop::of_field(&self.reason)
    }
    /// Writes `text` into `reason`, cut at a character boundary to fit.
    pub fn set_reason(&mut self, text: &str) {
        write_c_string(&mut self.reason, text);
    }
    /// Writes `text` into `name`, cut at a character boundary to fit.
    pub fn set_name(&mut self, text: &str) {
        write_c_string(&mut self.name, text);
    }
}

/// The state stream's user header; the payload is the chain's `n_joints` joints, then its `n_held` held
/// joints, then its `n_instruments` instruments (as in a response).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("tractrix.v2.StateHeader")]
pub struct StateHeader {
    /// Increases by one with every accepted change, over all chains; a gap means a missed sample.
    pub sequence: u64,
    /// The chain that changed.
    pub chain: u32,
    /// Joints in the payload.
    pub n_joints: u32,
    /// The [`Command`] that changed it.
    pub command: u32,
    /// Held joints after the joints in the payload (as in a response).
    pub n_held: u32,
    /// The `request_id` of that command.
    pub request_id: u64,
    /// Instruments after the held joints in the payload (as in a response).
    pub n_instruments: u32,
    /// Pulls after the instruments in the payload (as in a response).
    pub n_pulls: u32,
    /// The chain's knot after the change (as in a response: 0 when its scene does not ask).
    pub knot: u32,
    /// Eyelets after the pulls in the payload (as in a response).
    pub n_eyelets: u32,
}

/// One instrument as a payload carries it ([`INSTRUMENT_ELEMENTS`] elements: `a`, `b`, then
/// `(radius, 0 sphere / 1 capsule, 0)`). A sphere has `a == b`, its centre.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InstrumentPose {
    /// One end of the axis (a sphere's centre).
    pub a: Vec3,
    /// The other end (a sphere's centre again).
    pub b: Vec3,
    pub radius: f64,
    /// A capsule, not a sphere.
    pub capsule: bool,
}

impl InstrumentPose {
    /// Its payload elements.
    pub fn to_elements(&self) -> [Vec3; INSTRUMENT_ELEMENTS as usize] {
        let shape = if self.capsule { 1.0 } else { 0.0 };
        [self.a, self.b, Vec3::new(self.radius, shape, 0.0)]
    }
    /// From its payload elements (`None` unless there are exactly [`INSTRUMENT_ELEMENTS`]).
    pub fn from_elements(e: &[Vec3]) -> Option<Self> {
        match e {
            [a, b, r] => Some(InstrumentPose {
                a: *a,
                b: *b,
                radius: r.x,
                capsule: r.y != 0.0,
            }),
            _ => None,
        }
    }
}

/// A payload cut into its parts by the counts of its header; counts larger than the payload are cut
/// to what is there, so a malformed header cannot index out of it.
#[derive(Debug, Clone, Copy)]
pub struct Parts<'a> {
    pub joints: &'a [Vec3],
    pub angles: &'a [Vec3],
    /// `(index, 1 anchor / 0 grasp, 0)` each.
    pub held: &'a [Vec3],
    /// [`INSTRUMENT_ELEMENTS`] elements per instrument.
    pub instruments: &'a [Vec3],
    /// One pull per held joint, then one per instrument.
    pub pulls: &'a [Vec3],
    /// [`EYELET_ELEMENTS`] elements per eyelet.
    pub eyelets: &'a [Vec3],
    /// A describe's block of tissue: its corners `lo` and `hi` ([`TISSUE_ELEMENTS`]), or empty.
    pub tissue: &'a [Vec3],
}

/// One eyelet as a payload carries it ([`EYELET_ELEMENTS`] elements).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EyeletState {
    /// The fixed point the rope passes through.
    pub at: Vec3,
    /// The link through it (joints `link` and `link + 1`), while threaded.
    pub link: u32,
    /// Whether the rope still passes through it (false once an end has slid out).
    pub threaded: bool,
}

impl<'a> Parts<'a> {
    /// Cuts `payload` into `n_joints`, `n_angles`, `n_held`, `n_instruments`, `n_pulls` and
    /// `n_eyelets` parts.
    pub fn new(
        payload: &'a [Vec3],
        n_joints: u32,
        n_angles: u32,
        n_held: u32,
        n_inst: u32,
        (n_pulls, n_eyelets): (u32, u32),
    ) -> Self {
        let mut rest = payload;
        let mut take = |n: usize| {
            let (head, tail) = rest.split_at(n.min(rest.len()));
            rest = tail;
            head
        };
        let joints = take(n_joints as usize);
        let angles = take(n_angles as usize);
        let held = take(n_held as usize);
        let instruments = take((n_inst as usize).saturating_mul(INSTRUMENT_ELEMENTS as usize));
        let pulls = take(n_pulls as usize);
        let eyelets = take((n_eyelets as usize).saturating_mul(EYELET_ELEMENTS as usize));
        Parts {
            joints,
            angles,
            held,
            instruments,
            pulls,
            eyelets,
            tissue: &[],
        }
    }
    /// The parts of a response's payload.
    pub fn of_response(h: &ResponseHeader, payload: &'a [Vec3]) -> Self {
        let mut parts = Self::new(
            payload,
            h.n_joints,
            h.n_angles,
            h.n_held,
            h.n_instruments,
            (h.n_pulls, h.n_eyelets),
        );
        let used = [
            parts.joints,
            parts.angles,
            parts.held,
            parts.instruments,
            parts.pulls,
            parts.eyelets,
        ]
        .iter()
        .map(|p| p.len())
        .sum::<usize>();
        let rest = &payload[used..];
        let n = (h.n_tissue as usize).saturating_mul(TISSUE_ELEMENTS as usize);
        parts.tissue = &rest[..n.min(rest.len())];
        parts
    }
    /// A describe's block of tissue: its corners `(lo, hi)`.
    pub fn tissue_box(&self) -> Option<(Vec3, Vec3)> {
        match self.tissue {
            [lo, hi, ..] => Some((*lo, *hi)),
            _ => None,
        }
    }
    /// The parts of a state sample's payload (no rotations).
    pub fn of_state(h: &StateHeader, payload: &'a [Vec3]) -> Self {
        Self::new(
            payload,
            h.n_joints,
            0,
            h.n_held,
            h.n_instruments,
            (h.n_pulls, h.n_eyelets),
        )
    }
    /// The held joints: `(index, anchor of the scene)`.
    pub fn held_joints(&self) -> impl Iterator<Item = (u32, bool)> + 'a {
        self.held.iter().map(|v| (v.x as u32, v.y != 0.0))
    }
    /// For each held joint, whether the stretch from it to the next held joint toward the head is
    /// taut.
    pub fn taut(&self) -> impl Iterator<Item = bool> + 'a {
        self.held.iter().map(|v| v.z != 0.0)
    }
    /// The pull on each held joint: `(joint index, pull)`.
    pub fn held_pulls(&self) -> impl Iterator<Item = (u32, Vec3)> + 'a {
        self.held
            .iter()
            .zip(self.pulls)
            .map(|(h, p)| (h.x as u32, *p))
    }
    /// The pull on each instrument (in the scene's order).
    pub fn instrument_pulls(&self) -> &'a [Vec3] {
        self.pulls.get(self.held.len()..).unwrap_or(&[])
    }
    /// The eyelets.
    pub fn eyelet_states(&self) -> impl Iterator<Item = EyeletState> + 'a {
        self.eyelets
            .chunks_exact(EYELET_ELEMENTS as usize)
            .map(|e| EyeletState {
                at: e[0],
                link: e[1].x as u32,
                threaded: e[1].y != 0.0,
            })
    }
    /// The instruments.
    pub fn instrument_poses(&self) -> impl Iterator<Item = InstrumentPose> + 'a {
        self.instruments
            .chunks_exact(INSTRUMENT_ELEMENTS as usize)
            .filter_map(InstrumentPose::from_elements)
    }
}

fn c_string(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

/// Copies `text` into a NUL-padded buffer, keeping at least one NUL and whole UTF-8 characters.
pub fn write_c_string(buf: &mut [u8], text: &str) {
    let mut end = text.len().min(buf.len().saturating_sub(1));
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    buf.fill(0);
    buf[..end].copy_from_slice(&text.as_bytes()[..end]);
}

#[cfg(test)]
mod tests;
