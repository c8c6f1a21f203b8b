/* A haptic stylus on a needle driver, from C: on stitch.toml's `needle-drive-80` (its needle of radius 1
 * laid curving down, its point 0.05 above the tissue), the stylus turns the needle round its own circle,
 * a pose per step (tractrix_client_needle_pose), through the tissue and out: its point cuts the two holes
 * the suture then threads. Then one driven step (tractrix_client_needle_drive).
 * Usage: needle PREFIX (a service on solver-service/scenes/stitch.toml). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "tractrix_client.h"

/* The rotation vector (axis x angle) of a turn by `phi` about +y after a quarter turn about -x: the
 * needle's frame (it leaves the swage along +x, curving toward +y) laid in the plane y = 0, leaving along
 * (sin t, 0, -cos t) and curving toward (-cos t, 0, -sin t) at the angle t = 90 deg - phi of its circle. */
static tractrix_Vec3 turned(double phi) {
    double c = sqrt(0.5), s = sqrt(0.5); /* the quarter turn about -x: (w, x) = (cos 45, -sin 45) */
    double w = c * cos(phi / 2);
    double x = -s * cos(phi / 2), y = c * sin(phi / 2), z = s * sin(phi / 2);
    double v = sqrt(x * x + y * y + z * z);
    double angle = 2.0 * atan2(v, w);
    tractrix_Vec3 r = {x / v * angle, y / v * angle, z / v * angle};
    return r;
}

int main(int argc, char **argv) {
    tractrix_client *c = NULL;
    if (tractrix_client_open(argc > 1 ? argv[1] : NULL, TRACTRIX_WAIT_HYBRID, 5.0, 5.0, &c) != 0) {
        fprintf(stderr, "open: %s\n", tractrix_last_open_error());
        return 1;
    }
    uint32_t suture;
    if (tractrix_client_find_chain(c, "needle-drive-80", &suture) != 0) {
        fprintf(stderr, "find: %s\n", tractrix_client_error(c));
        return 1;
    }
    tractrix_Vec3 joints[128];
    size_t n = 0;
    /* The needle's circle: centre (50, 0, 0.55), radius 1, in y = 0; the swage starts at its top. */
    const double pi = acos(-1.0);
    int steps = 90, refused = 0;
    for (int k = 0; k <= steps; k++) {
        double phi = (250.0 * pi / 180.0) * k / steps, t = pi / 2 - phi;
        tractrix_Vec3 swage = {50.0 + cos(t), 0.0, 0.55 + sin(t)};
        if (tractrix_client_needle_pose(c, suture, swage, turned(phi), joints, 128, &n) != 0) {
            refused++;
            fprintf(stderr, "pose %d: %s\n", k, tractrix_client_error(c));
        }
    }
    printf("posed: %d poses, %d refused, head %.6f %.6f %.6f\n", steps + 1, refused, joints[n - 1].x,
           joints[n - 1].y, joints[n - 1].z);
    /* One more step along the circle, driven. */
    double t = pi / 2 - 255.0 * pi / 180.0;
    tractrix_Vec3 next = {50.0 + cos(t), 0.0, 0.55 + sin(t)};
    int rc = tractrix_client_needle_drive(c, suture, next, joints, 128, &n);
    if (rc != 0) { fprintf(stderr, "drive: %d %s\n", rc, tractrix_client_error(c)); return 1; }
    printf("driven: head %.6f %.6f %.6f\n", joints[n - 1].x, joints[n - 1].y, joints[n - 1].z);
    /* The eyelets: the response header's count (their points and threads follow the joints). */
    tractrix_RequestHeader q;
    memset(&q, 0, sizeof q);
    q.command = TRACTRIX_CMD_QUERY;
    q.chain = suture;
    tractrix_ResponseHeader r;
    tractrix_Vec3 all[256];
    if (tractrix_client_call(c, &q, NULL, 0, &r, all, 256) != 0) {
        fprintf(stderr, "query: %s\n", tractrix_client_error(c));
        return 1;
    }
    printf("eyelets: %u\n", r.n_eyelets);
    tractrix_client_close(c);
    return 0;
}
