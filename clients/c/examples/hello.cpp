// The smallest C++ program: move the rope's head and print where it is. Usage: hello [PREFIX]
#include <cstdio>
#include <vector>

#include "tractrix_client.hpp"

int main(int argc, char **argv) {
    try {
        tractrix::Client client(argc > 1 ? argv[1] : nullptr);
        const uint32_t rope = client.chain("rope");
        std::vector<tractrix_Vec3> joints;
        client.move(rope, TRACTRIX_JOINT_HEAD, {38.0, 5.0, 1.0}, joints);
        const tractrix_Vec3 &head = joints.back();
        std::printf("head at %g %g %g, %zu joints\n", head.x, head.y, head.z, joints.size());
    } catch (const tractrix::Error &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 1;
    }
    return 0;
}
