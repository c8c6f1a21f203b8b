//! A turn's targets: the throws, loops, tucks, wraps and the paths between them, split into
//! requests no longer than the script's step.

use super::*;

impl Turn {
    /// The absolute targets of this turn for a joint starting at `start`, split so that no request
    /// moves the joint more than `max_step`.
    pub fn targets(&self, start: [f64; 3], max_step: f64) -> Vec<[f64; 3]> {
        self.corners(start, None)
            .map(|c| densify(start, &c, max_step))
            .unwrap_or_default()
    }

    /// The absolute targets of this turn for its joint `joint` of the rope `joints` as the turn
    /// starts, split so that no request moves the joint more than `max_step`. A [`Tuck`] is aimed at
    /// the loop the rope has; an error when it has none, or when `joint` is not a joint of it.
    pub fn targets_on(
        &self,
        joints: &[[f64; 3]],
        joint: usize,
        max_step: f64,
    ) -> Result<Vec<[f64; 3]>, String> {
        self.targets_with(joints, joint, &[], max_step)
    }

    /// [`Turn::targets_on`] with the chain's instruments where they are (a [`Wrap`] needs them).
    pub fn targets_with(
        &self,
        joints: &[[f64; 3]],
        joint: usize,
        instruments: &[InstrumentEnds],
        max_step: f64,
    ) -> Result<Vec<[f64; 3]>, String> {
        let start = *joints
            .get(joint)
            .ok_or_else(|| format!("joint {joint} is not a joint of the rope"))?;
        let mut corners = self.corners(start, Some((joints, joint)))?;
        if let Some(w) = &self.wrap {
            let ends = instruments.get(w.instrument as usize).ok_or_else(|| {
                format!(
                    "wrap: instrument {} (the chain has {})",
                    w.instrument,
                    instruments.len()
                )
            })?;
            let k = corners.len() - self.waypoints.len();
            let from = if k > 0 { corners[k - 1] } else { start };
            let wound = wrap_path(from, *ends, w)?;
            corners.splice(k..k, wound);
        }
        Ok(densify(start, &corners, max_step))
    }

    /// The moves of this turn's [`Pose`] for its joint `joint` of the rope `joints` (the needle's
    /// swage, the head): the needle turned to the pose while the swage goes to the first waypoint,
    /// then kept so along the rest ([`needle_poses`]).
    pub fn pose_moves(
        &self,
        pose: &Pose,
        joints: &[[f64; 3]],
        joint: usize,
        instruments: &[InstrumentEnds],
        max_step: f64,
    ) -> Result<Vec<PoseMove>, String> {
        let path = self.targets_with(joints, joint, instruments, max_step)?;
        let start = joints[joint];
        let turning = self.waypoints.first().map_or(path.len(), |w| {
            densify(start, &[add(start, *w)], max_step).len()
        });
        needle_poses(start, instruments, &path, turning, pose, max_step)
    }

    /// The poses (centre, axis direction) an [`InstrumentMove`] turn sends, from the instrument's
    /// ends now, for the turn's joint at `joint_at`: steps that move no point of the instrument more
    /// than `max_step`.
    pub fn instrument_poses(
        &self,
        joint_at: [f64; 3],
        now: InstrumentEnds,
        max_step: f64,
    ) -> Vec<([f64; 3], [f64; 3])> {
        let Some(m) = &self.instrument else {
            return Vec::new();
        };
        let (a, b) = now;
        let len = norm(sub(b, a));
        let d0 = if len > 0.0 {
            scale(sub(b, a), 1.0 / len)
        } else {
            scale(m.axis, 1.0 / norm(m.axis))
        };
        let d1 = scale(m.axis, 1.0 / norm(m.axis));
        let c0 = add(a, scale(d0, 0.5 * len));
        let tip = add(joint_at, m.tip);
        let c1 = add(tip, scale(d1, 0.5 * len));
        // The farthest any point travels: the centre's distance plus the axis end's sweep.
        let angle = dot(d0, d1).clamp(-1.0, 1.0).acos();
        let travel = norm(sub(c1, c0)) + 0.5 * len * angle;
        let k = (travel / max_step).ceil().clamp(1.0, 1e7) as usize;
        (1..=k)
            .map(|i| {
                let t = i as f64 / k as f64;
                let c = add(c0, scale(sub(c1, c0), t));
                let d = add(scale(d0, 1.0 - t), scale(d1, t));
                let n = norm(d);
                // Opposite axes: turn about any axis across them.
                let d = if n > 1e-9 {
                    scale(d, 1.0 / n)
                } else {
                    let across = cross(
                        d0,
                        if d0[0].abs() < 0.9 {
                            [1.0, 0.0, 0.0]
                        } else {
                            [0.0, 1.0, 0.0]
                        },
                    );
                    scale(across, 1.0 / norm(across))
                };
                (c, d)
            })
            .collect()
    }

