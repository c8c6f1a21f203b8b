//! Clients of the tractrix solver service: the connection plumbing every binary shares, and thin binaries
//! on top (`chainctl`: one request from the shell; `hand`: a hand controller running a script, with
//! recording and replay).

pub mod accuracy;
pub mod cli;
pub mod connection;
pub mod hand;
pub mod latency;
pub mod latency_bench;
pub mod naming;
pub mod process;
pub mod reach;
pub mod render;
pub mod snake;
pub mod viewer;

pub use client::{CallError, ConnectOptions, Connection, Reply, StateStream, Svc};
pub use connection::{Pacer, ToolArgs, count_refusal};
/// How a client waits for its response (the protocol's [`shared::Wait`], which the service's loop
/// takes too).
pub use shared::Wait;
