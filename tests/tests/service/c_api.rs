//! The C library (issue 17): a C program and a C++ program, compiled here against
//! `tractrix_client.h` and linked with `libtractrix_client` (shared for C, static for C++), move the
//! rope of a running service and read its joints; the joints they print are bit for bit those a Rust
//! client reads. Refusals come back as the service's status with its reason; a buffer too small says
//! how many joints are needed.

use shared::{Command, RequestHeader};
use std::path::{Path, PathBuf};
use std::process::Command as Process;
use tests::{Service, bin, unique_prefix};

/// The directory of the binaries (and of the C library, built there if missing).
pub(crate) fn lib_dir() -> PathBuf {
    let dir = bin("solver-service")
        .parent()
        .expect("target dir")
        .to_path_buf();
    if !dir.join("libtractrix_client.so").exists() {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Process::new(cargo)
            // Every library of the workspace, as scripts/test.sh builds them: `-p tractrix-client` alone
            // resolves other features for the dependencies and builds them again.
            .args(["build", "--lib", "--profile", "test"])
            .status()
            .expect("run cargo build");
        assert!(status.success(), "building the C library failed");
    }
    assert!(dir.join("libtractrix_client.so").exists());
    dir
}

/// A fresh directory for the programs a test compiles and runs: under the build's scratch directory
/// (`target/tmp`, on the checkout's disk), not under `/tmp`, which a machine may mount `noexec`.
pub(crate) fn program_dir() -> tempfile::TempDir {
    let scratch = Path::new(env!("CARGO_TARGET_TMPDIR"));
    std::fs::create_dir_all(scratch).expect("create target/tmp");
    tempfile::tempdir_in(scratch).expect("a directory in target/tmp")
}

/// What a failed run of the program at `exe` needs to be understood: its mode and size, and the mount
/// options of its file system (an `exec` refused with "Permission denied" was seen once on CI).
pub(crate) fn describe_program(exe: &Path) -> String {
    use std::os::unix::fs::PermissionsExt;
    let file = match std::fs::metadata(exe) {
        Ok(m) => format!("mode {:o}, {} bytes", m.permissions().mode(), m.len()),
        Err(e) => format!("no file ({e})"),
    };
    let mount = Process::new("findmnt")
        .args(["-n", "-o", "TARGET,FSTYPE,OPTIONS", "-T"])
        .arg(exe.parent().unwrap_or(exe))
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|e| format!("findmnt: {e}"));
    format!("{}: {file}; mounted {mount}", exe.display())
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Runs `compiler` with `args`, under the umask 022: iceoryx2 0.10 sets the process's umask while it
/// binds a socket (`UnixDatagramSocket::bind`), so a compiler spawned by one test thread while another
/// connects inherits an owner-only umask, and the linker writes the program without its execute bits
/// ("Permission denied" running it; seen on a loaded CI runner).
fn compile(compiler: &str, args: &[&str]) {
    let out = Process::new("sh")
        .args(["-c", "umask 022; exec \"$0\" \"$@\"", compiler])
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("run {compiler}: {e}"));
    assert!(
        out.status.success(),
        "{compiler} {args:?}:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Compiles with every warning an error: `cc` as C11, `c++` as C++17 with the examples' folder on the
/// include path too; `rest` is the sources, libraries and output.
fn compile_strict(compiler: &str, include: &str, examples: &std::path::Path, rest: &[&str]) {
    let ex = examples.display().to_string();
    let mut args = vec!["-Wall", "-Wextra", "-Werror", "-I", include];
    if compiler == "cc" {
        args.insert(0, "-std=c11");
    } else {
        args.insert(0, "-std=c++17");
        args.extend(["-I", ex.as_str()]);
    }
    args.extend_from_slice(rest);
    compile(compiler, &args);
}

/// Compiles `clients/c/examples/NAME.c` strictly against the shared library into `dir`; its path.
fn compile_c_example(name: &str, dir: &Path) -> String {
    let lib_s = lib_dir().display().to_string();
    let include = root().join("shared/include").display().to_string();
    let examples = root().join("clients/c/examples");
    let exe = dir.join(name).display().to_string();
    compile_strict(
        "cc",
        &include,
        &examples,
        &[
            examples.join(format!("{name}.c")).to_str().unwrap(),
            "-L",
            &lib_s,
            "-ltractrix_client",
            &format!("-Wl,-rpath,{lib_s}"),
            "-lm",
            "-o",
            &exe,
        ],
    );
    exe
}

/// The joints a program printed as `joint I XBITS YBITS ZBITS`.
fn printed_joints(text: &str) -> Vec<[u64; 3]> {
    text.lines()
        .filter_map(|l| l.strip_prefix("joint "))
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(w.len(), 4, "{l}");
            let b = |s: &str| u64::from_str_radix(s, 16).unwrap();
            [b(w[1]), b(w[2]), b(w[3])]
        })
        .collect()
}

