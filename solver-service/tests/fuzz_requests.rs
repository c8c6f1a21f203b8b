//! A proptest-driven fuzzer of the request handler ([`World::apply`], what the service runs on every
//! request it receives): sequences of requests whose header bytes are arbitrary or mutated from a valid
//! request field by field (NaN, ±inf, ±0, subnormals, 1e308, `u32::MAX`, random bits), with arbitrary
//! target points, against a scene holding every chain form (planar and spatial, f64 and f32, free and
//! fixed base, with and without collision, with anchors), grasps and releases among the requests.
//!
//! After every request: no panic; the response is well formed (an error carries no elements and says
//! why, a success as many elements as it announces); a refused request left every chain bit for bit as
//! it was and the sequence number unchanged; every joint of every chain is finite and every link keeps
//! its length.
//!
//! CI runs 64 cases from a fixed seed (`cargo test -p solver-service --test fuzz_requests`); a longer run
//! from a random seed:
//! `PROPTEST_CASES=5000 cargo test --release -p solver-service --test fuzz_requests`.
//! With `FUZZ_LIMITS=max` the scene's limits are at the largest a scene may declare (substeps 2²⁰,
//! reach iterations 100 000, collision passes 10 000) and the service's default budget bounds the work
//! instead: the long run of the README.

use proptest::prelude::*;
use shared::{Command, JOINT_HEAD, RequestHeader, Status, Vec3};
use solver_service::serve::respond;
use solver_service::service::Solver;
use world::World;
use world::owners::LOCAL;
use world::scene::parse_scene;

/// Every chain form, with small substep and iteration limits so that no request can take long.
const SCENE: &str = r#"
[[instrument]]
name = "probe"
shape = "sphere"
center = [1.0, 1.0, 0.0]
radius = 0.3

[[instrument]]
name = "jaws"
shape = "sphere"
center = [4.0, 0.0, 0.0]
radius = 0.2
follows = "head"

[[instrument]]
name = "rod"
shape = "capsule"
a = [2.0, -1.0, -1.0]
b = [2.0, -1.0, 1.0]
radius = 0.2

[[chain]]
name = "rope64"
links = 12
link_length = 1.0
max_substeps = 64

[[chain]]
name = "rope32"
links = 12
link_length = 0.5
anchors = [6]
precision = "f32"
method = "paper"
max_substeps = 64

[[chain]]
name = "planar"
space = "planar"
links = 8
link_length = 1.0
base = [0.0, 0.0]
axis = [0.0, 1.0]
max_step = 0.5
max_substeps = 64

[[chain]]
name = "planar32"
space = "planar"
precision = "f32"
links = 8
link_length = 0.25
base = [0.0, 0.0]
axis = [1.0, 0.0]
max_substeps = 64

[[chain]]
name = "knotted"
links = 16
link_length = 0.25
anchors = [0]
thickness = 0.2
collision = "capsules"
instruments = ["probe", "rod", "jaws"]
collision_iterations = 8
max_substeps = 64

[[chain]]
name = "spheres"
links = 12
link_length = 0.5
collision = "paper-spheres"
collision_iterations = 4
max_substeps = 64

[[chain]]
name = "arm"
kind = "fixed-base"
space = "planar"
links = 10
link_length = 0.2
base = [0.0, 0.0]
axis = [1.0, 0.0]
max_substeps = 4
max_iterations = 200

[[chain]]
name = "arm3"
kind = "fixed-base"
links = 6
link_length = 0.5
strategy = "two-link"
max_substeps = 4
max_iterations = 200
max_bend = 30
"#;

const N_CHAINS: u32 = 8;

