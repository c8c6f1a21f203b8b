//! How a peer waits (spin, event, hybrid) and where its thread runs.

/// How a server of this protocol waits for requests, and how a client waits for its response.
///
/// `spin` polls without pause (one core at 100 %, the lowest latency); `event` sleeps until notified
/// (no CPU while idle, one wake-up per message); `hybrid` sleeps like `event` but spins for a short
/// budget after each message, so a burst (a 1 kHz haptic loop) is served at spin latency while an idle
/// peer sleeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum WaitMode {
    /// Busy-poll.
    Spin,
    /// Sleep until notified.
    Event,
    /// Sleep until notified, then spin for a budget after each message (the default).
    #[default]
    Hybrid,
}

impl WaitMode {
    /// The mode's name on command lines.
    pub fn name(self) -> &'static str {
        match self {
            WaitMode::Spin => "spin",
            WaitMode::Event => "event",
            WaitMode::Hybrid => "hybrid",
        }
    }
}

/// How a peer waits, with its spin budget: what the service's loop and a client's calls take
/// ([`WaitMode`] names it on command lines, where the budget is an option of its own).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wait {
    /// Busy-poll (the lowest latency; costs a core while waiting).
    Spin,
    /// Sleep until notified.
    Event,
    /// Sleep until notified; spin for the budget after each message (a server) or before sleeping
    /// (a client).
    Hybrid(std::time::Duration),
}

impl Wait {
    /// The mode, without the budget.
    pub fn mode(self) -> WaitMode {
        match self {
            Wait::Spin => WaitMode::Spin,
            Wait::Event => WaitMode::Event,
            Wait::Hybrid(_) => WaitMode::Hybrid,
        }
    }
}

impl WaitMode {
    /// This mode with a spin budget (used by `hybrid` only).
    pub fn with_budget(self, budget: std::time::Duration) -> Wait {
        match self {
            WaitMode::Spin => Wait::Spin,
            WaitMode::Event => Wait::Event,
            WaitMode::Hybrid => Wait::Hybrid(budget),
        }
    }
}

/// Pins the calling thread to CPU `core` (latency runs on two cores: the service on one, a client on
/// the other).
pub fn pin_current_thread(core: usize) -> Result<(), String> {
    let id = core_affinity::get_core_ids()
        .unwrap_or_default()
        .into_iter()
        .find(|c| c.id == core)
        .ok_or_else(|| format!("--pin {core}: no such core"))?;
    if core_affinity::set_for_current(id) {
        Ok(())
    } else {
        Err(format!("--pin {core}: the scheduler refused"))
    }
}
