//! An instrument moved against the rope: the rope pushed out of its way, substep by substep.

use super::*;

/// How many times a substep of a move with holds is halved when a joint jumps more than half the
/// smallest clearance in it (at most 2⁴ pieces).
pub(super) const GUARD_SPLITS: u32 = 4;

/// Moves obstacle `which` of `model` to the pose `to` (an instrument: a needle driver's jaws, a forceps
/// tip), pushing the chain out of its way. The motion is split into substeps that move no point of the
/// instrument more than half the smallest clearance (its centre moves on a straight line, a capsule's
/// axis turns in its plane at an even rate), and after each substep contacts are resolved as after a
/// move: held joints never move and, when nothing is held, the joint farthest from the instrument stays
/// put while the rest of the chain gives way. A contact only a held joint could resolve (the rope
/// driven through the instrument) *locks* the push: the chain is unchanged, and the caller keeps the
/// instrument where it was. An instrument moves; it does not change shape: `to` must be the same kind
/// with the same radius (and a capsule's axis its length), and planes do not move.
pub fn push_by_obstacle<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    model: &CollisionModel<T, D>,
    which: usize,
    to: &Obstacle<T, D>,
    max_substeps: u32,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    push_fixing(chain, model, which, to, max_substeps, &[], ws)
}

/// [`push_by_obstacle`] with the joints `also` (ascending) kept where they are besides the held ones
/// (the links through a chain's eyelets: [`crate::eyelet::push_threaded`]).
pub(crate) fn push_fixing<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    model: &CollisionModel<T, D>,
    which: usize,
    to: &Obstacle<T, D>,
    max_substeps: u32,
    also: &[usize],
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    model.options.validate()?;
    let Some(from) = model.obstacles.get(which) else {
        return Err(ChainError::BadOption("no such instrument"));
    };
    let path = InstrumentPath::new(from, to)?;
    let half = smallest_clearance(chain, model) * T::lit(0.5);
    let needed = (path.travel() / half).to_f64();
    if needed == 0.0 {
        return Ok(MoveOutcome::default());
    }
    if !(needed.is_finite() && needed <= max_substeps as f64) {
        return Err(ChainError::TooManySubsteps {
            required: if needed.is_finite() {
                needed.ceil() as u64
            } else {
                u64::MAX
            },
            limit: max_substeps,
        });
    }
    let k = (needed.ceil() as u32).max(1);
    // The joint that stays: the first held one, else the one farthest from the instrument.
    let mut held: Vec<usize> = chain.held().chain(also.iter().copied()).collect();
    held.sort_unstable();
    held.dedup();
    ws.pos.resize(chain.n_links() + 1, Vector::zeros());
    chain.write_positions(&mut ws.pos);
    let (m, rest): (usize, &[usize]) = match held.split_first() {
        Some((&m, rest)) => (m, rest),
        None => {
            let c = path.centre(T::zero());
            let far = (0..ws.pos.len())
                .max_by(|&i, &j| {
                    (ws.pos[i] - c)
                        .norm_squared()
                        .partial_cmp(&(ws.pos[j] - c).norm_squared())
                        .unwrap_or(core::cmp::Ordering::Equal)
                })
                .unwrap_or(0);
            (far, &[])
        }
    };
    let backup = chain.clone();
    let mut local = model.clone();
    let mut outcome = MoveOutcome {
        substeps: k,
        ..MoveOutcome::default()
    };
    let placing = (chain.n_links() as u64).saturating_mul(cost::RESTRAIGHTEN_PER_LINK);
    // The state after the last whole substep (a push that may stop short keeps it).
    let mut made = ws.frame.then(|| chain.clone());
    for s in 1..=k {
        local.obstacles[which] = if s == k {
            *to
        } else {
            path.at(T::lit(s as f64 / k as f64))
        };
        let stop = if ws.meter.charge(placing) {
            chain.write_positions(&mut ws.pos);
            match resolve(chain, m, rest, !also.is_empty(), &local, ws) {
                Ok((iterations, contacts)) => {
                    outcome.collision_iterations =
                        outcome.collision_iterations.saturating_add(iterations);
                    outcome.contacts = outcome.contacts.saturating_add(contacts);
                    if !chain.is_held(0) {
                        chain.translate_to(ws.pos[0]);
                    }
                    // Limits are checked on the state a push stopped short keeps.
                    match (&mut made, chain.check_limits()) {
                        (Some(keep), Ok(())) => keep.copy_from(chain),
                        (Some(_), Err(e)) => {
                            return push_short(chain, made, outcome, e, (s - 1, k));
                        }
                        (None, _) => {}
                    }
                    continue;
                }
                Err(stop) => stop.error(s, &ws.meter),
            }
        } else {
            ws.meter.over(s)
        };
        if made.is_some() {
            return push_short(chain, made, outcome, stop, (s - 1, k));
        }
        *chain = backup;
        return Err(stop);
    }
    if let Err(e) = chain.check_limits() {
        *chain = backup;
        return Err(e);
    }
    Ok(outcome)
}

/// A push stopped short inside its frame: the chain as its last whole substep left it (`made`),
/// `done.0` substeps of `done.1` made; the instrument goes to [`push_pose`] of them.
fn push_short<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    made: Option<Chain<T, D>>,
    mut outcome: MoveOutcome,
    error: ChainError,
    (whole, of): (u32, u32),
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    if let Some(m) = made {
        *chain = m;
    }
    outcome.substeps = whole;
    outcome.short = Some(Short {
        error,
        made: whole,
        of,
    });
    Ok(outcome)
}

