//! One door per action on a rope: a [`Rope`] borrows a chain with what its scene gives it (a
//! collision model and its workspace, the eyelets it passes through and theirs) and offers
//! [`Rope::move_to`] (and [`Rope::move_along`], a path of such moves), [`Rope::push`] (an instrument
//! pushed to a new pose, the rope giving way) and [`Rope::move_eyelet`] (an eyelet carried by the
//! tissue), each answering one [`MoveOutcome`] or one [`RopeError`].
//!
//! The door picks the method the rope's parts call for; the free functions it calls are its
//! implementation, and stay public for embedders that hold only a chain:
//!
//! | door | free chain | with collision | through eyelets | both |
//! |---|---|---|---|---|
//! | `move_to` | [`Chain::move_joint`] (held sides: [`crate::hold`]) | [`crate::collision::move_joint_colliding`] | [`crate::eyelet::move_threaded`] | [`crate::eyelet::move_threaded_colliding`] |
//! | `push` | – | [`crate::collision::push_by_obstacle`] | – | [`crate::eyelet::push_threaded`] |
//! | `move_eyelet` | – | – | [`crate::eyelet::move_eyelet`] | [`crate::eyelet::move_eyelet_colliding`] |
//!
//! A threaded move with collision reports its collision passes from the workspace's counters (the
//! passes that pushed something, as every other door reports them).
//!
//! ```
//! use nalgebra::Vector3;
//! use tractrix::{Chain, MoveOptions, rope::Rope};
//! let mut chain = Chain::<f64, 3>::straight(10, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
//! let target = Vector3::new(9.0, 3.0, 0.0);
//! let o = Rope::new(&mut chain).move_to(10, target, &MoveOptions::default()).unwrap();
//! assert_eq!(o.substeps, 1);
//! assert!((chain.head() - target).norm() < 1e-12);
//! ```

use crate::chain::{Chain, ChainError, MoveOptions, MoveOutcome};
use crate::collision::{CollisionModel, CollisionWorkspace, Obstacle};
use crate::eyelet::{Eyelet, EyeletError, EyeletWorkspace, Threaded};
use crate::math::{Embed3, Real, Vector};

/// Halvings of the substep in which a move stopped short ([`Rope::move_to`]).
pub const SHORT_HALVINGS: u32 = 5;

/// Tries of a move inside its frame ([`Rope::move_to`]), each with half the work left.
pub const WORK_TRIES: u32 = 6;

/// Why a door of a [`Rope`] refused (the rope unchanged: chain, eyelets and workspaces' state).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RopeError {
    /// The move itself (joint, target, substeps, a held side, a collision lock) is not valid.
    #[error(transparent)]
    Chain(#[from] ChainError),
    /// The eyelets refused it.
    #[error(transparent)]
    Eyelet(EyeletError),
}

impl From<EyeletError> for RopeError {
    fn from(e: EyeletError) -> Self {
        match e {
            EyeletError::Chain(c) => RopeError::Chain(c),
            e => RopeError::Eyelet(e),
        }
    }
}

/// A chain with its collision model and eyelets, as borrowed for one action ([`crate::rope`]).
#[derive(Debug)]
pub struct Rope<'a, T: Real, const D: usize> {
    chain: &'a mut Chain<T, D>,
    collision: Option<(&'a CollisionModel<T, D>, &'a mut CollisionWorkspace<T, D>)>,
    eyelets: Option<(&'a mut [Eyelet<T, D>], &'a mut EyeletWorkspace<T, D>)>,
}

