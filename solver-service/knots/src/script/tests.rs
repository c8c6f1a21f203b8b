use super::*;

#[test]
fn a_draw_turn_s_tail_is_set_by_with_tail_and_checked() {
    let base = Script::builtin("stitch-pass").unwrap();
    let draws = |s: &Script| s.turn.iter().filter_map(|t| t.draw).collect::<Vec<_>>();
    assert_eq!(draws(&base), vec![Draw { tail: STITCH_TAIL }]);
    let ten = base.clone().with_tail(10.0);
    assert_eq!(draws(&ten), vec![Draw { tail: 10.0 }]);
    assert!(ten.check().is_ok());
    // Only draw turns take it: a script without one is unchanged.
    let square = Script::builtin("square").unwrap();
    assert_eq!(square.clone().with_tail(3.0), square);
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let e = base.clone().with_tail(bad).check().unwrap_err();
        assert!(e.contains("draw.tail"), "{e}");
    }
    // In TOML it is `draw = { tail = L }` on the turn.
    let text = toml::to_string(&ten).unwrap();
    assert_eq!(Script::parse(&text, "ten").unwrap(), ten);
    assert!(text.contains("[turn.draw]\ntail = 10.0"), "{text}");
}

#[test]
fn a_perturbation_is_small_repeatable_and_off_at_seed_zero() {
    let base = Script::builtin("square").unwrap();
    let mut zero = base.clone();
    zero.perturb(0);
    assert_eq!(zero, base);
    let (mut a, mut b, mut c) = (base.clone(), base.clone(), base.clone());
    a.perturb(7);
    b.perturb(7);
    c.perturb(8);
    assert_eq!(a, b, "one seed, one script: the hands agree");
    assert_ne!(a, c);
    assert_ne!(a, base);
    for (p, q) in a.turn.iter().zip(&base.turn) {
        if let (Some(t), Some(u)) = (p.throw, q.throw) {
            assert!((t.scale / u.scale - 1.0).abs() <= 0.10);
            for k in 0..3 {
                assert!((t.outward[k] - u.outward[k]).abs() <= 0.05);
            }
            assert!(t.exit >= 0.0 && (t.exit - u.exit).abs() <= 1.0);
        }
        for (w, v) in p.waypoints.iter().zip(&q.waypoints) {
            let d = ((w[0] - v[0]).powi(2) + (w[1] - v[1]).powi(2) + (w[2] - v[2]).powi(2)).sqrt();
            assert!(d <= 0.1, "a waypoint moved by {d}");
        }
    }
    a.check().unwrap();
}

#[test]
fn a_tremor_is_bounded_repeatable_and_differs_between_hands() {
    let shake = |seed, hand: &str, amp| {
        let mut t = Tremor::new(seed, hand, amp);
        (0..1000)
            .map(|_| t.apply([1.0, 2.0, 3.0]))
            .collect::<Vec<_>>()
    };
    let a = shake(5, "A", 0.02);
    assert_eq!(a, shake(5, "A", 0.02));
    assert_ne!(a, shake(5, "B", 0.02));
    let mut largest = 0f64;
    for p in &a {
        let d = ((p[0] - 1.0).powi(2) + (p[1] - 2.0).powi(2) + (p[2] - 3.0).powi(2)).sqrt();
        assert!(d <= 0.02, "moved by {d}");
        largest = largest.max(d);
    }
    // Uniform in the ball: among 1000 draws some reach its outer tenth.
    assert!(largest > 0.018, "largest offset {largest}");
    assert!(shake(5, "A", 0.0).iter().all(|p| *p == [1.0, 2.0, 3.0]));
}

#[test]
fn builtins_round_trip_through_toml() {
    for name in BUILTINS {
        let s = Script::builtin(name).unwrap();
        s.check().unwrap();
        let text = toml::to_string(&s).unwrap();
        assert_eq!(Script::parse(&text, "x").unwrap(), s);
    }
}

