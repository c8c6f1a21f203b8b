//! The header fields every request checks, whatever it addresses (a chain or a bundle): the command,
//! the reserved words, the flags, every wire enumeration and every float option.

use shared::{Precision, RequestHeader, SubstepMode, WireMethod, WireStrategy};
use world::refusal::Refusal;
use world::refuse;

fn wire_enum<E: TryFrom<u32, Error = u32>>(v: u32, field: &str, range: &str) -> Result<E, Refusal> {
    E::try_from(v).map_err(|v| refuse!(BadOption, "{field} {v} is not one of {range}"))
}

/// The header fields every command checks, whatever it addresses: the command, the reserved words,
/// the flags (`allowed` bits), every wire enumeration and every float option.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Checked {
    pub command: shared::Command,
    pub method: WireMethod,
    pub precision: Precision,
    pub substep_mode: SubstepMode,
    pub strategy: WireStrategy,
}

/// Checks what [`Checked`] holds.
pub(crate) fn check_header(h: &RequestHeader, allowed: u32) -> Result<Checked, Refusal> {
    let command = shared::Command::try_from(h.command)
        .map_err(|c| refuse!(UnknownCommand, "command {c} is not one of 1..=10"))?;
    if h.reserved != [0, 0] {
        return Err(refuse!(BadOption, "reserved fields must be zero"));
    }
    if h.flags & !allowed != 0 {
        return Err(refuse!(
            BadOption,
            "unknown flag bits {:#x}",
            h.flags & !allowed
        ));
    }
    let method: WireMethod = wire_enum(h.method, "method", "0..=3")?;
    let precision: Precision = wire_enum(h.precision, "precision", "0..=2")?;
    let substep_mode: SubstepMode = wire_enum(h.substep_mode, "substep_mode", "0..=2")?;
    let strategy: WireStrategy = wire_enum(h.strategy, "strategy", "0..=3")?;
    // Every float option is checked, whether or not the command uses it: NonFinite means what it says
    // for any field.
    if !h.max_step.is_finite() {
        return Err(refuse!(NonFinite, "max_step is not finite"));
    }
    if !h.tolerance.is_finite() {
        return Err(refuse!(NonFinite, "tolerance is not finite"));
    }
    Ok(Checked {
        command,
        method,
        precision,
        substep_mode,
        strategy,
    })
}