fn rust_joints(svc: &Service) -> Vec<[u64; 3]> {
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    q.joints()
        .iter()
        .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
        .collect()
}

#[test]
fn c_and_cpp_programs_move_the_rope_and_read_the_same_joints() {
    let lib = lib_dir();
    let lib_s = lib.display().to_string();
    let include = root().join("shared/include").display().to_string();
    let examples = root().join("clients/c/examples");
    let dir = program_dir();
    let c_exe = compile_c_example("move", dir.path());
    let cpp_exe = dir.path().join("loop").display().to_string();
    compile_strict(
        "c++",
        &include,
        &examples,
        &[
            examples.join("loop.cpp").to_str().unwrap(),
            &format!("{lib_s}/libtractrix_client.a"),
            "-lpthread",
            "-ldl",
            "-lm",
            "-o",
            &cpp_exe,
        ],
    );

    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let out = Process::new(&c_exe).arg(&svc.prefix).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("described: rope, 40 links, length 40.0"),
        "{text}"
    );
    assert!(text.contains("held path: tail 0.0 0.0 0.0"), "{text}");
    assert!(
        text.contains("moved: 41 joints, head 38.000000 5.000000 1.000000"),
        "{text}"
    );
    // Both ends held, the head pulled to 42 from the tail along the line through them (the target
    // computed by the program): the head's pull is the 2 it could not go, and the rope is taut.
    assert!(
        text.contains("pulled: 2.000000 beyond, taut 1, stopped short: taut"),
        "{text}"
    );
    // grasp, path, release, move, two grasps, the pull, two releases: nine states, all on the
    // stream, in order.
    assert!(text.contains("query: state 9, 0 held"), "{text}");
    assert!(text.contains("streamed 9 states, the last 9"), "{text}");
    // A NaN target: the service's status (non-finite = 4) and its reason.
    assert!(text.contains("refused: 4 non-finite:"), "{text}");
    assert!(text.contains("small buffer: -7, needs 41"), "{text}");
    assert!(
        text.contains("arm pose: last link 0.000000 -0.200000"),
        "{text}"
    );
    assert!(
        text.contains("smooth path: head 2.000000 -47.000000 1.500000"),
        "{text}"
    );
    let c_joints = printed_joints(&text);
    assert_eq!(c_joints.len(), 41);
    assert_eq!(c_joints, rust_joints(&svc), "C read other joints than Rust");

    let out = Process::new(&cpp_exe)
        .args([svc.prefix.as_str(), "300", "1000"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{}", text.lines().next().unwrap_or(""));
    assert!(
        text.contains("300 moves at 1000 Hz: round trip p50"),
        "{text}"
    );
    assert_eq!(
        printed_joints(&text),
        rust_joints(&svc),
        "C++ read other joints than Rust"
    );

    // No service: a clear error, not a hang or a crash.
    let out = Process::new(&c_exe).arg(unique_prefix()).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("open: no solver-service runs with prefix"),
        "{err}"
    );
}

/// A C program drives a needle as a haptic stylus would (`clients/c/examples/needle.c` on
/// `stitch.toml`'s `needle-drive-80`): 91 poses round the needle's own circle through the tissue
/// (`tractrix_client_needle_pose`), then one driven step (`tractrix_client_needle_drive`). Every request
/// accepted, the head where the last step put it (computed here: the circle's point 255° on from its
/// top), and two eyelets, the holes the needle's point cut.
#[test]
fn a_c_program_poses_and_drives_the_needle() {
    let dir = program_dir();
    let exe = compile_c_example("needle", dir.path());
    let svc = super::stitch::stitch_service(&[]);
    let out = Process::new(&exe).arg(&svc.prefix).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("posed: 91 poses, 0 refused"), "{text}");
    let t = (90.0f64 - 255.0).to_radians();
    let want = format!(
        "driven: head {:.6} {:.6} {:.6}",
        50.0 + t.cos(),
        0.0,
        0.55 + t.sin()
    );
    assert!(text.contains(&want), "{text} (want {want})");
    assert!(text.contains("eyelets: 2"), "{text}");
}