#[test]
fn bad_scripts_name_the_line_and_field() {
    let e = Script::parse(
        "name = \"a\"\n[[turn]]\nhand = \"A\"\nchain = \"r\"\njoint = \"elbow\"\n",
        "s.toml",
    )
    .unwrap_err();
    assert!(e.contains("joint \"elbow\""), "{e}");
    let e = Script::parse(
        "name = \"a\"\n[[turn]]\nhand = \"A\"\nchain = 3\njoint = \"head\"\n",
        "s.toml",
    )
    .unwrap_err();
    assert!(e.starts_with("s.toml:4:"), "{e}");
    let e = Script::parse(
        "name = \"a\"\nmax_step = -1\n[[turn]]\nhand = \"A\"\nchain = \"r\"\njoint = \"head\"\n",
        "s",
    )
    .unwrap_err();
    assert!(e.contains("max_step"), "{e}");
}

#[test]
fn a_fed_loop_walks_back_by_its_circle_and_a_left_loop_is_the_mirror() {
    let script = |extra: &str| {
        Script::parse(
            &format!(
                "name = \"w\"\n[[turn]]\nhand = \"A\"\nchain = \"paper\"\njoint = \"head\"\nwide_loop = {{ outward = [1, 0, 0], side = [0, 1, 0], radius = 4{extra} }}\n"
            ),
            "w.toml",
        )
        .unwrap()
        .turn[0]
            .targets([40.0, 0.0, 0.0], 0.05)
    };
    let plain = script("");
    // Fed: the first step stays put along the rope (the hand draws back as much as it heads
    // out), and the tuck is the plain one moved back along -x by the circle's length, which
    // lies between the circle's and the circle's plus its rise of one unit.
    let fed = script(", feed = 1");
    assert!(fed[0][0] < 40.0 + 1e-3, "{:?}", fed[0]);
    let (a, b) = (plain.last().unwrap(), fed.last().unwrap());
    let back = a[0] - b[0];
    let circle = std::f64::consts::TAU * 4.0;
    assert!((circle..circle + 1.0).contains(&back), "{back}");
    assert!((a[1] - b[1]).abs() < 1e-9 && (a[2] - b[2]).abs() < 1e-9);
    // Left: every point of the right (default) loop with its height (along outward × side)
    // the other way.
    let left = script(", handedness = \"left\"");
    assert_eq!(left.len(), plain.len());
    for (l, r) in left.iter().zip(&plain) {
        assert!((l[0] - r[0]).abs() < 1e-9 && (l[1] - r[1]).abs() < 1e-9);
        assert!((l[2] + r[2]).abs() < 1e-9, "{l:?} {r:?}");
    }
    let bad = Script::parse(
        "name = \"w\"\n[[turn]]\nhand = \"A\"\nchain = \"paper\"\njoint = \"head\"\nwide_loop = { outward = [1, 0, 0], side = [0, 1, 0], feed = -1 }\n",
        "w.toml",
    )
    .unwrap_err();
    assert!(
        bad.contains("wide_loop.feed") && bad.contains("turn 1"),
        "{bad}"
    );
}

#[test]
fn a_wide_loop_needs_a_side_across_its_direction_and_keeps_the_step() {
    let text = |side: &str| {
        format!(
            "name = \"w\"\n[[turn]]\nhand = \"A\"\nchain = \"paper\"\njoint = \"head\"\nwide_loop = {{ outward = [1, 0, 0], side = {side} }}\n"
        )
    };
    let e = Script::parse(&text("[2, 0, 0]"), "w.toml").unwrap_err();
    assert!(e.contains("not parallel"), "{e}");
    let s = Script::parse(&text("[0.5, 1, 0]"), "w.toml").unwrap();
    let l = s.turn[0].wide_loop.unwrap();
    assert_eq!((l.radius, l.exit), (4.5, 5.4));
    let p = s.turn[0].targets([0.0; 3], 0.05);
    let mut prev = [0.0; 3];
    for q in &p {
        let d = norm([q[0] - prev[0], q[1] - prev[1], q[2] - prev[2]]);
        assert!(d <= 0.05 + 1e-12, "{d}");
        prev = *q;
    }
    // The loop lies on the +y side (its far side two radii out), rises one unit to cross, dips
    // one under, and the pull ends 1.3 radii + exit back along -x, level with the loop's centre.
    let ys = p.iter().map(|q| q[1]);
    assert!(ys.clone().fold(f64::MIN, f64::max) > 8.0);
    assert!(ys.fold(f64::MAX, f64::min) > -3.0);
    let zs = p.iter().map(|q| q[2]);
    assert!(zs.clone().fold(f64::MIN, f64::max) > 0.99);
    assert!(zs.fold(f64::MAX, f64::min) < -0.99);
    let end = *p.last().unwrap();
    assert!(
        (end[0] + 1.3 * 4.5 + 5.4).abs() < 1e-9 && (end[1] - 4.5).abs() < 1e-9,
        "{end:?}"
    );
}