    /// The corners of the turn's path; a tuck needs the rope.
    fn corners(
        &self,
        start: [f64; 3],
        rope: Option<(&[[f64; 3]], usize)>,
    ) -> Result<Vec<[f64; 3]>, String> {
        let mut corners: Vec<[f64; 3]> = Vec::new();
        if let Some(th) = &self.throw {
            corners.extend(throw_path(start, th));
        }
        if let Some(l) = &self.wide_loop {
            let from = corners.last().copied().unwrap_or(start);
            corners.extend(loop_path(from, l));
        }
        if let Some(t) = &self.tuck {
            let (joints, joint) = rope.ok_or("a tuck needs the rope's joints")?;
            corners.extend(tuck_path(joints, joint, t)?);
        }
        corners.extend(self.waypoints.iter().map(|w| add(start, *w)));
        Ok(corners)
    }
}

/// The corners of a throw's path (400 points on the trefoil, then the exit).
pub(super) fn throw_path(start: [f64; 3], th: &Throw) -> Vec<[f64; 3]> {
    if th.lobe {
        return lobe_path(start, th);
    }
    let [u, v, w] = throw_frame(th.outward);
    let mirror = if th.handedness == Handedness::Right {
        -1.0
    } else {
        1.0
    };
    let n = 400;
    let local: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            [
                (t.sin() + 2.0 * (2.0 * t).sin()) * th.scale,
                (t.cos() - 2.0 * (2.0 * t).cos()) * th.scale,
                -(3.0 * t).sin() * th.scale * mirror,
            ]
        })
        .collect();
    // Enter at the trefoil's point nearest the hand (least along its x axis), one unit ahead.
    let c = (0..n)
        .min_by(|&i, &j| local[i][0].total_cmp(&local[j][0]))
        .expect("points");
    let world = |p: [f64; 3]| {
        let q = [
            p[0] - local[c][0] + 1.0,
            p[1] - local[c][1],
            p[2] - local[c][2],
        ];
        add(
            start,
            add(add(scale(u, q[0]), scale(v, q[1])), scale(w, q[2])),
        )
    };
    let mut out: Vec<[f64; 3]> = (1..=n).map(|k| world(local[(c + k) % n])).collect();
    let last = *out.last().expect("points");
    let away = add(last, add(scale(u, 3.0), scale(v, -3.0)));
    out.push(away);
    if th.exit > 0.0 {
        out.push(add(away, scale(u, th.exit)));
    }
    out
}