/// A C# program (P/Invoke, as a Unity script would call the library), compiled with Mono's `mcs` and
/// run with `mono` (`scripts/system-packages.sh` installs both), moves the rope and reads the same joints as Rust.
#[test]
fn a_csharp_program_moves_the_rope_through_p_invoke() {
    if !tests::system_packages("the C# example", &["mcs", "mono"]) {
        return;
    }
    let lib = lib_dir();
    let dir = program_dir();
    let exe = dir.path().join("move.exe").display().to_string();
    compile(
        "mcs",
        &[
            &format!("-out:{exe}"),
            root().join("clients/c/examples/Move.cs").to_str().unwrap(),
        ],
    );
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let out = Process::new("mono")
        .arg(&exe)
        .arg(&svc.prefix)
        .env("LD_LIBRARY_PATH", &lib)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("moved: 41 joints, head 37.000000 6.000000 0.500000"),
        "{text}"
    );
    assert!(text.contains("refused: 4 non-finite:"), "{text}");
    assert_eq!(
        printed_joints(&text),
        rust_joints(&svc),
        "C# read other joints than Rust"
    );
}

/// The README's smallest program in each language (C, C++, C#, Python, Rust; each under 40 lines) moves
/// the rope's head to the same point and prints it.
#[test]
fn every_language_s_smallest_program_moves_the_rope() {
    let lib = lib_dir();
    let lib_s = lib.display().to_string();
    let include = root().join("shared/include").display().to_string();
    let examples = root().join("clients/c/examples");
    let dir = program_dir();
    let exe = |n: &str| dir.path().join(n).display().to_string();
    compile_strict(
        "cc",
        &include,
        &examples,
        &[
            examples.join("hello.c").to_str().unwrap(),
            "-L",
            &lib_s,
            "-ltractrix_client",
            &format!("-Wl,-rpath,{lib_s}"),
            "-o",
            &exe("hello_c"),
        ],
    );
    compile_strict(
        "c++",
        &include,
        &examples,
        &[
            examples.join("hello.cpp").to_str().unwrap(),
            "-L",
            &lib_s,
            "-ltractrix_client",
            &format!("-Wl,-rpath,{lib_s}"),
            "-o",
            &exe("hello_cpp"),
        ],
    );
    let csharp = tests::system_packages("the C# hello", &["mcs", "mono"]);
    if csharp {
        compile(
            "mcs",
            &[
                &format!("-out:{}", exe("hello.exe")),
                examples.join("Hello.cs").to_str().unwrap(),
            ],
        );
    }
    let rust = {
        let p = lib.join("examples/hello");
        if !p.exists() {
            tests::cargo_build(&["--example", "hello", "--profile", "test"]);
        }
        p.display().to_string()
    };
    let python = root().join("target/pyenv/bin/python").display().to_string();
    let hello_py = root()
        .join("clients/python/examples/hello.py")
        .display()
        .to_string();

    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let runs: Vec<(&str, Vec<String>)> = vec![
        ("C", vec![exe("hello_c")]),
        ("C++", vec![exe("hello_cpp")]),
        ("C#", vec!["mono".into(), exe("hello.exe")]),
        ("Python", vec![python, hello_py]),
        ("Rust", vec![rust]),
    ];
    let runs: Vec<_> = runs
        .into_iter()
        .filter(|(l, _)| csharp || *l != "C#")
        .collect();
    for (lang, cmd) in runs {
        let out = Process::new(&cmd[0])
            .args(&cmd[1..])
            .arg(&svc.prefix)
            .env("LD_LIBRARY_PATH", &lib)
            .output()
            .unwrap_or_else(|e| panic!("{lang}: {e}"));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{lang}: {text}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(text.trim(), "head at 38 5 1, 41 joints", "{lang}");
    }
}
