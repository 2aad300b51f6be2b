//! `pamctl tare`.

use crate::LinkArgs;
use pam_protocol::RequestBody;

pub fn run(link: &LinkArgs, out: &mut dyn std::io::Write) -> anyhow::Result<()> {
    let client = super::connect(link)?;
    client.command(RequestBody::Tare)?;
    super::done(out, "tared: the present load-cell reading is zero force")
}
