//! Recordings read back and replayed against a service, each answer compared with the recorded one.

use super::*;

/// Reads recordings (JSON lines), each line checked.
pub fn read_records(path: &std::path::Path) -> anyhow::Result<Vec<Record>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("read {}", path.display()))?;
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            let r: Record = serde_json::from_str(l)
                .with_context(|| format!("{}:{}: not a record", path.display(), i + 1))?;
            if !r.target.iter().all(|x| x.is_finite()) {
                anyhow::bail!("{}:{}: field `target`: not finite", path.display(), i + 1);
            }
            Ok(r)
        })
        .collect()
}

/// What a replay found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReplayReport {
    pub sent: u64,
    /// `(record index, what differed)`.
    pub mismatches: Vec<(usize, String)>,
}

/// Sends the recorded requests again, in the order the service applied them (by sequence number, then
/// time), after resetting each chain they touch when `reset`; compares each status and each returned
/// state bit for bit (digest).
pub fn replay(
    conn: &mut Connection,
    mut records: Vec<Record>,
    reset: bool,
) -> anyhow::Result<ReplayReport> {
    records.sort_by_key(|r| (r.sequence, r.t_ns));
    let mut chains: Vec<(String, u32)> = Vec::new();
    for r in &records {
        if !chains.iter().any(|c| c.0 == r.chain) {
            let id = conn.require_chain(&r.chain)?;
            chains.push((r.chain.clone(), id));
        }
    }
    if reset {
        for (_, id) in &chains {
            let rep = conn.call(RequestHeader::new(Command::Reset, *id), &[])?;
            anyhow::ensure!(rep.is_ok(), "reset refused: {}", rep.header.reason_str());
        }
    }
    let mut out = ReplayReport::default();
    for (i, r) in records.iter().enumerate() {
        let id = chains
            .iter()
            .find(|c| c.0 == r.chain)
            .map(|c| c.1)
            .unwrap_or(0);
        let command = shared::text::parse_command(&r.command).map_err(anyhow::Error::msg)?;
        let mut h = RequestHeader::new(command, id);
        if r.pull {
            h.flags |= shared::FLAG_PULL;
        }
        if r.drive {
            h.flags |= shared::FLAG_DRIVE;
        }
        if r.rotation.is_some() {
            h.flags |= shared::FLAG_POSE;
        }
        h.joint = r.joint;
        let target = Vec3::new(r.target[0], r.target[1], r.target[2]);
        let with_axis;
        let points: &[Vec3] = match (command, r.axis.or(r.rotation)) {
            (Command::Move, Some(a)) => {
                with_axis = [target, Vec3::new(a[0], a[1], a[2])];
                &with_axis
            }
            (Command::Move, _) | (Command::Instrument, None) => std::slice::from_ref(&target),
            (Command::Instrument, Some(a)) => {
                with_axis = [target, Vec3::new(a[0], a[1], a[2])];
                &with_axis
            }
            _ => &[],
        };
        let (status, dg) = conn.call_with(h, points, |rh, pts| {
            let n = (rh.n_joints as usize).min(pts.len());
            (rh.status, digest(&pts[..n]))
        })?;
        out.sent += 1;
        let name = Status::from_u32(status).map_or("unknown", |s| s.name());
        if name != r.status {
            out.mismatches
                .push((i, format!("status {name}, recorded {}", r.status)));
        } else if dg != r.digest {
            out.mismatches.push((
                i,
                format!("state digest {dg:08x}, recorded {:08x}", r.digest),
            ));
        }
    }
    Ok(out)
}
