//! `pamctl disarm`.

use crate::LinkArgs;
use pam_protocol::RequestBody;

pub fn run(link: &LinkArgs, out: &mut dyn std::io::Write) -> Result<(), String> {
    let client = super::connect(link)?;
    client
        .command(RequestBody::Disarm)
        .map_err(|e| e.to_string())?;
    super::done(out, "disarmed: outputs vented")
}
