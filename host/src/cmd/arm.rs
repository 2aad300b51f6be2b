//! `pamctl arm`.

use crate::LinkArgs;
use pam_protocol::RequestBody;

pub fn run(link: &LinkArgs, out: &mut dyn std::io::Write) -> anyhow::Result<()> {
    let client = super::connect(link)?;
    client.command(RequestBody::Arm)?;
    super::done(
        out,
        "armed. The device disarms itself (command timeout) unless its commander keeps \
         talking: use `pamctl set … --hold`, or `pamctl watch`/`record` with `--keep-alive`",
    )
}
