// tractrix_client.hpp: a C++ RAII wrapper over tractrix_client.h (header only). Errors are exceptions
// carrying the return code and the message; the client closes itself.
#pragma once
#include <stdexcept>
#include <string>
#include <vector>

#include "tractrix_client.h"

namespace tractrix {

struct Error : std::runtime_error {
    int code;
    Error(int rc, const std::string &what) : std::runtime_error(what), code(rc) {}
};

class Client {
  public:
    explicit Client(const char *prefix = nullptr, int wait = TRACTRIX_WAIT_HYBRID, double connect_s = 5.0,
                    double call_s = 5.0) {
        int rc = tractrix_client_open(prefix, wait, connect_s, call_s, &c_);
        if (rc != 0) throw Error(rc, tractrix_last_open_error());
    }
    ~Client() { tractrix_client_close(c_); }
    Client(const Client &) = delete;
    Client &operator=(const Client &) = delete;

    uint32_t chain(const std::string &name) {
        uint32_t id = 0;
        check(tractrix_client_find_chain(c_, name.c_str(), &id));
        return id;
    }
    // Moves `joint` to `target`; the joints are written into `joints` (resized as needed, no
    // allocation once it has the chain's size).
    void move(uint32_t chain, uint32_t joint, tractrix_Vec3 target, std::vector<tractrix_Vec3> &joints) {
        size_t n = 0;
        joints.resize(joints.empty() ? 64 : joints.capacity());
        int rc = tractrix_client_move(c_, chain, joint, target, joints.data(), joints.size(), &n);
        if (rc == TRACTRIX_E_BUFFER) {
            joints.resize(n);
            rc = tractrix_client_query(c_, chain, joints.data(), joints.size(), &n);
        }
        check(rc);
        joints.resize(n);
    }
    std::vector<tractrix_Vec3> query(uint32_t chain) {
        std::vector<tractrix_Vec3> joints(64);
        size_t n = 0;
        int rc = tractrix_client_query(c_, chain, joints.data(), joints.size(), &n);
        if (rc == TRACTRIX_E_BUFFER) {
            joints.resize(n);
            rc = tractrix_client_query(c_, chain, joints.data(), joints.size(), &n);
        }
        check(rc);
        joints.resize(n);
        return joints;
    }
    void grasp(uint32_t chain, uint32_t joint) { check(tractrix_client_grasp(c_, chain, joint)); }
    void release(uint32_t chain, uint32_t joint) { check(tractrix_client_release(c_, chain, joint)); }
    void reset(uint32_t chain) { check(tractrix_client_reset(c_, chain)); }

  private:
    void check(int rc) {
        if (rc != 0) throw Error(rc, tractrix_client_error(c_));
    }
    tractrix_client *c_ = nullptr;
};

}  // namespace tractrix
