//! What every tool's `main` shares: exit codes 0 ok, 1 failure, 2 usage (clap's own usage errors exit 2
//! too), and a closed stdout (`chainctl query rope | head -1`) ending the tool quietly.

use std::process::ExitCode;

/// A usage error (bad arguments): the tool exits with 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Usage(pub String);

/// Wraps a message as a [`Usage`] error, for `.map_err(usage)?`.
pub fn usage(msg: impl std::fmt::Display) -> anyhow::Error {
    Usage(msg.to_string()).into()
}

/// Whether an error is a write to a closed pipe.
fn broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Runs a tool's `run` and maps the result to an exit code: the code `run` returned, 2 for a [`Usage`]
/// error, 1 for any other (printed as `tool: message`), 0 without a word when the reader of stdout went
/// away (a `println!` to a closed pipe included).
pub fn main(tool: &str, run: impl FnOnce() -> anyhow::Result<u8>) -> ExitCode {
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let text = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if text.starts_with("failed printing to stdout") && text.contains("Broken pipe") {
            std::process::exit(0);
        }
        default_hook(info);
    }));
    match run() {
        Ok(code) => ExitCode::from(code),
        Err(e) if broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{tool}: {e:#}");
            if e.is::<Usage>() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
