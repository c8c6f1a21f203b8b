//! Issue 39, the needle's pass of a stitch through the service: a `hand` process runs the built-in
//! `needle-pass` on the sutures of `stitch.toml` (80 and 160 links, 20 units each), taking the head
//! (the needle's end) into the block of tissue, under the incision and out, then drawing the suture
//! through. Checked on the last state by code of the test: two eyelets, both threaded, on the tissue's
//! top face (z = 0) on either side of the incision (x = 28); each lies on the rope (the nearest
//! segment of the joints, to 1e-9); every link keeps its length; the suture's capsules are a thickness
//! apart; and a tail is left before the entry (its length along the rope, computed here, is printed).

use shared::{Command, Parts, RequestHeader, Vec3};
use std::process::{Command as Process, Stdio};
use tests::{Service, bin, unique_prefix};

fn needle_pass(chain: &str, link: f64) {
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../solver-service/scenes/stitch.toml"
    );
    let svc = Service::start(
        &unique_prefix(),
        &["--scene", scene, "--no-persist", "--wait", "event"],
    );
    let hand = Process::new(bin("hand"))
        .args(["--prefix", &svc.prefix, "run", "--quiet"])
        .args([
            "--builtin",
            "needle-pass",
            "--chain",
            chain,
            "--identify",
            chain,
        ])
        .stdout(Stdio::piped())
        .spawn()
        .expect("spawn hand");
    let out = tests::hand_output(hand);
    let mut c = svc.connect();
    let id = c.require_chain(chain).unwrap();
    let r = c.call(RequestHeader::new(Command::Query, id), &[]).unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    let parts = Parts::of_response(&r.header, &r.payload);
    let joints = parts.joints;
    for (k, w) in joints.windows(2).enumerate() {
        let (a, b) = (w[0], w[1]);
        let l = ((b.x - a.x).powi(2) + (b.y - a.y).powi(2) + (b.z - a.z).powi(2)).sqrt();
        assert!((l - link).abs() < 1e-12, "{chain}: link {k} is {l}");
    }
    // The suture's capsules (0.1 thick) are apart: links two or more apart along the rope at least a
    // thickness apart, less the 1 % tolerance (the clients' segment distance, not the service's).
    let v = |p: Vec3| nalgebra::Vector3::new(p.x, p.y, p.z);
    let mut closest = f64::INFINITY;
    for i in 0..joints.len() - 1 {
        for j in i + 2..joints.len() - 1 {
            let d = clients::check::segment_distance(
                v(joints[i]),
                v(joints[i + 1]),
                v(joints[j]),
                v(joints[j + 1]),
            );
            closest = closest.min(d);
        }
    }
    assert!(
        closest >= 0.1 * 0.99 - 1e-9,
        "{chain}: links {closest} apart"
    );
    let eyelets: Vec<_> = parts.eyelet_states().collect();
    assert_eq!(eyelets.len(), 2, "{chain}: {eyelets:?}");
    let (entry, exit) = (eyelets[0], eyelets[1]);
    for e in [entry, exit] {
        assert!(e.threaded, "{chain}: {e:?}");
        assert!(e.at.z.abs() < 1e-12, "{chain}: not on the top face: {e:?}");
        let (_, d, _) = tests::nearest_link(joints, e.at.to_array());
        assert!(d < 1e-9, "{chain}: eyelet {e:?} is {d:e} off the rope");
    }
    assert!(
        (22.0..28.0).contains(&entry.at.x) && (28.0..34.0).contains(&exit.at.x),
        "{chain}: in at {:?}, out at {:?}",
        entry.at,
        exit.at
    );
    let (k, _, along) = tests::nearest_link(joints, entry.at.to_array());
    let tail = k as f64 * link + along;
    println!(
        "{chain}: in at x = {:.3}, out at x = {:.3}, a tail of {tail:.2} before the entry",
        entry.at.x, exit.at.x
    );
    assert!(tail > 1.0, "{chain}: only {tail} of tail left");
    // The hand's report of the eyelets names both and the same tail.
    let line = out
        .lines()
        .find(|l| l.starts_with("eyelets: "))
        .unwrap_or_else(|| panic!("{chain}: no eyelets line: {out}"));
    assert!(line.starts_with("eyelets: 2 threaded of 2"), "{line}");
    let reported: f64 = line
        .rsplit("rope before the first: ")
        .next()
        .and_then(|x| x.trim().parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!((reported - tail).abs() < 1e-6, "{line} against {tail}");
}

#[test]
fn the_needle_passes_through_the_tissue_at_80_links() {
    needle_pass("suture-80", 0.25);
}

#[test]
fn the_needle_passes_through_the_tissue_at_160_links() {
    needle_pass("suture-160", 0.125);
}
