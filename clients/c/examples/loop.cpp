// A haptic loop in C++: moves the rope's head around a circle at RATE Hz (0: back to back) for N moves
// and reports the round trip's percentiles and the proxy's lag (how far the head stayed behind its
// target: a move that cannot be finished inside the service's frame stops short, and the next goes on
// from there). Usage: loop PREFIX [N] [RATE]. Prints the last joints' bits for checking.
#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <vector>

#include "tractrix_client.hpp"

static uint64_t bits(double x) { uint64_t b; std::memcpy(&b, &x, sizeof b); return b; }

int main(int argc, char **argv) {
    const char *prefix = argc > 1 ? argv[1] : nullptr;
    const int n = argc > 2 ? std::atoi(argv[2]) : 1000;
    const double rate = argc > 3 ? std::atof(argv[3]) : 1000.0;
    try {
        tractrix::Client client(prefix);
        const uint32_t rope = client.chain("rope");
        std::vector<tractrix_Vec3> joints = client.query(rope);
        // The same motion as `latency client`: the head around a circle of radius 0.5 through where it
        // starts, 200 moves per turn; the first tenth of the moves warms up and is not counted.
        const tractrix_Vec3 start_head = joints.back();
        const int warmup = n / 10;
        std::vector<double> rtt_us, lag;
        rtt_us.reserve(n);
        lag.reserve(n);
        using clock = std::chrono::steady_clock;
        const auto start = clock::now();
        const auto period = std::chrono::duration<double>(rate > 0 ? 1.0 / rate : 0.0);
        for (int i = 0; i < warmup + n; i++) {
            if (rate > 0) std::this_thread::sleep_until(start + std::chrono::duration_cast<clock::duration>(period * i));
            const double a = 2.0 * M_PI * (i % 200) / 200.0;
            const tractrix_Vec3 target = {start_head.x + 0.5 * (std::cos(a) - 1.0), start_head.y + 0.5 * std::sin(a),
                                          start_head.z};
            const auto t0 = clock::now();
            client.move(rope, TRACTRIX_JOINT_HEAD, target, joints);
            const double us = std::chrono::duration<double, std::micro>(clock::now() - t0).count();
            const tractrix_Vec3 head = joints.back();
            const double behind = std::sqrt((head.x - target.x) * (head.x - target.x) +
                                            (head.y - target.y) * (head.y - target.y) +
                                            (head.z - target.z) * (head.z - target.z));
            if (i >= warmup) {
                rtt_us.push_back(us);
                lag.push_back(behind);
            }
        }
        std::sort(lag.begin(), lag.end());
        std::sort(rtt_us.begin(), rtt_us.end());
        auto pct = [&](double p) { return rtt_us[static_cast<size_t>(p * (rtt_us.size() - 1))]; };
        std::printf("%d moves at %.0f Hz: round trip p50 %.1f us, p99 %.1f us, max %.1f us\n", n, rate, pct(0.5),
                    pct(0.99), rtt_us.back());
        std::printf("the head behind its target: p50 %.3g, p99 %.3g, max %.3g\n", lag[lag.size() / 2],
                    lag[static_cast<size_t>(0.99 * (lag.size() - 1))], lag.back());
        for (size_t i = 0; i < joints.size(); i++)
            std::printf("joint %zu %016" PRIx64 " %016" PRIx64 " %016" PRIx64 "\n", i, bits(joints[i].x),
                        bits(joints[i].y), bits(joints[i].z));
    } catch (const tractrix::Error &e) {
        std::fprintf(stderr, "tractrix error %d: %s\n", e.code, e.what());
        return 1;
    }
    return 0;
}
