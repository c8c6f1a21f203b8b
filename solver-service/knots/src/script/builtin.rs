//! The built-in scripts ([`BUILTINS`]): the knots, the instrument ties and the needle's passes.

use super::*;

impl Script {
    /// A built-in script by name (see [`BUILTINS`]).
    pub fn builtin(name: &str) -> Option<Script> {
        let throw = |h, outward: [f64; 3], exit| Throw {
            handedness: h,
            outward,
            scale: 0.8,
            exit,
            lobe: false,
        };
        let two_hands = |second| Script {
            name: name.into(),
            max_step: 0.05,
            // The throws need the rope to slide through the other end's hand: with both ends
            // held, none of them ties (BENCHMARKS.md, knots).
            grasp: false,
            turn: vec![
                // A throws at the tail end and walks on far enough that B's pull, which drags the
                // rope toward B, does not bring the tail back through A's knot.
                turn(
                    "A",
                    "reef",
                    "tail",
                    Some(throw(Handedness::Left, [-1.0, 0.0, 0.0], 30.0)),
                    vec![],
                ),
                turn(
                    "B",
                    "reef",
                    "head",
                    Some(throw(second, [1.0, 0.0, 0.0], 0.0)),
                    vec![],
                ),
            ],
        };
        match name {
            "overhand" => Some(Script {
                name: name.into(),
                max_step: 0.1,
                grasp: true,
                turn: vec![turn(
                    "A",
                    "overhand",
                    "head",
                    Some(Throw {
                        handedness: Handedness::Left,
                        outward: [1.0, 0.0, 0.0],
                        scale: 0.9,
                        // The rope slides through the knot after the head: walking on 12 units
                        // brings the knot near the middle of the 40-unit rope.
                        exit: 12.0,
                        lobe: false,
                    }),
                    vec![],
                )],
            }),
            // A suture with a bend radius (chains `bend-80`, `bend-160`, `bend-320` of knots.toml: 40
            // units, R_min 1.5): the head draws the trefoil entered at a lobe, a path with no corner
            // (tightest bend about 1.55 units), then walks on 3 units. One script for every resolution
            // from 80 links on (BENCHMARKS.md, "Knots over resolution and bend radius").
            "overhand-bend" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: vec![turn(
                    "A",
                    "bend-80",
                    "head",
                    Some(Throw {
                        handedness: Handedness::Left,
                        outward: [1.0, 0.0, 0.0],
                        scale: 1.2,
                        exit: 3.0,
                        lobe: true,
                    }),
                    vec![],
                )],
            }),
            // The paper's rope (40 unit links, free): one wide loop and a tuck, heading away from the
            // rope along +x with the loop on the +y side.
            "overhand-wide" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: vec![Turn {
                    wide_loop: Some(WideLoop {
                        outward: [1.0, 0.0, 0.0],
                        side: [0.0, 1.0, 0.0],
                        radius: default_loop_radius(),
                        exit: default_loop_exit(),
                        feed: 0.0,
                        handedness: Handedness::Right,
                        tuck: true,
                    }),
                    ..turn("A", "paper", "head", None, vec![])
                }],
            }),
            "square" => Some(two_hands(Handedness::Right)),
            "granny" => Some(two_hands(Handedness::Left)),
            // The tail held (by the scene or a second hand), the rope hanging in a U from it to the
            // hand, both ends pointing up (+y): the head throws upward, away from the rope, and walks
            // on, then sideways.
            "overhand-u" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: vec![
                    turn(
                        "A",
                        "rope",
                        "head",
                        Some(Throw {
                            handedness: Handedness::Left,
                            outward: [0.0, 1.0, 0.0],
                            scale: 0.9,
                            exit: 6.0,
                            lobe: false,
                        }),
                        vec![],
                    ),
                    turn("A", "rope", "head", None, vec![[4.0, 0.0, 0.0]]),
                ],
            }),
            // The paper's rope with its tail anchored by the scene (chain `suture`): the head's hand
            // draws the wide loop feeding rope toward the anchor, tucks, then pulls the knot snug
            // back along the rope (tuned to unit links).
            "overhand-anchored" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: vec![
                    Turn {
                        wide_loop: Some(held_loop()),
                        ..turn("A", "suture", "head", None, vec![])
                    },
                    turn("A", "suture", "head", None, vec![[-HELD_PULL, 0.0, 0.0]]),
                ],
            }),
            // The overhand with both ends held, tied by hand round B's finger (chain `hands`): the
            // first throw of `square-held`, one script at every resolution.
            "overhand-held" => Some(instrument_tie(name, "hands", 1.0)),
            "overhands-held" => Some(overhands_held(name, Handedness::Left)),
            // The two-handed knots tied round each other: B's finger takes the driver's part.
            "square-held" => Some(two_throw_tie(name, "hands", 1.0, Handedness::Left)),
            "granny-held" => Some(two_throw_tie(name, "hands", 1.0, Handedness::Right)),
            "instrument-tie" => Some(instrument_tie(name, "tie", 1.0)),
            "surgeons-tie" => Some(instrument_tie(name, "tie", 2.0)),
            "surgeons-knot" => Some(two_throw_tie(name, "tie", 2.0, Handedness::Left)),
            "instrument-square" => Some(two_throw_tie(name, "tie", 1.0, Handedness::Left)),
            "instrument-granny" => Some(two_throw_tie(name, "tie", 1.0, Handedness::Right)),
            "square-u" => Some(two_hands_u(name, Handedness::Right)),
            "granny-u" => Some(two_hands_u(name, Handedness::Left)),
            "wave" => Some(Script {
                name: name.into(),
                max_step: 0.1,
                grasp: true,
                turn: vec![turn(
                    "A",
                    "rope",
                    "head",
                    None,
                    vec![
                        [2.0, 3.0, 0.0],
                        [4.0, -3.0, 1.0],
                        [6.0, 3.0, -1.0],
                        [8.0, 0.0, 0.0],
                    ],
                )],
            }),
            // The needle's pass of a stitch (chain `suture-80` of `stitch.toml`, the head the
            // needle's end): down into the tissue 4.5 before the head's start, under the incision
            // (x = 28) 2.2 deep, up and out 11.5 on, then drawing the suture through until about 4
            // units of tail are left before the entry. Where the head
            // goes in and comes out the service makes the entry and exit eyelets. Not grasped: the
            // head is the moved joint; nothing else holds the suture.
            "needle-pass" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: false,
                turn: vec![turn(
                    "A",
                    "suture-80",
                    "head",
                    None,
                    vec![
                        [3.0, 0.0, -1.0],
                        [4.5, 0.0, -2.8],
                        [6.0, 0.0, -3.8],
                        [8.0, 0.0, -4.2],
                        [10.0, 0.0, -3.8],
                        [11.5, 0.0, -2.8],
                        [12.5, 0.0, -1.0],
                        [14.0, 0.0, 0.5],
                        [17.0, 0.0, 2.0],
                    ],
                )],
            }),
            // The pass with two hands (chain `suture-held-80` of `stitch.toml`, laid across the
            // table from (20, -5, 2) along y): the forceps (hand B) hold the tail where it lies, the
            // driver (hand A) holds the head and swings it round the forceps to beside the bite
            // (sideways, then on, the suture following like a snake: moved back along its own line,
            // a tractrix rope is pushed end on and piles up), loads the needle and drives it through
            // both sides of x = 28 as `stitch-pass` does, then draws the suture through both eyelets
            // toward the held tail.
            "needle-pass-held" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: true,
                turn: [
                    // A little toward the needle (a grip perturbed by up to 0.1 stays within the
                    // rope's reach: the suture lies straight between the hands).
                    vec![turn(
                        "B",
                        "suture-held-80",
                        "tail",
                        None,
                        vec![[0.0, 0.3, 0.0]],
                    )],
                    // Round the forceps to beside the bite, arriving from +y (the suture trailing
                    // sideways, out of the needle's way), then loaded and driven through both sides
                    // of x = 28 (the needle's radius 0.5: its circle centred 0.05 above the top at
                    // x = 28, its point 0.22 above it when loaded), then the suture drawn through,
                    // up and on along +x.
                    loaded_and_driven(
                        "suture-held-80",
                        vec![
                            [3.0, -1.0, 0.0],
                            [6.0, -3.0, 0.0],
                            [8.383, -7.0, 0.0],
                            [8.383, -12.0, -0.5],
                            [8.383, -13.5, -1.3],
                        ],
                        [0.0, -1.5, -0.3286],
                        vec![[0.5, 0.0, 0.8], [4.5, 0.0, 1.7]],
                        None,
                    ),
                ]
                .concat(),
            }),
            // The needle driven round its own circle (chain `needle-drive-80` of `stitch.toml`: 10
            // units of suture in 80 links, its needle of radius 1 and 120° laid curving down, its
            // point just above the tissue): the driver turns the needle 250° (its point goes in,
            // under and out, cutting the two holes; the swage follows it through them, and the
            // suture threads them), then draws the suture up and back through both holes.
            "needle-drive" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: false,
                turn: vec![
                    Turn {
                        drive: Some(Drive { angle: 250.0 }),
                        ..turn("A", "needle-drive-80", "head", None, vec![])
                    },
                    turn(
                        "A",
                        "needle-drive-80",
                        "head",
                        None,
                        vec![[-0.3, 0.0, 1.0], [-1.0, 0.0, 2.0], [-2.5, 0.0, 2.5]],
                    ),
                ],
            }),
            // The needle's pass of the whole stitch (chain `stitch-80` or `stitch-160` of
            // `stitch.toml`, laid along +x from x = -25 to the needle's swage at x = 15, half a unit
            // above the tissue; the needle, radius 0.7 and 120°, curving up from the head link), as
            // a surgeon loads and drives a curved needle: the driver swings the swage aside (to
            // y = 1.5) and over the bite; lifts it, turning the needle (a pose turn) to arch over the
            // entry, high enough that its point cannot reach the tissue while it turns; then brings
            // it down into the plane y = 0, its point at 160° of a circle centred 0.05 above the
            // tissue's top at x = 15.95 and the suture hanging from the swage sideways, out of the
            // needle's way. The driver then drives it 345° round that circle: its point cuts the
            // entry (x ≈ 15.25) and the exit (≈ 16.65) either side of the incision at x = 15.9, the
            // swage follows it through both and the suture threads them. Then the suture is drawn
            // on along +x and up until the tail before the entry, free, is [`STITCH_TAIL`] long
            // (`hand run --tail` sets another). Not grasped: the
            // tail must slide toward the entry. The point starts 0.29 above the tissue, room for a
            // person's hand (`--perturb`) to set the swage 0.2 lower.
            "stitch-pass" => Some(Script {
                name: name.into(),
                max_step: 0.05,
                grasp: false,
                turn: loaded_and_driven(
                    "stitch-80",
                    vec![[0.0, 1.5, 0.1], [1.4862, 1.5, 0.2]],
                    [0.0, -1.5, -0.2],
                    vec![[0.66, 0.0, 0.85], [23.31, 0.0, 1.85]],
                    Some(STITCH_TAIL),
                ),
            }),
            _ => None,
        }
    }
}

