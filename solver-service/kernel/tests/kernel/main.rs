//! Kernel tests: one binary, one module per topic.
//!
//! * `link`: one link, three ways, against each other and against the ground truth; where the paper's
//!   form breaks.
//! * `chain`: invariants of RESOLUTION-TRACTRIX (lengths, landing, planarity, motion dying out), interior
//!   and tail moves, errors that change nothing.
//! * `extremes`: 10⁶ random moves (zero, collinear, perpendicular, 10⁻¹²·L, 10⁹·L), link lengths from
//!   10⁻⁶ to 10⁶, chains of 1 and 10⁶ links, f32 drift.
//! * `convergence`: error against the continuous ground truth on a 40-link rope following a helix, per
//!   doubling of substeps (≈4× tractrix, ≈2× follow-the-leader).
//! * `collision`: clearance kept after every accepted move (tree vs brute force, spheres, obstacles),
//!   locked moves change nothing, the overhand knot holds with collision on a fine enough rope.
//! * `fixed_base`: both strategies converge with the base unmoved; unreachable targets are reported;
//!   the DLS baseline; joint angles.
//! * `hold`: held joints bit for bit unchanged, moves landing or refused with the nearest point,
//!   lengths kept, no holds = the free move bit for bit.
//! * `instrument`: instruments moved by pose push the rope without penetration, keep held joints, and
//!   lock when the rope would pass through them.
//! * `resumed`: a held rope's substep that needs several requests' work inside a frame goes on from
//!   its kept passes and lands, its held side moving a joint more than half a clearance.
//! * `strands`: many strands at once, against one chain per strand, SIMD against the baseline bit for
//!   bit, halves on two threads, refusals, lengths over 10⁵ moves.
//! * `eyelet`: a rope threaded through fixed points slides through them both ways by any length,
//!   each point on its link to 1e-9 after every move, an interior joint pushed through passes the
//!   eyelet on, the rope leaves an eyelet when its end slides out.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

mod chain;
mod collision;
mod convergence;
mod extremes;
mod eyelet;
mod fixed_base;
mod hold;
mod instrument;
mod limits;
mod link;
mod resumed;
mod strands;
mod support;