impl<'a, T: Real, const D: usize> Rope<'a, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// A rope of `chain` alone: no collision, no eyelets.
    pub fn new(chain: &'a mut Chain<T, D>) -> Self {
        Rope {
            chain,
            collision: None,
            eyelets: None,
        }
    }

    /// With collision against `model` (its obstacles and instruments), in the workspace `ws` (whose
    /// work limit and counters carry over between actions).
    pub fn with_collision(
        mut self,
        model: &'a CollisionModel<T, D>,
        ws: &'a mut CollisionWorkspace<T, D>,
    ) -> Self {
        self.collision = Some((model, ws));
        self
    }

    /// Threaded through `eyelets` (in the order of their links along the rope; their links and flags
    /// are updated by the moves), in the workspace `ws`. A rope given eyelets, even none, moves as a
    /// threaded rope (a rope that may pierce tissue has none yet).
    pub fn with_eyelets(
        mut self,
        eyelets: &'a mut [Eyelet<T, D>],
        ws: &'a mut EyeletWorkspace<T, D>,
    ) -> Self {
        self.eyelets = Some((eyelets, ws));
        self
    }

    /// Moves joint `joint` straight to `target`, the rope following: held joints stay, contacts are
    /// resolved after every substep with collision, the rope slides through its eyelets. Through
    /// eyelets only `opts.max_substeps` counts (substeps of at most half the shortest link).
    ///
    /// A move that stops short inside its frame ([`CollisionWorkspace::stop_short`]) on anything but
    /// the frame's work is taken on into the substep that stopped it, by [`SHORT_HALVINGS`] halvings
    /// of that substep's way from where it stopped: each half the rope can make is made, so the joint
    /// stops within 2⁻⁵ of a substep of where the rope stopped it (one substep of a knot pulled
    /// tight is the whole pull: without them a jammed knot's pull made nothing).
    pub fn move_to(
        &mut self,
        joint: usize,
        target: Vector<T, D>,
        opts: &MoveOptions<T>,
    ) -> Result<MoveOutcome, RopeError> {
        let framed = self
            .collision
            .as_ref()
            .is_some_and(|(_, ws)| ws.stops_short());
        if !framed {
            return self.move_once(joint, target, opts);
        }
        if self
            .collision
            .as_ref()
            .is_some_and(|(_, ws)| ws.keeps_unfinished())
        {
            // A resolution out of work is kept and the next request resumes it, with all its work.
            let outcome = self.move_once(joint, target, opts)?;
            let from = self.chain.joint(joint);
            return self.halving(outcome, from, target, |rope, to| {
                rope.move_once(joint, to, opts)
            });
        }
        // Each try may spend half the work left, so that one out of work before its first substep
        // leaves work for a quarter of its way; a piece made goes on toward the target.
        let mut outcome = MoveOutcome::default();
        let mut goal = target;
        for _ in 0..WORK_TRIES {
            let o = self.try_with_half(|rope| rope.move_once(joint, goal, opts))?;
            outcome.add(&MoveOutcome { short: None, ..o });
            outcome.short = o.short;
            match o.short {
                None if goal == target => return Ok(outcome),
                None => goal = target,
                Some(s) if matches!(s.error, ChainError::OverWork { .. }) => {
                    if s.made == 0 {
                        let from = self.chain.joint(joint);
                        goal = from + (goal - from) * T::lit(0.25);
                    } else {
                        goal = target;
                    }
                }
                Some(_) => {
                    let from = self.chain.joint(joint);
                    return self.halving(outcome, from, goal, |rope, to| {
                        rope.move_once(joint, to, opts)
                    });
                }
            }
        }
        Ok(outcome)
    }

    /// Runs `f` on the rope with half the collision work left to spend.
    fn try_with_half(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<MoveOutcome, RopeError>,
    ) -> Result<MoveOutcome, RopeError> {
        let limit = self.collision.as_mut().map(|(_, ws)| ws.hold_back(2));
        let o = f(self);
        if let (Some(l), Some((_, ws))) = (limit, self.collision.as_mut()) {
            ws.give_back(l);
        }
        o
    }

    /// Takes a door's move that stopped short (`outcome`, from `from` where it stands now toward
    /// `to`) on into the substep that stopped it: [`SHORT_HALVINGS`] halvings of that substep's
    /// way, each half the rope can make made (`once` the door's single try to a point). A move
    /// made whole, or stopped by the frame's work, is answered as it is.
    fn halving(
        &mut self,
        mut outcome: MoveOutcome,
        from: Vector<T, D>,
        to: Vector<T, D>,
        mut once: impl FnMut(&mut Self, Vector<T, D>) -> Result<MoveOutcome, RopeError>,
    ) -> Result<MoveOutcome, RopeError> {
        let Some(short) = outcome.short else {
            return Ok(outcome);
        };
        if matches!(short.error, ChainError::OverWork { .. }) {
            return Ok(outcome);
        }
        let way = (to - from) / T::lit(f64::from(short.of.saturating_sub(short.made).max(1)));
        let (mut lo, mut hi) = (T::zero(), T::one());
        for _ in 0..SHORT_HALVINGS {
            let mid = (lo + hi) * T::lit(0.5);
            let o = once(self, from + way * mid)?;
            outcome.add(&MoveOutcome { short: None, ..o });
            match o.short {
                None => lo = mid,
                Some(s) if matches!(s.error, ChainError::OverWork { .. }) => break,
                // The rope made part of the half: it stands there now.
                Some(s) if s.made > 0 => lo = mid,
                Some(_) => hi = mid,
            }
        }
        Ok(outcome)
    }

    /// [`Rope::move_to`] without the halvings of a substep that stopped short.
    fn move_once(
        &mut self,
        joint: usize,
        target: Vector<T, D>,
        opts: &MoveOptions<T>,
    ) -> Result<MoveOutcome, RopeError> {
        let Rope {
            chain,
            collision,
            eyelets,
        } = self;
        match (collision, eyelets) {
            (Some((model, cws)), Some((eyelets, ews))) => counting_passes(cws, |cws| {
                crate::eyelet::move_threaded_colliding(
                    chain,
                    joint,
                    target,
                    eyelets,
                    opts.max_substeps,
                    model,
                    cws,
                    ews,
                )
            }),
            (None, Some((eyelets, ews))) => Ok(threaded(
                crate::eyelet::move_threaded(
                    chain,
                    joint,
                    target,
                    eyelets,
                    opts.max_substeps,
                    ews,
                )?,
                0,
            )),
            (Some((model, cws)), None) => Ok(crate::collision::move_joint_colliding(
                chain, joint, target, opts, model, cws,
            )?),
            (None, None) => Ok(chain.move_joint(joint, target, opts)?),
        }
    }

    /// Moves joint `joint` through `targets` in order, one [`Rope::move_to`] each, their outcomes
    /// summed. A free chain validates every target first and moves all or none
    /// ([`Chain::move_along`]); with collision or eyelets a refusal may leave the earlier targets
    /// reached (the caller restores the rope, as the service's world does); a move that stops short
    /// inside its frame ([`CollisionWorkspace::stop_short`]) ends the path there.
    pub fn move_along(
        &mut self,
        joint: usize,
        targets: &[Vector<T, D>],
        opts: &MoveOptions<T>,
    ) -> Result<MoveOutcome, RopeError> {
        if let [target] = targets {
            return self.move_to(joint, *target, opts);
        }
        if self.collision.is_none() && self.eyelets.is_none() {
            return Ok(self.chain.move_along(joint, targets, opts)?);
        }
        let mut total = MoveOutcome::default();
        for t in targets {
            total.add(&self.move_to(joint, *t, opts)?);
            if total.short.is_some() {
                // Stopped short inside its frame: the targets after it are not tried.
                break;
            }
        }
        Ok(total)
    }

    /// Moves obstacle `which` of the collision model to the pose `to` (an instrument), pushing the rope
    /// out of its way in at most `max_substeps` substeps; on a rope through eyelets the links through
    /// them stay. The caller puts the obstacle at `to` in its model once this succeeds. Refused
    /// without a collision model.
    pub fn push(
        &mut self,
        which: usize,
        to: &Obstacle<T, D>,
        max_substeps: u32,
    ) -> Result<MoveOutcome, RopeError> {
        let Rope {
            chain,
            collision,
            eyelets,
        } = self;
        let Some((model, cws)) = collision else {
            return Err(ChainError::BadOption("a push needs a collision model").into());
        };
        match eyelets {
            Some((eyelets, ews)) if !eyelets.is_empty() => Ok(crate::eyelet::push_threaded(
                chain,
                model,
                which,
                to,
                eyelets,
                max_substeps,
                cws,
                ews,
            )?),
            _ => Ok(crate::collision::push_by_obstacle(
                chain,
                model,
                which,
                to,
                max_substeps,
                cws,
            )?),
        }
    }

    /// Moves eyelet `index` to `to` (the tissue moving it), carrying the rope's point at it, in at
    /// most `max_substeps` substeps, with collision when the rope has it; one that stops short
    /// inside its frame is taken on into its last substep as [`Rope::move_to`] is. Refused without
    /// eyelets.
    pub fn move_eyelet(
        &mut self,
        index: usize,
        to: Vector<T, D>,
        max_substeps: u32,
    ) -> Result<MoveOutcome, RopeError> {
        let outcome = self.move_eyelet_once(index, to, max_substeps)?;
        let Some(from) = self
            .eyelets
            .as_ref()
            .and_then(|(e, _)| e.get(index))
            .map(|e| e.at)
        else {
            return Ok(outcome);
        };
        self.halving(outcome, from, to, |rope, at| {
            rope.move_eyelet_once(index, at, max_substeps)
        })
    }

    /// [`Rope::move_eyelet`] without the halvings of a substep that stopped short.
    fn move_eyelet_once(
        &mut self,
        index: usize,
        to: Vector<T, D>,
        max_substeps: u32,
    ) -> Result<MoveOutcome, RopeError> {
        let Rope {
            chain,
            collision,
            eyelets,
        } = self;
        let Some((eyelets, ews)) = eyelets else {
            return Err(ChainError::BadOption("the rope passes through no eyelet").into());
        };
        match collision {
            Some((model, cws)) => counting_passes(cws, |cws| {
                crate::eyelet::move_eyelet_colliding(
                    chain,
                    index,
                    to,
                    eyelets,
                    max_substeps,
                    model,
                    cws,
                    ews,
                )
            }),
            None => Ok(threaded(
                crate::eyelet::move_eyelet(chain, index, to, eyelets, max_substeps, ews)?,
                0,
            )),
        }
    }
}

/// A threaded move with collision, `run` on the collision workspace, its outcome with the passes
/// its resolutions counted.
fn counting_passes<T: Real, const D: usize>(
    cws: &mut CollisionWorkspace<T, D>,
    run: impl FnOnce(&mut CollisionWorkspace<T, D>) -> Result<Threaded, EyeletError>,
) -> Result<MoveOutcome, RopeError> {
    let before = cws.stats().passes;
    let t = run(cws)?;
    Ok(threaded(t, cws.stats().passes - before))
}

/// A threaded move's outcome as every door's, with its collision passes.
fn threaded(t: Threaded, passes: u64) -> MoveOutcome {
    MoveOutcome {
        substeps: t.substeps,
        held_iterations: t.held_iterations,
        collision_iterations: u32::try_from(passes).unwrap_or(u32::MAX),
        left: t.left,
        stuck: t.stuck,
        short: t.short,
        ..MoveOutcome::default()
    }
}