/// A turn of `hand` moving `joint` of `chain` through a throw (if any), then `waypoints`; nothing
/// else (set the other fields on it: `Turn { wrap, ..turn(..) }`).
pub fn turn(
    hand: &str,
    chain: &str,
    joint: &str,
    throw: Option<Throw>,
    waypoints: Vec<[f64; 3]>,
) -> Turn {
    Turn {
        hand: hand.into(),
        chain: chain.into(),
        joint: joint.into(),
        throw,
        wide_loop: None,
        tuck: None,
        wrap: None,
        instrument: None,
        tighten: None,
        drive: None,
        pose: None,
        draw: None,
        waypoints,
    }
}

/// One hand's needle pass (hand A, the chain's head): along `approach` to beside the bite (the
/// suture trailing sideways from the swage, out of the needle's way); then a pose turn that lifts the
/// swage (0.8 up, 0.3 toward the bite's plane) turning the needle to [`LOADED`], high enough that its
/// point cannot reach the tissue while it turns, and brings it `down` (from where the approach
/// ended) onto its circle, the point 0.2 or more above the tissue; then a drive of 345° round that
/// circle (the point cuts the entry and the exit, the swage follows it through both); then the
/// suture drawn through along `draw`, until a tail of `tail` is left if given ([`Draw`]). One pose
/// turn, not two: a perturbed hand's waypoint errors add up turn by turn.
pub(super) fn loaded_and_driven(
    chain: &str,
    approach: Vec<[f64; 3]>,
    down: [f64; 3],
    draw: Vec<[f64; 3]>,
    tail: Option<f64>,
) -> Vec<Turn> {
    vec![
        turn("A", chain, "head", None, approach),
        Turn {
            pose: Some(LOADED),
            ..turn("A", chain, "head", None, vec![[0.0, -0.3, 0.8], down])
        },
        Turn {
            drive: Some(Drive { angle: 345.0 }),
            ..turn("A", chain, "head", None, vec![])
        },
        Turn {
            draw: tail.map(|tail| Draw { tail }),
            ..turn("A", chain, "head", None, draw)
        },
    ]
}

