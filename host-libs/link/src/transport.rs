//! Byte streams to the device: a serial port (USB CDC-ACM) or TCP (the emulator).

use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

use crate::LinkError;

/// Where the device is, parsed from `--device`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeviceAddress {
    /// `tcp://host:port`
    Tcp(String),
    /// A serial port path (`/dev/ttyACM0`, `COM3`).
    Serial(String),
}

impl DeviceAddress {
    pub fn parse(s: &str) -> Result<DeviceAddress, LinkError> {
        let s = s.trim();
        if s.is_empty() {
            return Err(LinkError::NoDevice);
        }
        if let Some(rest) = s.strip_prefix("tcp://") {
            let ok = rest
                .rsplit_once(':')
                .is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok());
            if !ok {
                return Err(LinkError::BadTcpAddress(s.to_string()));
            }
            return Ok(DeviceAddress::Tcp(rest.to_string()));
        }
        if s.contains("://") {
            return Err(LinkError::UnknownScheme(s.to_string()));
        }
        Ok(DeviceAddress::Serial(s.to_string()))
    }
}

/// A byte stream split into a reading and a writing half (the reader lives in its own
/// thread). Reads time out after a short while so that thread can notice a shutdown.
pub struct Stream {
    pub reader: Box<dyn Read + Send>,
    pub writer: Box<dyn Write + Send>,
}

const READ_POLL: Duration = Duration::from_millis(20);

/// Opens the device; errors say what to check.
pub fn open(address: &DeviceAddress, connect_timeout: Duration) -> Result<Stream, LinkError> {
    match address {
        DeviceAddress::Tcp(hostport) => {
            let addrs: Vec<_> = hostport
                .to_socket_addrs()
                .map_err(|source| LinkError::Resolve {
                    host: hostport.clone(),
                    source,
                })?
                .collect();
            let mut last = None;
            for a in &addrs {
                match TcpStream::connect_timeout(a, connect_timeout) {
                    Ok(s) => {
                        s.set_nodelay(true).ok();
                        s.set_read_timeout(Some(READ_POLL)).ok();
                        let w = s.try_clone().map_err(|e| LinkError::Split {
                            device: format!("tcp://{hostport}"),
                            reason: e.to_string(),
                        })?;
                        return Ok(Stream {
                            reader: Box::new(s),
                            writer: Box::new(w),
                        });
                    }
                    Err(e) => last = Some(e),
                }
            }
            Err(LinkError::Connect {
                host: hostport.clone(),
                reason: last
                    .map(|e| e.to_string())
                    .unwrap_or_else(|| "no address".into()),
            })
        }
        DeviceAddress::Serial(path) => {
            // CDC-ACM ignores the baud rate; 115200 suits a real UART bridge too
            let port = serialport::new(path, 115_200)
                .timeout(READ_POLL)
                .open()
                .map_err(|source| LinkError::OpenSerial {
                    path: path.clone(),
                    source,
                })?;
            let w = port.try_clone().map_err(|e| LinkError::Split {
                device: format!("serial port {path}"),
                reason: e.to_string(),
            })?;
            Ok(Stream {
                reader: Box::new(port),
                writer: Box::new(w),
            })
        }
    }
}

/// Serial ports that may be the robot, USB ones first.
pub fn list_ports() -> Result<Vec<(String, String)>, LinkError> {
    let mut ports = serialport::available_ports().map_err(LinkError::ListPorts)?;
    // the robot first, then other USB ports, then the rest
    ports.sort_by_key(|p| match &p.port_type {
        serialport::SerialPortType::UsbPort(u)
            if (u.vid, u.pid) == (pam_protocol::USB_VID, pam_protocol::USB_PID) =>
        {
            0
        }
        serialport::SerialPortType::UsbPort(_) => 1,
        _ => 2,
    });
    Ok(ports
        .into_iter()
        .map(|p| {
            let what = match p.port_type {
                serialport::SerialPortType::UsbPort(u) => format!(
                    "USB {:04x}:{:04x}{}{}{}",
                    u.vid,
                    u.pid,
                    u.manufacturer.map(|m| format!(" {m}")).unwrap_or_default(),
                    u.product.map(|m| format!(" {m}")).unwrap_or_default(),
                    if (u.vid, u.pid) == (pam_protocol::USB_VID, pam_protocol::USB_PID) {
                        "  <- the PAM robot firmware"
                    } else {
                        ""
                    }
                ),
                serialport::SerialPortType::PciPort => "PCI".into(),
                serialport::SerialPortType::BluetoothPort => "Bluetooth".into(),
                serialport::SerialPortType::Unknown => "unknown".into(),
            };
            (p.port_name, what)
        })
        .collect())
}
