/*
 * tractrix_client.h: the solver service's client with a C ABI (C, C++, C# by P/Invoke).
 *
 * Link with libtractrix_client.so or libtractrix_client.a (cargo build --release -p tractrix-client;
 * the static library also needs -lpthread -ldl -lm). The wire types come from tractrix.h.
 *
 * Return values: 0 success; > 0 the service refused and the value is a tractrix_Status
 * (TRACTRIX_UNREACHABLE, TRACTRIX_LOCKED, ...); < 0 a failure on this side (TRACTRIX_E_*). After any
 * non-zero return, tractrix_client_error(client) says why (UTF-8; for a refusal the service's reason),
 * valid until the next call on that client. A failed open leaves its message in
 * tractrix_last_open_error() (per thread).
 *
 * Joints are copied into the caller's buffer of `capacity` elements and their count written to
 * *n_joints (which may be NULL); pass NULL and 0 to skip them. A buffer too small returns
 * TRACTRIX_E_BUFFER with the count needed in *n_joints; the request itself was applied.
 *
 * Thread safety: a client may be used from any thread, and shared: calls on one client are serialised
 * (one client per thread is the fast way). A stream is used by one thread at a time. Close streams
 * before their client. No function blocks longer than the client's timeouts; none lets a panic out.
 */
#ifndef TRACTRIX_CLIENT_H
#define TRACTRIX_CLIENT_H

#include <stddef.h>
#include <stdint.h>

#include "tractrix.h"