/// Where a push of an instrument from `from` to `to` that stopped short after `made` of its `of`
/// substeps ([`MoveOutcome::short`]) left it: on its way, as the push moved it (`to` when all were
/// made, `from` when none).
pub fn push_pose<T: Real, const D: usize>(
    from: &Obstacle<T, D>,
    to: &Obstacle<T, D>,
    made: u32,
    of: u32,
) -> Result<Obstacle<T, D>, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    if made >= of {
        return Ok(*to);
    }
    if made == 0 {
        return Ok(*from);
    }
    Ok(InstrumentPath::new(from, to)?.at(T::lit(f64::from(made) / f64::from(of))))
}

/// An instrument's motion between two poses of the same shape.
pub(super) struct InstrumentPath<T: Real, const D: usize> {
    from: Obstacle<T, D>,
    /// Centre at the start and at the end.
    c0: Vector<T, D>,
    c1: Vector<T, D>,
    /// A capsule's half axis at the start and the end (zero for a sphere), and the angle between them.
    h0: Vector<T, D>,
    h1: Vector<T, D>,
    angle: T,
}

impl<T: Real, const D: usize> InstrumentPath<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    fn new(from: &Obstacle<T, D>, to: &Obstacle<T, D>) -> Result<Self, ChainError> {
        let bad = |m| Err(ChainError::BadOption(m));
        let finite = |v: &Vector<T, D>| all_finite(v);
        let (c0, c1, h0, h1) = match (from, to) {
            (
                Obstacle::Sphere {
                    center: a,
                    radius: r,
                },
                Obstacle::Sphere {
                    center: b,
                    radius: q,
                },
            ) => {
                if r != q {
                    return bad("an instrument keeps its radius");
                }
                (*a, *b, Vector::zeros(), Vector::zeros())
            }
            (
                Obstacle::Capsule { a, b, radius: r },
                Obstacle::Capsule {
                    a: a1,
                    b: b1,
                    radius: q,
                },
            ) => {
                if r != q {
                    return bad("an instrument keeps its radius");
                }
                let half = T::lit(0.5);
                let (h0, h1) = ((*b - *a) * half, (*b1 - *a1) * half);
                let (l0, l1) = (h0.norm(), h1.norm());
                // The same length to rounding (a pose rebuilt from a centre and a direction).
                let tol = l0 * T::lit(1e-9).max(T::EPSILON * T::lit(16.0)) + T::EPSILON;
                if !finite(a1) || !finite(b1) || (l0 - l1).abs() > tol {
                    return bad("an instrument keeps its length");
                }
                ((*a + *b) * half, (*a1 + *b1) * half, h0, h1)
            }
            (Obstacle::HalfSpace { .. }, _) => return bad("a plane does not move"),
            (Obstacle::Block { .. }, _) => return bad("a block does not move"),
            _ => return bad("an instrument keeps its shape"),
        };
        if !finite(&c1) {
            return Err(ChainError::NonFinite);
        }
        let (l0, l1) = (h0.norm(), h1.norm());
        let angle = if l0 > T::zero() && l1 > T::zero() {
            let cos = (h0.dot(&h1) / (l0 * l1)).max(-T::one()).min(T::one());
            cos.acos()
        } else {
            T::zero()
        };
        if angle > T::lit(3.1) {
            return bad("an instrument turns less than half a turn per request");
        }
        Ok(InstrumentPath {
            from: *from,
            c0,
            c1,
            h0,
            h1,
            angle,
        })
    }

    /// The farthest any point of the instrument travels: the centre's distance plus the arc of the
    /// axis's end.
    fn travel(&self) -> T {
        (self.c1 - self.c0).norm() + self.h0.norm() * self.angle
    }

    fn centre(&self, t: T) -> Vector<T, D> {
        self.c0 + (self.c1 - self.c0) * t
    }

    /// The pose at fraction `t` of the way.
    fn at(&self, t: T) -> Obstacle<T, D> {
        let c = self.centre(t);
        match self.from {
            Obstacle::Capsule { radius, .. } => {
                // Slerp of the half axis (its length is kept).
                let h = if self.angle > T::lit(1e-9) {
                    let s = self.angle.sin();
                    self.h0 * (((T::one() - t) * self.angle).sin() / s)
                        + self.h1 * ((t * self.angle).sin() / s)
                } else {
                    self.h0 + (self.h1 - self.h0) * t
                };
                Obstacle::Capsule {
                    a: c - h,
                    b: c + h,
                    radius,
                }
            }
            other => match other {
                Obstacle::Sphere { radius, .. } => Obstacle::Sphere { center: c, radius },
                o => o,
            },
        }
    }
}

/// The smallest clearance any contact of this chain can have: half of what a substep may move.
/// The links not tested against obstacle `k` of `model`: those it holds, and for a block those that
/// pass through it (`through`).
pub(super) fn untested<T: Real, const D: usize>(
    model: &CollisionModel<T, D>,
    k: usize,
    through: &core::ops::Range<usize>,
) -> [core::ops::Range<usize>; 2] {
    let held = model
        .holding
        .iter()
        .find(|h| h.obstacle == k)
        .map_or(0..0, |h| h.links.clone());
    let through = match model.obstacles.get(k) {
        Some(Obstacle::Block { .. }) => through.clone(),
        _ => 0..0,
    };
    [held, through]
}

/// Whether link `i` presses into obstacle `k` of `model` rather than keeping its radius from it:
/// a block's links within `pressed` of either end of those that pass through it (`through`).
pub(super) fn presses<T: Real, const D: usize>(
    model: &CollisionModel<T, D>,
    k: usize,
    through: &core::ops::Range<usize>,
    pressed: usize,
    i: usize,
) -> bool {
    matches!(model.obstacles.get(k), Some(Obstacle::Block { .. }))
        && !through.is_empty()
        && ((i < through.start && i + pressed >= through.start)
            || (i >= through.end && i < through.end.saturating_add(pressed)))
}
