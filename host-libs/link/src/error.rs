//! The link's one error type: what went wrong, and with [`LinkError::help`] what to do
//! about it (pamctl prints both).

use pam_protocol::{ErrorCode, PROTOCOL_VERSION};
use std::time::Duration;

#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    #[error("no device given")]
    NoDevice,
    #[error("`{0}` is not a TCP device address")]
    BadTcpAddress(String),
    #[error("`{0}`: unknown scheme")]
    UnknownScheme(String),
    #[error("cannot resolve `{host}`: {source}")]
    Resolve {
        host: String,
        source: std::io::Error,
    },
    #[error("cannot connect to tcp://{host}: {reason}")]
    Connect { host: String, reason: String },
    #[error("cannot open serial port {path}: {source}")]
    OpenSerial {
        path: String,
        source: serialport::Error,
    },
    /// Splitting an open port or socket into a reading and a writing half failed.
    #[error("{device}: {reason}")]
    Split { device: String, reason: String },
    #[error("cannot list serial ports: {0}")]
    ListPorts(serialport::Error),
    #[error("cannot write to the device: {0}")]
    Write(std::io::Error),
    #[error("cannot encode the request ({0})")]
    Encode(String),
    /// No reply in time.
    #[error("no reply to {request} within {} ms", after.as_millis())]
    Timeout {
        request: &'static str,
        after: Duration,
    },
    /// The device refused the request; it changed nothing.
    #[error("the device refused {request} ({code:?}): {}", advice(*code))]
    Refused {
        request: &'static str,
        code: ErrorCode,
    },
    /// The device closed the link.
    #[error("the device closed the link (unplugged, reset, or the emulator stopped)")]
    Disconnected,
    /// The device does not speak our protocol version.
    #[error(
        "protocol version mismatch: pamctl speaks version {PROTOCOL_VERSION}, the device {}",
        match device { Some(v) => format!("speaks version {v}"), None => "refused it".to_string() }
    )]
    Version { device: Option<u16> },
    /// Same protocol version, different wire types: the device's
    /// [`pam_protocol::SCHEMA_FINGERPRINT`] is not ours.
    #[error(
        "wire format mismatch: pamctl's schema fingerprint is {host:#010x}, the device reports \
         {device:#010x} (both say protocol version {PROTOCOL_VERSION}, but their message types \
         differ, so replies would be misread)"
    )]
    Fingerprint { host: u32, device: u32 },
    /// A reply of the wrong kind (a device bug).
    #[error("the device answered {request} with the wrong kind of reply")]
    Unexpected { request: &'static str },
}

impl LinkError {
    /// What to do about it.
    pub fn help(&self) -> &'static str {
        use LinkError::*;
        match self {
            NoDevice => {
                "pass --device /dev/ttyACM0 (USB) or --device tcp://127.0.0.1:PORT (emulator), \
                 or set PAMCTL_DEVICE; `pamctl ports` lists the serial ports"
            }
            BadTcpAddress(_) => "write it as tcp://HOST:PORT, e.g. tcp://127.0.0.1:7878",
            UnknownScheme(_) => "use a serial port path (/dev/ttyACM0) or tcp://HOST:PORT",
            Resolve { .. } => "check the host name of the --device address",
            Connect { .. } => "is the emulator running (`pamctl sim`) and listening on that port?",
            OpenSerial { .. } => {
                "check the cable, that no other program holds the port, and your permission \
                 on it (Linux: add yourself to the `dialout` group); `pamctl ports` lists the ports"
            }
            Split { .. } | Write(_) => "check the cable or the emulator, then try again",
            ListPorts(_) => "give the port with --device instead",
            Encode(_) => "this is a pamctl bug; please report it with the command line",
            Timeout { .. } => {
                "is the device powered and running the pamctl-compatible firmware? \
                 (check the --device address)"
            }
            Refused { .. } => "the device changed nothing; correct the request and send it again",
            Disconnected => "reconnect the device (or restart the emulator) and try again",
            Version { .. } | Fingerprint { .. } => {
                "flash the firmware built from the same source as this pamctl \
                 (`cargo xtask firmware`), or update pamctl to the one that matches the firmware"
            }
            Unexpected { .. } => {
                "a device bug: note the firmware version (`pamctl status`) and report it"
            }
        }
    }
}

/// What a refusal means for the user.
pub fn advice(code: ErrorCode) -> &'static str {
    match code {
        ErrorCode::Malformed => {
            "the device could not read the request (corrupted on the link); try again"
        }
        ErrorCode::UnsupportedVersion => "the device speaks another protocol version",
        ErrorCode::OutOfRange => {
            "a value is NaN or outside the device's limits; nothing was changed (see `pamctl config get limits`)"
        }
        ErrorCode::WrongState => {
            "not allowed in the device's present state (see `pamctl status`): disarm first, or clear the faults"
        }
        ErrorCode::FaultStillPresent => {
            "a fault condition is still present: remove its cause (see `pamctl status`), then clear again"
        }
        ErrorCode::NotHomed => {
            "the encoders are not homed: put the arm at the neutral pose and run `pamctl home`"
        }
        ErrorCode::StorageFailed => {
            "the device's flash failed, or the device has no configuration store; the configuration in use is unchanged"
        }
        ErrorCode::NoStoredConfig => {
            "the device's flash holds no good configuration record (see `pamctl status`); nothing was changed"
        }
        ErrorCode::Implausible => {
            "the sensors contradict this calibration: tare with the handle free, home at the neutral pose, a positive load-cell gain; nothing was changed"
        }
        ErrorCode::NoSession => {
            "arming and setting a mode need the handshake on this link first (pamctl does it on connecting; another client must send `Hello` and use the session it returns)"
        }
        ErrorCode::NotCommander => {
            "only the client that armed or set the mode last keeps the device armed; this one is not it (`pamctl set … --hold SECONDS` keeps a mode alive)"
        }
        ErrorCode::SchemaMismatch => {
            "the device is built with another wire format: flash the firmware built from the same source as this pamctl"
        }
        ErrorCode::ServiceModeOff => {
            "the pressures mode is a service mode behind the device's interlock: `pamctl set pressures --service` turns it on (disarmed, idle or already in the pressures mode)"
        }
    }
}