/// A rope written here: straight along +x from the origin to (20, 0, 0), then a circle of radius
/// `r` about (20, r) drawn counter-clockwise from its bottom, rising to `z = 1` over its last
/// quarter, its end `back` short of the bottom (in unit-ish links).
fn looped_rope(r: f64, back: f64) -> Vec<[f64; 3]> {
    let mut p: Vec<[f64; 3]> = (0..=20).map(|k| [k as f64, 0.0, 0.0]).collect();
    let m = 40;
    for k in 1..=m {
        let a = (std::f64::consts::TAU - back / r) * k as f64 / m as f64;
        let z = (4.0 * k as f64 / m as f64 - 3.0).max(0.0);
        p.push([20.0 + r * a.sin(), r - r * a.cos(), z]);
    }
    p
}

#[test]
fn a_tuck_finds_the_loop_where_it_lies_and_threads_it() {
    let tuck = Tuck {
        outward: [1.0, 0.0, 0.0],
        side: [0.0, 1.0, 0.0],
        clearance: 1.0,
        exit: 2.0,
        handedness: Handedness::Right,
    };
    let turn = Turn {
        tuck: Some(tuck),
        ..turn("B", "paper", "head", None, vec![])
    };
    // The end closes the loop just past the rope it crosses (a proper crossing), or 0.4 short of
    // it (closed within the clearance): either way the loop of radius 3 about (20, 3) is found.
    for back in [-0.3, 0.4] {
        let rope = looped_rope(3.0, back);
        let head = rope.len() - 1;
        let p = turn.targets_on(&rope, head, 0.05).unwrap();
        let mut prev = rope[head];
        for q in &p {
            assert!(norm([q[0] - prev[0], q[1] - prev[1], q[2] - prev[2]]) <= 0.05 + 1e-12);
            prev = *q;
        }
        // Under the far side (x beyond 23, below the loop), up through the middle (near
        // (20, 3) and rising), over the near side (x short of 17, above), then 2 on along −x.
        assert!(p.iter().any(|q| q[0] > 23.5 && q[2] < -0.5), "back {back}");
        let through = p
            .iter()
            .filter(|q| (q[0] - 20.0).abs() < 1.0 && (q[1] - 3.0).abs() < 1.0)
            .map(|q| q[2]);
        let (lo, hi) = through.fold((f64::MAX, f64::MIN), |(a, b), z| (a.min(z), b.max(z)));
        assert!(lo < -0.5 && hi > 0.5, "back {back}: {lo} {hi}");
        let end = p.last().unwrap();
        assert!(end[0] < 15.5 && end[2] > 0.5, "back {back}: {end:?}");
        // The left tuck is the same path the other way up.
        let left = Turn {
            tuck: Some(Tuck {
                handedness: Handedness::Left,
                ..tuck
            }),
            ..turn.clone()
        };
        let q = left.targets_on(&rope, head, 0.05).unwrap();
        assert!(q.iter().any(|x| x[0] > 23.5 && x[2] > 0.5), "back {back}");
        assert!(
            q.iter().all(|x| !(x[0] > 23.5 && x[2] < -0.5)),
            "back {back}"
        );
        let end = q.last().unwrap();
        assert!(end[0] < 15.5 && end[2] < -0.5, "back {back}: {end:?}");
    }
    // A straight rope has no loop: the turn is refused; so is a joint that is not an end.
    let straight: Vec<[f64; 3]> = (0..=40).map(|k| [k as f64, 0.0, 0.0]).collect();
    let e = turn.targets_on(&straight, 40, 0.05).unwrap_err();
    assert!(e.contains("no loop"), "{e}");
    assert!(turn.targets_on(&looped_rope(3.0, -0.3), 20, 0.05).is_err());
    assert!(turn.targets_on(&straight, 41, 0.05).is_err());
    // A circle whose end stops farther from the rope than the clearance (2.3 above it) is no
    // loop yet.
    let open = looped_rope(3.0, 4.0);
    assert!(turn.targets_on(&open, 60, 0.05).is_err());
}

