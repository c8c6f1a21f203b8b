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
