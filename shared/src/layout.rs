//! Every wire type's byte layout, checked at compile time: what the crate docs' table and the C
//! header list, and what the other languages' mirrors are checked against.

use crate::{RequestHeader, ResponseHeader, StateHeader, Vec3};

/// One field of a wire type, as the crate docs' layout table lists it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldLayout {
    pub name: &'static str,
    pub offset: usize,
    /// The C type, as a C header declares it (`uint32_t`, `double`, `uint8_t[32]` ...).
    pub c_type: &'static str,
}

/// Layout of one wire type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TypeLayout {
    pub name: &'static str,
    /// The iceoryx2 type name.
    pub type_name: &'static str,
    pub size: usize,
    pub align: usize,
    pub fields: &'static [FieldLayout],
}

macro_rules! wire_layout {
    ($t:ident, $tn:literal, size = $size:literal, align = $align:literal,
     [$($f:ident : $c:literal @ $off:literal),* $(,)?]) => {
        const _: () = {
            assert!(core::mem::size_of::<$t>() == $size);
            assert!(core::mem::align_of::<$t>() == $align);
            $(assert!(core::mem::offset_of!($t, $f) == $off);)*
        };
        impl $t {
            /// The byte layout (checked at compile time).
            pub const LAYOUT: TypeLayout = TypeLayout {
                name: stringify!($t),
                type_name: $tn,
                size: $size,
                align: $align,
                fields: &[$(FieldLayout { name: stringify!($f), offset: $off, c_type: $c }),*],
            };
        }
    };
}

wire_layout!(Vec3, "tractrix.v2.Vec3", size = 24, align = 8, [
    x: "double" @ 0, y: "double" @ 8, z: "double" @ 16,
]);
wire_layout!(RequestHeader, "tractrix.v2.RequestHeader", size = 96, align = 8, [
    command: "uint32_t" @ 0, chain: "uint32_t" @ 4, joint: "uint32_t" @ 8, method: "uint32_t" @ 12,
    precision: "uint32_t" @ 16, substep_mode: "uint32_t" @ 20, substeps: "uint32_t" @ 24,
    strategy: "uint32_t" @ 28, max_iterations: "uint32_t" @ 32, flags: "uint32_t" @ 36,
    client_listener: "uint64_t[2]" @ 40, request_id: "uint64_t" @ 56, max_step: "double" @ 64,
    tolerance: "double" @ 72, reserved: "uint64_t[2]" @ 80,
]);
wire_layout!(ResponseHeader, "tractrix.v2.ResponseHeader", size = 288, align = 8, [
    status: "uint32_t" @ 0, command: "uint32_t" @ 4, chain: "uint32_t" @ 8, n_joints: "uint32_t" @ 12,
    n_angles: "uint32_t" @ 16, iterations: "uint32_t" @ 20, substeps: "uint32_t" @ 24,
    paper_fallbacks: "uint32_t" @ 28, sequence: "uint64_t" @ 32, request_id: "uint64_t" @ 40,
    solve_ns: "uint64_t" @ 48, residual: "double" @ 56, n_chains: "uint32_t" @ 64, kind: "uint32_t" @ 68,
    dims: "uint32_t" @ 72, n_links: "uint32_t" @ 76, precision: "uint32_t" @ 80, method: "uint32_t" @ 84,
    collision: "uint32_t" @ 88, substep_mode: "uint32_t" @ 92, substeps_default: "uint32_t" @ 96,
    n_held: "uint32_t" @ 100, max_step: "double" @ 104, total_length: "double" @ 112,
    thickness: "double" @ 120, name: "uint8_t[32]" @ 128, reason: "uint8_t[96]" @ 160,
    n_instruments: "uint32_t" @ 256, limits: "uint32_t" @ 260, limit_value: "double" @ 264,
    n_pulls: "uint32_t" @ 272, knot: "uint32_t" @ 276, n_eyelets: "uint32_t" @ 280,
    n_tissue: "uint32_t" @ 284,
]);
wire_layout!(StateHeader, "tractrix.v2.StateHeader", size = 48, align = 8, [
    sequence: "uint64_t" @ 0, chain: "uint32_t" @ 8, n_joints: "uint32_t" @ 12, command: "uint32_t" @ 16,
    n_held: "uint32_t" @ 20, request_id: "uint64_t" @ 24, n_instruments: "uint32_t" @ 32,
    n_pulls: "uint32_t" @ 36, knot: "uint32_t" @ 40, n_eyelets: "uint32_t" @ 44,
]);

/// Every wire type's layout, in the order of the crate docs' table.
pub const WIRE_TYPES: [TypeLayout; 4] = [
    Vec3::LAYOUT,
    RequestHeader::LAYOUT,
    ResponseHeader::LAYOUT,
    StateHeader::LAYOUT,
];
