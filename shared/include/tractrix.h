/* tractrix.h — the wire types of the tractrix solver service, protocol v2, for C, C++ and C#.
 *
 * Mirrors shared/src/lib.rs (the Rust crate `shared`, module `protocol`), which documents
 * every field; the test `cargo test -p shared --test c_header` compiles this header with the
 * machine's C compiler (and C++ compiler, when there is one) together with size and offset assertions
 * generated from the Rust types, so the two cannot drift apart.
 *
 * Little-endian, natural alignment, no implicit padding: every gap is a named `reserved` field that
 * must be zero. Zero every field of a request you do not set: zero means "the chain's default".
 *
 * Services (names relative to the iceoryx2 prefix, default "tractrix_"):
 *   "tractrix/command"      request-response: request user header tractrix_RequestHeader, payload a
 *                           slice of tractrix_Vec3 (targets); response user header
 *                           tractrix_ResponseHeader, payload a slice of tractrix_Vec3 (n_joints joints,
 *                           then n_angles rotation vectors, then n_held held joints: x the index,
 *                           y 1 for an anchor of the scene and 0 for a grasp, z 1 when the stretch
 *                           to the next held joint toward the head is taut, else 0, then
 *                           n_instruments instruments, three elements each: the axis ends a and b
 *                           (equal for a sphere), then (radius, 0 sphere / 1 capsule, 0), then n_pulls
 *                           pulls, one per held joint and one per instrument: the vector from where
 *                           its owner last asked it to be to where the rope let it be, zero when
 *                           slack (times a coupling stiffness: the force on the hand; FLAG_PULL)).
 *   "tractrix/state"        publish-subscribe: user header tractrix_StateHeader, payload tractrix_Vec3[]
 *                           (n_joints joints, n_held held joints, n_instruments instruments, n_pulls
 *                           pulls).
 *   "tractrix/bundle-state" publish-subscribe, only for a scene with bundles: user header
 *                           tractrix_StateHeader, payload all joints of one bundle (strand after
 *                           strand, each tail first); at most TRACTRIX_MAX_BUNDLE_SUBSCRIBERS
 *                           subscribers buffering TRACTRIX_BUNDLE_STATE_BUFFER samples each.
 *   "tractrix/wake-server"  event: notify after sending unless the server spins.
 *   "tractrix/wake-client"  event: the server notifies the listener whose id is in client_listener.
 * iceoryx2 type names (C++: static constexpr const char* IOX2_TYPE_NAME) are the TRACTRIX_TYPE_NAME_*
 * macros below; peers with other type names are refused at open (another protocol version).
 */
#ifndef TRACTRIX_H
#define TRACTRIX_H

#include <stddef.h>
#include <stdint.h>

#define TRACTRIX_PROTOCOL_VERSION 2u
#define TRACTRIX_SERVICE_COMMAND "tractrix/command"
#define TRACTRIX_SERVICE_STATE "tractrix/state"
#define TRACTRIX_SERVICE_BUNDLE_STATE "tractrix/bundle-state"
#define TRACTRIX_SERVICE_WAKE_SERVER "tractrix/wake-server"
#define TRACTRIX_SERVICE_WAKE_CLIENT "tractrix/wake-client"
#define TRACTRIX_DEFAULT_PREFIX "tractrix_"
#define TRACTRIX_MAX_LINKS 65536u
#define TRACTRIX_MAX_HELD 64u
#define TRACTRIX_MAX_GRASPS_PER_CLIENT 16u
#define TRACTRIX_MAX_INSTRUMENTS 64u
#define TRACTRIX_INSTRUMENT_ELEMENTS 3u
/* Eyelets a chain may pass through, and elements per eyelet: its point, then (link, 1 threaded, 0). */
#define TRACTRIX_MAX_EYELETS 64u
#define TRACTRIX_EYELET_ELEMENTS 2u
/* Elements of a chain's block of tissue in a describe's payload: its corners lo and hi. */
#define TRACTRIX_TISSUE_ELEMENTS 2u
#define TRACTRIX_MAX_RESPONSE_ELEMENTS \
    (2u * TRACTRIX_MAX_LINKS + 1u + 2u * TRACTRIX_MAX_HELD + \
     (TRACTRIX_INSTRUMENT_ELEMENTS + 1u) * TRACTRIX_MAX_INSTRUMENTS + \
     TRACTRIX_EYELET_ELEMENTS * TRACTRIX_MAX_EYELETS + TRACTRIX_TISSUE_ELEMENTS)
