//! The bounds on what a scene or a request may ask for: every size read from outside is checked
//! against one of these before anything is allocated. The wire protocol (`shared`) states the same
//! bounds to clients; the service checks at compile time that the two agree.

/// Most chains in one scene.
pub const MAX_CHAINS: usize = 256;
/// Most links in one chain.
pub const MAX_LINKS: usize = 65_536;
/// Most bytes of a chain's or bundle's name (UTF-8).
pub const MAX_NAME_BYTES: usize = 31;
/// Most held joints (anchors and grasps) one chain may have; a grasp beyond is refused.
pub const MAX_HELD: usize = 64;
/// Most eyelets one chain may pass through.
pub const MAX_EYELETS: usize = 64;
/// Most grasps one client may own on one chain, so that one client cannot take all [`MAX_HELD`] slots.
pub const MAX_GRASPS_PER_CLIENT: usize = 16;
/// Most joints (strands × (links + 1)) of one bundle.
pub const MAX_BUNDLE_JOINTS: usize = 1 << 20;
/// Most strands in a bundle.
pub const MAX_BUNDLE_STRANDS: usize = 1 << 17;

/// How far from the origin, in shortest links, a free chain's target may lie on any axis: 2³² links in
/// f64 and 2¹² in f32. Beyond it the spacing of floating-point numbers exceeds 2⁻²⁰ of a link (f64) or
/// 2⁻¹¹ (f32), and joint positions there can no longer carry the link lengths. A 1-unit link in f64
/// may be moved 4.3·10⁹ units from the origin.
pub fn max_coordinate(shortest_link: f64, f32_chain: bool) -> f64 {
    shortest_link * if f32_chain { 4096.0 } else { 4_294_967_296.0 }
}
