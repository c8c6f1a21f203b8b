//! Knot identification from a chain's geometry: unknot, trefoil, square, granny, double overhand,
//! surgeon's knot or other.
//!
//! An open rope has no knot type until it is closed. The rope is closed through a point far away (three
//! times the rope's radius from its centroid, so the closing arc stays clear of the knotted region), seen
//! along a projection direction, and its crossings found with their over/under order and their signs.
//! The cyclic sequence of crossings along the rope (its Gauss code) is reduced with Reidemeister moves I
//! (a crossing met twice in a row: a kink) and II (two crossings met in a row twice, over-over and
//! under-under: a bigon). The reduced diagram's Jones polynomial, a knot invariant computed from the
//! Kauffman bracket (a sum over the 2^c smoothings of its `c` crossings, taken by a sweep over the
//! crossings that merges the smoothings that pair the open arcs alike), names the knot:
//!
//! | knot | Jones polynomial `V(t)` (one chirality; the mirror has `t → 1/t`) | determinant | writhe |
//! |---|---|---|---|
//! | unknot | `1` | 1 | 0 |
//! | trefoil (overhand) | `t + t³ − t⁴` | 3 | ±3 |
//! | granny = trefoil # trefoil | `(t + t³ − t⁴)²` | 9 | ±6 |
//! | square = trefoil # mirror | `(t + t³ − t⁴)(t⁻¹ + t⁻³ − t⁻⁴)` | 9 | 0 |
//! | double overhand (5₁, the cinquefoil; the surgeon's first throw) | `t² + t⁴ − t⁵ + t⁶ − t⁷` | 5 | ±5 |
//! | surgeon's knot = double overhand # mirror trefoil | `(t² + t⁴ − t⁵ + t⁶ − t⁷)(t⁻¹ + t⁻³ − t⁻⁴)` | 15 | ±2 |
//!
//! The determinant `|V(−1)|` alone cannot tell square from granny, nor the double overhand from the
//! figure eight (4₁, also 5), nor the surgeon's knot from its granny form (the second throw the same
//! way as the first: `5₁ # 3₁`, also 15) or the prime knot 7₄ (also 15); the polynomial can. Any
//! other polynomial is "other" (the three-twist knot 5₂, for one, which an overhand with a twisted
//! loop makes).
//!
//! The double overhand is the (2, 5) torus knot: the Knot Atlas (knot 5₁: "also known as the Double
//! Overhand Knot") and Wikipedia ("Cinquefoil knot": "the closed version of the double overhand
//! knot") both say so, and a coil of two turns round a strand, its ends joined past the strand's, is
//! the closed 2-braid σ₁⁵ (four half-twists of the coil and the crossing that closes it).
//!
//! What is checked, exactly: the open rope is closed in six ways (six closure directions spread over the
//! sphere), and each closed curve is named from one projection. A closed curve has one knot type, so
//! every generic view of one closure gives the same name; views only differ in whether they are
//! degenerate (three strands nearly meeting, a crossing on a joint), and [`identify`] tries up to three
//! views per closure to find a generic one. What can differ is the closures: an open rope's knot
//! depends on how it is closed when the ends are inside the tangle (a closing arc through the knot). The
//! report gives the majority name and how many of the six closures agree with it.
//! This is a tool (it allocates); it is not on the per-move path.
//!
//! Beside the namer, the crate holds the geometry the knots are tied with and checked by, written once
//! and used by the kernel's and the world's tests and benches as by the hand controllers:
//!
//! * [`script`]: hand scripts (turns, throws, loops, tucks, wraps, instrument poses, the needle's arc)
//!   and the built-in knots;
//! * [`check`]: independent checks (segment distance, the swept-volume crossing check between two
//!   states), sharing no code with the solver they check;
//! * [`contact`]: where a knot's crossings are, and which way pulls a joint away from them;
//! * [`vec3`]: the scripts' small arithmetic on `[f64; 3]`.
//!
//! No I/O and no solver: the crate depends on nalgebra, serde and toml only.

pub mod check;
pub mod contact;
mod diagram;
mod kind;
mod name;
pub mod script;
pub mod vec3;

pub use kind::*;
pub use name::*;