#define TRACTRIX_MAX_PATH_POINTS 4096u
#define TRACTRIX_MAX_CHAINS 256u
#define TRACTRIX_NAME_LEN 32u
#define TRACTRIX_REASON_LEN 96u
#define TRACTRIX_JOINT_HEAD 0xFFFFFFFFu
#define TRACTRIX_FLAG_ANGLES 1u
/* A bundle's move by one rigid motion of its heads: points (t, rotation vector r); head_i = R(r) h0_i + t.
 * A move of the head of a chain with a needle: points (swage, rotation vector r): the needle leaves its
 * swage along R(r)·x, curving toward R(r)·y (a 6-DOF stylus's pose); its point cuts holes in tissue. */
#define TRACTRIX_FLAG_POSE 2u
/* Grasp, release, move, path, reset: take over the grasps of other clients the request touches. */
#define TRACTRIX_FLAG_TAKE_OVER 4u
/* Reach: an orientation goal, points (head target, direction of the last link). */
#define TRACTRIX_FLAG_ORIENT 8u
/* Reach: a box goal, points (corner of smallest coordinates, corner of largest); no motion inside. */
#define TRACTRIX_FLAG_IN_BOX 16u
/* Reach: a ball goal, points (centre, (radius, 0, 0)); no motion inside. */
#define TRACTRIX_FLAG_IN_BALL 32u
/* Path: follow the natural cubic spline through the joint and the points (C2) instead of straight segments. */
#define TRACTRIX_FLAG_SMOOTH 64u
/* Move (one target) and instrument: pull. A move the rope cannot make in full goes as far as it can
 * instead of being refused; the rest is the pull of that joint or instrument (n_pulls elements). */
#define TRACTRIX_FLAG_PULL 128u
/* A move of the head of a chain with a needle: the needle driven along its own arc to the target (a
 * needle driver's turn); where its point crosses the tissue's surface it cuts a hole. */
#define TRACTRIX_FLAG_DRIVE 256u
#define TRACTRIX_MAX_BUNDLE_JOINTS 1048576u
#define TRACTRIX_MAX_BUNDLE_STRANDS 131072u
#define TRACTRIX_BUNDLE_STATE_BUFFER 2u
#define TRACTRIX_MAX_BUNDLE_SUBSCRIBERS 4u
#define TRACTRIX_COLLISION_SELF 1u
#define TRACTRIX_COLLISION_OBSTACLES 2u
#define TRACTRIX_COLLISION_PAPER_SPHERES 4u
/* A describe's limits field: the chain's joint limits (limit_value: radius, cone angle in radians,
 * widest cone, widest range width). */
#define TRACTRIX_LIMITS_NONE 0u
#define TRACTRIX_LIMITS_BEND_RADIUS 1u
#define TRACTRIX_LIMITS_CONE 2u
#define TRACTRIX_LIMITS_CONES 3u
#define TRACTRIX_LIMITS_RANGES 4u

/* The knot field of a response and a state: the chain's knot, for a chain whose scene asks for it
 * (knot = true); TRACTRIX_KNOT_NOT_ASKED otherwise. */
#define TRACTRIX_KNOT_NOT_ASKED 0u
#define TRACTRIX_KNOT_UNKNOT 1u
#define TRACTRIX_KNOT_TREFOIL 2u
#define TRACTRIX_KNOT_SQUARE 3u
#define TRACTRIX_KNOT_GRANNY 4u
#define TRACTRIX_KNOT_DOUBLE_OVERHAND 5u
#define TRACTRIX_KNOT_SURGEONS 6u
#define TRACTRIX_KNOT_OTHER 7u