/// The scene, with every limit at the largest a scene may declare if `max_limits`.
fn scene_text(max_limits: bool) -> String {
    if !max_limits {
        return SCENE.to_string();
    }
    SCENE
        .lines()
        .map(|l| {
            if l.starts_with("max_substeps") {
                format!("max_substeps = {}", world::scene::MAX_SUBSTEPS_LIMIT)
            } else if l.starts_with("max_iterations") {
                "max_iterations = 100000".to_string()
            } else if l.starts_with("collision_iterations") {
                "collision_iterations = 10000".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Floats a careless or hostile client sends, and arbitrary bit patterns.
fn float() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => -3.0..3.0f64,
        1 => -50.0..50.0f64,
        2 => prop::sample::select(vec![
            0.0, -0.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e308, -1e308, f64::MAX,
            f64::MIN_POSITIVE, 1e-310, -1e-310, 1e-12, 1e12, 0.5, 1.0,
        ]),
        1 => any::<u64>().prop_map(f64::from_bits),
    ]
}

/// Counts and indices: small and valid, boundaries, or anything.
fn small_u32(valid: u32) -> impl Strategy<Value = u32> {
    prop_oneof![
        4 => 0..=valid,
        1 => prop::sample::select(vec![valid + 1, 1000, 100_000, 100_001, u32::MAX - 1, u32::MAX]),
        1 => any::<u32>(),
    ]
}

fn point() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        // planar chains need z = 0
        3 => (float(), float()).prop_map(|(x, y)| Vec3::new(x, y, 0.0)),
        2 => (float(), float(), float()).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
    ]
}

/// A valid request, then zero to three of its fields (or one of its points) replaced by a hostile
/// value: most requests reach the kernel, and each check meets values just past its edge.
fn structured_request() -> impl Strategy<Value = (RequestHeader, Vec<Vec3>)> {
    let header = (
        (
            prop::sample::select(vec![1u32, 1, 1, 2, 2, 3, 3, 3, 4, 5, 6, 7, 8, 8, 9, 10, 10]),
            0..N_CHAINS,
            prop_oneof![3 => Just(JOINT_HEAD), 2 => 0..=16u32],
            0..=3u32,
            0..=2u32,
            1..=8u32,
            0.05..2.0f64,
        ),
        (
            0..=2u32,
            prop_oneof![1 => 1..=3u32, 2 => 0..=300u32],
            // No flag, the rotations, or a pull (`FLAG_PULL`: moves and instruments stop short).
            prop::sample::select(vec![0u32, 0, 1, shared::FLAG_PULL]),
            any::<u64>(),
            prop_oneof![Just(0.0), 1e-9..1e-2f64],
        ),
    )
        .prop_map(
            |(
                (command, chain, joint, method, substep_mode, substeps, max_step),
                (strategy, max_iterations, flags, request_id, tolerance),
            )| {
                // The command that fits the chain (chains 6 and 7 have a fixed base): mutations break
                // the fit, not the base request.
                let fixed = chain >= 6;
                let command = match Command::from_u32(command) {
                    Some(Command::Move | Command::Path) if fixed => Command::Reach as u32,
                    Some(Command::Reach) if !fixed => Command::Move as u32,
                    _ => command,
                };
                RequestHeader {
                    command,
                    chain,
                    joint,
                    method,
                    precision: 0,
                    substep_mode: if command == Command::Reach as u32 {
                        0
                    } else {
                        substep_mode
                    },
                    substeps: if fixed { substeps.min(4) } else { substeps },
                    strategy,
                    max_iterations,
                    flags,
                    client_listener: [0, 0],
                    request_id,
                    max_step,
                    tolerance,
                    reserved: [0, 0],
                }
            },
        );
    let points = prop::collection::vec(sane_point(), 1..=6);
    let mutation = || {
        (
            0..15usize,
            any::<u32>(),
            small_u32(16),
            float(),
            point(),
            any::<u64>(),
        )
    };
    let mutations = prop_oneof![
        3 => Just(vec![]),
        3 => prop::collection::vec(mutation(), 1..=1),
        1 => prop::collection::vec(mutation(), 2..=3),
    ];
    (header, points, mutations).prop_map(|(mut h, mut points, mutations)| {
        // As many points as the command takes.
        match Command::from_u32(h.command) {
            Some(Command::Path) => {}
            Some(Command::Move | Command::Reach) => points.truncate(1),
            Some(Command::Instrument) => points.truncate(2),
            _ => points.clear(),
        }
        for (field, word, small, x, p, bits) in mutations {
            let u = if word % 2 == 0 { word } else { small };
            match field {
                0 => h.command = u,
                1 => h.chain = u,
                2 => h.joint = u,
                3 => h.method = u,
                4 => h.precision = u,
                5 => h.substep_mode = u,
                6 => h.substeps = u,
                7 => h.strategy = u,
                8 => h.max_iterations = u,
                9 => h.flags = u,
                10 => h.max_step = x,
                11 => h.tolerance = x,
                12 => h.reserved[(word % 2) as usize] = bits,
                13 => points.resize([0, 2, 4097][word as usize % 3], p),
                _ => {
                    if points.is_empty() {
                        points.push(p);
                    } else {
                        let k = word as usize % points.len();
                        points[k] = p;
                    }
                }
            }
        }
        (h, points)
    })
}

