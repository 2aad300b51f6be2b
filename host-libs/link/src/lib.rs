//! The host end of the PAM robot's link: byte transports (serial, TCP) and the protocol
//! client (handshake with version and schema-fingerprint check, requests, telemetry, fault
//! events). pamctl, the end-to-end tests and any other host program talk to the device
//! (a board or the emulator) through it.

pub mod client;
pub mod error;
pub mod faults;
pub mod transport;

pub use client::{Client, DropCounter};
pub use error::{advice, LinkError};
pub use faults::fault_names;
pub use transport::{list_ports, open, DeviceAddress, Stream};
