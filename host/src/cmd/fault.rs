//! `pamctl fault clear`.

use crate::LinkArgs;
use clap::Subcommand;
use pam_protocol::RequestBody;

#[derive(Subcommand, Debug)]
pub enum FaultCommand {
    /// Clear the latched faults (refused while a fault condition persists). Leaves the
    /// robot disarmed.
    Clear,
}

pub fn run(c: FaultCommand, link: &LinkArgs, out: &mut dyn std::io::Write) -> anyhow::Result<()> {
    match c {
        FaultCommand::Clear => {
            let client = super::connect(link)?;
            client.command(RequestBody::ClearFaults)?;
            super::done(out, "faults cleared; the robot is disarmed")
        }
    }
}
