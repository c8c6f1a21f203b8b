//! A [`World`] addressed by wire requests: decoded against its scene (a chain's request by
//! [`super::request`], a bundle's by [`super::bundle`]), answered, encoded with its sequence numbers.

use super::request::{decode, encode};
use shared::{RequestHeader, ResponseHeader, Vec3};
use world::World;
use world::command::{Answer, Command};
use world::refusal::Refusal;
use world::refuse;

/// The wire's door to a [`World`]: requests decoded against its scene, answers encoded with its
/// sequence numbers (the payload is the world's: [`World::elements_for`]).
pub trait WireWorld {
    /// Checks a wire request against the scene ([`super::request::decode`], [`super::bundle::decode`]).
    fn decode<'a>(&self, h: &RequestHeader, points: &'a [Vec3]) -> Result<Command<'a>, Refusal>;
    /// The response header of a request: from its answer or its refusal ([`super::request::encode`]), with a
    /// bundle's sequence and description.
    fn encode(&self, req: &RequestHeader, result: &Result<Answer, Refusal>) -> ResponseHeader;
    /// Decodes and applies a wire request as no client, behind the panic guard (the journal's
    /// replay, tests).
    fn apply_wire(&mut self, h: &RequestHeader, points: &[Vec3]) -> Result<Answer, Refusal>;
}

impl WireWorld for World {
    fn decode<'a>(&self, h: &RequestHeader, points: &'a [Vec3]) -> Result<Command<'a>, Refusal> {
        if h.command != shared::Command::Snapshot as u32
            && let Some((index, b)) = self.bundle_of(h.chain)
        {
            return super::bundle::decode(h, points, &b.spec).map(|op| Command::Bundle {
                handle: h.chain,
                index,
                op,
            });
        }
        let total = self.specs().len() + self.bundles().len();
        if h.chain as usize >= total
            && h.command != shared::Command::Snapshot as u32
            && shared::Command::try_from(h.command).is_ok()
        {
            return Err(refuse!(
                UnknownChain,
                "chain {} (the scene has 0..{total})",
                h.chain
            ));
        }
        decode(h, points, self.specs())
    }

    fn encode(&self, req: &RequestHeader, result: &Result<Answer, Refusal>) -> ResponseHeader {
        let bundle = self.bundle_of(req.chain);
        let sequence = bundle.map_or(self.sequence(), |(_, b)| b.sequence);
        let mut h = encode(req, result, sequence, self.specs());
        h.n_chains = (self.specs().len() + self.bundles().len()) as u32;
        if let (Ok(o), Some((_, b))) = (result, bundle)
            && o.describe
        {
            super::bundle::describe(&b.spec, &mut h);
        }
        h
    }

    fn apply_wire(&mut self, h: &RequestHeader, points: &[Vec3]) -> Result<Answer, Refusal> {
        let req = self.decode(h, points)?;
        self.apply_guarded(world::owners::LOCAL, &req)
    }
}
