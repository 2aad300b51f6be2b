//! The device emulator: `pam_device::Device` — the firmware's own device service — run in
//! real time against `pam_twin`'s plant, serving the link protocol on TCP and (Linux) on a
//! pseudo-terminal.
//!
//! One real-time thread owns the device and the twin. Every period it takes the request
//! bytes the connections delivered, answers them, steps the device with the twin's raw
//! sensor readings (encoder counts through 16-bit counters, load-cell volts — the same front
//! end as on the board), holds the device's output currents on the twin for one period, and
//! queues the replies, telemetry and fault events for the connections' writer threads. It
//! sleeps to absolute deadlines (`start + k · period`): a late period is caught up at once,
//! so the device clock never drifts from the wall clock.
//!
//! Connections: replies go back to the connection that sent the request; telemetry and
//! fault events go to the newest connection that has sent anything (one client at a time;
//! a new client takes the stream over, an old one may keep sending heartbeats). If a
//! connection cannot keep up, whole frames are dropped (the telemetry `seq` shows the gap),
//! never the real-time loop.

mod config;
mod conn;
mod emulator;
pub mod error;
pub mod flash;
pub mod inject;
mod plant;
mod rt;
pub mod soak;
mod stats;

pub use config::{emulator_version, HandleMode, Miswire, SimConfig};
pub use emulator::Emulator;
pub use error::EmulatorError;
pub use inject::{Injection, Scheduled};
pub use stats::LoopStats;
