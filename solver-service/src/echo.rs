//! The raw echo: the latency bench's baseline. The service's ports, serving loop and waits, no
//! validation, no solving, no state stream: every request gets a zeroed [`ResponseHeader`] (echoing
//! `request_id`) and `elements` copies of one point. `solver-service echo` serves it.

use crate::serve::{ElementSink, ElementSource, Handled, Handler};
use shared::{RequestHeader, ResponseHeader, Vec3};
use world::elements::Counts;

/// Answers every request with `elements` copies of one point.
#[derive(Debug, Clone, Copy)]
pub struct Echo {
    /// Elements per response.
    pub elements: u32,
}

impl Handler for Echo {
    const SOLVES: bool = false;

    fn answer(&mut self, _client: u128, req: &RequestHeader, _points: &[Vec3]) -> Handled {
        Handled {
            header: ResponseHeader {
                request_id: req.request_id,
                n_joints: self.elements,
                ..ResponseHeader::default()
            },
            chain: 0,
            counts: Counts {
                joints: self.elements,
                ..Counts::default()
            },
            changed: false,
            bundle: false,
            landing: None,
        }
    }

    fn write<K: ElementSink>(&self, _chain: u32, _counts: &Counts, sink: K) -> K::Out {
        sink.take(Same)
    }
}

/// One point, again and again.
struct Same;

impl Iterator for Same {
    type Item = Vec3;
    fn next(&mut self) -> Option<Vec3> {
        Some(Vec3::new(1.0, 2.0, 3.0))
    }
}

impl ElementSource for Same {}