#[test]
fn a_tuck_on_a_long_chain_looks_only_near_the_hand() {
    let turn = Turn {
        tuck: Some(Tuck {
            outward: [1.0, 0.0, 0.0],
            side: [0.0, 1.0, 0.0],
            clearance: 1.0,
            exit: 2.0,
            handedness: Handedness::Right,
        }),
        ..super::turn("B", "long", "head", None, vec![])
    };
    // 65 536 joints leading in along −x, then the loop at the head: found.
    let lead: Vec<[f64; 3]> = (0..65_536)
        .map(|k| [k as f64 - 65_536.0, 0.0, 0.0])
        .collect();
    let rope: Vec<[f64; 3]> = lead.iter().copied().chain(looped_rope(3.0, -0.3)).collect();
    assert!(turn.targets_on(&rope, rope.len() - 1, 0.05).is_ok());
    // The same loop followed by more straight rope than the search walks (going on from the
    // loop's end, away from it): seen from that end, no loop.
    let mut far = looped_rope(3.0, -0.3);
    let from = *far.last().unwrap();
    far.extend((1..=LOOP_SEARCH_JOINTS).map(|k| [from[0] - k as f64, from[1], 5.0]));
    let e = turn.targets_on(&far, far.len() - 1, 0.05).unwrap_err();
    assert!(e.contains("no loop"), "{e}");
}

#[test]
fn a_wrap_winds_round_the_instrument_where_it_is_and_an_instrument_turn_steps_its_pose() {
    let tie = Script::builtin("instrument-tie").unwrap();
    let wrap = tie.turn.iter().find(|t| t.wrap.is_some()).unwrap().clone();
    let w = wrap.wrap.unwrap();
    // A driver along +z from (1, 2, 0): the hand's end at (10, 2, 3) starts the circle on the
    // +x side, `at` up from the tip, winds once counter-clockwise seen along +z, advancing along
    // the axis by the pitch (negative: toward the tip).
    let rope: Vec<[f64; 3]> = (0..=10).map(|k| [k as f64, 2.0, 3.0]).collect();
    let driver = ([1.0, 2.0, 0.0], [1.0, 2.0, 14.0]);
    let p = wrap.targets_with(&rope, 10, &[driver], 0.05).unwrap();
    let mut prev = rope[10];
    for q in &p {
        assert!(norm(sub(*q, prev)) <= 0.05 + 1e-12);
        prev = *q;
    }
    let on_circle: Vec<&[f64; 3]> = p
        .iter()
        .filter(|q| ((q[0] - 1.0).hypot(q[1] - 2.0) - w.radius).abs() < 1e-9)
        .collect();
    assert!(on_circle.len() > 40, "{}", on_circle.len());
    let first = on_circle[0];
    assert!((first[0] - (1.0 + w.radius)).abs() < 1e-9 && (first[2] - w.at).abs() < 1e-9);
    let last = p.last().unwrap();
    assert!((last[0] - first[0]).abs() < 1e-9 && (last[2] - w.at - w.pitch).abs() < 1e-9);
    // Counter-clockwise about +z: a quarter of the way round the circle is on the +y side.
    let quarter = on_circle[on_circle.len() / 4];
    assert!(quarter[1] > 2.0 + 0.9 * w.radius, "{quarter:?}");
    // No instrument, or a sphere: refused.
    assert!(wrap.targets_with(&rope, 10, &[], 0.05).is_err());
    let ball = ([1.0, 2.0, 0.0], [1.0, 2.0, 0.0]);
    assert!(wrap.targets_with(&rope, 10, &[ball], 0.05).is_err());

    // The driver carried from where the scene parks it to the tail: its tip ends on the joint,
    // its axis along the script's, and no step moves any point more than the step.
    let carry = tie.turn.iter().find(|t| t.instrument.is_some()).unwrap();
    let m = carry.instrument.unwrap();
    let park = (
        [0.0, -6.0, 0.0],
        [7.0 * 2f64.sqrt(), -6.0, 7.0 * 2f64.sqrt()],
    );
    let tail = [0.5, 0.0, 0.0];
    let poses = carry.instrument_poses(tail, park, 0.05);
    let half = 7.0;
    let ends = |(c, d): ([f64; 3], [f64; 3])| (sub(c, scale(d, half)), add(c, scale(d, half)));
    let mut prev = park;
    for pose in &poses {
        assert!((norm(pose.1) - 1.0).abs() < 1e-12);
        let (a, b) = ends(*pose);
        assert!(norm(sub(a, prev.0)) <= 0.05 + 1e-9 && norm(sub(b, prev.1)) <= 0.05 + 1e-9);
        prev = (a, b);
    }
    let (a, _) = ends(*poses.last().unwrap());
    assert!(norm(sub(a, add(tail, m.tip))) < 1e-9);
    let axis = poses.last().unwrap().1;
    let want = scale(m.axis, 1.0 / norm(m.axis));
    assert!(norm(sub(axis, want)) < 1e-12);

    // An instrument turn moves nothing else; bad numbers name the field.
    let bad = |extra: &str| {
        Script::parse(
            &format!(
                "name = \"i\"\n[[turn]]\nhand = \"B\"\nchain = \"tie\"\njoint = \"tail\"\n{extra}\n"
            ),
            "i.toml",
        )
        .unwrap_err()
    };
    let e = bad("waypoints = [[1, 0, 0]]\ninstrument = { index = 0, tip = [0, 0, 0] }");
    assert!(e.contains("moves nothing else"), "{e}");
    let e = bad("instrument = { index = 0, tip = [0, 0, 0], axis = [0, 0, 0] }");
    assert!(e.contains("instrument.axis"), "{e}");
    let e = bad("tuck = { outward = [1, 0, 0], side = [2, 0, 0] }");
    assert!(e.contains("tuck.outward"), "{e}");
    let e = bad("wrap = { instrument = 0, at = 3, radius = -1 }");
    assert!(e.contains("wrap.radius"), "{e}");
    let e = bad("wrap = { instrument = 0, at = 3, radius = 1, turns = 1000 }");
    assert!(e.contains("wrap.turns"), "{e}");
}