#define TRACTRIX_TYPE_NAME_VEC3 "tractrix.v2.Vec3"
#define TRACTRIX_TYPE_NAME_REQUESTHEADER "tractrix.v2.RequestHeader"
#define TRACTRIX_TYPE_NAME_RESPONSEHEADER "tractrix.v2.ResponseHeader"
#define TRACTRIX_TYPE_NAME_STATEHEADER "tractrix.v2.StateHeader"

/* Commands (RequestHeader.command). */
enum tractrix_command {
    TRACTRIX_CMD_MOVE = 1,
    TRACTRIX_CMD_PATH = 2,
    TRACTRIX_CMD_REACH = 3,
    TRACTRIX_CMD_QUERY = 4,
    TRACTRIX_CMD_RESET = 5,
    TRACTRIX_CMD_DESCRIBE = 6,
    TRACTRIX_CMD_SNAPSHOT = 7,
    TRACTRIX_CMD_GRASP = 8,
    TRACTRIX_CMD_RELEASE = 9,
    TRACTRIX_CMD_INSTRUMENT = 10,
    TRACTRIX_CMD_EYELET = 11
};

/* Statuses (ResponseHeader.status); on error, `reason` says why and the state is unchanged. */
enum tractrix_status {
    TRACTRIX_OK = 0,
    TRACTRIX_UNKNOWN_COMMAND = 1,
    TRACTRIX_UNKNOWN_CHAIN = 2,
    TRACTRIX_JOINT_OUT_OF_RANGE = 3,
    TRACTRIX_NON_FINITE = 4,
    TRACTRIX_BAD_OPTION = 5,
    TRACTRIX_BAD_POINT_COUNT = 6,
    TRACTRIX_UNREACHABLE = 7,
    TRACTRIX_NOT_CONVERGED = 8,
    TRACTRIX_TOO_MANY_SUBSTEPS = 9,
    TRACTRIX_WRONG_CHAIN_KIND = 10,
    TRACTRIX_OFF_PLANE = 11,
    TRACTRIX_PERSISTENCE_FAILED = 12,
    TRACTRIX_INTERNAL = 13,
    TRACTRIX_LOCKED = 14,
    TRACTRIX_TOO_FAR = 15,
    TRACTRIX_OVER_BUDGET = 16,
    TRACTRIX_JOINT_LIMIT = 17,
    TRACTRIX_HELD = 18
};

/* RequestHeader.method, .precision, .substep_mode, .strategy; ResponseHeader.kind. */
enum tractrix_method { TRACTRIX_METHOD_DEFAULT = 0, TRACTRIX_METHOD_TRACTRIX = 1, TRACTRIX_METHOD_PAPER = 2, TRACTRIX_METHOD_FTL = 3 };
enum tractrix_precision { TRACTRIX_PRECISION_DEFAULT = 0, TRACTRIX_PRECISION_F64 = 1, TRACTRIX_PRECISION_F32 = 2 };
enum tractrix_substep_mode { TRACTRIX_SUBSTEPS_DEFAULT = 0, TRACTRIX_SUBSTEPS_FIXED = 1, TRACTRIX_SUBSTEPS_MAX_STEP = 2 };
enum tractrix_strategy { TRACTRIX_STRATEGY_DEFAULT = 0, TRACTRIX_STRATEGY_TRANSLATE_BACK = 1, TRACTRIX_STRATEGY_TWO_LINK = 2, TRACTRIX_STRATEGY_PULL_BACK = 3 };
enum tractrix_chain_kind { TRACTRIX_KIND_FREE = 0, TRACTRIX_KIND_FIXED_BASE = 1, TRACTRIX_KIND_BUNDLE = 2 };

/* 24 bytes, align 8. */
typedef struct tractrix_Vec3 {
    double x; /* offset 0 */
    double y; /* offset 8 */
    double z; /* offset 16 */
} tractrix_Vec3;