/// Targets near the chains of the scene: planar ones (z = 0) half the time.
fn sane_point() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        1 => (-3.0..3.0f64, -3.0..3.0f64).prop_map(|(x, y)| Vec3::new(x, y, 0.0)),
        1 => (-15.0..15.0f64, -15.0..15.0f64, -5.0..5.0f64).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
    ]
}

/// Any 96 bytes, read as a header (what a peer with another layout would send).
fn raw_header() -> impl Strategy<Value = RequestHeader> {
    prop::collection::vec(any::<u8>(), size_of::<RequestHeader>())
        .prop_map(|bytes| bytemuck::pod_read_unaligned::<RequestHeader>(&bytes))
}

fn request() -> impl Strategy<Value = (RequestHeader, Vec<Vec3>)> {
    prop_oneof![
        8 => structured_request(),
        1 => (
            raw_header(),
            prop_oneof![
                3 => prop::collection::vec(point(), 0..=2),
                1 => prop::collection::vec(point(), 4090..=4100),
            ],
        ),
    ]
}

/// Every chain's joints as bits.
/// Every chain's joints and held joints, and its instruments' poses, as bits.
fn snapshot(set: &World) -> Vec<Vec<[u64; 3]>> {
    (0..set.len() as u32)
        .map(|c| {
            let mut v: Vec<[u64; 3]> = set
                .elements_with(c, false, true, true, (false, false))
                .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                .collect();
            let poses = set.instrument_poses(c);
            v.extend(poses.iter().flatten().map(|x| [x.to_bits(), 0, 0]));
            v
        })
        .collect()
}

fn check_invariants(set: &World) -> Result<(), TestCaseError> {
    for (c, spec) in set.specs().iter().enumerate() {
        let joints: Vec<Vec3> = set.elements_of(c as u32, false).map(Vec3::from).collect();
        prop_assert_eq!(joints.len(), spec.lengths.len() + 1);
        prop_assert!(
            joints.iter().all(|j| j.is_finite()),
            "chain {} has a non-finite joint",
            spec.name
        );
        // A length read back from two published positions is off by their rounding: a few ulps of the
        // chain's precision at each position's magnitude (positions are compensated prefix sums, the
        // link vectors keep their lengths to an ulp). The bound is that, not a fraction of the length
        // growing with the distance from the origin (issue 15).
        let eps = if spec.precision == world::scene::Precision::F32 {
            f64::from(f32::EPSILON)
        } else {
            f64::EPSILON
        };
        let norm = |v: &Vec3| (v.x * v.x + v.y * v.y + v.z * v.z).sqrt();
        for (k, w) in joints.windows(2).enumerate() {
            let d =
                ((w[1].x - w[0].x).powi(2) + (w[1].y - w[0].y).powi(2) + (w[1].z - w[0].z).powi(2))
                    .sqrt();
            let l = spec.lengths[k];
            let bound = 8.0 * eps * (norm(&w[0]) + norm(&w[1]) + l);
            prop_assert!(
                (d - l).abs() <= bound,
                "chain {} link {}: length {} instead of {} (off by {:e}, bound {:e})",
                spec.name,
                k,
                d,
                l,
                (d - l).abs(),
                bound
            );
        }
        if spec.dims == 2 {
            prop_assert!(
                joints.iter().all(|j| j.z == 0.0),
                "{} left its plane",
                spec.name
            );
        }
        // The serving loop's fast gather writes what the element iterator yields, bit for bit, for
        // every part a response may carry and for a payload cut short anywhere.
        let bits = |v: &[Vec3]| -> Vec<[u64; 3]> {
            v.iter()
                .map(|e| [e.x.to_bits(), e.y.to_bits(), e.z.to_bits()])
                .collect()
        };
        for parts in 0..16u32 {
            let (a, h, i, p) = (
                parts & 1 != 0,
                parts & 2 != 0,
                parts & 4 != 0,
                parts & 8 != 0,
            );
            let all: Vec<Vec3> = set
                .elements_with(c as u32, a, h, i, (p, false))
                .map(Vec3::from)
                .collect();
            for n in [all.len(), all.len() / 2, 1, 0] {
                let mut got = vec![Vec3::new(7.0, 7.0, 7.0)];
                set.elements_with(c as u32, a, h, i, (p, false))
                    .gather_into(&mut got, n);
                prop_assert_eq!(bits(&got[..1]), bits(&[Vec3::new(7.0, 7.0, 7.0)]));
                prop_assert_eq!(
                    bits(&got[1..]),
                    bits(&all[..n]),
                    "chain {}, parts {}, n {}",
                    spec.name,
                    parts,
                    n
                );
            }
        }
    }
    Ok(())
}

