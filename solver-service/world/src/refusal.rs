//! Why a command was refused: a [`Cause`] (each one the wire numbers as a status) and a short reason
//! formatted into a fixed buffer, so that a refusal allocates nothing. The kernel's errors become
//! refusals by `From`.

use std::fmt::Write as _;
use tractrix::math::Embed3;
use tractrix::{ChainError, ReachError, Real, Vector};

/// Most bytes of a refusal's reason (UTF-8; a longer one is cut at a character boundary).
pub const MAX_REASON_BYTES: usize = 95;

/// What kind of refusal. Every refusal leaves the world unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Cause {
    /// The command is not one the door knows.
    UnknownCommand,
    /// The chain is not one of the scene's.
    UnknownChain,
    /// The joint is past the head.
    JointOutOfRange,
    /// A target or option is NaN or infinite.
    NonFinite,
    /// An option is out of range.
    BadOption,
    /// The number of target points does not fit the command.
    BadPointCount,
    /// A target lies outside the workspace (a fixed base's, a held side's).
    Unreachable,
    /// A fixed-base solve hit its iteration limit.
    NotConverged,
    /// The move would need more substeps than the chain allows.
    TooManySubsteps,
    /// The command does not apply to this chain's kind.
    WrongChainKind,
    /// A planar chain got a target off its plane.
    OffPlane,
    /// A snapshot or journal write failed (the door's persistence); the command was not applied.
    PersistenceFailed,
    /// Something that should not happen (a kernel invariant, a response too large).
    Internal,
    /// Collision handling could not keep the links apart.
    Locked,
    /// A free chain's target lies too far from the origin for its precision.
    TooFar,
    /// The command would take more work than the budget per command.
    OverBudget,
    /// A joint would be left beyond its limit.
    JointLimit,
    /// The joint is held by another client's grasp, or is an anchor of the scene.
    Held,
}

/// A refused command: the cause, what was wrong, and how far a reach got.
#[derive(Debug, Clone)]
pub struct Refusal {
    /// Why.
    pub cause: Cause,
    reason: [u8; MAX_REASON_BYTES],
    /// Bytes of `reason` used.
    len: u8,
    /// Reach: the residual reached (unreachable: the distance to the workspace).
    pub residual: f64,
    /// Reach: the iterations spent.
    pub iterations: u32,
    /// A move stopped by collision handling (locked, over the budget): the substep where it stopped.
    pub substeps: u32,
}

const _: () = assert!(
    MAX_REASON_BYTES <= u8::MAX as usize,
    "a reason's length must fit a byte"
);

impl Refusal {
    /// A refusal with a reason formatted into the fixed buffer (cut at [`MAX_REASON_BYTES`]).
    pub fn new(cause: Cause, args: std::fmt::Arguments<'_>) -> Self {
        let mut r = Refusal {
            cause,
            reason: [0; MAX_REASON_BYTES],
            len: 0,
            residual: 0.0,
            iterations: 0,
            substeps: 0,
        };
        let _ = r.write_fmt(args);
        r
    }

    /// The reason as text.
    pub fn reason(&self) -> &str {
        std::str::from_utf8(&self.reason[..usize::from(self.len)]).unwrap_or("")
    }
}

impl std::fmt::Write for Refusal {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        for ch in s.chars() {
            let mut b = [0u8; 4];
            let e = ch.encode_utf8(&mut b).as_bytes();
            let len = usize::from(self.len);
            if len + e.len() > MAX_REASON_BYTES {
                return Ok(());
            }
            self.reason[len..len + e.len()].copy_from_slice(e);
            // At most MAX_REASON_BYTES (95): fits the byte.
            self.len = (len + e.len()) as u8;
        }
        Ok(())
    }
}

/// A [`Refusal`] of the named [`Cause`], its reason formatted: `refuse!(BadOption, "substeps {n}")`.
#[macro_export]
macro_rules! refuse {
    ($cause:ident, $($fmt:tt)*) => {
        $crate::refusal::Refusal::new($crate::refusal::Cause::$cause, format_args!($($fmt)*))
    };
}
impl From<tractrix::RopeError> for Refusal {
    fn from(e: tractrix::RopeError) -> Self {
        match e {
            tractrix::RopeError::Chain(c) => c.into(),
            tractrix::RopeError::Eyelet(e) => e.into(),
        }
    }
}