/* 96 bytes, align 8. */
typedef struct tractrix_RequestHeader {
    uint32_t command; /* offset 0 */
    uint32_t chain; /* offset 4 */
    uint32_t joint; /* offset 8 */
    uint32_t method; /* offset 12 */
    uint32_t precision; /* offset 16 */
    uint32_t substep_mode; /* offset 20 */
    uint32_t substeps; /* offset 24 */
    uint32_t strategy; /* offset 28 */
    uint32_t max_iterations; /* offset 32 */
    uint32_t flags; /* offset 36 */
    uint64_t client_listener[2]; /* offset 40 */
    uint64_t request_id; /* offset 56 */
    double max_step; /* offset 64 */
    double tolerance; /* offset 72 */
    uint64_t reserved[2]; /* offset 80 */
} tractrix_RequestHeader;

/* 288 bytes, align 8. */
typedef struct tractrix_ResponseHeader {
    uint32_t status; /* offset 0 */
    uint32_t command; /* offset 4 */
    uint32_t chain; /* offset 8 */
    uint32_t n_joints; /* offset 12 */
    uint32_t n_angles; /* offset 16 */
    uint32_t iterations; /* offset 20 */
    uint32_t substeps; /* offset 24 */
    uint32_t paper_fallbacks; /* offset 28 */
    uint64_t sequence; /* offset 32 */
    uint64_t request_id; /* offset 40 */
    uint64_t solve_ns; /* offset 48 */
    double residual; /* offset 56 */
    uint32_t n_chains; /* offset 64 */
    uint32_t kind; /* offset 68 */
    uint32_t dims; /* offset 72 */
    uint32_t n_links; /* offset 76 */
    uint32_t precision; /* offset 80 */
    uint32_t method; /* offset 84 */
    uint32_t collision; /* offset 88 */
    uint32_t substep_mode; /* offset 92 */
    uint32_t substeps_default; /* offset 96 */
    uint32_t n_held; /* offset 100 */
    double max_step; /* offset 104 */
    double total_length; /* offset 112 */
    double thickness; /* offset 120 */
    uint8_t name[32]; /* offset 128 */
    uint8_t reason[96]; /* offset 160 */
    uint32_t n_instruments; /* offset 256 */
    uint32_t limits; /* offset 260 */
    double limit_value; /* offset 264 */
    uint32_t n_pulls; /* offset 272 */
    uint32_t knot; /* offset 276 */
    uint32_t n_eyelets; /* offset 280 */
    uint32_t n_tissue; /* offset 284: describe: 1 when the tissue's two corners follow the eyelets */
} tractrix_ResponseHeader;

/* 48 bytes, align 8. */
typedef struct tractrix_StateHeader {
    uint64_t sequence; /* offset 0 */
    uint32_t chain; /* offset 8 */
    uint32_t n_joints; /* offset 12 */
    uint32_t command; /* offset 16 */
    uint32_t n_held; /* offset 20 */
    uint64_t request_id; /* offset 24 */
    uint32_t n_instruments; /* offset 32 */
    uint32_t n_pulls; /* offset 36 */
    uint32_t knot; /* offset 40 */
    uint32_t n_eyelets; /* offset 44 */
} tractrix_StateHeader;

#ifdef __cplusplus
#define TRACTRIX_STATIC_ASSERT static_assert
#else
#define TRACTRIX_STATIC_ASSERT _Static_assert
#endif

TRACTRIX_STATIC_ASSERT(sizeof(tractrix_Vec3) == 24, "tractrix_Vec3 size");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_Vec3, x) == 0, "tractrix_Vec3 starts with x");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_Vec3, y) == 8, "tractrix_Vec3.y offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_Vec3, z) == 16, "tractrix_Vec3.z offset");

TRACTRIX_STATIC_ASSERT(sizeof(tractrix_RequestHeader) == 96, "tractrix_RequestHeader size");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, command) == 0, "tractrix_RequestHeader starts with command");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, chain) == 4, "tractrix_RequestHeader.chain offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, joint) == 8, "tractrix_RequestHeader.joint offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, method) == 12, "tractrix_RequestHeader.method offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, precision) == 16, "tractrix_RequestHeader.precision offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, substep_mode) == 20, "tractrix_RequestHeader.substep_mode offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, substeps) == 24, "tractrix_RequestHeader.substeps offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, strategy) == 28, "tractrix_RequestHeader.strategy offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, max_iterations) == 32, "tractrix_RequestHeader.max_iterations offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, flags) == 36, "tractrix_RequestHeader.flags offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, client_listener) == 40, "tractrix_RequestHeader.client_listener offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, request_id) == 56, "tractrix_RequestHeader.request_id offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, max_step) == 64, "tractrix_RequestHeader.max_step offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, tolerance) == 72, "tractrix_RequestHeader.tolerance offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_RequestHeader, reserved) == 80, "tractrix_RequestHeader.reserved offset");

