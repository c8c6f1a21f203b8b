/* The smallest C program: move the rope's head and print where it is. Usage: hello [PREFIX] */
#include <stdio.h>

#include "tractrix_client.h"

int main(int argc, char **argv) {
    tractrix_client *client;
    if (tractrix_client_open(argc > 1 ? argv[1] : NULL, TRACTRIX_WAIT_HYBRID, 5.0, 5.0, &client) != 0) {
        fprintf(stderr, "%s\n", tractrix_last_open_error());
        return 1;
    }
    uint32_t rope;
    tractrix_Vec3 joints[64];
    size_t n = 0;
    tractrix_Vec3 target = {38.0, 5.0, 1.0};
    if (tractrix_client_find_chain(client, "rope", &rope) != 0 ||
        tractrix_client_move(client, rope, TRACTRIX_JOINT_HEAD, target, joints, 64, &n) != 0) {
        fprintf(stderr, "%s\n", tractrix_client_error(client));
        tractrix_client_close(client);
        return 1;
    }
    printf("head at %g %g %g, %zu joints\n", joints[n - 1].x, joints[n - 1].y, joints[n - 1].z, n);
    tractrix_client_close(client);
    return 0;
}