/// The tail the whole stitch's pass leaves before the entry (units): about as long as
/// `stitch-tie-80`'s, so that its instrument tie follows.
pub const STITCH_TAIL: f64 = 15.25;

/// A curved needle loaded for a bite along +x under a tissue's top, in the plane y = const: its swage
/// at 40° of its circle (seen from −y, angles from +x toward +z), leaving it toward the top of the
/// circle and curving toward its centre, so that its point (120° on, at 160°) leads it down into the
/// tissue on the −x side when it is driven ([`Drive`]).
pub(super) const LOADED: Pose = Pose {
    tangent: [-0.642_787_610, 0.0, 0.766_044_443],
    bend: [-0.766_044_443, 0.0, -0.642_787_610],
};

/// The wide loop of the held overhand on the paper's rope, straight along +x and held at its tail: a
/// loop of radius 4 (on unit links a smaller one does not survive the tuck; BENCHMARKS.md, knots),
/// the rope fed toward the hold as the circle is drawn.
pub(super) fn held_loop() -> WideLoop {
    WideLoop {
        outward: [1.0, 0.0, 0.0],
        side: [0.0, 1.0, 0.0],
        radius: 4.0,
        exit: 2.0,
        feed: 1.0,
        handedness: Handedness::Right,
        tuck: true,
    }
}