#ifdef __cplusplus
extern "C" {
#endif

#define TRACTRIX_E_ARGUMENT (-1)     /* a null pointer, a name not UTF-8, an option out of range */
#define TRACTRIX_E_NO_SERVICE (-2)   /* no service with that prefix (within the connect timeout) */
#define TRACTRIX_E_VERSION (-3)      /* the service speaks another protocol version */
#define TRACTRIX_E_TIMEOUT (-4)      /* no response within the call timeout */
#define TRACTRIX_E_DISCONNECTED (-5) /* the service went away before answering */
#define TRACTRIX_E_IPC (-6)          /* iceoryx2 failed (the message says where) */
#define TRACTRIX_E_BUFFER (-7)       /* the caller's buffer is too small (count needed written) */
#define TRACTRIX_E_PANIC (-8)        /* a panic was caught: a bug, please report the message */
#define TRACTRIX_E_NO_CHAIN (-9)     /* no chain of that name */

#define TRACTRIX_WAIT_SPIN 0   /* busy-poll for the response: lowest latency, a core while waiting */
#define TRACTRIX_WAIT_EVENT 1  /* sleep until the service wakes the client */
#define TRACTRIX_WAIT_HYBRID 2 /* spin 50 us, then sleep */

typedef struct TractrixClient tractrix_client;
typedef struct TractrixStream tractrix_stream;

/* Connects to the service with iceoryx2 prefix `prefix` (NULL: $TRACTRIX_IOX_PREFIX or the default),
 * waiting up to connect_timeout_s for it to appear; each call then waits up to call_timeout_s (both
 * 0..3600). Writes the client to *out. */
int tractrix_client_open(const char *prefix, int wait, double connect_timeout_s, double call_timeout_s,
                         tractrix_client **out);
/* The message of this thread's last failed open (empty after a success). */
const char *tractrix_last_open_error(void);
/* Closes a client (NULL is ignored). */
void tractrix_client_close(tractrix_client *client);
/* Why the last call on this client failed (empty after a success). */
const char *tractrix_client_error(const tractrix_client *client);

/* The handle of the chain named `name` (TRACTRIX_E_NO_CHAIN if none). */
int tractrix_client_find_chain(tractrix_client *client, const char *name, uint32_t *chain);
/* The chain's description (name, kind, links, total length, defaults) in *description. */
int tractrix_client_describe(tractrix_client *client, uint32_t chain, tractrix_ResponseHeader *description);

/* Moves `joint` (0 = tail, TRACTRIX_JOINT_HEAD = head) straight to `target`. */
int tractrix_client_move(tractrix_client *client, uint32_t chain, uint32_t joint, tractrix_Vec3 target,
                         tractrix_Vec3 *joints, size_t capacity, size_t *n_joints);
/* Moves `joint` toward `target` as far as the rope lets it (TRACTRIX_FLAG_PULL: stops short where the
 * stretch to a held joint is out of length, contact jams or a joint limit is met, instead of being
 * refused). *pull: where the rope let the joint be less where it was asked to be (zero when slack;
 * times a coupling stiffness, the force on the hand: docs/tension.md); *taut: 1 when a stretch of rope
 * from the joint to a neighbouring held joint is straight. Either may be NULL. */
int tractrix_client_pull(tractrix_client *client, uint32_t chain, uint32_t joint, tractrix_Vec3 target,
                         tractrix_Vec3 *joints, size_t capacity, size_t *n_joints, tractrix_Vec3 *pull,
                         int *taut);
/* Why the last tractrix_client_pull on this client stopped short of its target (the service's reason
 * on an ok response, docs/tension.md): TRACTRIX_PULL_STOP_NONE when it made the whole move (or
 * failed), else one of the others; TRACTRIX_E_ARGUMENT for a NULL client. */
enum {
    TRACTRIX_PULL_STOP_NONE = 0,
    TRACTRIX_PULL_STOP_TAUT = 1,
    TRACTRIX_PULL_STOP_JAMMED = 2,
    TRACTRIX_PULL_STOP_LIMIT = 3,
    TRACTRIX_PULL_STOP_WORK = 4
};
int tractrix_client_pull_stop(const tractrix_client *client);
/* A chain with a needle: poses the needle as a 6-DOF stylus holds the needle driver (TRACTRIX_FLAG_POSE):
 * its swage (the head) to `swage`, the needle turned by the rotation vector `rotation` (axis x angle,
 * radians) from its own frame, in which it leaves the swage along +x and curves toward +y. Where its point
 * crosses the tissue's surface it cuts a hole the rope then threads. */
int tractrix_client_needle_pose(tractrix_client *client, uint32_t chain, tractrix_Vec3 swage, tractrix_Vec3 rotation,
                                tractrix_Vec3 *joints, size_t capacity, size_t *n_joints);
/* A chain with a needle: drives the needle along its own arc, its swage (the head) to `target`
 * (TRACTRIX_FLAG_DRIVE: a target on the needle's circle turns it about its centre), cutting holes as above. */
int tractrix_client_needle_drive(tractrix_client *client, uint32_t chain, tractrix_Vec3 target, tractrix_Vec3 *joints,
                                 size_t capacity, size_t *n_joints);
/* Moves `joint` through n_points targets in order (1..4096). */
int tractrix_client_path(tractrix_client *client, uint32_t chain, uint32_t joint, const tractrix_Vec3 *points,
                         size_t n_points, tractrix_Vec3 *joints, size_t capacity, size_t *n_joints);
/* The same along the natural cubic spline through the joint and the points (C2) instead of straight segments. */
int tractrix_client_path_smooth(tractrix_client *client, uint32_t chain, uint32_t joint, const tractrix_Vec3 *points,
                                size_t n_points, tractrix_Vec3 *joints, size_t capacity, size_t *n_joints);
/* A fixed-base chain's head to `target`; the distance left in *residual (may be NULL). */
int tractrix_client_reach(tractrix_client *client, uint32_t chain, tractrix_Vec3 target, tractrix_Vec3 *joints,
                          size_t capacity, size_t *n_joints, double *residual);
/* A fixed-base chain's head to a goal: goal TRACTRIX_FLAG_ORIENT (a: the head's target, b: the last link's
 * direction), TRACTRIX_FLAG_IN_BOX (a, b: the smallest and largest corners) or TRACTRIX_FLAG_IN_BALL (a: the
 * centre, b.x: the radius); 0: the point a. The distance left in *residual (may be NULL). */
int tractrix_client_reach_goal(tractrix_client *client, uint32_t chain, uint32_t goal, tractrix_Vec3 a,
                               tractrix_Vec3 b, tractrix_Vec3 *joints, size_t capacity, size_t *n_joints,
                               double *residual);
/* The chain's current joints. */
int tractrix_client_query(tractrix_client *client, uint32_t chain, tractrix_Vec3 *joints, size_t capacity,
                          size_t *n_joints);
/* Back to the scene's initial state. */
int tractrix_client_reset(tractrix_client *client, uint32_t chain);
/* Holds `joint` where it is (a hand's grasp) / lets it go. */
int tractrix_client_grasp(tractrix_client *client, uint32_t chain, uint32_t joint);
int tractrix_client_release(tractrix_client *client, uint32_t chain, uint32_t joint);
/* Moves instrument `index` of the chain to `centre`, turned to *axis (capsules; NULL for a sphere). */
int tractrix_client_instrument(tractrix_client *client, uint32_t chain, uint32_t index, tractrix_Vec3 centre,
                               const tractrix_Vec3 *axis, tractrix_Vec3 *joints, size_t capacity,
                               size_t *n_joints);
/* Any request: the response header is written to *response (for refusals too), its elements
 * (the whole payload: n_joints + n_angles + n_held + 3 * n_instruments + n_pulls) to (elements,
 * capacity). */
int tractrix_client_call(tractrix_client *client, const tractrix_RequestHeader *header,
                         const tractrix_Vec3 *points, size_t n_points, tractrix_ResponseHeader *response,
                         tractrix_Vec3 *elements, size_t capacity);

/* The state stream: every accepted change, in order. `joints` points at the sample's whole payload:
 * n_joints joints, then header->n_held held joints, then 3 * header->n_instruments instrument elements,
 * then header->n_pulls pulls (the header's counts are cut to what the payload holds). */
typedef void (*tractrix_on_state)(void *user, const tractrix_StateHeader *header, const tractrix_Vec3 *joints,
                                  size_t n_joints);
int tractrix_stream_open(tractrix_client *client, tractrix_stream **out);
/* Hands the next waiting state to on_state (joints borrowed for the call). 1: delivered, 0: none
 * waiting, < 0: an error. Never blocks. */
int tractrix_stream_next(tractrix_stream *stream, tractrix_on_state on_state, void *user);
void tractrix_stream_close(tractrix_stream *stream);

#ifdef __cplusplus
}
#endif

#endif /* TRACTRIX_CLIENT_H */
