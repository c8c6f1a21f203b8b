//! Who holds which grasp (issue 35): a grasp belongs to the client that took it, named by its iceoryx2
//! client port id. Another client's release of that joint, move of it or reset of the chain is refused
//! as [`crate::refusal::Cause::Held`], the owner in the reason, unless the command takes the grasp
//! over (then the grasps it touches become the requester's). One client owns at most
//! [`MAX_GRASPS_PER_CLIENT`] grasps of a chain, so the chain's [`crate::sizes::MAX_HELD`] slots
//! cannot all be taken by one client.
//!
//! Unowned grasps ([`LOCAL`] as owner) are anyone's: those of batch mode, of a journal's replay (the
//! owner is not journaled: after `--restore` every grasp is a clamp that any client may release or
//! take), and those whose owner's port has gone ([`Owners::forget_absent`], run by the service while
//! grasps are owned: a client that exits or dies leaves its grasps holding, unowned). Anchors are the
//! scene's and are refused earlier, at decoding, for every client.
//!
//! Ownership is not part of the persisted state: it never changes a joint, only who may.

use crate::command::Command;
use crate::refusal::Refusal;
use crate::refuse;
use crate::sizes::MAX_GRASPS_PER_CLIENT;

/// The requester of batch mode, the Unix socket and the journal's replay, and the owner of an unowned
/// grasp.
pub const LOCAL: u128 = 0;

/// The owners of the grasps of every chain (anchors are not listed).
#[derive(Debug, Clone, Default)]
pub struct Owners {
    /// Per chain: (joint, owner) for every owned grasp.
    chains: Vec<Vec<(usize, u128)>>,
    /// A chain's list before the last change, while it can be undone.
    undo: Option<(usize, Vec<(usize, u128)>)>,
}

impl Owners {
    /// No grasp owned, over `chains` chains.
    pub fn new(chains: usize) -> Self {
        Owners {
            chains: vec![Vec::new(); chains],
            undo: None,
        }
    }

    fn owner(&self, chain: usize, joint: usize) -> u128 {
        self.chains[chain]
            .iter()
            .find(|(j, _)| *j == joint)
            .map_or(LOCAL, |(_, o)| *o)
    }

    /// Whether `client` may make `req` (before it runs): a refusal names the owner in the way.
    pub fn check(&self, client: u128, req: &Command<'_>) -> Result<(), Refusal> {
        let (chain, joint, take_over) = match *req {
            Command::Grasp {
                chain,
                joint,
                take_over,
            }
            | Command::Release {
                chain,
                joint,
                take_over,
            } => (chain as usize, Some(joint), take_over),
            Command::Move {
                chain,
                joint,
                take_over,
                ..
            } => (chain as usize, Some(joint), take_over),
            Command::Reset { chain, take_over } => (chain as usize, None, take_over),
            _ => return Ok(()),
        };
        let Some(list) = self.chains.get(chain) else {
            return Ok(());
        };
        let other = |o: u128| o != LOCAL && o != client;
        if !take_over {
            let blocking = match joint {
                Some(j) => Some(self.owner(chain, j))
                    .filter(|&o| other(o))
                    .map(|o| (j, o)),
                None => list.iter().copied().find(|&(_, o)| other(o)),
            };
            if let Some((j, o)) = blocking {
                return Err(refuse!(
                    Held,
                    "joint {j} is grasped by client {o:x}; flag take-over (4) takes it"
                ));
            }
        }
        // A grasp, or a move that takes another client's grasp over, would give the client one more.
        let gains = match *req {
            Command::Grasp { joint, .. } => Some(joint),
            Command::Move {
                joint,
                take_over: true,
                ..
            } if other(self.owner(chain, joint)) => Some(joint),
            _ => None,
        };
        if let (Some(joint), true) = (gains, client != LOCAL) {
            let mine = list.iter().filter(|&&(_, o)| o == client).count();
            if self.owner(chain, joint) != client && mine >= MAX_GRASPS_PER_CLIENT {
                return Err(refuse!(
                    BadOption,
                    "this client owns {mine} grasps of the chain, the most one client may"
                ));
            }
        }
        Ok(())
    }

