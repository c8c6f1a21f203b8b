/* Moves the rope's head from C and reads the joints back (README, "Use it from your simulator").
 * Usage: move PREFIX. Prints the joints' bits (x y z as hex of the doubles) after a query. */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "tractrix_client.h"

static uint64_t bits(double x) { uint64_t b; memcpy(&b, &x, sizeof b); return b; }

static void on_state(void *user, const tractrix_StateHeader *h, const tractrix_Vec3 *joints, size_t n) {
    (void)joints;
    *(uint64_t *)user = h->sequence;
    printf("state %" PRIu64 ": chain %u, %zu joints\n", h->sequence, h->chain, n);
}

int main(int argc, char **argv) {
    tractrix_client *c = NULL;
    if (tractrix_client_open(argc > 1 ? argv[1] : NULL, TRACTRIX_WAIT_HYBRID, 5.0, 5.0, &c) != 0) {
        fprintf(stderr, "open: %s\n", tractrix_last_open_error());
        return 1;
    }
    uint32_t rope;
    if (tractrix_client_find_chain(c, "rope", &rope) != 0) {
        fprintf(stderr, "find: %s\n", tractrix_client_error(c));
        return 1;
    }
    tractrix_ResponseHeader d;
    if (tractrix_client_describe(c, rope, &d) != 0) { fprintf(stderr, "describe: %s\n", tractrix_client_error(c)); return 1; }
    printf("described: %s, %u links, length %.1f\n", d.name, d.n_links, d.total_length);
    tractrix_stream *stream = NULL;
    if (tractrix_stream_open(c, &stream) != 0) { fprintf(stderr, "stream: %s\n", tractrix_client_error(c)); return 1; }
    tractrix_Vec3 joints[64];
    size_t n = 0;
    /* Hold the tail while the head walks a path, then let go. */
    tractrix_Vec3 path[2] = {{39.0, 2.0, 0.0}, {38.5, 3.5, 0.5}};
    if (tractrix_client_grasp(c, rope, 0) != 0 ||
        tractrix_client_path(c, rope, TRACTRIX_JOINT_HEAD, path, 2, joints, 64, &n) != 0 ||
        tractrix_client_release(c, rope, 0) != 0) {
        fprintf(stderr, "grasp, path, release: %s\n", tractrix_client_error(c));
        return 1;
    }
    printf("held path: tail %.1f %.1f %.1f\n", joints[0].x, joints[0].y, joints[0].z);
    tractrix_Vec3 target = {38.0, 5.0, 1.0};
    int rc = tractrix_client_move(c, rope, TRACTRIX_JOINT_HEAD, target, joints, 64, &n);
    if (rc != 0) { fprintf(stderr, "move: %d %s\n", rc, tractrix_client_error(c)); return 1; }
    printf("moved: %zu joints, head %.6f %.6f %.6f\n", n, joints[n - 1].x, joints[n - 1].y, joints[n - 1].z);
    /* Both ends held, the head pulled along the line from the tail to 2 beyond the rope's length
     * (42): the head stops where the rope is taut and the rest is the pull a haptic hand would feel. */
    tractrix_Vec3 pull, tail = joints[0], head = joints[n - 1];
    int taut = 0;
    tractrix_Vec3 dir = {head.x - tail.x, head.y - tail.y, head.z - tail.z};
    double far = 42.0 / sqrt(dir.x * dir.x + dir.y * dir.y + dir.z * dir.z);
    tractrix_Vec3 beyond = {tail.x + dir.x * far, tail.y + dir.y * far, tail.z + dir.z * far};
    if (tractrix_client_grasp(c, rope, 0) != 0 || tractrix_client_grasp(c, rope, TRACTRIX_JOINT_HEAD) != 0 ||
        tractrix_client_pull(c, rope, TRACTRIX_JOINT_HEAD, beyond, joints, 64, &n, &pull, &taut) != 0 ||
        tractrix_client_release(c, rope, TRACTRIX_JOINT_HEAD) != 0 || tractrix_client_release(c, rope, 0) != 0) {
        fprintf(stderr, "pull: %s\n", tractrix_client_error(c));
        return 1;
    }
    printf("pulled: %.6f beyond, taut %d, stopped short: %s\n",
           sqrt(pull.x * pull.x + pull.y * pull.y + pull.z * pull.z), taut,
           tractrix_client_pull_stop(c) == TRACTRIX_PULL_STOP_TAUT ? "taut" : "other");
    /* A refusal comes back as the service's status, with its reason. */
    tractrix_Vec3 nan_target = {NAN, 0.0, 0.0};
    rc = tractrix_client_move(c, rope, TRACTRIX_JOINT_HEAD, nan_target, joints, 64, &n);
    printf("refused: %d %s\n", rc, tractrix_client_error(c));
    /* Too small a buffer: the count needed. */
    rc = tractrix_client_query(c, rope, joints, 4, &n);
    printf("small buffer: %d, needs %zu\n", rc, n);
    /* The general call: a query with its full response header. */
    tractrix_RequestHeader q;
    memset(&q, 0, sizeof q);
    q.command = TRACTRIX_CMD_QUERY;
    q.chain = rope;
    tractrix_ResponseHeader r;
    rc = tractrix_client_call(c, &q, NULL, 0, &r, joints, 64);
    if (rc != 0) { fprintf(stderr, "query: %s\n", tractrix_client_error(c)); return 1; }
    n = r.n_joints;
    printf("query: state %" PRIu64 ", %u held\n", r.sequence, r.n_held);
    uint64_t last = 0;
    int states = 0;
    while (tractrix_stream_next(stream, on_state, &last) == 1) states++;
    printf("streamed %d states, the last %" PRIu64 "\n", states, last);
    tractrix_stream_close(stream);
    /* The arm's head at (1.1, 0.8) with its last link pointing down (Korein & Badler's orientation goal). */
    uint32_t arm;
    tractrix_Vec3 arm_joints[16];
    size_t na = 0;
    tractrix_Vec3 at = {1.1, 0.8, 0.0}, down = {0.0, -1.0, 0.0};
    if (tractrix_client_find_chain(c, "arm", &arm) != 0 ||
        tractrix_client_reach_goal(c, arm, TRACTRIX_FLAG_ORIENT, at, down, arm_joints, 16, &na, NULL) != 0) {
        fprintf(stderr, "reach goal: %s\n", tractrix_client_error(c));
        return 1;
    }
    printf("arm pose: last link %.6f %.6f\n", arm_joints[na - 1].x - arm_joints[na - 2].x,
           arm_joints[na - 1].y - arm_joints[na - 2].y);
    /* The snake's head along a smooth curve through two key points (C2, not two straight segments). */
    uint32_t snake;
    tractrix_Vec3 snake_joints[256];
    size_t ns = 0;
    tractrix_Vec3 keys[2] = {{1.0, -49.0, 1.0}, {2.0, -47.0, 1.5}};
    if (tractrix_client_find_chain(c, "snake", &snake) != 0 ||
        tractrix_client_path_smooth(c, snake, TRACTRIX_JOINT_HEAD, keys, 2, snake_joints, 256, &ns) != 0) {
        fprintf(stderr, "smooth path: %s\n", tractrix_client_error(c));
        return 1;
    }
    printf("smooth path: head %.6f %.6f %.6f\n", snake_joints[ns - 1].x, snake_joints[ns - 1].y,
           snake_joints[ns - 1].z);
    for (size_t i = 0; i < n; i++)
        printf("joint %zu %016" PRIx64 " %016" PRIx64 " %016" PRIx64 "\n", i, bits(joints[i].x),
               bits(joints[i].y), bits(joints[i].z));
    tractrix_client_close(c);
    return 0;
}