/// A throw's right-handed unit frame (u, v, u × v), u along `outward`: a rotation, so the trefoil's
/// handedness is kept whatever the outward direction.
pub(super) fn throw_frame(outward: [f64; 3]) -> [[f64; 3]; 3] {
    let u = scale(outward, 1.0 / norm(outward));
    let helper = if u[2].abs() < 0.9 {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let v = {
        let c = cross(helper, u);
        scale(c, 1.0 / norm(c))
    };
    [u, v, cross(u, v)]
}

/// A [`Throw`] with `lobe`: the trefoil from just past one lobe's tip round to just before it
/// (parameter π + 0.2 to 3π − 0.2), turned so that the entering tangent points along `outward`, one
/// unit ahead of the hand, then `exit` units on along the leaving tangent.
pub(super) fn lobe_path(start: [f64; 3], th: &Throw) -> Vec<[f64; 3]> {
    let mirror = if th.handedness == Handedness::Right {
        -1.0
    } else {
        1.0
    };
    let at = |t: f64| {
        [
            (t.sin() + 2.0 * (2.0 * t).sin()) * th.scale,
            (t.cos() - 2.0 * (2.0 * t).cos()) * th.scale,
            -(3.0 * t).sin() * th.scale * mirror,
        ]
    };
    let tangent = |t: f64| {
        let d = sub(at(t + 1e-6), at(t - 1e-6));
        scale(d, 1.0 / norm(d))
    };
    let pi = std::f64::consts::PI;
    let (t0, t1) = (pi + 0.2, 3.0 * pi - 0.2);
    // The local frame (T, N, B) at the entry, T the tangent, onto the world's (u, w, −v): a rotation.
    let t_local = tangent(t0);
    let up = [0.0, 0.0, 1.0];
    let n_local = {
        let n = sub(up, scale(t_local, dot(up, t_local)));
        scale(n, 1.0 / norm(n))
    };
    let b_local = cross(t_local, n_local);
    let [u, v, w] = throw_frame(th.outward);
    let origin = at(t0);
    let world = |p: [f64; 3]| {
        let q = sub(p, origin);
        let local = [dot(q, t_local) + 1.0, dot(q, n_local), dot(q, b_local)];
        add(
            start,
            add(
                add(scale(u, local[0]), scale(w, local[1])),
                scale(v, -local[2]),
            ),
        )
    };
    let n = 400;
    let mut out: Vec<[f64; 3]> = (0..=n)
        .map(|k| world(at(t0 + (t1 - t0) * k as f64 / n as f64)))
        .collect();
    if th.exit > 0.0 {
        let last = *out.last().expect("points");
        let dir = sub(world(add(at(t1), tangent(t1))), world(at(t1)));
        out.push(add(last, scale(dir, th.exit)));
    }
    out
}

/// The unit frame of a wide loop: along `outward`, across it toward `side`, and their cross product.
pub(super) fn loop_frame(outward: [f64; 3], side: [f64; 3]) -> Option<[[f64; 3]; 3]> {
    let n = norm(outward);
    if !(n > 0.0 && n.is_finite() && side.iter().all(|c| c.is_finite())) {
        return None;
    }
    let u = scale(outward, 1.0 / n);
    let across = add(side, scale(u, -dot(side, u)));
    let m = norm(across);
    let tiny = 1e-9 * norm(side).max(f64::MIN_POSITIVE);
    if !(m.is_finite() && m > tiny) {
        return None;
    }
    let v = scale(across, 1.0 / m);
    Some([u, v, cross(u, v)])
}

/// A wide loop's path in its own frame (along `outward`, across toward `side`, up), from its
/// origin: a Catmull-Rom curve through the loop's 24 points and the tuck's, eight corners per span
/// (the circle is the first 24 spans), mirrored for a left loop.
pub(super) fn loop_local(l: &WideLoop) -> Vec<[f64; 3]> {
    let r = l.radius;
    // The circle about (0, r) entered at its near point, rising one unit over the last 30 % to
    // cross the rope it laid; then under the far side, up through the loop, over the near side, and
    // the pull.
    let mut pts: Vec<[f64; 3]> = vec![[0.0; 3]];
    let n = LOOP_POINTS;
    for k in 1..=n {
        let a = -std::f64::consts::FRAC_PI_2 + std::f64::consts::TAU * k as f64 / n as f64;
        let rise = 0.7 * n as f64;
        let z = if (k as f64) < rise {
            0.0
        } else {
            (k as f64 - rise) / (n as f64 - rise)
        };
        pts.push([r * a.cos(), r + r * a.sin(), z]);
    }
    if l.tuck {
        pts.extend(tuck_local(r, l.exit));
    }
    // The mirror knot: every crossing the other way up.
    if l.handedness == Handedness::Left {
        for p in &mut pts {
            p[2] = -p[2];
        }
    }
    catmull_rom(&pts)
}

/// The drawn tuck in a loop's frame (the loop a circle of radius `r` about `(0, r)`, entered and
/// closed at the origin): on past the crossing, under the far side, up through the middle, over the
/// near side, and `exit` on.
pub(super) fn tuck_local(r: f64, exit: f64) -> [[f64; 3]; 8] {
    [
        [0.6 * r, -0.4 * r, 0.3],
        [1.3 * r, 0.1 * r, -1.0],
        [1.1 * r, 0.5 * r, -1.0],
        [0.2 * r, r, -1.0],
        [-0.2 * r, r, 0.0],
        [-0.5 * r, r, 1.0],
        [-1.3 * r, r, 1.0],
        [-1.3 * r - exit, r, 1.0],
    ]
}

/// A Catmull-Rom curve through `pts` (the ends repeated), eight samples per span.
pub(super) fn catmull_rom(pts: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let at = |i: isize| pts[i.clamp(0, pts.len() as isize - 1) as usize];
    let mut out = Vec::new();
    for i in 0..pts.len() as isize - 1 {
        let (p0, p1, p2, p3) = (at(i - 1), at(i), at(i + 1), at(i + 2));
        for j in 1..=8 {
            let t = j as f64 / 8.0;
            let (t2, t3) = (t * t, t * t * t);
            let c = |d: usize| {
                0.5 * (2.0 * p1[d]
                    + (p2[d] - p0[d]) * t
                    + (2.0 * p0[d] - 5.0 * p1[d] + 4.0 * p2[d] - p3[d]) * t2
                    + (3.0 * p1[d] - p0[d] - 3.0 * p2[d] + p3[d]) * t3)
            };
            out.push([c(0), c(1), c(2)]);
        }
    }
    out
}

/// The corners of a [`Wrap`] from `from` round the instrument with ends `(a, b)`.
pub(super) fn wrap_path(
    from: [f64; 3],
    (a, b): InstrumentEnds,
    w: &Wrap,
) -> Result<Vec<[f64; 3]>, String> {
    let axis = sub(b, a);
    let len = norm(axis);
    if !(len > 0.0 && len.is_finite()) {
        return Err("wrap: the instrument has no axis (a sphere)".into());
    }
    let u = scale(axis, 1.0 / len);
    let centre = add(a, scale(u, w.at));
    // Start at the circle's point nearest the hand; if the hand is on the axis, anywhere.
    let off = sub(from, centre);
    let across = sub(off, scale(u, dot(off, u)));
    let e1 = if norm(across) > 1e-9 {
        scale(across, 1.0 / norm(across))
    } else {
        let c = cross(
            u,
            if u[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            },
        );
        scale(c, 1.0 / norm(c))
    };
    let sign = if w.handedness == Handedness::Right {
        1.0
    } else {
        -1.0
    };
    let e2 = scale(cross(u, e1), sign);
    let per_turn = 48.0;
    let n = (w.turns * per_turn).ceil().max(1.0) as usize;
    Ok((0..=n)
        .map(|k| {
            let f = w.turns * k as f64 / n as f64;
            let t = std::f64::consts::TAU * f;
            add(
                centre,
                add(
                    add(scale(e1, w.radius * t.cos()), scale(e2, w.radius * t.sin())),
                    scale(u, w.pitch * f),
                ),
            )
        })
        .collect())
}

/// Points of a wide loop's circle.
pub(super) const LOOP_POINTS: usize = 24;

/// How many joints from the hand's end a tuck looks at for its loop. The search compares segment
/// pairs (quadratic in what it walks), so on a long chain it stays near the end: a hand's loop lies
/// within a few loops' worth of rope of its end, and the knot ropes are a few hundred links at most.
pub const LOOP_SEARCH_JOINTS: usize = 1024;

/// The loop nearest the end `joint` (0 or the last) of the rope `joints`, seen along `w` in the frame
/// `(u, v, w)`: walking from the end (at most [`LOOP_SEARCH_JOINTS`] joints), the first stretch of
/// rope whose projection comes back across the rope walked before it (at least four links and twice
/// `min_span` across, so that a kink is no loop). Returns the loop's joints.
pub(super) fn find_loop(
    joints: &[[f64; 3]],
    joint: usize,
    [u, v, _]: [[f64; 3]; 3],
    min_span: f64,
    reach: f64,
) -> Option<Vec<[f64; 3]>> {
    let n = joints.len();
    if n < 6 || (joint != 0 && joint != n - 1) {
        return None;
    }
    let walk: Vec<[f64; 3]> = if joint == 0 {
        joints.iter().take(LOOP_SEARCH_JOINTS).copied().collect()
    } else {
        joints
            .iter()
            .rev()
            .take(LOOP_SEARCH_JOINTS)
            .copied()
            .collect()
    };
    let n = walk.len();
    let mut flat: Vec<[f64; 2]> = walk.iter().map(|p| [dot(*p, u), dot(*p, v)]).collect();
    // The end's link reaches half a link past the end: a hand that closed its loop right above the
    // rope it crosses (the circle drawn to where it began) crosses it there.
    flat[0] = [
        1.5 * flat[0][0] - 0.5 * flat[1][0],
        1.5 * flat[0][1] - 0.5 * flat[1][1],
    ];
    let spread_ok = |ring: &[[f64; 3]]| {
        let spread = |d: [f64; 3]| {
            let xs = ring.iter().map(|p| dot(*p, d));
            xs.clone().fold(f64::MIN, f64::max) - xs.fold(f64::MAX, f64::min)
        };
        spread(u).min(spread(v)) >= 2.0 * min_span
    };
    // Segment a (walk[a]..walk[a + 1]) against the later segments b ≥ a + 4.
    for a in 0..n - 1 {
        for b in a + 4..n - 1 {
            if segments_cross(flat[a], flat[a + 1], flat[b], flat[b + 1])
                && spread_ok(&walk[a + 1..=b])
            {
                return Some(walk[a + 1..=b].to_vec());
            }
        }
    }
    // No crossing: the end's own link may have closed the loop short of the rope it headed for,
    // by up to `reach` (a hand's aim is no better); the nearest such approach closes it.
    (4..n - 1)
        .map(|b| {
            (
                segment_distance_2d(flat[0], flat[1], flat[b], flat[b + 1]),
                b,
            )
        })
        .filter(|&(d, b)| d < reach && spread_ok(&walk[1..=b]))
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, b)| walk[1..=b].to_vec())
}

