//! What every tool's `main` shares: exit codes 0 ok, 1 failure, 2 usage.

/// A usage error (bad arguments): the tool exits with 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Usage(pub String);

/// Wraps a message as a [`Usage`] error, for `.map_err(usage)?`.
pub fn usage(msg: impl std::fmt::Display) -> anyhow::Error {
    Usage(msg.to_string()).into()
}

/// Prints an error as `tool: message` and exits: the code `run` returned, 2 for a [`Usage`] error, 1 for
/// any other.
pub fn exit_with(tool: &str, result: anyhow::Result<i32>) -> ! {
    std::process::exit(match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("{tool}: {e:#}");
            if e.is::<Usage>() { 2 } else { 1 }
        }
    })
}
