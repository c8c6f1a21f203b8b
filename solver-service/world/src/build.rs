//! Why a scene's world could not be built.

use tractrix::ChainError;

/// Why a scene's world could not be built (a validated scene builds; these are the kernel's last
/// word and the operating system's).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// A chain the kernel refuses.
    #[error("chain {name:?}: {source}")]
    Chain {
        /// The chain.
        name: String,
        /// The kernel's reason.
        source: ChainError,
    },
    /// A bundle the kernel refuses.
    #[error("bundle {name:?}: {source}")]
    Bundle {
        /// The bundle.
        name: String,
        /// The kernel's reason.
        source: tractrix::strands::StrandsError,
    },
    /// A bundle whose helper thread could not start.
    #[error("bundle {name:?}: cannot start its helper thread: {why}")]
    Helper {
        /// The bundle.
        name: String,
        /// The operating system's reason.
        why: String,
    },
}