TRACTRIX_STATIC_ASSERT(sizeof(tractrix_ResponseHeader) == 288, "tractrix_ResponseHeader size");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, status) == 0, "tractrix_ResponseHeader starts with status");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, command) == 4, "tractrix_ResponseHeader.command offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, chain) == 8, "tractrix_ResponseHeader.chain offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_joints) == 12, "tractrix_ResponseHeader.n_joints offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_angles) == 16, "tractrix_ResponseHeader.n_angles offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, iterations) == 20, "tractrix_ResponseHeader.iterations offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, substeps) == 24, "tractrix_ResponseHeader.substeps offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, paper_fallbacks) == 28, "tractrix_ResponseHeader.paper_fallbacks offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, sequence) == 32, "tractrix_ResponseHeader.sequence offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, request_id) == 40, "tractrix_ResponseHeader.request_id offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, solve_ns) == 48, "tractrix_ResponseHeader.solve_ns offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, residual) == 56, "tractrix_ResponseHeader.residual offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_chains) == 64, "tractrix_ResponseHeader.n_chains offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, kind) == 68, "tractrix_ResponseHeader.kind offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, dims) == 72, "tractrix_ResponseHeader.dims offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_links) == 76, "tractrix_ResponseHeader.n_links offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, precision) == 80, "tractrix_ResponseHeader.precision offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, method) == 84, "tractrix_ResponseHeader.method offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, collision) == 88, "tractrix_ResponseHeader.collision offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, substep_mode) == 92, "tractrix_ResponseHeader.substep_mode offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, substeps_default) == 96, "tractrix_ResponseHeader.substeps_default offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_held) == 100, "tractrix_ResponseHeader.n_held offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, max_step) == 104, "tractrix_ResponseHeader.max_step offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, total_length) == 112, "tractrix_ResponseHeader.total_length offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, thickness) == 120, "tractrix_ResponseHeader.thickness offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, name) == 128, "tractrix_ResponseHeader.name offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, reason) == 160, "tractrix_ResponseHeader.reason offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_instruments) == 256, "tractrix_ResponseHeader.n_instruments offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, limits) == 260, "tractrix_ResponseHeader.limits offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, limit_value) == 264, "tractrix_ResponseHeader.limit_value offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_pulls) == 272, "tractrix_ResponseHeader.n_pulls offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, knot) == 276, "tractrix_ResponseHeader.knot offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_eyelets) == 280, "tractrix_ResponseHeader.n_eyelets offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_ResponseHeader, n_tissue) == 284, "tractrix_ResponseHeader.n_tissue offset");

TRACTRIX_STATIC_ASSERT(sizeof(tractrix_StateHeader) == 48, "tractrix_StateHeader size");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, sequence) == 0, "tractrix_StateHeader starts with sequence");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, chain) == 8, "tractrix_StateHeader.chain offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, n_joints) == 12, "tractrix_StateHeader.n_joints offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, command) == 16, "tractrix_StateHeader.command offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, n_held) == 20, "tractrix_StateHeader.n_held offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, request_id) == 24, "tractrix_StateHeader.request_id offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, n_instruments) == 32, "tractrix_StateHeader.n_instruments offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, n_pulls) == 36, "tractrix_StateHeader.n_pulls offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, knot) == 40, "tractrix_StateHeader.knot offset");
TRACTRIX_STATIC_ASSERT(offsetof(tractrix_StateHeader, n_eyelets) == 44, "tractrix_StateHeader.n_eyelets offset");

#endif /* TRACTRIX_H */
