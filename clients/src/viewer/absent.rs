//! Without the feature `rerun` there is no view: [`RerunView::open`] says how to build one, and the
//! type has no values, so nothing else can be called.

use super::Sink;
use anyhow::{Result, bail};
use std::time::Duration;

/// A Rerun recording; this build has none (uninhabited).
#[derive(Debug)]
pub enum RerunView {}

impl RerunView {
    /// Always an error naming the build that has the viewer.
    pub fn open(_sink: Sink<'_>) -> Result<Self> {
        bail!(
            "this build of watch has no Rerun viewer; build it with \
             `cargo build --release -p clients --features rerun` (scripts/test.sh does)"
        )
    }
    /// Unreachable (no value exists).
    pub fn add_chain(
        &mut self,
        _chain: u32,
        _name: &str,
        _thickness: f64,
        _free: bool,
        _limit: Option<super::LimitView>,
    ) {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn tissue(&mut self, _chain: u32, _corners: ([f64; 3], [f64; 3])) -> Result<()> {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn state(&mut self, _: u64, _: u32, _: &[[f64; 3]], _: super::Around<'_>) -> Result<()> {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn add_bundle(&mut self, _chain: u32, _name: &str) {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn bundle_state(&mut self, _: u64, _: u32, _: &[[f64; 3]], _: usize) -> Result<()> {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn missed(&mut self, _sequence: u64, _missed: u64) -> Result<()> {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn round_trip(&mut self, _sequence: u64, _rtt: Duration) -> Result<()> {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn identify_one(&mut self) -> Result<bool> {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn logged(&self) -> u64 {
        match *self {}
    }
    /// Unreachable (no value exists).
    pub fn finish(self) -> Result<()> {
        match self {}
    }
}
