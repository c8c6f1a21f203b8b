//! `shared/include/tractrix.h`, the C header other languages start from, checked against the Rust
//! types with the machine's C compiler (and its C++ compiler when there is one):
//!
//! * a translation unit that includes the header and asserts, with `_Static_assert`, every size,
//!   alignment, field offset and field size, every constant and every enumeration value, generated
//!   here from the Rust definitions (`shared::WIRE_TYPES`, `Status::ALL`, `Command::ALL`);
//! * a C program that fills a request header field by field and prints its bytes, compared with the
//!   bytes of the same Rust value.

use shared::{ChainKind, Command, RequestHeader, Status, WIRE_TYPES};
use std::path::{Path, PathBuf};
use std::process::Command as Process;

fn header_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("include")
}

/// The size in bytes of a C type of the layout table (`uint32_t`, `double`, `uint8_t[32]` ...).
fn c_size(c: &str) -> usize {
    let (base, n) = match c.split_once('[') {
        Some((b, n)) => (b, n.trim_end_matches(']').parse::<usize>().unwrap()),
        None => (c, 1),
    };
    n * match base {
        "uint8_t" => 1,
        "uint32_t" => 4,
        "uint64_t" | "double" => 8,
        other => panic!("unknown C type {other}"),
    }
}

fn assertions() -> String {
    let mut s = String::from("#include \"tractrix.h\"\n");
    let mut check =
        |cond: String| s.push_str(&format!("TRACTRIX_STATIC_ASSERT({cond}, \"{cond}\");\n"));
    for t in WIRE_TYPES {
        let c = format!("tractrix_{}", t.name);
        check(format!("sizeof({c}) == {}", t.size));
        check(format!("alignof({c}) == {}", t.align));
        for f in t.fields {
            check(format!("offsetof({c}, {}) == {}", f.name, f.offset));
            check(format!(
                "sizeof((({c} *)0)->{}) == {}",
                f.name,
                c_size(f.c_type)
            ));
        }
        check(format!(
            "sizeof(TRACTRIX_TYPE_NAME_{}) == {}",
            t.name.to_uppercase(),
            t.type_name.len() + 1
        ));
    }
    for st in Status::ALL {
        let name = st.name().to_uppercase().replace('-', "_");
        check(format!("TRACTRIX_{name} == {}", st as u32));
    }
    for cmd in Command::ALL {
        check(format!(
            "TRACTRIX_CMD_{} == {}",
            cmd.name().to_uppercase(),
            cmd as u32
        ));
    }
    for kind in ChainKind::ALL {
        let name = match kind {
            ChainKind::Free => "FREE",
            ChainKind::FixedBase => "FIXED_BASE",
            ChainKind::Bundle => "BUNDLE",
        };
        check(format!("TRACTRIX_KIND_{name} == {}", kind as u32));
    }
    for (name, v) in [
        ("PROTOCOL_VERSION", u64::from(shared::PROTOCOL_VERSION)),
        ("MAX_LINKS", u64::from(shared::MAX_LINKS)),
        (
            "MAX_RESPONSE_ELEMENTS",
            u64::from(shared::MAX_RESPONSE_ELEMENTS),
        ),
        ("MAX_PATH_POINTS", u64::from(shared::MAX_PATH_POINTS)),
        ("MAX_HELD", u64::from(shared::MAX_HELD)),
        (
            "MAX_GRASPS_PER_CLIENT",
            u64::from(shared::MAX_GRASPS_PER_CLIENT),
        ),
        ("MAX_INSTRUMENTS", u64::from(shared::MAX_INSTRUMENTS)),
        ("MAX_EYELETS", u64::from(shared::MAX_EYELETS)),
        ("EYELET_ELEMENTS", u64::from(shared::EYELET_ELEMENTS)),
        ("TISSUE_ELEMENTS", u64::from(shared::TISSUE_ELEMENTS)),
        (
            "INSTRUMENT_ELEMENTS",
            u64::from(shared::INSTRUMENT_ELEMENTS),
        ),
        ("MAX_CHAINS", u64::from(shared::MAX_CHAINS)),
        ("NAME_LEN", shared::NAME_LEN as u64),
        ("REASON_LEN", shared::REASON_LEN as u64),
        ("JOINT_HEAD", u64::from(shared::JOINT_HEAD)),
        ("FLAG_ANGLES", u64::from(shared::FLAG_ANGLES)),
        ("FLAG_POSE", u64::from(shared::FLAG_POSE)),
        ("FLAG_TAKE_OVER", u64::from(shared::FLAG_TAKE_OVER)),
        ("FLAG_ORIENT", u64::from(shared::FLAG_ORIENT)),
        ("FLAG_IN_BOX", u64::from(shared::FLAG_IN_BOX)),
        ("FLAG_IN_BALL", u64::from(shared::FLAG_IN_BALL)),
        ("FLAG_SMOOTH", u64::from(shared::FLAG_SMOOTH)),
        ("FLAG_PULL", u64::from(shared::FLAG_PULL)),
        ("FLAG_DRIVE", u64::from(shared::FLAG_DRIVE)),
        ("MAX_BUNDLE_JOINTS", u64::from(shared::MAX_BUNDLE_JOINTS)),
        ("MAX_BUNDLE_STRANDS", u64::from(shared::MAX_BUNDLE_STRANDS)),
        ("BUNDLE_STATE_BUFFER", shared::BUNDLE_STATE_BUFFER as u64),
        (
            "MAX_BUNDLE_SUBSCRIBERS",
            shared::MAX_BUNDLE_SUBSCRIBERS as u64,
        ),
        ("COLLISION_SELF", u64::from(shared::COLLISION_SELF)),
        (
            "COLLISION_OBSTACLES",
            u64::from(shared::COLLISION_OBSTACLES),
        ),
        (
            "COLLISION_PAPER_SPHERES",
            u64::from(shared::COLLISION_PAPER_SPHERES),
        ),
        ("LIMITS_NONE", u64::from(shared::LIMITS_NONE)),
        ("LIMITS_BEND_RADIUS", u64::from(shared::LIMITS_BEND_RADIUS)),
        ("LIMITS_CONE", u64::from(shared::LIMITS_CONE)),
        ("LIMITS_CONES", u64::from(shared::LIMITS_CONES)),
        ("LIMITS_RANGES", u64::from(shared::LIMITS_RANGES)),
        ("KNOT_NOT_ASKED", u64::from(shared::KNOT_NOT_ASKED)),
        ("KNOT_UNKNOT", u64::from(shared::KNOT_UNKNOT)),
        ("KNOT_TREFOIL", u64::from(shared::KNOT_TREFOIL)),
        ("KNOT_SQUARE", u64::from(shared::KNOT_SQUARE)),
        ("KNOT_GRANNY", u64::from(shared::KNOT_GRANNY)),
        (
            "KNOT_DOUBLE_OVERHAND",
            u64::from(shared::KNOT_DOUBLE_OVERHAND),
        ),
        ("KNOT_SURGEONS", u64::from(shared::KNOT_SURGEONS)),
        ("KNOT_OTHER", u64::from(shared::KNOT_OTHER)),
    ] {
        check(format!("TRACTRIX_{name} == {v}u"));
    }
    s
}

