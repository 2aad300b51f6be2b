//! Byte streams to the device: a serial port (USB CDC-ACM) or TCP (the emulator).

use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// Where the device is, parsed from `--device`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeviceAddress {
    /// `tcp://host:port`
    Tcp(String),
    /// A serial port path (`/dev/ttyACM0`, `COM3`).
    Serial(String),
}

impl DeviceAddress {
    pub fn parse(s: &str) -> Result<DeviceAddress, String> {
        let s = s.trim();
        if s.is_empty() {
            return Err(no_device_message());
        }
        if let Some(rest) = s.strip_prefix("tcp://") {
            let ok = rest
                .rsplit_once(':')
                .is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok());
            if !ok {
                return Err(format!(
                    "`{s}` is not a TCP device address: write it as tcp://HOST:PORT, e.g. tcp://127.0.0.1:7878"
                ));
            }
            return Ok(DeviceAddress::Tcp(rest.to_string()));
        }
        if s.contains("://") {
            return Err(format!(
                "`{s}`: unknown scheme; use a serial port path (/dev/ttyACM0) or tcp://HOST:PORT"
            ));
        }
        Ok(DeviceAddress::Serial(s.to_string()))
    }
}

pub fn no_device_message() -> String {
    "no device given: pass --device /dev/ttyACM0 (USB) or --device tcp://127.0.0.1:PORT (emulator), \
     or set PAMCTL_DEVICE; `pamctl ports` lists the serial ports"
        .to_string()
}

/// A byte stream split into a reading and a writing half (the reader lives in its own
/// thread). Reads time out after a short while so that thread can notice a shutdown.
pub struct Stream {
    pub reader: Box<dyn Read + Send>,
    pub writer: Box<dyn Write + Send>,
}

const READ_POLL: Duration = Duration::from_millis(20);

/// Opens the device; errors say what to check.
pub fn open(address: &DeviceAddress, connect_timeout: Duration) -> Result<Stream, String> {
    match address {
        DeviceAddress::Tcp(hostport) => {
            let addrs: Vec<_> = hostport
                .to_socket_addrs()
                .map_err(|e| format!("cannot resolve `{hostport}`: {e}"))?
                .collect();
            let mut last = None;
            for a in &addrs {
                match TcpStream::connect_timeout(a, connect_timeout) {
                    Ok(s) => {
                        s.set_nodelay(true).ok();
                        s.set_read_timeout(Some(READ_POLL)).ok();
                        let w = s
                            .try_clone()
                            .map_err(|e| format!("tcp://{hostport}: {e}"))?;
                        return Ok(Stream {
                            reader: Box::new(s),
                            writer: Box::new(w),
                        });
                    }
                    Err(e) => last = Some(e),
                }
            }
            Err(format!(
                "cannot connect to tcp://{hostport}: {}; is the emulator running (`pamctl sim`) and listening on that port?",
                last.map(|e| e.to_string())
                    .unwrap_or_else(|| "no address".into())
            ))
        }
        DeviceAddress::Serial(path) => {
            // CDC-ACM ignores the baud rate; 115200 suits a real UART bridge too
            let port = serialport::new(path, 115_200)
                .timeout(READ_POLL)
                .open()
                .map_err(|e| {
                    format!(
                        "cannot open serial port {path}: {e}; check the cable, that no other program holds the port, \
                         and your permission on it (Linux: add yourself to the `dialout` group); `pamctl ports` lists the ports"
                    )
                })?;
            let w = port
                .try_clone()
                .map_err(|e| format!("serial port {path}: {e}"))?;
            Ok(Stream {
                reader: Box::new(port),
                writer: Box::new(w),
            })
        }
    }
}

/// Serial ports that may be the robot, USB ones first.
pub fn list_ports() -> Result<Vec<(String, String)>, String> {
    let mut ports =
        serialport::available_ports().map_err(|e| format!("cannot list serial ports: {e}"))?;
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