/// Requests per status over the whole run: a fuzzer whose requests all bounce off the first check
/// would test nothing, so the run must reach the kernel often and see (almost) every status.
#[derive(Default)]
struct Coverage {
    by_status: [u64; Status::ALL.len()],
    changed: u64,
    /// The most collision work the meter charged one request.
    metered: u64,
    /// Moves and poses answered stopped short inside their frame.
    short: u64,
}

fn run_case(
    requests: &[(RequestHeader, Vec<Vec3>)],
    cov: &mut Coverage,
) -> Result<(), TestCaseError> {
    let max_limits = std::env::var("FUZZ_LIMITS").is_ok_and(|v| v == "max");
    let scene = parse_scene(&scene_text(max_limits), "fuzz.toml").expect("fuzz scene");
    let mut set = World::new(&scene).expect("chain set");
    // A budget the fuzzer's own requests reach (long paths, many reach iterations), so the over-budget
    // refusal is exercised like every other; the scene's substep caps keep the rest under it. With the
    // limits at their maximum, the service's own default budget is what bounds the work.
    if !max_limits {
        set.set_budget(5_000);
    }
    let mut solver = Solver::new(set, None, std::time::Duration::ZERO);
    let mut elements = Vec::new();
    for (req, points) in requests {
        let before = snapshot(solver.set());
        let seq = solver.set().sequence();
        let (h, changed) = respond(&mut solver, LOCAL, req, points, &mut elements);
        let Some(status) = Status::from_u32(h.status) else {
            return Err(TestCaseError::fail(format!(
                "status {} is not a Status",
                h.status
            )));
        };
        cov.by_status[status as usize] += 1;
        cov.changed += u64::from(changed);
        // Collision work (detection, passes, re-solves) is metered by the kernel as it runs: never
        // more than the budget, accepted or refused.
        prop_assert!(
            solver.set().last_work() <= solver.set().budget(),
            "{} link-steps of collision work charged, budget {}",
            solver.set().last_work(),
            solver.set().budget()
        );
        cov.metered = cov.metered.max(solver.set().last_work());
        prop_assert_eq!(h.request_id, req.request_id);
        if status == Status::Ok {
            // Empty, but for a move or a pose that stopped short inside its frame: why
            // (`PullStop`).
            let moved = req.command == Command::Move as u32
                || req.command == Command::Path as u32
                || req.command == Command::Instrument as u32;
            cov.short += u64::from(h.pull_stop().is_some());
            prop_assert!(
                h.reason_str().is_empty() || (moved && h.pull_stop().is_some()),
                "an ok response's reason: {}",
                h.reason_str()
            );
            prop_assert_eq!(solver.set().sequence(), seq + u64::from(changed));
            if req.command != Command::Snapshot as u32 && req.command != Command::Describe as u32 {
                prop_assert_eq!(
                    elements.len(),
                    (h.n_joints + h.n_angles + h.n_held + 3 * h.n_instruments + h.n_pulls) as usize
                );
                prop_assert_eq!(h.n_pulls, h.n_held + h.n_instruments);
            }
            prop_assert!(
                elements.iter().all(|v| v.is_finite()),
                "a NaN would be published"
            );
            prop_assert!(h.residual.is_finite());
            // A move's residual is where its joint landed, as the response has it, from where it
            // was sent (the last point of a path).
            if req.command == Command::Move as u32 {
                let j = if req.joint == shared::JOINT_HEAD {
                    h.n_joints as usize - 1
                } else {
                    req.joint as usize
                };
                let (p, t) = (elements[j], points[points.len() - 1]);
                let d = ((p.x - t.x) * (p.x - t.x)
                    + (p.y - t.y) * (p.y - t.y)
                    + (p.z - t.z) * (p.z - t.z))
                    .sqrt();
                prop_assert!(
                    (h.residual - d).abs() <= 1e-12 * (1.0 + d),
                    "residual {} of a move whose joint {j} landed {d} from its target",
                    h.residual
                );
            }
        } else {
            prop_assert!(!changed);
            prop_assert_eq!(
                (h.n_joints, h.n_angles, h.n_held, h.n_instruments),
                (0, 0, 0, 0)
            );
            prop_assert!(elements.is_empty());
            prop_assert!(
                !h.reason_str().is_empty(),
                "status {:?} without a reason",
                status
            );
            prop_assert_eq!(solver.set().sequence(), seq);
            prop_assert!(
                snapshot(solver.set()) == before,
                "a refused request changed the state"
            );
        }
        check_invariants(solver.set())?;
    }
    Ok(())
}