/// Distance between two segments of the plane (they do not cross).
pub(super) fn segment_distance_2d(p: [f64; 2], q: [f64; 2], r: [f64; 2], s: [f64; 2]) -> f64 {
    let point = |x: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        let d = [b[0] - a[0], b[1] - a[1]];
        let l2 = d[0] * d[0] + d[1] * d[1];
        let t = if l2 > 0.0 {
            (((x[0] - a[0]) * d[0] + (x[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        ((x[0] - a[0] - t * d[0]).powi(2) + (x[1] - a[1] - t * d[1]).powi(2)).sqrt()
    };
    point(p, r, s)
        .min(point(q, r, s))
        .min(point(r, p, q))
        .min(point(s, p, q))
}

/// Whether two segments of the plane cross (proper crossings only).
pub(super) fn segments_cross(p: [f64; 2], q: [f64; 2], r: [f64; 2], s: [f64; 2]) -> bool {
    let orient = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    let (d1, d2) = (orient(r, s, p), orient(r, s, q));
    let (d3, d4) = (orient(p, q, r), orient(p, q, s));
    d1 * d2 < 0.0 && d3 * d4 < 0.0
}

/// The corners of a tuck (see [`Tuck`]) through the loop nearest the end `joint` of `joints`.
pub(super) fn tuck_path(
    joints: &[[f64; 3]],
    joint: usize,
    t: &Tuck,
) -> Result<Vec<[f64; 3]>, String> {
    let frame = loop_frame(t.outward, t.side)
        .ok_or("tuck.outward and tuck.side must be finite, non-zero and not parallel")?;
    let [u, v, w] = frame;
    let ring = find_loop(joints, joint, frame, t.clearance.min(1.0), t.clearance)
        .ok_or("no loop to tuck through: the rope does not cross itself near the hand's end")?;
    let k = ring.len() as f64;
    let c = scale(ring.iter().fold([0.0; 3], |a, p| add(a, *p)), 1.0 / k);
    let along = |d: [f64; 3]| ring.iter().map(move |p| dot(add(*p, scale(c, -1.0)), d));
    let far = along(u).fold(f64::MIN, f64::max);
    let near = -along(u).fold(f64::MAX, f64::min);
    let bottom = -along(v).fold(f64::MAX, f64::min);
    let rho = ring
        .iter()
        .map(|p| {
            let d = add(*p, scale(c, -1.0));
            (dot(d, u).powi(2) + dot(d, v).powi(2)).sqrt()
        })
        .sum::<f64>()
        / k;
    let (d, e) = (t.clearance, t.exit);
    let up = if t.handedness == Handedness::Left {
        -1.0
    } else {
        1.0
    };
    let local = [
        [0.6 * rho, -bottom - 0.4 * rho, 0.3 * d],
        [far + d, -bottom + 0.1 * rho, -d],
        [far + 0.5 * d, -0.5 * rho, -d],
        [0.2 * rho, 0.0, -d],
        [-0.2 * rho, 0.0, 0.0],
        [-0.5 * rho, 0.0, d],
        [-near - d, 0.0, d],
        [-near - d - e, 0.0, d],
    ];
    Ok(local
        .iter()
        .map(|p| {
            add(
                c,
                add(add(scale(u, p[0]), scale(v, p[1])), scale(w, up * p[2])),
            )
        })
        .collect())
}

/// The corners of a wide loop's path (see [`WideLoop`]) from `start`, fed back along `outward` by
/// `feed` times the circle drawn so far.
pub(super) fn loop_path(start: [f64; 3], l: &WideLoop) -> Vec<[f64; 3]> {
    let Some([u, v, w]) = loop_frame(l.outward, l.side) else {
        return Vec::new();
    };
    let local = loop_local(l);
    let circle = LOOP_POINTS * 8;
    let mut out: Vec<[f64; 3]> = local
        .iter()
        .map(|p| {
            add(
                start,
                add(add(scale(u, p[0]), scale(v, p[1])), scale(w, p[2])),
            )
        })
        .collect();
    if l.feed > 0.0 {
        let (mut drawn, mut prev) = (0.0, start);
        for (k, p) in out.iter_mut().enumerate() {
            if k < circle {
                drawn += norm([p[0] - prev[0], p[1] - prev[1], p[2] - prev[2]]);
                prev = *p;
            }
            *p = add(*p, scale(u, -l.feed * drawn));
        }
    }
    out
}

pub(super) fn densify(start: [f64; 3], corners: &[[f64; 3]], max_step: f64) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    let mut prev = start;
    for &p in corners {
        let d = [p[0] - prev[0], p[1] - prev[1], p[2] - prev[2]];
        let k = (norm(d) / max_step).ceil().clamp(1.0, 1e7) as usize;
        for i in 1..=k {
            out.push(add(prev, scale(d, i as f64 / k as f64)));
        }
        prev = p;
    }
    out
}
