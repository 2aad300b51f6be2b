//! The emulator's one error type: what went wrong, and with [`EmulatorError::help`] what
//! to do about it (pamctl prints both).

#[derive(Debug, thiserror::Error)]
pub enum EmulatorError {
    #[error("command timeout {seconds} s is outside the device's range (0–1 s]")]
    CommandTimeout { seconds: f32 },
    #[error("the device refused the emulator's calibration: {0:?}")]
    Calibration(pam_protocol::ErrorCode),
    #[error("cannot start the emulator's {thread} thread: {source}")]
    Thread {
        thread: &'static str,
        source: std::io::Error,
    },
    #[error("cannot listen on {address}: {source}")]
    Listen {
        address: String,
        source: std::io::Error,
    },
    #[cfg(target_os = "linux")]
    #[error("cannot {what} a pseudo-terminal: {source}")]
    Pty {
        what: &'static str,
        source: nix::Error,
    },
    #[error("cannot open a pseudo-terminal: {0}")]
    PtyIo(std::io::Error),
    #[error("the emulator has stopped")]
    Stopped,
    #[error("`{text}`: {reason}")]
    Injection { text: String, reason: String },
    #[error("--miswire `{text}`: {reason}")]
    Miswire { text: String, reason: String },
    #[error("`{text}`: {source}")]
    PlantFault {
        text: String,
        source: pam_twin::faults::FaultParseError,
    },
    #[error("--config-flash {path}: {source}")]
    ConfigFlash {
        path: String,
        source: std::io::Error,
    },
    #[error("the emulated configuration flash: {0}")]
    ConfigStore(String),
}

impl EmulatorError {
    /// What to do about it.
    pub fn help(&self) -> &'static str {
        use EmulatorError::*;
        match self {
            CommandTimeout { .. } => "give --command-timeout-s between 0 and 1 (the firmware's default is 0.1)",
            Calibration(_) => "an emulator bug: the twin's encoder calibration should always be accepted",
            Thread { .. } => "the system is out of threads or memory; close other programs and try again",
            Listen { .. } => "is another emulator using the port? choose another with --listen HOST:PORT (port 0: any free one)",
            #[cfg(target_os = "linux")]
            Pty { .. } => "check that /dev/ptmx exists and is usable, or serve on TCP only (without --pty)",
            PtyIo(_) => "check that /dev/ptmx exists and is usable, or serve on TCP only (without --pty)",
            Stopped => "start the emulator again",
            ConfigFlash { .. } => "give a file the emulator can read and write (it is created when missing), or leave --config-flash out for a flash in memory",
            ConfigStore(_) => "an emulator bug: the emulated flash's geometry should always fit the store",
            Miswire { .. } => {
                "write one of swap_channels:A,B, swap_joint1_muscles, encoder_inverted:joint=N, \
                 encoder_counts:joint=N,scale=S, loadcell_rotated:deg=D, loadcell_inverted:axis=x|z, \
                 loadcell_gain:axis=x|z,scale=S, loadcell_axes_swapped, tare_offset:x=N,z=N"
            }
            Injection { .. } | PlantFault { .. } => {
                "write KIND@SECONDS with KIND one of estop, estop_release, handle_release, overrun:periods=N or a plant \
                 fault (`pamctl sim --help` lists them), e.g. loadcell_frozen@5"
            }
        }
    }
}
