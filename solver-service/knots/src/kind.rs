//! What the namer can name ([`KnotType`]) and the largest diagram it evaluates.

/// The knots [`crate::identify`] can name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum KnotType {
    /// No knot.
    Unknot,
    /// The overhand knot, either hand.
    Trefoil,
    /// The square (reef) knot: a trefoil and its mirror in series.
    Square,
    /// The granny knot: two trefoils of the same hand in series.
    Granny,
    /// The double overhand knot (the knot 5₁, the cinquefoil): an overhand whose end passes twice
    /// round, the first throw of the surgeon's knot (the long end wrapped twice round the needle
    /// driver).
    DoubleOverhand,
    /// The surgeon's knot: a double overhand and a trefoil of the other hand in series (the square
    /// knot with its first throw doubled; the surgeon's double throw, then a single throw the other
    /// way).
    Surgeons,
    /// Anything else (including diagrams too large to evaluate).
    Other,
}

impl KnotType {
    /// Lower-case name, as printed by the tools.
    pub fn name(self) -> &'static str {
        match self {
            KnotType::Unknot => "unknot",
            KnotType::Trefoil => "trefoil",
            KnotType::Square => "square",
            KnotType::Granny => "granny",
            KnotType::DoubleOverhand => "double-overhand",
            KnotType::Surgeons => "surgeons",
            KnotType::Other => "other",
        }
    }
}

/// Reduced diagrams larger than this are not evaluated and count as [`KnotType::Other`] (the bracket's
/// sweep keeps at most 2^k partial states after k crossings, fewer on a narrow diagram).
pub const MAX_EVALUATED_CROSSINGS: usize = 18;
