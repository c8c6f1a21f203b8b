//! A bundle of strands (hair, fur, many sutures) swept on both cores: the kernel's
//! [`tractrix::strands::Strands`] cut in two at a block boundary, one half kept by the caller's thread
//! and one owned by a helper thread that sleeps on a channel between moves.
//!
//! A move validates every target first (an error changes nothing), stages the helper's half and sends
//! it over (moving a `Vec` moves three words, not the strands), sweeps its own half meanwhile, and takes
//! the helper's half back. Waking the helper costs a futex wake-up (tens of µs on a loaded VM), which is
//! why small bundles stay on one thread: the cut is made only when a move's link-steps reach
//! [`TWO_CORES_FROM`]. The helper never spins, so it takes a core only while it computes; a client that
//! busy-polls on the other core competes with it (then pass `two_cores = false`).

use nalgebra::Vector3;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;
use tractrix::strands::{LANES, Simd, StrandReal, Strands, StrandsError};

/// Link-steps per move (strands × links × substeps) from which a bundle is swept on two cores.
pub const TWO_CORES_FROM: usize = 50_000;

type Job<T> = (Strands<T>, usize);

/// Why a move of a bundle's strands was not made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MoveError {
    /// The targets or substeps (nothing changed).
    #[error(transparent)]
    Strands(#[from] StrandsError),
    /// The helper thread died mid-move (a kernel bug) with half of the strands.
    #[error("the strands helper thread died with half of the strands")]
    HelperDied,
}

#[derive(Debug)]
struct Helper<T> {
    to: Option<SyncSender<Job<T>>>,
    from: Receiver<(Strands<T>, Result<(), StrandsError>)>,
    thread: Option<JoinHandle<()>>,
}