    /// Records what an accepted `req` of `client` did to the grasps; `anchors` are never owned.
    pub fn record(&mut self, client: u128, req: &Command<'_>, anchors: &[u32]) {
        let chain = match *req {
            Command::Grasp { chain, joint, .. } if !anchors.contains(&(joint as u32)) => chain,
            Command::Release { chain, .. }
            | Command::Move {
                chain,
                take_over: true,
                ..
            }
            | Command::Reset { chain, .. } => chain,
            _ => {
                self.undo = None;
                return;
            }
        } as usize;
        let Some(list) = self.chains.get_mut(chain) else {
            return;
        };
        self.undo = Some((chain, list.clone()));
        match *req {
            Command::Grasp { joint, .. } => {
                list.retain(|&(j, _)| j != joint);
                if client != LOCAL {
                    list.push((joint, client));
                }
            }
            Command::Release { joint, .. } => list.retain(|&(j, _)| j != joint),
            Command::Move { joint, .. } => {
                for e in list.iter_mut().filter(|e| e.0 == joint) {
                    e.1 = client;
                }
            }
            _ => list.clear(),
        }
    }

    /// Forgets the undo of the request before (a new request begins).
    pub fn begin(&mut self) {
        self.undo = None;
    }

    /// Undoes the last [`Owners::record`] (the change it followed was undone).
    pub fn undo(&mut self) {
        if let Some((chain, list)) = self.undo.take() {
            self.chains[chain] = list;
        }
    }

    /// Whether any grasp has an owner (the service then looks for owners that have gone).
    pub fn any(&self) -> bool {
        self.chains.iter().any(|l| !l.is_empty())
    }

    /// Leaves the grasps of clients for which `present` is false holding, unowned; returns how many.
    pub fn forget_absent(&mut self, present: impl Fn(u128) -> bool) -> usize {
        let mut n = 0;
        for l in &mut self.chains {
            let before = l.len();
            l.retain(|&(_, o)| present(o));
            n += before - l.len();
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::Point;

    fn grasp(joint: usize) -> Command<'static> {
        Command::Grasp {
            chain: 0,
            joint,
            take_over: false,
        }
    }

    /// A move that takes another client's grasp over gives the mover one more grasp: it counts
    /// against the cap like a grasp does, so taking over cannot raise a client past it.
    #[test]
    fn taking_a_grasp_over_by_a_move_counts_against_the_cap() {
        let (a, b) = (0xa, 0xb);
        let mut owners = Owners::new(1);
        let cap = MAX_GRASPS_PER_CLIENT;
        for j in 0..cap {
            owners.check(a, &grasp(j)).unwrap();
            owners.record(a, &grasp(j), &[]);
        }
        owners.check(b, &grasp(40)).unwrap();
        owners.record(b, &grasp(40), &[]);
        let target = [Point::new(1.0, 0.0, 0.0)];
        let take = Command::Move {
            chain: 0,
            joint: 40,
            targets: &target,
            options: tractrix::MoveOptions::default(),
            take_over: true,
            smooth: false,
            pull: false,
            needle: crate::command::NeedleMove::Carried,
        };
        let e = owners.check(a, &take).unwrap_err();
        assert_eq!(e.cause, crate::refusal::Cause::BadOption, "{}", e.reason());
        assert!(
            e.reason().contains("the most one client may"),
            "{}",
            e.reason()
        );
        // A move of a joint it already owns, or a take-over below the cap, is allowed.
        let own = Command::Move {
            chain: 0,
            joint: 0,
            targets: &target,
            options: tractrix::MoveOptions::default(),
            take_over: true,
            smooth: false,
            pull: false,
            needle: crate::command::NeedleMove::Carried,
        };
        owners.check(a, &own).unwrap();
        let release = Command::Release {
            chain: 0,
            joint: 0,
            take_over: false,
        };
        owners.record(a, &release, &[]);
        owners.check(a, &take).unwrap();
        owners.record(a, &take, &[]);
        assert_eq!(owners.owner(0, 40), a);
    }
}