#[test]
fn arbitrary_requests_never_break_the_state() {
    // CI runs the same 64 cases every time (a fixed seed); `PROPTEST_CASES=N` runs N cases from a
    // fresh random seed.
    let cases: Option<u32> = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok());
    let config = ProptestConfig {
        cases: cases.unwrap_or(64),
        failure_persistence: None,
        ..ProptestConfig::default()
    };
    let mut runner = if cases.is_some() {
        proptest::test_runner::TestRunner::new(config)
    } else {
        proptest::test_runner::TestRunner::new_with_rng(
            config,
            proptest::test_runner::TestRng::deterministic_rng(
                proptest::test_runner::RngAlgorithm::ChaCha,
            ),
        )
    };
    let cov = std::cell::RefCell::new(Coverage::default());
    let result = runner.run(&prop::collection::vec(request(), 1..40), |requests| {
        run_case(&requests, &mut cov.borrow_mut())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let cov = cov.into_inner();
    let total: u64 = cov.by_status.iter().sum();
    for s in Status::ALL {
        eprintln!("{:>20} {:>6}", s.name(), cov.by_status[s as usize]);
    }
    eprintln!("{:>20} {:>6} of {total}", "changed the state", cov.changed);
    eprintln!(
        "{:>20} {:>6} link-steps (most collision work charged one request)",
        "metered", cov.metered
    );
    // The run reached the kernel and changed chains often, and met every status a request can
    // cause (not PersistenceFailed and Internal, which need faults outside the handler; not Locked,
    // which a move that meets a lock no longer ends in: it stops short inside its frame, and those
    // are met).
    eprintln!("{:>20} {:>6}", "stopped short", cov.short);
    assert!(cov.short > 0, "no move stopped short");
    assert!(
        cov.changed * 10 >= total,
        "only {} of {total} requests changed a chain",
        cov.changed
    );
    for s in Status::ALL {
        if !matches!(
            s,
            Status::PersistenceFailed | Status::Internal | Status::Locked
        ) {
            assert!(cov.by_status[s as usize] > 0, "no request ended in {s:?}");
        }
    }
}