/// How far the held overhand's hand pulls back along the rope after the tuck: the knot snug, before
/// it jams (a jammed knot locks the hand's moves).
pub(super) const HELD_PULL: f64 = 8.0;

/// Two overhands in series on the paper's rope (built-in `overhands-held`, chain `paper`: 40 unit
/// links, straight along +x), each tied by one hand in its own end, each end held by its hand for the
/// whole script (A the tail, B the head), the hands moving alternately (six alternations). The whole
/// rope has the square knot's type (a connected sum of two mirror trefoils), but the strands do not
/// hold each other: a cut between the knots leaves a trefoil in each half (issue 34); the reef and
/// the granny tied round each other are the built-ins `square-held` and `granny-held`. A first gives
/// the rope slack: its end 4 units toward B, dipping aside and up on the way (the rope between the knots would otherwise be taut after B's throw, and A's circle
/// would drag B's knot until it jammed; a move straight along a straight rope only pushes it along,
/// so the hand goes round). Each throw is a fed loop of radius 2 drawn by one hand (the circle only)
/// and a tuck that watches the rope ([`Tuck`]: the end threaded through the loop where it lies); B
/// throws first (a right trefoil), then A (`second`: `Left` mirrors it, a square knot; `Right`, a
/// granny); then each hand pulls its end back along the rope by one unit, twice, in turn.
pub fn overhands_held(name: &str, second: Handedness) -> Script {
    let hand = |h: &str| {
        turn(
            h,
            "paper",
            if h == "A" { "tail" } else { "head" },
            None,
            vec![],
        )
    };
    // Each hand heads away from the rope (B along +x, A along −x), the loop on the +y side.
    let outward = |h: &str| [if h == "A" { -1.0 } else { 1.0 }, 0.0, 0.0];
    let handedness = |h: &str| {
        if h == "A" { second } else { Handedness::Right }
    };
    let circle = |h: &str| Turn {
        wide_loop: Some(WideLoop {
            outward: outward(h),
            side: [0.0, 1.0, 0.0],
            radius: HELD_TWO_RADIUS,
            exit: 0.0,
            feed: 1.0,
            handedness: handedness(h),
            tuck: false,
        }),
        ..hand(h)
    };
    let tuck = |h: &str| Turn {
        tuck: Some(Tuck {
            outward: outward(h),
            side: [0.0, 1.0, 0.0],
            clearance: default_tuck_clearance(),
            exit: 2.0,
            handedness: handedness(h),
        }),
        ..hand(h)
    };
    let pull = |h: &str| Turn {
        waypoints: vec![[-outward(h)[0], 0.0, 0.0]],
        ..hand(h)
    };
    Script {
        name: name.into(),
        max_step: 0.05,
        grasp: true,
        turn: vec![
            Turn {
                waypoints: vec![[4.0, -2.0, 0.5], [4.0, 0.0, 0.0]],
                ..hand("A")
            },
            circle("B"),
            tuck("B"),
            circle("A"),
            tuck("A"),
            pull("B"),
            pull("A"),
            pull("B"),
            pull("A"),
        ],
    }
}

