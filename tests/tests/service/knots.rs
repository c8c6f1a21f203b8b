//! Knots tied by hand processes through the service (issue 4): the overhand by one hand, the square and
//! granny knots by two hands taking turns as two processes; every published state of the rope keeps
//! non-adjacent links a thickness apart; a replay of the recordings reproduces every state bit for bit.

use knots::KnotType;
use shared::{Command, RequestHeader};
use std::process::{Child, Command as Process, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use tests::{Service, bin, unique_prefix};

type V = nalgebra::Vector3<f64>;

/// The rope's thickness in `knots.toml`, and the collision tolerance the kernel guarantees (1 %).
const THICKNESS: f64 = 0.2;
const TOLERANCE: f64 = 0.01;

fn knot_service() -> Service {
    service_on(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../solver-service/scenes/knots.toml"
    ))
}

/// A service on the scene file `scene`, with the state buffer the watchers need.
fn service_on(scene: &str) -> Service {
    Service::start(
        &unique_prefix(),
        // The watchers check that no state is missed: a buffer of a second of states at the hands'
        // 1 kHz (the default 64 is 64 ms, too short for a watcher starved on a loaded machine).
        &[
            "--scene",
            scene,
            "--wait",
            "event",
            "--no-persist",
            "--state-buffer",
            "1024",
        ],
    )
}

fn hand(svc: &Service, args: &[&str]) -> Child {
    Process::new(bin("hand"))
        .arg("--prefix")
        .arg(&svc.prefix)
        .arg("run")
        .args(["--rate", "1000", "--quiet", "--turn-timeout", "60"])
        .args(args)
        .stdout(Stdio::piped())
        .spawn()
        .expect("spawn hand")
}

/// Waits (with a deadline) for a hand and returns its stdout.
fn finish(child: Child) -> String {
    let (st, out) = exit_of(child);
    assert!(st.success(), "hand failed: {st}\n{out}");
    out
}

/// Waits (with a deadline) for a hand that may have had requests refused as over-budget (a hand
/// whose moves were locked for a while asks, when it goes on, for a move long enough to cost more
/// than the service's work budget per request); it exits 1 then. Any other failure fails the test.
fn finish_allowing_over_budget(child: Child) -> String {
    let (st, out) = exit_of(child);
    let only_budget = out.lines().filter(|l| l.contains("refused:")).all(|l| {
        l.split("refused:")
            .nth(1)
            .unwrap_or("")
            .split(',')
            .all(|r| r.trim().ends_with("over-budget"))
    });
    assert!(
        st.success() || (st.code() == Some(1) && out.contains("refused:") && only_budget),
        "hand failed: {st}\n{out}"
    );
    out
}

