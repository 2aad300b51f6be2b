//! `pamctl`: the researcher's command line for the PAM rehabilitation robot.
//! Logic lives here, one module per subcommand; `main.rs` only parses and reports.

pub mod cmd;
pub mod plotjuggler;
pub mod report;

use clap::{Args, Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "pamctl",
    version,
    about = "Command line of the pneumatic-muscle rehabilitation robot"
)]
pub struct Cli {
    #[command(flatten)]
    pub link: LinkArgs,
    #[command(subcommand)]
    pub command: Command,
}

/// How to reach the device (every command that talks to it).
#[derive(Args, Debug, Clone)]
pub struct LinkArgs {
    /// The device: a serial port (/dev/ttyACM0, COM3) or tcp://HOST:PORT (the emulator).
    #[arg(long, global = true, env = "PAMCTL_DEVICE")]
    pub device: Option<String>,
    /// How long to wait for each reply, ms.
    #[arg(long, global = true, default_value_t = 1000)]
    pub timeout_ms: u64,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Ask the robot model (no device needed): capability, inverse model, reference tables.
    #[command(subcommand)]
    Model(cmd::model::ModelCommand),
    /// Identify the robot from logs as in the thesis (§4.3–4.6, §5.3).
    #[command(subcommand)]
    Ident(cmd::ident::IdentCommand),
    /// List the serial ports that may be the robot.
    Ports,
    /// State, mode, faults, loop timing and a live sample of the device.
    Status,
    /// Arm the robot (it must be homed and free of faults).
    Arm,
    /// Disarm: the outputs vent at once.
    Disarm,
    /// Take the present pose as the neutral pose (α = 0). Disarmed only.
    Home,
    /// Take the present load-cell reading as zero force. Disarmed only.
    Tare,
    /// Guided first bring-up: encoders, I/P channel map and tare, checked against the model
    /// (handle free, nobody near the arm); resumable (docs/bring-up.md).
    Commission(cmd::commission::CommissionArgs),
    /// Latched faults.
    #[command(subcommand)]
    Fault(cmd::fault::FaultCommand),
    /// Set the control mode and its targets.
    Set(cmd::set::SetArgs),
    /// Robot parameters, calibration and limits, as TOML.
    #[command(subcommand)]
    Config(cmd::config::ConfigCommand),
    /// Record telemetry to a log-format-v1 CSV file.
    Record(cmd::record::RecordArgs),
    /// The thesis protocols on the connected device, one log per trial.
    Experiment(cmd::experiment::ExperimentArgs),
    /// Live view of the telemetry with small plots (`--once` / non-terminal: plain text).
    Watch(cmd::watch::WatchArgs),
    /// The device emulator: pam-device against the digital twin, in real time, on TCP/pty.
    Sim(cmd::sim::SimArgs),
    /// One thesis experiment on the digital twin (no device), written as a log, with hidden
    /// effects if asked: the logs the model loop is tried on.
    Simulate(cmd::simulate::SimulateArgs),
    /// Propose the closed force loop's gain scale from a force-step log, with its margins
    /// and predicted step response (nothing is sent to the device).
    Tune(cmd::tune::TuneArgs),
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    let out = &mut std::io::stdout();
    let link = &cli.link;
    match cli.command {
        Command::Model(m) => cmd::model::run(m, out),
        Command::Ident(c) => cmd::ident::run(c, out),
        Command::Ports => cmd::ports::run(out),
        Command::Status => cmd::status::run(link, out),
        Command::Arm => cmd::arm::run(link, out),
        Command::Disarm => cmd::disarm::run(link, out),
        Command::Home => cmd::home::run(link, out),
        Command::Tare => cmd::tare::run(link, out),
        Command::Commission(c) => cmd::commission::run(c, link, out),
        Command::Fault(f) => cmd::fault::run(f, link, out),
        Command::Set(s) => cmd::set::run(s, link, out),
        Command::Config(c) => cmd::config::run(c, link, out),
        Command::Record(r) => cmd::record::run(r, link, out),
        Command::Sim(s) => cmd::sim::run(s, out),
        Command::Simulate(s) => cmd::simulate::run(s, out),
        Command::Tune(t) => cmd::tune::run(t, out),
        Command::Watch(w) => cmd::watch::run(w, link, out),
        Command::Experiment(e) => cmd::experiment::run(e, link, out),
    }
}