impl From<tractrix::eyelet::EyeletError> for Refusal {
    fn from(e: tractrix::eyelet::EyeletError) -> Self {
        use tractrix::eyelet::EyeletError;
        match e {
            EyeletError::Chain(c) => c.into(),
            EyeletError::Fold { link } => {
                refuse!(
                    Locked,
                    "the rope would fold through the eyelet on link {link}"
                )
            }
            EyeletError::TooClose { a, b } => refuse!(
                Locked,
                "eyelets {a} and {b} would come within one link of each other"
            ),
            EyeletError::NearHeld { held } => refuse!(
                Held,
                "held joint {held} is within two links of an eyelet or of the moved joint: the \
                 rope cannot close on it"
            ),
            EyeletError::PastStop { joint } => refuse!(
                NotConverged,
                "the rope slid through an eyelet past joint {joint}"
            ),
            e @ (EyeletError::NotOnChain { .. } | EyeletError::Unordered) => {
                refuse!(Internal, "eyelets: {e}")
            }
        }
    }
}

impl From<ChainError> for Refusal {
    fn from(e: ChainError) -> Self {
        match e {
            ChainError::NonFinite => {
                refuse!(NonFinite, "target does not fit the chain's precision")
            }
            ChainError::JointOutOfRange { joint, last } => {
                refuse!(JointOutOfRange, "joint {joint} (the chain has 0..={last})")
            }
            ChainError::TooManySubsteps { required, limit } => refuse!(
                TooManySubsteps,
                "the move needs {required} substeps; the chain allows {limit}"
            ),
            ChainError::BadOption(s) => refuse!(BadOption, "{s}"),
            ChainError::Locked {
                substep,
                iterations,
                penetration,
            } => {
                let mut r = refuse!(
                    Locked,
                    "links still {penetration:.2e} too close after {iterations} passes at substep {substep}"
                );
                r.substeps = substep;
                r.iterations = iterations;
                r
            }
            ChainError::Jumped { substep, jump } => {
                let mut r = refuse!(
                    Locked,
                    "a joint would jump {jump:.2e} through the rope at substep {substep}"
                );
                r.substeps = substep;
                r
            }
            ChainError::HeldUnreachable {
                held,
                nearest,
                residual,
            } => {
                let mut r = refuse!(
                    Unreachable,
                    "{residual:.3e} out of reach of held joint {held}; nearest {}",
                    Point(nearest[0], nearest[1], nearest[2])
                );
                r.residual = residual;
                r
            }
            ChainError::HeldNotConverged {
                iterations,
                residual,
            } => {
                let mut r = refuse!(
                    NotConverged,
                    "held side: {iterations} iterations, residual {residual:.3e}"
                );
                r.iterations = iterations;
                r.residual = residual;
                r
            }
            ChainError::JointLimit {
                joint,
                angle,
                excess,
            } => refuse!(
                JointLimit,
                "joint {joint} would turn {:.3}°, {:.2e}° beyond its limit",
                angle.to_degrees(),
                excess.to_degrees()
            ),
            ChainError::OverWork {
                substep,
                work,
                limit,
            } => {
                let mut r = refuse!(
                    OverBudget,
                    "collision work reached {work:.2e} link-steps at substep {substep}; the budget \
                     is {limit:.2e} (--budget): a shorter move, or a larger --budget"
                );
                r.substeps = substep;
                r
            }
            e @ (ChainError::Empty | ChainError::BadLength { .. }) => refuse!(Internal, "{e}"),
        }
    }
}

/// A point in a reason: `(x, y, z)`, six decimals.
struct Point(f64, f64, f64);

impl Point {
    fn of<T: Real, const D: usize>(v: &Vector<T, D>) -> Self
    where
        Vector<T, D>: Embed3<T>,
    {
        let n = v.to_3d();
        Point(n.x.to_f64(), n.y.to_f64(), n.z.to_f64())
    }
}

impl std::fmt::Display for Point {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "({:.6}, {:.6}, {:.6})", self.0, self.1, self.2)
    }
}

impl<T: Real, const D: usize> From<ReachError<T, D>> for Refusal
where
    Vector<T, D>: Embed3<T>,
{
    fn from(e: ReachError<T, D>) -> Self {
        match e {
            ReachError::Unreachable { nearest, residual } => {
                let mut r = refuse!(
                    Unreachable,
                    "{:.3e} outside the workspace; nearest {}",
                    residual.to_f64(),
                    Point::of(&nearest)
                );
                r.residual = residual.to_f64();
                r
            }
            ReachError::NotConverged {
                iterations,
                residual,
                reached,
            } => {
                let mut r = match reached {
                    Some(n) => refuse!(
                        NotConverged,
                        "{iterations} iterations, residual {:.3e}; nearest reached {}",
                        residual.to_f64(),
                        Point::of(&n)
                    ),
                    None => refuse!(
                        NotConverged,
                        "{iterations} iterations, residual {:.3e}",
                        residual.to_f64()
                    ),
                };
                r.iterations = iterations;
                r.residual = residual.to_f64();
                r
            }
            ReachError::Chain(e) => e.into(),
        }
    }
}