fn compile(compiler: &str, args: &[&str], src: &Path, out: &Path) {
    let o = Process::new(compiler)
        .args(args)
        .arg("-I")
        .arg(header_dir())
        .arg(src)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap_or_else(|e| panic!("run {compiler}: {e}"));
    assert!(
        o.status.success(),
        "{compiler} {args:?} {}:\n{}",
        src.display(),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn the_c_header_matches_the_rust_types() {
    let dir = tempfile::tempdir().unwrap();
    let c = dir.path().join("asserts.c");
    std::fs::write(&c, format!("#include <stdalign.h>\n{}", assertions())).unwrap();
    compile(
        "cc",
        &["-std=c11", "-Wall", "-Wextra", "-Werror", "-c"],
        &c,
        &dir.path().join("asserts.o"),
    );
    // C++ users include the same header.
    if Process::new("c++").arg("--version").output().is_ok() {
        let cpp = dir.path().join("asserts.cpp");
        std::fs::write(&cpp, assertions()).unwrap();
        compile(
            "c++",
            &["-std=c++17", "-Wall", "-Wextra", "-Werror", "-c"],
            &cpp,
            &dir.path().join("asserts_cpp.o"),
        );
    }
}

#[test]
fn a_request_built_in_c_has_the_bytes_of_the_rust_one() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("bytes.c");
    std::fs::write(
        &src,
        r#"#include <stdio.h>
#include <string.h>
#include "tractrix.h"
int main(void) {
    tractrix_RequestHeader h;
    memset(&h, 0, sizeof h);
    h.command = TRACTRIX_CMD_PATH;
    h.chain = 7;
    h.joint = TRACTRIX_JOINT_HEAD;
    h.method = TRACTRIX_METHOD_PAPER;
    h.precision = TRACTRIX_PRECISION_F64;
    h.substep_mode = TRACTRIX_SUBSTEPS_MAX_STEP;
    h.substeps = 12;
    h.strategy = TRACTRIX_STRATEGY_TWO_LINK;
    h.max_iterations = 345;
    h.flags = TRACTRIX_FLAG_ANGLES;
    h.client_listener[0] = 0x0123456789abcdefull;
    h.client_listener[1] = 0xfedcba9876543210ull;
    h.request_id = 99;
    h.max_step = 0.25;
    h.tolerance = 1e-9;
    const unsigned char *p = (const unsigned char *)&h;
    for (size_t i = 0; i < sizeof h; i++) printf("%02x", p[i]);
    printf("\n");
    return 0;
}
"#,
    )
    .unwrap();
    let exe = dir.path().join("bytes");
    compile("cc", &["-std=c11", "-Wall", "-Werror"], &src, &exe);
    let out = Process::new(&exe).output().unwrap();
    assert!(out.status.success());
    let c_hex = String::from_utf8(out.stdout).unwrap();
    let mut h = RequestHeader::new(Command::Path, 7);
    h.method = shared::WireMethod::Paper as u32;
    h.precision = shared::Precision::F64 as u32;
    h.substep_mode = shared::SubstepMode::MaxStep as u32;
    h.substeps = 12;
    h.strategy = shared::WireStrategy::TractrixTwoLink as u32;
    h.max_iterations = 345;
    h.flags = shared::FLAG_ANGLES;
    h.client_listener = [0x0123456789abcdef, 0xfedcba9876543210];
    h.request_id = 99;
    h.max_step = 0.25;
    h.tolerance = 1e-9;
    let rust_hex: String = bytemuck::bytes_of(&h)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(c_hex.trim(), rust_hex);
}
