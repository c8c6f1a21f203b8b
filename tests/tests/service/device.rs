//! A hand played as a haptic device (`hand run --device`, issue 68). What a device sends does not
//! depend on the machine's speed in these ways, so they are checked: every sample's target differs
//! from every other (the tremor never holds still, and nothing is sent again), the hand reports its
//! samples and its lag, the overhand is tied, and the recording replays bit for bit. How many samples
//! a slow answer skips does depend on the speed: only that the count is reported is checked.

use std::process::Command as Process;
use tests::{Service, bin, unique_prefix};

#[test]
fn a_device_hand_sends_each_target_once_and_its_recording_replays() {
    let svc = Service::start(
        &unique_prefix(),
        &[
            "--scene",
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../solver-service/scenes/knots.toml"
            ),
            "--no-persist",
        ],
    );
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("device-A.jsonl");
    let out = Process::new(bin("hand"))
        .arg("--prefix")
        .arg(&svc.prefix)
        .args(["run", "--builtin", "overhand", "--device", "--quiet"])
        .args(["--identify", "overhand", "--record"])
        .arg(&rec)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    let device = text
        .lines()
        .find(|l| l.contains(": device: "))
        .unwrap_or_else(|| panic!("no device line: {text}"));
    assert!(
        device.contains("skipped") && device.contains("lag"),
        "{device}"
    );
    assert!(text.contains("knot: trefoil"), "{text}");
    // Every move's target, from the recording (its JSON lines, read here: a move's line has no
    // `command`; the grasp and the release carry no target).
    let targets: Vec<[u64; 3]> = std::fs::read_to_string(&rec)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v["command"].is_null() || v["command"] == "move")
        .map(|v| {
            let t = v["target"].as_array().unwrap();
            [0, 1, 2].map(|i| t[i].as_f64().unwrap().to_bits())
        })
        .collect();
    assert!(targets.len() > 500, "{} samples", targets.len());
    let mut sorted = targets.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), targets.len(), "a target was sent twice");
    let replay = Process::new(bin("hand"))
        .arg("--prefix")
        .arg(&svc.prefix)
        .arg("replay")
        .arg(&rec)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&replay.stdout);
    assert!(replay.status.success(), "{text}");
    assert!(text.contains(": 0 differed"), "{text}");
}

/// Both hands of `square-held` on the 160-link `hands-160` as haptic devices (`--device`, 1 kHz),
/// inside the service's default frame (1 ms of work per request): the square knot tied, then pulled
/// tight by both hands as devices (each pull stops where the person feels the knot resist). Checked
/// by the test's own code: the knot's determinant is the square knot's (9) after the tie and after
/// the tightening, each strand alone (the rope cut at the stitch) is unknotted (determinant 1), and
/// the tightening drew the ends apart (by more than a rope's thickness, 0.2: under load a device
/// skips samples, its hand jumps further and the knot jams sooner).
#[test]
fn two_device_hands_tie_and_tighten_the_square_knot_at_160_links() {
    use shared::{Command, RequestHeader};
    let svc = Service::start(
        &unique_prefix(),
        &[
            "--scene",
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../solver-service/scenes/knots.toml"
            ),
            "--no-persist",
        ],
    );
    let chain = "hands-160";
    let hands = |args: &[&str]| {
        let spawn = |hand: &str| {
            Process::new(bin("hand"))
                .arg("--prefix")
                .arg(&svc.prefix)
                .args(["run", "--quiet", "--device", "--turn-timeout", "300"])
                .args(["--hand", hand, "--chain", chain])
                .args(args)
                .stdout(std::process::Stdio::piped())
                .spawn()
                .expect("spawn hand")
        };
        let (b, a) = (spawn("B"), spawn("A"));
        format!("{}{}", tests::hand_output(a), tests::hand_output(b))
    };
    let mut c = svc.connect();
    let id = c.require_chain(chain).unwrap();
    let joints = |c: &mut clients::Connection| -> Vec<[f64; 3]> {
        let q = c.call(RequestHeader::new(Command::Query, id), &[]).unwrap();
        q.joints().iter().map(|p| p.to_array()).collect()
    };
    let check = |js: &[[f64; 3]], when: &str| {
        let (det, views) = tests::knot_check::determinant(js);
        assert_eq!((det, views >= 2), (9, true), "{when}: not the square knot");
        let at = super::knots::stitch(&svc, id);
        let strands = (
            tests::knot_check::determinant(&js[..=at]).0,
            tests::knot_check::determinant(&js[at..]).0,
        );
        assert_eq!(strands, (1, 1), "{when}: the strands cut at joint {at}");
    };
    let out = hands(&["--builtin", "square-held"]);
    assert!(out.contains(": device: "), "{out}");
    let tied = joints(&mut c);
    check(&tied, "tied");
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("tighten.toml");
    let turn = |hand: &str, joint: &str| {
        format!(
            "[[turn]]\nhand = \"{hand}\"\nchain = \"{chain}\"\njoint = \"{joint}\"\n\
             tighten = {{ speed = 0.05 }}\n\n"
        )
    };
    std::fs::write(
        &script,
        format!(
            "name = \"tighten-device\"\n\n{}{}",
            turn("A", "head"),
            turn("B", "tail")
        ),
    )
    .unwrap();
    let out = hands(&["--script", script.to_str().unwrap()]);
    let pulls: Vec<&str> = out.lines().filter(|l| l.contains("tighten turn")).collect();
    assert_eq!(pulls.len(), 2, "{out}");
    let tight = joints(&mut c);
    check(&tight, "tightened");
    let span = |js: &[[f64; 3]]| {
        let (a, b) = (js[0], js[js.len() - 1]);
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    println!("{}", pulls.join("\n"));
    assert!(
        span(&tight) > span(&tied) + 0.2,
        "the ends {} apart tied, {} tightened",
        span(&tied),
        span(&tight)
    );
}