/// The radius of each throw's loop in the two-handed held knots: two loops and their tucks fit in 40
/// units (BENCHMARKS.md, knots: a fed loop of radius 4, which the drawn tuck needs on unit links,
/// takes more than half the rope).
pub(super) const HELD_TWO_RADIUS: f64 = 2.0;

/// The radius of the instrument ties' coils round the driver's jaws (a capsule of radius 0.8): the
/// rope (0.1 from its axis to its surface) lies on the jaws with a thickness of play, so the driver
/// holds the coil open until the tail is drawn through it, whatever the rope's resolution. A loose coil
/// (radius 2.2, the first choice) kept its loop only on unit links: cut into 80 links the rope left
/// the jaws and untied (BENCHMARKS.md, "Knots through the service at every resolution").
pub(super) const WRAP_RADIUS: f64 = 1.1;

/// Where the surgeon's double wrap starts (units from the driver's tip) and how far it advances toward
/// the tip per turn. On the frictionless jaws the rope just behind the winding hand slides along the
/// driver toward the tip, farther the finer the rope (after one turn started 4 from the tip, the
/// rope on the jaws reached 3.3 from the tip at 80 links, 0.9 at 160). Wound 0.6 per turn from 4
/// units, the first turn slid past the place of the second, the lead-in crossed over the coil, and
/// the tail drawn through it tied 5₂ instead of the double overhand 5₁ at 160 and 320 links, in every
/// run (BENCHMARKS.md, "Knot success through the service"). Started 10 from the tip and advancing
/// 4.5 per turn, each turn is laid nearer the tip than the last one slid to, at every resolution
/// from 40 to 320 links (perturbation seeds 1 to 5, tried as scripts before this was built in).
pub(super) const DOUBLE_WRAP_AT: f64 = 10.0;
pub(super) const DOUBLE_WRAP_PITCH: f64 = -4.5;