impl<T> Drop for Helper<T> {
    fn drop(&mut self) {
        // Closing the channel ends the helper's loop.
        self.to = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Strands on one or two cores (see the module docs).
#[derive(Debug)]
pub struct Bundle<T: StrandReal + Send> {
    first: Strands<T>,
    /// The helper's half while it is home (always, between moves).
    second: Option<Strands<T>>,
    helper: Option<Helper<T>>,
    /// Strands in `first`.
    split: usize,
    n_strands: usize,
    simd: Simd,
}

impl<T: StrandReal + Send> Clone for Bundle<T> {
    /// A copy of the strands, with a helper of its own when this one has one (or on one thread if
    /// the helper cannot be started).
    fn clone(&self) -> Self {
        let whole = self.whole();
        match Bundle::new(whole.clone(), self.on_two_cores()) {
            Ok(b) => b,
            Err(_) => Bundle {
                split: whole.n_strands(),
                n_strands: whole.n_strands(),
                first: whole,
                second: None,
                helper: None,
                simd: self.simd,
            },
        }
    }
}

impl<T: StrandReal + Send> Bundle<T> {
    /// Takes `strands`; cuts them in two and starts the helper thread when `two_cores` and a one-substep
    /// move would reach [`TWO_CORES_FROM`] link-steps.
    pub fn new(mut strands: Strands<T>, two_cores: bool) -> std::io::Result<Self> {
        let n_strands = strands.n_strands();
        let work = n_strands * strands.n_links();
        let at = strands.n_blocks() / 2;
        let second = if two_cores && work >= TWO_CORES_FROM {
            strands.split_off_blocks(at)
        } else {
            None
        };
        let helper = match second {
            None => None,
            Some(_) => {
                let (to, jobs) = sync_channel::<Job<T>>(1);
                let (done, from) = sync_channel(1);
                let thread = std::thread::Builder::new()
                    .name("strands-helper".into())
                    .spawn(move || {
                        for (mut half, substeps) in jobs {
                            let r = half.sweep_staged(substeps, Simd::Best);
                            if done.send((half, r)).is_err() {
                                break;
                            }
                        }
                    })?;
                Some(Helper {
                    to: Some(to),
                    from,
                    thread: Some(thread),
                })
            }
        };
        Ok(Bundle {
            split: if second.is_some() {
                at * LANES
            } else {
                n_strands
            },
            n_strands,
            first: strands,
            second,
            helper,
            simd: Simd::Best,
        })
    }

    /// Whether moves run on two cores.
    pub fn on_two_cores(&self) -> bool {
        self.helper.is_some()
    }
    /// Strands.
    pub fn n_strands(&self) -> usize {
        self.n_strands
    }
    /// Links per strand.
    pub fn n_links(&self) -> usize {
        self.first.n_links()
    }

    /// Moves every strand's head to its target in `substeps` substeps. On error nothing changes.
    pub fn move_heads(&mut self, targets: &[Vector3<T>], substeps: usize) -> Result<(), MoveError> {
        if targets.len() != self.n_strands {
            return Err(StrandsError::TargetCount {
                got: targets.len(),
                want: self.n_strands,
            }
            .into());
        }
        if substeps == 0 {
            return Err(StrandsError::NoSubsteps.into());
        }
        let (mine, theirs) = targets.split_at(self.split);
        self.first.stage(mine)?;
        let Some(mut second) = self.second.take() else {
            if self.helper.is_some() {
                // Only after the helper died mid-move (a kernel bug): its half went with it.
                return Err(MoveError::HelperDied);
            }
            return Ok(self.first.sweep_staged(substeps, self.simd)?);
        };
        if let Err(e) = second.stage(theirs) {
            self.second = Some(second);
            return Err(match e {
                StrandsError::NonFinite(i) => StrandsError::NonFinite(i + self.split),
                e => e,
            }
            .into());
        }
        let sent = match self.helper.as_ref().and_then(|h| h.to.as_ref()) {
            Some(to) => to.send((second, substeps)).map_err(|e| e.0.0),
            None => Err(second),
        };
        if let Err(mut second) = sent {
            // The helper is gone: both halves on this thread from now on.
            self.helper = None;
            let r = second.sweep_staged(substeps, self.simd);
            self.second = Some(second);
            return Ok(r.and_then(|()| self.first.sweep_staged(substeps, self.simd))?);
        }
        let mine = self.first.sweep_staged(substeps, self.simd);
        // Returns when the helper answers, or at once with an error if it has died (its sender drops).
        let back = self.helper.as_ref().map(|h| h.from.recv());
        match back {
            Some(Ok((half, r))) => {
                self.second = Some(half);
                Ok(r.and(mine)?)
            }
            _ => Err(MoveError::HelperDied),
        }
    }

    /// All the strands in one [`Strands`] (a copy).
    pub fn whole(&self) -> Strands<T> {
        let mut w = self.first.clone();
        if let Some(s) = &self.second {
            // `first` is whole blocks of the same strands: appending cannot fail.
            let _ = w.append_blocks(s.clone());
        }
        w
    }

    /// Puts every strand back as in `whole` (the same shape: a reset to the scene's strands); the cut
    /// between the two threads stays where it is.
    pub fn set_to(&mut self, whole: &Strands<T>) {
        let mut first = whole.clone();
        if self.second.is_some() {
            self.second = first.split_off_blocks(self.split / LANES);
        } else if self.helper.is_some() {
            // The helper died with its half: from now on everything lives on this thread.
            self.helper = None;
            self.split = self.n_strands;
        }
        self.first = first;
    }

    /// Blocks of [`LANES`] strands.
    pub fn n_blocks(&self) -> usize {
        self.n_strands.div_ceil(LANES)
    }

    /// Block `b`'s joints, strand after strand, each tail first, written through `f` straight into
    /// `out` ([`Strands::block_joints_into`]); returns how many were written (0 for a block lost with a
    /// dead helper, or past the end).
    pub fn block_joints_into<U>(
        &self,
        b: usize,
        out: &mut [U],
        f: impl FnMut(Vector3<T>) -> U,
    ) -> usize {
        let first = self.first.n_blocks();
        if b < first {
            self.first.block_joints_into(b, out, f)
        } else if let Some(s) = &self.second {
            s.block_joints_into(b - first, out, f)
        } else {
            0
        }
    }

    /// Calls `f` with strand `i`'s joints, tail first (nothing for a strand lost with a dead helper).
    pub fn for_each_joint(&self, i: usize, f: impl FnMut(Vector3<T>)) {
        if i < self.split {
            self.first.for_each_joint(i, f);
        } else if let Some(s) = &self.second {
            s.for_each_joint(i - self.split, f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bundle_on_two_cores_moves_as_one_strands_does() {
        let heads: Vec<Vector3<f64>> = (0..3001)
            .map(|i| Vector3::new((i % 50) as f64, 0.0, (i / 50) as f64))
            .collect();
        let whole = Strands::straight(&heads, 20, 0.5, -Vector3::y()).unwrap();
        let mut one = whole.clone();
        let mut two = Bundle::new(whole, true).unwrap();
        assert!(two.on_two_cores());
        for f in 0..20 {
            let a = f as f64 * 0.3;
            let targets: Vec<_> = heads
                .iter()
                .map(|h| h + Vector3::new(a.cos(), 0.2, a.sin()))
                .collect();
            one.move_heads(&targets, 2, Simd::Best).unwrap();
            two.move_heads(&targets, 2).unwrap();
        }
        for i in [0, 1, 1499, 1500, 1504, 3000] {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            one.for_each_joint(i, |p| a.push(p));
            two.for_each_joint(i, |p| b.push(p));
            assert_eq!(a, b, "strand {i}");
        }
        // A bad target in the helper's half is refused with its index, and nothing moves.
        let mut bad: Vec<_> = heads.clone();
        bad[2999].x = f64::NAN;
        let before: Vec<_> = (0..3001)
            .map(|i| {
                let mut v = Vec::new();
                two.for_each_joint(i, |p| v.push(p));
                v
            })
            .collect();
        let e = two.move_heads(&bad, 1).unwrap_err();
        assert_eq!(e, MoveError::Strands(StrandsError::NonFinite(2999)), "{e}");
        assert!(two.move_heads(&heads[1..], 1).is_err());
        for (i, b) in before.iter().enumerate() {
            let mut v = Vec::new();
            two.for_each_joint(i, |p| v.push(p));
            assert_eq!(&v, b);
        }
        let small = Strands::straight(&heads[..10], 20, 0.5, -Vector3::y()).unwrap();
        assert!(!Bundle::new(small, true).unwrap().on_two_cores());
    }
}
