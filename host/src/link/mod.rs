//! The host end of the link: byte transports (serial, TCP) and the protocol client.

pub mod client;
pub mod transport;

pub use client::{Client, ClientError, DropCounter};
pub use transport::{open, DeviceAddress};