/// A turn of the instrument tie on chain `tie` through `waypoints`: hand A moves the head (the long
/// end), hand B the tail (the short end, in the driver's jaws).
pub(super) fn tie_turn(chain: &str, h: &str, waypoints: Vec<[f64; 3]>) -> Turn {
    turn(
        h,
        chain,
        if h == "A" { "head" } else { "tail" },
        None,
        waypoints,
    )
}

/// The instrument tie of surgery on chain `tie` of `knots.toml` (the paper's rope stitched in at joint
/// 16, the needle driver `driver` riding with the tail): hand B holds the short end's tail in the
/// driver's jaws, lays the short end in a U and then turns the driver's axis along +x, its tip on the
/// tail, so that the short end's last 3 units trail straight behind the tip; hand A holds the long
/// end (the head), brings it over the stitch to the far side of the driver, level with it, and winds
/// it round the driver's jaws 4 units from the tip (the double wrap from 10, [`DOUBLE_WRAP_AT`]), the
/// coil progressing toward the tip (its lead-in on the side the tail leaves by); B pulls the tail along the driver's axis through the coil (the
/// driver riding with it, the coil sliding off its tip onto the tail); then the hands draw their ends
/// out of the knot, which tightens between them (eight turns, five changes of hand). Turning the
/// driver after the U is laid keeps its body off the short end (turned first, it lay along the
/// straight rope and B's first moves were locked). `wraps` is how many times A winds the long end
/// round the driver: 1 (built-in `instrument-tie`, a half knot: the trefoil), or the surgeon's 2
/// (built-in `surgeons-tie`: the double overhand, 5₁).
pub(super) fn instrument_tie(name: &str, chain: &str, wraps: f64) -> Script {
    let hand = |h: &str, w| tie_turn(chain, h, w);
    let axis = [1.0, 0.0, 0.0];
    Script {
        name: name.into(),
        max_step: 0.05,
        grasp: true,
        turn: vec![
            // The short end laid in a U, its last 3 units straight behind the tip along the axis.
            hand(
                "B",
                vec![
                    [3.0, -4.0, 1.0],
                    [7.0, -2.0, 3.0],
                    [7.0, 0.0, 3.0],
                    [10.0, 0.0, 3.0],
                ],
            ),
            // Then the driver's tip to the tail (it rode there with the tail), its axis along +x.
            Turn {
                instrument: Some(InstrumentMove {
                    index: 0,
                    tip: [0.0; 3],
                    axis,
                }),
                ..hand("B", vec![])
            },
            // The long end over the stitch to the far side of the driver, level with the coil.
            hand("A", vec![[-12.0, 3.0, 2.0], [-26.0, 2.2, 3.0]]),
            Turn {
                wrap: Some(Wrap {
                    instrument: 0,
                    at: if wraps > 1.0 { DOUBLE_WRAP_AT } else { 4.0 },
                    radius: WRAP_RADIUS,
                    turns: wraps,
                    pitch: if wraps > 1.0 { DOUBLE_WRAP_PITCH } else { -0.6 },
                    handedness: Handedness::Right,
                }),
                ..hand("A", vec![])
            },
            // The tail pulled through the coil along the driver's axis.
            hand("B", vec![scale(axis, 10.0)]),
            // Both ends drawn out of the knot, which tightens between them.
            hand("A", vec![[-6.0, 3.0, -3.0]]),
            hand("B", vec![[3.0, 0.0, 1.0]]),
            hand("A", vec![[-6.0, 0.0, 0.0]]),
        ],
    }
}