#[test]
fn targets_start_next_to_the_hand_and_respect_the_step() {
    let t = &Script::builtin("square").unwrap().turn[0];
    let start = [0.0, 0.0, 0.0];
    let p = t.targets(start, 0.05);
    let mut prev = start;
    for q in &p {
        let d = norm([q[0] - prev[0], q[1] - prev[1], q[2] - prev[2]]);
        assert!(d <= 0.05 + 1e-12, "{d}");
        prev = *q;
    }
    // Heads outward (−x) and ends 30 further on.
    assert!(p.last().unwrap()[0] < -30.0);
}

/// A pose turn's moves, checked by the test's own arc and Rodrigues' formula: a needle of radius 1
/// and 120° in four capsules, swaged at the origin along +x curving toward +z, turned to leave
/// along −x curving toward +y while its swage goes 1 along +y. The last move is the pose asked for
/// (its frame's x the tangent and y the bend, to 1e-12), the swage ends where the path does, and
/// no point of the needle moves more than the step (plus the swage's own) between moves.
/// A point of the unit-radius arc swaged at `c`, leaving along `t`, curving toward `b`, `phi` on.
fn arc(c: [f64; 3], t: [f64; 3], b: [f64; 3], phi: f64) -> [f64; 3] {
    let (s, k) = (phi.sin(), phi.cos());
    [0, 1, 2].map(|i| c[i] + b[i] + t[i] * s - b[i] * k)
}

/// Rodrigues' formula: `v` turned by the rotation vector `r`.
fn rodrigues(r: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    let a = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    if a == 0.0 {
        return v;
    }
    let k = r.map(|c| c / a);
    let dot = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    let cross = [
        k[1] * v[2] - k[2] * v[1],
        k[2] * v[0] - k[0] * v[2],
        k[0] * v[1] - k[1] * v[0],
    ];
    [0, 1, 2].map(|i| v[i] * a.cos() + cross[i] * a.sin() + k[i] * dot * (1.0 - a.cos()))
}

/// A unit-radius needle of 120° in four capsules swaged at the origin along +x, curving toward
/// +z.
fn test_needle() -> Vec<InstrumentEnds> {
    let ends: Vec<[f64; 3]> = (0..=4)
        .map(|k| {
            arc(
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0],
                120f64.to_radians() * k as f64 / 4.0,
            )
        })
        .collect();
    ends.windows(2).map(|w| (w[0], w[1])).collect()
}

