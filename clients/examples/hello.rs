//! The smallest Rust client: move the rope's head and print where it is.
//! `cargo run --release --example hello -- [PREFIX]`
use clients::{ConnectOptions, Connection};
use shared::{Command, JOINT_HEAD, RequestHeader, Vec3};

fn main() -> anyhow::Result<()> {
    let prefix = std::env::args()
        .nth(1)
        .unwrap_or_else(shared::prefix_from_env);
    let mut conn =
        Connection::connect(ConnectOptions::for_tool(&prefix, 5.0).map_err(anyhow::Error::msg)?)?;
    let rope = conn
        .find_chain("rope")?
        .ok_or_else(|| anyhow::anyhow!("no chain \"rope\""))?;
    let mut move_head = RequestHeader::new(Command::Move, rope);
    move_head.joint = JOINT_HEAD;
    let reply = conn.call(move_head, &[Vec3::new(38.0, 5.0, 1.0)])?;
    if !reply.is_ok() {
        anyhow::bail!("{}", reply.header.reason_str());
    }
    let head = reply.joints()[reply.joints().len() - 1];
    println!(
        "head at {} {} {}, {} joints",
        head.x,
        head.y,
        head.z,
        reply.joints().len()
    );
    Ok(())
}
