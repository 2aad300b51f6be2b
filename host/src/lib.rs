//! `pamctl`: the researcher's command line for the PAM rehabilitation robot.
//! Logic lives here, one module per subcommand; `main.rs` only parses and reports.

pub mod cmd;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "pamctl",
    version,
    about = "Command line of the pneumatic-muscle rehabilitation robot"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Ask the robot model (no device needed): capability, inverse model, reference tables.
    #[command(subcommand)]
    Model(cmd::model::ModelCommand),
    /// Identify the robot from logs as in the thesis (§4.3–4.6, §5.3).
    #[command(subcommand)]
    Ident(cmd::ident::IdentCommand),
}

pub fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Model(m) => cmd::model::run(m, &mut std::io::stdout()),
        Command::Ident(c) => cmd::ident::run(c, &mut std::io::stdout()),
    }
}