/// Two throws by instrument tie on `chain` (`tie`, or `hands`, where B's finger is the instrument):
/// the first throw of [`instrument_tie`] with `wraps` turns round the driver, then a single throw,
/// also by the driver, wound `second`-handed: left, the other way, with 2 wraps the surgeon's knot
/// (built-in `surgeons-knot`: the double overhand, then the single throw), with 1 the square knot
/// (built-ins `instrument-square`, and `square-held` by hand); right, the same way, the granny
/// (`instrument-granny`, `granny-held`). B draws the tail out a little more (the first throw
/// tightens), lifts it and carries it back over the knot to the long end's side, turns the driver to
/// point away from the knot (through the vertical, so that its body sweeps no rope), and lowers it;
/// the short end now runs from the knot straight into the driver's tip. A brings the long end up
/// beside the driver from beyond the coil's place and winds it once round the jaws, 3 units from the
/// tip, left-handed (the first throw's wrap seen in a mirror across the knot: the second throw the
/// other way, as the surgeon's and the square knot have it), or right-handed for the granny, one
/// and a half turns (A comes from the side a left-handed turn starts on: one right-handed turn from
/// there ended short of the short end and the second throw was lost, a trefoil in every run tried at
/// 40, 80 and 160 links); B pulls the tail through along the driver; the hands draw their ends
/// apart. Eighteen turns, ten changes of hand.
pub(super) fn two_throw_tie(name: &str, chain: &str, wraps: f64, second: Handedness) -> Script {
    let mut script = instrument_tie(name, chain, wraps);
    let hand = |h: &str, w| tie_turn(chain, h, w);
    let turn_driver = |axis| Turn {
        instrument: Some(InstrumentMove {
            index: 0,
            tip: [0.0; 3],
            axis,
        }),
        ..hand("B", vec![])
    };
    script.turn.extend([
        hand("B", vec![[4.0, 0.0, -2.0]]),
        hand("B", vec![[0.0, 0.0, 4.0], [-14.0, 0.0, 4.0]]),
        turn_driver([0.0, 0.0, 1.0]),
        turn_driver([-1.0, 0.0, 0.0]),
        hand("B", vec![[0.0, 0.0, -3.0]]),
        hand("A", vec![[5.0, -0.7, 2.0], [11.0, -1.5, 3.0]]),
        Turn {
            wrap: Some(Wrap {
                instrument: 0,
                at: 3.0,
                radius: WRAP_RADIUS,
                turns: if second == Handedness::Left { 1.0 } else { 1.5 },
                pitch: -0.6,
                handedness: second,
            }),
            ..hand("A", vec![])
        },
        hand("B", vec![[-5.0, 0.0, 0.0]]),
        hand("A", vec![[6.0, 0.0, 0.0]]),
        hand("B", vec![[-3.0, 0.0, 0.0]]),
    ]);
    script
}

/// The two-handed knots on a rope hanging in a U between the hands (A the tail, B the head), each
/// hand holding its end throughout; six alternating turns: A throws (upward, away from the rope), B
/// pulls its side out, A pulls back, B throws (`second`: mirrored for the square), A pulls, B pulls.
pub(super) fn two_hands_u(name: &str, second: Handedness) -> Script {
    let throw = |handedness| Throw {
        handedness,
        outward: [0.0, 1.0, 0.0],
        scale: 0.45,
        exit: 3.0,
        lobe: false,
    };
    let turn = |hand: &str, throw: Option<Throw>, waypoints: Vec<[f64; 3]>| {
        turn(
            hand,
            "rope",
            if hand == "A" { "tail" } else { "head" },
            throw,
            waypoints,
        )
    };
    Script {
        name: name.into(),
        max_step: 0.05,
        grasp: true,
        turn: vec![
            turn("A", Some(throw(Handedness::Left)), vec![]),
            turn("B", None, vec![[3.0, 0.0, 0.0]]),
            turn("A", None, vec![[-3.0, 0.0, 0.0]]),
            turn("B", Some(throw(second)), vec![]),
            turn("A", None, vec![[-2.0, 0.0, 0.0]]),
            turn("B", None, vec![[2.0, 0.0, 0.0]]),
        ],
    }
}
