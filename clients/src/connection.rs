//! What the command-line tools add to a connection ([`client`]): the service options every tool
//! takes, a pacer for fixed-rate requests, a count of refusals.

pub use client::*;

use std::time::{Duration, Instant};

/// The service options every command-line tool takes (`#[command(flatten)]`).
#[derive(Debug, Clone, clap::Args)]
pub struct ToolArgs {
    /// iceoryx2 prefix of the service.
    #[arg(long, env = shared::PREFIX_ENV, default_value = shared::DEFAULT_PREFIX)]
    pub prefix: String,
    /// Seconds to wait for the service to appear.
    #[arg(long, default_value_t = 5.0)]
    pub wait_for_service: f64,
}

impl ToolArgs {
    /// Connects with [`ConnectOptions::for_tool`].
    pub fn connect(&self) -> anyhow::Result<Connection> {
        let opts = ConnectOptions::for_tool(&self.prefix, self.wait_for_service)
            .map_err(anyhow::Error::msg)?;
        Ok(Connection::connect(opts)?)
    }
}

/// Paces requests at a fixed rate: request `i` is due `i` periods after the first (late requests go at
/// once, so a slow answer does not shift the schedule).
#[derive(Debug, Clone, Copy)]
pub struct Pacer {
    start: Instant,
    period: Option<Duration>,
}

impl Pacer {
    /// `rate_hz` requests per second; 0 means as fast as the service answers.
    pub fn new(rate_hz: f64) -> Self {
        Pacer {
            start: Instant::now(),
            period: (rate_hz > 0.0).then(|| Duration::from_secs_f64(1.0 / rate_hz)),
        }
    }
    /// Sleeps until request `i` is due.
    pub fn wait(&self, i: usize) {
        if let Some(p) = self.period {
            let due = self.start + p * i as u32;
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
    }
}

/// Counts a refusal by status name.
pub fn count_refusal(refused: &mut Vec<(String, u64)>, name: &str) {
    match refused.iter_mut().find(|r| r.0 == name) {
        Some(r) => r.1 += 1,
        None => refused.push((name.to_string(), 1)),
    }
}