/// A drive's moves: each swage on the needle's circle (centre (0, 0, 1), radius 1, in y = 0) and
/// each pose's frame (by the test's Rodrigues formula) tangent there, curving toward the centre,
/// to 1e-12; the swage goes the way the point leads (+x first); the steps at most `max_step`.
#[test]
fn a_drive_s_poses_keep_the_needle_on_its_circle() {
    let moves = needle_arc([0.0; 3], &test_needle(), 90.0, 0.05).unwrap();
    assert_eq!(
        moves.len(),
        (std::f64::consts::FRAC_PI_2 / 0.05).ceil() as usize
    );
    let mut before = [0.0; 3];
    for (k, (p, r)) in moves.iter().enumerate() {
        let to_centre = [-p[0], -p[1], 1.0 - p[2]];
        let off = (to_centre.iter().map(|c| c * c).sum::<f64>().sqrt() - 1.0).abs();
        assert!(off < 1e-12 && p[1].abs() < 1e-12, "move {k}: {p:?}");
        let (t, b) = (
            rodrigues(*r, [1.0, 0.0, 0.0]),
            rodrigues(*r, [0.0, 1.0, 0.0]),
        );
        for i in 0..3 {
            assert!((b[i] - to_centre[i]).abs() < 1e-12, "move {k}: bend {b:?}");
        }
        let dot: f64 = (0..3).map(|i| t[i] * to_centre[i]).sum();
        assert!(dot.abs() < 1e-12, "move {k}: tangent {t:?}");
        let step = (0..3)
            .map(|i| (p[i] - before[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(step <= 0.05 + 1e-12, "move {k}: a step of {step}");
        before = *p;
    }
    assert!(moves[0].0[0] > 0.0, "the swage went back: {:?}", moves[0].0);
    let last = moves.last().unwrap().0;
    assert!((last[0] - 1.0).abs() < 1e-12 && (last[2] - 1.0).abs() < 1e-12);
}

#[test]
fn a_pose_turn_turns_the_needle_to_its_pose_in_small_steps() {
    let (x, z) = ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    let caps = test_needle();
    let path: Vec<[f64; 3]> = (1..=20).map(|k| [0.0, k as f64 * 0.05, 0.0]).collect();
    let pose = Pose {
        tangent: [-1.0, 0.0, 0.0],
        bend: [0.0, 1.0, 0.0],
    };
    let moves = needle_poses([0.0; 3], &caps, &path, path.len(), &pose, 0.05).unwrap();
    let (last_at, last_r) = *moves.last().unwrap();
    let close = |a: [f64; 3], b: [f64; 3], tol: f64| (0..3).all(|i| (a[i] - b[i]).abs() < tol);
    assert!(
        close(rodrigues(last_r, x), pose.tangent, 1e-12),
        "{last_r:?}"
    );
    assert!(close(rodrigues(last_r, [0.0, 1.0, 0.0]), pose.bend, 1e-12));
    assert!(close(last_at, [0.0, 1.0, 0.0], 1e-12), "{last_at:?}");
    // The needle's ends at each move (at the start: its frame is x, z).
    let needle = |at: [f64; 3], t: [f64; 3], b: [f64; 3]| -> Vec<[f64; 3]> {
        (0..=4)
            .map(|k| arc(at, t, b, 120f64.to_radians() * k as f64 / 4.0))
            .collect()
    };
    let mut before = needle([0.0; 3], x, z);
    let mut at_before = [0.0; 3];
    // A half turn about the bisector of the two frames: the point's path is 2rθ at most.
    assert!(
        moves.len() >= (2.0 * std::f64::consts::PI / 0.05) as usize,
        "{}",
        moves.len()
    );
    for (at, r) in &moves {
        let now = needle(*at, rodrigues(*r, x), rodrigues(*r, [0.0, 1.0, 0.0]));
        let swage = (0..3)
            .map(|i| (at[i] - at_before[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        for (p, q) in now.iter().zip(&before) {
            let d = (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>().sqrt();
            assert!(d <= 0.05 + swage + 1e-9, "a needle end moved {d}");
        }
        before = now;
        at_before = *at;
    }
}
