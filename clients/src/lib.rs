//! Clients of the tractrix solver service: the connection plumbing every binary shares, and thin binaries
//! on top (`chainctl`: one request from the shell).

pub mod connection;

pub use connection::{CallError, ClientWait, ConnectOptions, Connection, Reply, StateStream};