/// Waits up to 120 s for a hand to exit; its exit status and stdout.
fn exit_of(mut child: Child) -> (std::process::ExitStatus, String) {
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            let mut out = String::new();
            std::io::Read::read_to_string(child.stdout.as_mut().unwrap(), &mut out).unwrap();
            return (st, out);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("a hand did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Smallest distance between the axes of non-adjacent links (pairs whose joints are far apart are
/// skipped: they cannot be closer than one thickness). Links with less than a thickness of rope
/// between them touch even on a straight rope, so they are not a pair here (links of `link` length:
/// at least ⌈thickness / link⌉ links apart).
fn clearance(p: &[V], link: f64) -> f64 {
    let reach = (2.0 * link + THICKNESS).powi(2);
    let apart = ((THICKNESS / link) - 1e-9).ceil().max(1.0) as usize;
    let mut best = f64::INFINITY;
    for i in 0..p.len() - 1 {
        for j in i + 1 + apart..p.len() - 1 {
            if (p[i] - p[j]).norm_squared() > reach {
                continue;
            }
            best = best.min(knots::check::segment_distance(
                p[i],
                p[i + 1],
                p[j],
                p[j + 1],
            ));
        }
    }
    best
}

/// Watches the state stream on its own thread: checks every published state of `chain` and that no
/// state was missed (sequence numbers without gaps). Returns (states checked, smallest clearance).
struct Watcher {
    stop: Arc<AtomicBool>,
    handle: std::thread::JoinHandle<Watched>,
}

/// What a [`Watcher`] saw: states checked, the smallest clearance, how many different tail
/// positions (bit for bit) the states had, and how many states moved the tail, the head, and both
/// (bit for bit, against the state before).
struct Watched {
    checked: u64,
    min: f64,
    tails: usize,
    tail_moved: u64,
    head_moved: u64,
    both_moved: u64,
    /// The smallest surface gap between an instrument and a link it does not hold, over all states.
    gap: f64,
}

impl Watcher {
    /// Watches `chain`, whose links are `link` long.
    fn start(svc: &Service, chain: u32, link: f64) -> Watcher {
        Watcher::start_skipping(svc, chain, link, 0)
    }

    /// Watches `chain`; its first `skip` links are held by its instruments (not checked against them).
    fn start_skipping(svc: &Service, chain: u32, link: f64, skip: usize) -> Watcher {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let mut conn = svc.connect();
        let seq0 = conn
            .call(RequestHeader::new(Command::Query, chain), &[])
            .unwrap()
            .header
            .sequence;
        drop(conn);
        let prefix = svc.prefix.clone();
        let (ready_tx, ready) = std::sync::mpsc::channel();
        let handle = std::thread::spawn(move || {
            let conn = clients::Connection::connect(clients::ConnectOptions {
                prefix,
                ..clients::ConnectOptions::default()
            })
            .unwrap();
            let stream = conn.subscribe().unwrap();
            let _ = ready_tx.send(());
            let (mut next, mut checked, mut min) = (seq0 + 1, 0u64, f64::INFINITY);
            let mut tails: Vec<[u64; 3]> = Vec::new();
            let bits = |p: V| {
                let b = p.map(f64::to_bits);
                [b.x, b.y, b.z]
            };
            let mut ends: Option<([u64; 3], [u64; 3])> = None;
            let (mut tail_moved, mut head_moved, mut both_moved) = (0u64, 0u64, 0u64);
            let mut gap = f64::INFINITY;
            let mut idle_since = None;
            loop {
                let got = stream
                    .try_next(|h, p| {
                        // The test's own reading of the layout: joints, held joints, then three
                        // elements per instrument (the axis ends a and b, then the radius).
                        let at = (h.n_joints + h.n_held) as usize;
                        let instruments: Vec<(V, V, f64)> = p
                            .get(at..at + 3 * h.n_instruments as usize)
                            .unwrap_or(&[])
                            .chunks(3)
                            .map(|e| {
                                (
                                    V::new(e[0].x, e[0].y, e[0].z),
                                    V::new(e[1].x, e[1].y, e[1].z),
                                    e[2].x,
                                )
                            })
                            .collect();
                        (
                            h.sequence,
                            h.chain,
                            p[..h.n_joints as usize]
                                .iter()
                                .map(|q| V::new(q.x, q.y, q.z))
                                .collect::<Vec<_>>(),
                            instruments,
                        )
                    })
                    .unwrap();
                match got {
                    Some((seq, c, pts, instruments)) => {
                        idle_since = None;
                        if seq < next {
                            continue; // published before the watcher subscribed
                        }
                        assert_eq!(seq, next, "a published state was missed");
                        next += 1;
                        if c == chain {
                            min = min.min(clearance(&pts, link));
                            checked += 1;
                            let t = bits(pts[0]);
                            if !tails.contains(&t) {
                                tails.push(t);
                            }
                            let h = bits(pts[pts.len() - 1]);
                            if let Some((t0, h0)) = ends {
                                tail_moved += u64::from(t != t0);
                                head_moved += u64::from(h != h0);
                                both_moved += u64::from(t != t0 && h != h0);
                            }
                            ends = Some((t, h));
                            // Each instrument's axis against the links it does not hold (those
                            // from `skip` on), less its radius and half the rope's thickness. The
                            // instruments after the first are a needle's pieces, swaged to the head:
                            // they hold the links within their reach of it (their radius, half their
                            // length and half the rope's thickness, in links, and one more).
                            for (k, (a, b, r)) in instruments.iter().enumerate() {
                                let n = pts.len() - 1;
                                let end = if k == 0 {
                                    n
                                } else {
                                    let reach = r + 0.5 * (b - a).norm() + 0.5 * THICKNESS;
                                    n.saturating_sub((reach / link).ceil() as usize + 1)
                                };
                                for w in pts[..=end].windows(2).skip(skip) {
                                    let d = knots::check::segment_distance(w[0], w[1], *a, *b);
                                    gap = gap.min(d - r - 0.5 * THICKNESS);
                                }
                            }
                        }
                    }
                    None => {
                        if flag.load(Ordering::Relaxed) {
                            let t = *idle_since.get_or_insert_with(Instant::now);
                            if t.elapsed() > Duration::from_millis(300) {
                                return Watched {
                                    checked,
                                    min,
                                    tails: tails.len(),
                                    tail_moved,
                                    head_moved,
                                    both_moved,
                                    gap,
                                };
                            }
                        }
                        std::thread::sleep(Duration::from_micros(200));
                    }
                }
            }
        });
        // Subscribed before any hand starts: a state published earlier would count as missed.
        ready
            .recv_timeout(Duration::from_secs(20))
            .expect("the watcher subscribes");
        Watcher { stop, handle }
    }

    fn finish(self) -> (u64, f64) {
        let w = self.finish_all();
        (w.checked, w.min)
    }

    fn finish_all(self) -> Watched {
        self.stop.store(true, Ordering::Relaxed);
        self.handle.join().expect("watcher")
    }
}

/// The knot the identification names in `chain`, cross-checked: the knot determinant computed by the
/// tests' own code from the same joints ([`tests::knot_check`], no code shared with the kernel) must
/// be the named knot's (1 unknot, 3 trefoil, 5 double overhand, 9 square or granny), in most of its
/// views.
/// The joints of chain `id` now, as the service reports them.
fn joints_of(svc: &Service, id: u32) -> Vec<[f64; 3]> {
    svc.connect()
        .call(RequestHeader::new(Command::Query, id), &[])
        .unwrap()
        .joints()
        .iter()
        .map(|q| [q.x, q.y, q.z])
        .collect()
}

/// The stitch of chain `id`, where its two strands meet: its first anchor (a held joint the scene
/// holds; the query's held list marks it), else the joint halfway between the links of its threaded
/// eyelets (the bite).
pub(super) fn stitch(svc: &Service, id: u32) -> usize {
    let q = svc
        .connect()
        .call(RequestHeader::new(Command::Query, id), &[])
        .unwrap();
    let parts = q.parts();
    if let Some(a) = parts.held.iter().find(|h| h.y == 1.0) {
        return a.x as usize;
    }
    let links: Vec<u32> = parts
        .eyelet_states()
        .filter(|e| e.threaded)
        .map(|e| e.link)
        .collect();
    let (lo, hi) = (links.iter().min().unwrap(), links.iter().max().unwrap());
    ((lo + hi) / 2 + 1) as usize
}

fn knot_of(svc: &Service, chain: &str) -> knots::KnotReport {
    let mut c = svc.connect();
    let id = c.find_chain(chain).unwrap().unwrap();
    let k = clients::hand::knot_of(&mut c, id).unwrap();
    let joints = joints_of(svc, id);
    let expected = match k.kind {
        KnotType::Unknot => Some(1),
        KnotType::Trefoil => Some(3),
        KnotType::DoubleOverhand => Some(5),
        KnotType::Surgeons => Some(15),
        KnotType::Square | KnotType::Granny => Some(9),
        KnotType::Other => None,
    };
    let (det, views) = tests::knot_check::determinant(&joints);
    if let Some(d) = expected {
        assert_eq!(
            det, d,
            "{chain}: the identification says {k:?}, the tests' own determinant is {det} ({views} of 3 views)"
        );
        assert!(
            views >= 2,
            "{chain}: determinant {det} in {views} of 3 views"
        );
    }
    k
}

fn assert_never_passed_through(checked: u64, min: f64, expected_states: u64) {
    assert!(
        checked >= expected_states,
        "checked {checked} states, expected {expected_states}"
    );
    assert!(
        min >= THICKNESS * (1.0 - TOLERANCE) - 1e-9,
        "two non-adjacent links came {min} apart (thickness {THICKNESS})"
    );
}

#[test]
fn one_hand_ties_an_overhand_knot_a_trefoil() {
    let svc = knot_service();
    let id = svc.connect().find_chain("overhand").unwrap().unwrap();
    let w = Watcher::start(&svc, id, 0.25);
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().display().to_string();
    let out = finish(hand(
        &svc,
        &["--builtin", "overhand", "--svg", &svg, "--frames", "4"],
    ));
    let (checked, min) = w.finish();
    assert!(out.contains("0 locked"), "{out}");
    // Key frames (figure 5): the start and 4 in the one turn, each a panel with a caption.
    let pic = std::fs::read_to_string(dir.path().join("overhand-A.svg")).unwrap();
    let captions = pic
        .lines()
        .filter(|l| l.contains("hand A, turn 1, move"))
        .count();
    assert!(pic.lines().any(|l| l.trim() == "overhand: start"), "{pic}");
    assert!((4..=5).contains(&captions), "{captions} key frames");
    assert_never_passed_through(checked, min, 400);
    let k = knot_of(&svc, "overhand");
    assert_eq!(k.kind, KnotType::Trefoil, "{k:?}");
    assert!(
        k.agreeing * 3 >= k.closures * 2,
        "a clear majority of closures: {k:?}"
    );
}

/// The paper's own rope (figure 5: 40 links of unit length, 0.2 thick): one hand ties the overhand
/// with one wide loop and a tuck, the knot in the middle third of the rope.
#[test]
fn one_hand_ties_an_overhand_on_the_papers_forty_unit_links() {
    let svc = knot_service();
    let id = svc.connect().find_chain("paper").unwrap().unwrap();
    let w = Watcher::start(&svc, id, 1.0);
    let out = finish(hand(&svc, &["--builtin", "overhand-wide"]));
    let (checked, min) = w.finish();
    assert!(out.contains("0 locked"), "{out}");
    assert_never_passed_through(checked, min, 1000);
    let k = knot_of(&svc, "paper");
    assert_eq!(k.kind, KnotType::Trefoil, "{k:?}");
    assert_eq!((k.crossings, k.determinant), (3, 3), "{k:?}");
    assert_knot_near_the_middle(&svc, id, 40);
}

/// A suture with a bend radius (issue 34): one script, `overhand-bend`, written in units of length,
/// ties the overhand through the service on the same 40-unit rope in 80 and in 320 links (chains
/// `bend-80` and `bend-320` of `knots.toml`, R_min 1.5). Every published state keeps the rope apart
/// from itself; the final rope is a trefoil (the tests' own determinant agrees) and turns at no joint
/// by more than the bend radius allows, `2·atan(L / 2R_min)`, computed here from the joints.
#[test]
fn one_script_ties_the_overhand_on_a_suture_with_a_bend_radius_at_80_and_320_links() {
    let svc = knot_service();
    for (chain, links) in [("bend-80", 80usize), ("bend-320", 320)] {
        let len = 40.0 / links as f64;
        let id = svc.connect().find_chain(chain).unwrap().unwrap();
        let w = Watcher::start(&svc, id, len);
        let out = finish(hand(
            &svc,
            &["--builtin", "overhand-bend", "--chain", chain],
        ));
        let (checked, min) = w.finish();
        assert_never_passed_through(checked, min, 600);
        let k = knot_of(&svc, chain);
        assert_eq!(k.kind, KnotType::Trefoil, "{chain}: {k:?}\n{out}");
        let joints: Vec<V> = svc
            .connect()
            .call(RequestHeader::new(Command::Query, id), &[])
            .unwrap()
            .joints()
            .iter()
            .map(|q| V::new(q.x, q.y, q.z))
            .collect();
        assert_eq!(joints.len(), links + 1);
        let cone = 2.0 * (len / 3.0f64).atan();
        for (j, w) in joints.windows(3).enumerate() {
            let (a, b) = (w[1] - w[0], w[2] - w[1]);
            let turn = a.cross(&b).norm().atan2(a.dot(&b));
            assert!(
                turn <= cone + 1e-6,
                "{chain}: joint {} turns {turn}, beyond {cone}",
                j + 1
            );
        }
    }
}

/// Where the knot is: the links that touch a non-adjacent link (closer than twice the thickness),
/// found here from the joints; the middle of that span lies in the middle third of the rope.
fn assert_knot_near_the_middle(svc: &Service, id: u32, links: usize) {
    let mut c = svc.connect();
    let joints: Vec<V> = c
        .call(RequestHeader::new(Command::Query, id), &[])
        .unwrap()
        .joints()
        .iter()
        .map(|q| V::new(q.x, q.y, q.z))
        .collect();
    let n = joints.len() - 1;
    assert_eq!(n, links);
    let mut touching = Vec::new();
    for i in 0..n {
        for j in i + 2..n {
            let d =
                knots::check::segment_distance(joints[i], joints[i + 1], joints[j], joints[j + 1]);
            if d < 2.0 * THICKNESS {
                touching.extend([i, j]);
            }
        }
    }
    let (Some(lo), Some(hi)) = (touching.iter().min(), touching.iter().max()) else {
        panic!("no two non-adjacent links touch: no knot to place");
    };
    let middle = (lo + hi) as f64 / 2.0;
    assert!(
        (n as f64 / 3.0..=2.0 * n as f64 / 3.0).contains(&middle),
        "the knot spans links {lo}..={hi}, not around the middle"
    );
}

/// The paper's rope held at its tail (figure 5 with the far end held, issue 16): anchored by the scene
/// (chain `suture`), the head's hand ties the overhand. The held tail is bit for bit the same in every
/// published state, no state lets the rope through itself, and the knot is a trefoil near the middle.
#[test]
fn the_overhand_is_tied_on_the_papers_rope_held_at_its_tail() {
    let svc = knot_service();
    for (chain, script, hands) in [("suture", "overhand-anchored", &["A"][..])] {
        let id = svc.connect().find_chain(chain).unwrap().unwrap();
        let w = Watcher::start(&svc, id, 1.0);
        let children: Vec<Child> = hands
            .iter()
            .map(|h| hand(&svc, &["--builtin", script, "--hand", h]))
            .collect();
        for child in children {
            let out = finish(child);
            assert!(out.contains("0 locked"), "{script}: {out}");
        }
        let seen = w.finish_all();
        assert_never_passed_through(seen.checked, seen.min, 1000);
        assert_eq!(
            seen.tails, 1,
            "{script}: the held tail moved in a published state"
        );
        let k = knot_of(&svc, chain);
        assert_eq!(k.kind, KnotType::Trefoil, "{script}: {k:?}");
        assert_eq!((k.crossings, k.determinant), (3, 3), "{script}: {k:?}");
        assert_knot_near_the_middle(&svc, id, 40);
    }
}

/// An overhand in each end of the paper's rope held at both ends (figure 6, issue 16; built-in
/// `overhands-held`, once called `square-held`): two hand processes on chain `paper` (40 unit links,
/// 0.2 thick), A holding the tail and B the head for the whole script, moving alternately (six
/// alternations: A gives slack, each throws, each pulls twice in turn). B's throw is a right
/// trefoil, A's mirrors it: the whole rope has the square knot's type.
/// In every published state one end at most has moved (bit for bit) since the state before, so the
/// hand that waits holds its end still while the other moves; no state lets the rope through itself;
/// the knot, named by the identification, lies around the middle of the rope. And it is what a
/// knot-tier would call two overhands in series (issue 34): a cut leaves a trefoil in each half.
#[test]
fn two_hands_tie_an_overhand_in_each_end_of_the_papers_rope_both_ends_held() {
    let svc = knot_service();
    let id = svc.connect().find_chain("paper").unwrap().unwrap();
    for (script, expected) in [("overhands-held", KnotType::Square)] {
        let mut c = svc.connect();
        assert!(
            c.call(RequestHeader::new(Command::Reset, id), &[])
                .unwrap()
                .is_ok()
        );
        drop(c);
        let w = Watcher::start(&svc, id, 1.0);
        let hands: Vec<Child> = ["A", "B"]
            .iter()
            .map(|h| hand(&svc, &["--builtin", script, "--hand", h]))
            .collect();
        for h in hands {
            let out = finish(h);
            assert!(!out.contains("skipped"), "{script}: {out}");
        }
        let seen = w.finish_all();
        assert_never_passed_through(seen.checked, seen.min, 1000);
        assert_eq!(
            seen.both_moved, 0,
            "{script}: a state moved both held ends at once"
        );
        assert!(
            seen.tail_moved > 100 && seen.head_moved > 100,
            "{script}: both hands moved their ends ({} and {} states)",
            seen.tail_moved,
            seen.head_moved
        );
        let k = knot_of(&svc, "paper");
        assert_eq!(k.kind, expected, "{script}: {k:?}");
        assert_eq!(k.determinant, 9, "{script}: {k:?}");
        assert!(k.writhe.abs() <= 2, "{script}: {k:?}");
        assert_knot_near_the_middle(&svc, id, 40);
        // What these scripts tie, as a knot-tier would see it (issue 34): two overhands one after the
        // other, each hand's in its own end, not one knot whose strands hold each other. The tests'
        // own determinant finds a cut with a trefoil (3) in each half, and the identification's
        // `in_series` reports the same; a reef tied round itself would have neither.
        let joints = joints_of(&svc, id);
        let own_cut = (8..=32).find(|&k| {
            tests::knot_check::determinant(&joints[..=k]).0 == 3
                && tests::knot_check::determinant(&joints[k..]).0 == 3
        });
        assert!(
            own_cut.is_some(),
            "{script}: no cut leaves a trefoil in each half"
        );
        let mut c = svc.connect();
        let series = clients::hand::series_of(&mut c, id, &k).unwrap();
        let Some(Some(s)) = series else {
            panic!("{script}: the identification finds no two knots in series: {series:?}");
        };
        assert_eq!(
            (s.first.kind, s.second.kind),
            (KnotType::Trefoil, KnotType::Trefoil),
            "{script}: {s:?}"
        );
    }
}

/// The instrument tie (issue 16, beyond the paper): on chain `tie` of `knots.toml` (the paper's rope
/// stitched in at joint 16), hand B lays the short end and carries the needle driver (a capsule of
/// radius 0.8 riding with the tail) to its tail, hand A winds the long end round the driver's jaws
/// (once: a trefoil, the instrument tie's half knot), B pulls the tail through the coil along the
/// driver, and the hands draw their ends out. The rope ends in a trefoil; the driver ends where B's
/// jaws have the tail; no published state lets the rope into the driver (the links it holds aside) or
/// through itself; at most one end moves per state; the recordings replay bit for bit.
#[test]
fn two_hands_tie_the_instrument_tie_with_a_needle_driver() {
    instrument_tie("instrument-tie", KnotType::Trefoil, 3..=3, 3);
}

/// The two-handed square and granny knots as a person ties them, the strands round each other
/// (issue 34): chain `hands` of `knots.toml` (40 units held 16 from the tail, as over a post; hand B's
/// finger, a capsule riding with the tail, where the instrument tie has the driver), A winding the
/// long end round B's finger and B drawing its end through, twice; one script each (`square-held`,
/// `granny-held`), at 40 and at 160 links (chain `hands-160`). The whole rope is the composite (the
/// tests' own determinant 9; the square's writhe near 0, the granny's not), and no cut leaves a knot
/// in each half, by the tests' own determinant and by the identification ([`instrument_tie_on`]); the
/// finger, clearance, one-end-per-state and replay checks of the instrument tie.
#[test]
fn two_hands_tie_the_square_and_granny_round_each_other_at_40_and_160_links() {
    for (script, kind) in [
        ("square-held", KnotType::Square),
        ("granny-held", KnotType::Granny),
    ] {
        for (chain, link) in [("hands", 1.0), ("hands-160", 0.25)] {
            instrument_tie_on(script, chain, link, kind, 6..=u32::MAX, 9);
        }
    }
}

/// The overhand with both ends held, as a person ties it in a held rope (issue 34): the first throw of
/// `square-held` (A winds the long end once round B's finger, B draws its end through), one script
/// (`overhand-held`) at 40 and at 160 links. A trefoil (the tests' own determinant 3), the finger,
/// clearance, one-end-per-state and replay checks of the instrument tie.
#[test]
fn two_hands_tie_the_overhand_round_a_finger_at_40_and_160_links() {
    for (chain, link) in [("hands", 1.0), ("hands-160", 0.25)] {
        instrument_tie_on("overhand-held", chain, link, KnotType::Trefoil, 3..=3, 3);
    }
}

/// The granny knot by instrument tie (`instrument-granny`): the second throw wound the same way as the
/// first, at 40 and 160 links; the same checks.
#[test]
fn two_hands_tie_the_granny_with_a_needle_driver_at_40_and_160_links() {
    for (chain, link) in [("tie", 1.0), ("tie-160", 0.25)] {
        instrument_tie_on(
            "instrument-granny",
            chain,
            link,
            KnotType::Granny,
            6..=u32::MAX,
            9,
        );
    }
}

/// The same script, unchanged, on the same suture cut into 160 links (chain `tie-160`: 0.25-unit
/// links, stitched in 16 units from the tail, its own driver): the coil lies on the driver's jaws,
/// which hold it open whatever the link length, and the rope ends in the same trefoil (issue 34).
#[test]
fn the_instrument_tie_script_ties_the_same_knot_at_160_links() {
    instrument_tie_on(
        "instrument-tie",
        "tie-160",
        0.25,
        KnotType::Trefoil,
        3..=3,
        3,
    );
}

/// The surgeon's instrument tie: the same moves with the long end wound twice round the driver. The
/// rope ends in the double overhand (5₁: 5 crossings, determinant 5), the surgeon's first throw.
#[test]
fn two_hands_tie_the_surgeons_double_wrap_with_a_needle_driver() {
    instrument_tie("surgeons-tie", KnotType::DoubleOverhand, 5..=5, 5);
}

/// The surgeon's knot by instrument tie: the double wrap's throw, then B carries the short end back
/// over the knot and A winds the long end once round the driver the other way, B pulls it through.
/// The rope ends in the surgeon's knot (determinant 15; no diagram of it has fewer than 8 crossings,
/// and the reduction by Reidemeister I and II need not reach 8).
#[test]
fn two_hands_tie_the_surgeons_knot_with_a_needle_driver() {
    instrument_tie("surgeons-knot", KnotType::Surgeons, 8..=u32::MAX, 15);
}

/// The square knot by instrument tie: the same two throws with one wrap in the first (determinant 9;
/// no diagram of it has fewer than 6 crossings).
#[test]
fn two_hands_tie_the_square_knot_with_a_needle_driver() {
    instrument_tie("instrument-square", KnotType::Square, 6..=u32::MAX, 9);
}

fn instrument_tie(
    script: &str,
    kind: KnotType,
    crossings: std::ops::RangeInclusive<u32>,
    determinant: u64,
) {
    instrument_tie_on(script, "tie", 1.0, kind, crossings, determinant);
}

/// [`instrument_tie`] on chain `chain` of `knots.toml`, whose links are `link` long.
fn instrument_tie_on(
    script: &str,
    chain: &str,
    link: f64,
    kind: KnotType,
    crossings: std::ops::RangeInclusive<u32>,
    determinant: u64,
) {
    instrument_tie_in(
        knot_service(),
        script,
        (chain, link),
        (kind, crossings, determinant),
        (&[], &[]),
    );
}

/// [`instrument_tie_on`] on the service `svc` (its scene has `chain`); returns it for more checks.
/// `before`: recordings of what was done to the chain before the tie (a needle's pass), replayed
/// with the tie's; `extra`: more arguments for both hands (`--tighten 0.05`).
pub(super) fn instrument_tie_in(
    svc: Service,
    script: &str,
    (chain, link): (&str, f64),
    (kind, crossings, determinant): (KnotType, std::ops::RangeInclusive<u32>, u64),
    (before, extra): (&[std::path::PathBuf], &[&str]),
) -> Service {
    let id = svc.connect().find_chain(chain).unwrap().unwrap();
    // The links the driver holds: within its reach of the tail (its radius 0.8, half its length 7
    // and half the thickness 0.1: 7.9 units, rounded up to links, and one more; 9 on unit links),
    // checked here from the next on.
    let skip = (7.9 / link).ceil() as usize + 2;
    let w = Watcher::start_skipping(&svc, id, link, skip);
    let dir = tempfile::tempdir().unwrap();
    let rec = |h: &str| dir.path().join(format!("tie-{h}.jsonl"));
    let hands: Vec<Child> = ["A", "B"]
        .iter()
        .map(|h| {
            let r = rec(h).display().to_string();
            let mut args = vec![
                "--builtin",
                script,
                "--hand",
                h,
                "--record",
                &r,
                "--chain",
                chain,
            ];
            args.extend_from_slice(extra);
            hand(&svc, &args)
        })
        .collect();
    for h in hands {
        finish_allowing_over_budget(h);
    }
    let seen = w.finish_all();
    eprintln!("{script}: smallest gap to the driver {}", seen.gap);
    assert_never_passed_through(seen.checked, seen.min, 1000);
    // Each state moves one hand's end. (With `--tighten` a hand lets go of its end after its last
    // pull while the other still pulls, dragging the freed end: not counted there.)
    if extra.is_empty() {
        assert_eq!(seen.both_moved, 0, "a state moved both ends at once");
    }
    assert!(seen.gap.is_finite(), "no state carried the driver");
    assert!(
        seen.gap >= (0.8 + 0.5 * THICKNESS) * -TOLERANCE,
        "the rope entered the driver by {}",
        -seen.gap
    );
    let k = knot_of(&svc, chain);
    assert_eq!(k.kind, kind, "{chain}: {k:?}");
    assert!(crossings.contains(&k.crossings), "{chain}: {k:?}");
    assert_eq!(k.determinant, determinant, "{chain}: {k:?}");
    match kind {
        KnotType::Square => assert!(k.writhe.abs() <= 2, "{chain}: {k:?}"),
        KnotType::Granny => assert!(k.writhe.abs() >= 4, "{chain}: {k:?}"),
        _ => {}
    }
    // One knot whose strands hold each other, not knots in series: no cut of the rope leaves a knot
    // in each half, by the tests' own determinant (every fourth joint from a tenth of the rope to
    // nine tenths) and by the identification.
    let joints = joints_of(&svc, id);
    let n = joints.len() - 1;
    let own_cut = (n / 10..=9 * n / 10).step_by(4).find(|&c| {
        tests::knot_check::determinant(&joints[..=c]).0 > 1
            && tests::knot_check::determinant(&joints[c..]).0 > 1
    });
    assert_eq!(own_cut, None, "{chain}: a cut leaves a knot in each half");
    let series = clients::hand::series_of(&mut svc.connect(), id, &k).unwrap();
    assert!(
        matches!(series, None | Some(None)),
        "{chain}: the identification finds knots in series: {series:?}"
    );
    // The real knot, strand by strand (issue 68): cut at the stitch, each strand alone is unknotted
    // (an overhand in one end, with a throw after it, has the composite's type too, and no cut leaves
    // a knot in each half). The tests' own determinant: 1 for each strand (a trefoil's is 3, 5₁'s 5).
    if matches!(
        kind,
        KnotType::Square | KnotType::Granny | KnotType::Surgeons
    ) {
        let at = stitch(&svc, id);
        let strands = (
            tests::knot_check::determinant(&joints[..=at]).0,
            tests::knot_check::determinant(&joints[at..]).0,
        );
        assert_eq!(
            strands,
            (1, 1),
            "{chain}: the strands cut at the stitch (joint {at}) have determinants {strands:?}"
        );
    }
    // The driver was carried: its tip is on the tail (B put it there and it rode with the tail),
    // far from where the scene parked it.
    let q = svc
        .connect()
        .call(RequestHeader::new(Command::Query, id), &[])
        .unwrap();
    let tail = q.joints()[0];
    let driver = q.instruments()[0];
    let off = ((driver.a.x - tail.x).powi(2)
        + (driver.a.y - tail.y).powi(2)
        + (driver.a.z - tail.z).powi(2))
    .sqrt();
    assert!(off < 0.1, "the driver's tip is {off} from the tail");
    assert!(
        (driver.a.y + 6.0).abs() > 5.0,
        "the driver is still where the scene parked it"
    );
    // The recordings (moves, grasps and the driver's poses) replay bit for bit from the scene.
    let out = Process::new(bin("hand"))
        .arg("--prefix")
        .arg(&svc.prefix)
        .arg("replay")
        .args(before)
        .arg(rec("A"))
        .arg(rec("B"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains(": 0 differed"), "{text}");
    let driver_again = svc
        .connect()
        .call(RequestHeader::new(Command::Query, id), &[])
        .unwrap()
        .instruments()[0];
    assert_eq!(
        (driver_again.a.to_array(), driver_again.b.to_array()),
        (driver.a.to_array(), driver.b.to_array())
    );
    svc
}

/// Issue 39: the surgeon's knot by instrument tie over a bite through tissue: `stitch.toml`'s
/// `stitch-tie` (40 links) and `stitch-tie-80`, the suture of `tie` with its anchor replaced by an
/// entry and an exit eyelet, the rope sticking in them by friction. Checked as the instrument ties
/// are (every state, the knot by the tests' own determinant, the replay), and at the end both eyelets
/// threaded on the rope (to 1e-9, measured here) on the links the scene put them on: the bite held
/// while the knot was tied.
#[test]
fn two_hands_tie_the_surgeons_knot_over_a_bite_with_friction() {
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../solver-service/scenes/stitch.toml"
    );
    for (chain, link, points) in [
        ("stitch-tie", 1.0, [14.5, 17.5]),
        ("stitch-tie-80", 0.5, [15.25, 16.75]),
    ] {
        let svc = service_on(scene);
        let svc = instrument_tie_in(
            svc,
            "surgeons-knot",
            (chain, link),
            (KnotType::Surgeons, 8..=u32::MAX, 15),
            (&[], &[]),
        );
        let id = svc.connect().find_chain(chain).unwrap().unwrap();
        let q = svc
            .connect()
            .call(RequestHeader::new(Command::Query, id), &[])
            .unwrap();
        let parts = shared::Parts::of_response(&q.header, &q.payload);
        let eyelets: Vec<_> = parts.eyelet_states().collect();
        assert_eq!(eyelets.len(), 2, "{chain}: {eyelets:?}");
        for (e, x) in eyelets.iter().zip(points) {
            assert!(e.threaded && e.at.x == x, "{chain}: {e:?}");
            let (k, d, _) = tests::nearest_link(parts.joints, e.at.to_array());
            assert!(d < 1e-9, "{chain}: eyelet {e:?} {d:e} off the rope");
            assert_eq!(
                k,
                (x / link).floor() as usize,
                "{chain}: the rope slid: {e:?}"
            );
        }
    }
}

/// Two hand processes, started together, take turns on the 80-unit rope.
fn two_hands(script: &str, dir: &std::path::Path, svc: &Service) -> (u64, f64) {
    let id = svc.connect().find_chain("reef").unwrap().unwrap();
    let w = Watcher::start(svc, id, 0.25);
    let rec = |h: &str| {
        dir.join(format!("{script}-{h}.jsonl"))
            .display()
            .to_string()
    };
    let a = hand(
        svc,
        &["--builtin", script, "--hand", "A", "--record", &rec("A")],
    );
    let b = hand(
        svc,
        &["--builtin", script, "--hand", "B", "--record", &rec("B")],
    );
    finish(a);
    finish(b);
    w.finish()
}

#[test]
fn two_hand_processes_tie_a_square_knot_and_its_replay_is_bit_for_bit() {
    let svc = knot_service();
    let dir = tempfile::tempdir().unwrap();
    let (checked, min) = two_hands("square", dir.path(), &svc);
    assert_never_passed_through(checked, min, 2000);
    let k = knot_of(&svc, "reef");
    assert_eq!(k.kind, KnotType::Square, "{k:?}");
    assert_eq!(k.determinant, 9);

    // Replay both recordings on the same service: the chain is reset, the requests re-sent in the
    // order the service applied them, every returned state compared bit for bit.
    let out = Process::new(bin("hand"))
        .arg("--prefix")
        .arg(&svc.prefix)
        .arg("replay")
        .arg(dir.path().join("square-A.jsonl"))
        .arg(dir.path().join("square-B.jsonl"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains(": 0 differed"), "{text}");
    assert_eq!(knot_of(&svc, "reef").kind, KnotType::Square);
}

#[test]
fn both_throws_the_same_way_tie_a_granny_knot() {
    let svc = knot_service();
    let dir = tempfile::tempdir().unwrap();
    let (checked, min) = two_hands("granny", dir.path(), &svc);
    assert_never_passed_through(checked, min, 2000);
    let k = knot_of(&svc, "reef");
    assert_eq!(k.kind, KnotType::Granny, "{k:?}");
    assert!(
        k.writhe.abs() >= 4,
        "a granny's writhe is far from 0: {k:?}"
    );
}
