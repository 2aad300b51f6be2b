//! Protocol client: handshake with version and schema-fingerprint check, requests with timeouts, the telemetry
//! stream with drop counting, fault events.

use crate::transport::{self, DeviceAddress};
use crate::LinkError;
use pam_protocol::{
    encode_frame, DeviceInfo, DeviceMessage, ErrorCode, FaultEvent, FrameDecoder, Reply, ReplyData,
    Request, RequestBody, Telemetry, MAX_FRAME, NO_SESSION, PROTOCOL_VERSION, SCHEMA_FINGERPRINT,
};
use std::io::{ErrorKind, Write};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Counts telemetry frames lost on the link from the gaps in their sequence numbers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DropCounter {
    last_seq: Option<u32>,
    pub received: u64,
    pub dropped: u64,
}

impl DropCounter {
    /// Records a sample; returns how many frames were lost just before it.
    pub fn record(&mut self, seq: u32) -> u64 {
        // wrapping difference: a u32 wrap is no gap; an old or repeated frame is no loss
        // and does not move the reference
        let lost = match self.last_seq {
            Some(last) => {
                let d = seq.wrapping_sub(last);
                if (1..u32::MAX / 2).contains(&d) {
                    self.last_seq = Some(seq);
                    (d - 1) as u64
                } else {
                    0
                }
            }
            None => {
                self.last_seq = Some(seq);
                0
            }
        };
        self.received += 1;
        self.dropped += lost;
        lost
    }
}

/// Everything the reader thread shares with the client.
struct Shared {
    stop: AtomicBool,
    forward_telemetry: AtomicBool,
    /// Frames from the device that failed CRC/COBS/decoding.
    corrupted: AtomicU64,
    /// The request id a caller is waiting for ([`NOT_WAITING`] if none): other replies
    /// (heartbeats', late ones) are dropped by the reader instead of piling up.
    awaited: AtomicU32,
    /// Every byte read from the link (throughput statistics).
    bytes_received: AtomicU64,
}

const NOT_WAITING: u32 = u32::MAX;

pub struct Client {
    writer: Mutex<Box<dyn Write + Send>>,
    next_id: Mutex<u16>,
    replies: Receiver<Reply>,
    telemetry: Receiver<Telemetry>,
    faults: Receiver<FaultEvent>,
    shared: Arc<Shared>,
    reader: Option<JoinHandle<()>>,
    timeout: Duration,
    info: DeviceInfo,
}

fn body_name(b: &RequestBody) -> &'static str {
    match b {
        RequestBody::Hello { .. } => "the handshake",
        RequestBody::Heartbeat => "heartbeat",
        RequestBody::Arm => "arm",
        RequestBody::Disarm => "disarm",
        RequestBody::Home => "home",
        RequestBody::Tare => "tare",
        RequestBody::ClearFaults => "fault clear",
        RequestBody::GetStatus => "status",
        RequestBody::SetMode(_) => "the mode change",
        RequestBody::GetConfig(_) => "config get",
        RequestBody::SetConfig(_) => "config set",
        RequestBody::SetTelemetry { .. } => "the telemetry rate",
        RequestBody::PersistConfig => "config persist",
        RequestBody::RestoreConfig => "config restore",
        RequestBody::EraseConfig => "config erase",
        RequestBody::SetServiceMode { .. } => "the service mode",
        RequestBody::TakeCommand => "taking the command",
    }
}

impl Client {
    /// Opens `--device`, does the handshake and checks the protocol version and the
    /// schema fingerprint.
    pub fn connect(device: &str, timeout: Duration) -> Result<Client, LinkError> {
        let address = DeviceAddress::parse(device)?;
        let stream = transport::open(&address, timeout)?;
        Self::over(stream, timeout, PROTOCOL_VERSION)
    }

    /// Handshake over an open stream, announcing `protocol_version` (tests use another one
    /// to see the mismatch handled).
    pub fn over(
        stream: transport::Stream,
        timeout: Duration,
        protocol_version: u16,
    ) -> Result<Client, LinkError> {
        let (reply_tx, replies) = channel();
        let (telemetry_tx, telemetry) = channel();
        let (fault_tx, faults) = channel();
        let shared = Arc::new(Shared {
            stop: AtomicBool::new(false),
            forward_telemetry: AtomicBool::new(false),
            corrupted: AtomicU64::new(0),
            awaited: AtomicU32::new(NOT_WAITING),
            bytes_received: AtomicU64::new(0),
        });
        let reader = {
            let shared = shared.clone();
            let mut r = stream.reader;
            std::thread::spawn(move || {
                read_loop(&mut *r, &shared, reply_tx, telemetry_tx, fault_tx)
            })
        };
        let mut client = Client {
            writer: Mutex::new(stream.writer),
            next_id: Mutex::new(1),
            replies,
            telemetry,
            faults,
            shared,
            reader: Some(reader),
            timeout,
            info: DeviceInfo {
                protocol_version: 0,
                schema_fingerprint: 0,
                firmware_version: pam_protocol::Version {
                    major: 0,
                    minor: 0,
                    patch: 0,
                },
                period_us: 0,
                params_hash: 0,
                session: NO_SESSION,
            },
        };
        // a lone delimiter ends whatever half frame the device may hold from before
        client.write_bytes(&[0])?;
        match client.request(RequestBody::Hello {
            protocol_version,
            schema_fingerprint: SCHEMA_FINGERPRINT,
        }) {
            Ok(ReplyData::Hello(info))
                if info.protocol_version == PROTOCOL_VERSION
                    && info.schema_fingerprint == SCHEMA_FINGERPRINT =>
            {
                client.info = info;
                Ok(client)
            }
            Ok(ReplyData::Hello(info)) if info.protocol_version == PROTOCOL_VERSION => {
                Err(LinkError::Fingerprint {
                    host: SCHEMA_FINGERPRINT,
                    device: info.schema_fingerprint,
                })
            }
            Ok(ReplyData::Hello(info)) => Err(LinkError::Version {
                device: Some(info.protocol_version),
            }),
            Ok(_) => Err(LinkError::Unexpected {
                request: "the handshake",
            }),
            Err(LinkError::Refused {
                code: ErrorCode::UnsupportedVersion,
                ..
            }) => Err(LinkError::Version { device: None }),
            Err(e) => Err(e),
        }
    }

    /// What the device said in the handshake.
    pub fn info(&self) -> &DeviceInfo {
        &self.info
    }

    fn write_bytes(&self, bytes: &[u8]) -> Result<(), LinkError> {
        // a writer poisoned by a panicking thread is a link that can no longer be used
        let mut w = self.writer.lock().map_err(|_| LinkError::Disconnected)?;
        w.write_all(bytes)
            .and_then(|_| w.flush())
            .map_err(LinkError::Write)
    }

    /// Raw bytes onto the link (tests use it to inject corruption).
    pub fn send_raw(&self, bytes: &[u8]) -> Result<(), LinkError> {
        self.write_bytes(bytes)
    }

    fn send(&self, body: RequestBody, await_reply: bool) -> Result<u16, LinkError> {
        let id = {
            let mut next = self.next_id.lock().map_err(|_| LinkError::Disconnected)?;
            let id = *next;
            // 0 is the device's "unknown request" id
            *next = next.wrapping_add(1).max(1);
            id
        };
        if await_reply {
            self.shared.awaited.store(id as u32, Ordering::SeqCst);
        }
        let mut buf = [0u8; MAX_FRAME];
        let request = Request {
            id,
            body,
            session: self.info.session,
        };
        let n =
            encode_frame(&request, &mut buf).map_err(|e| LinkError::Encode(format!("{e:?}")))?;
        self.write_bytes(&buf[..n])?;
        Ok(id)
    }

    /// Sends a request and waits for its reply (one request at a time).
    pub fn request(&self, body: RequestBody) -> Result<ReplyData, LinkError> {
        let result = self.request_inner(body);
        self.shared.awaited.store(NOT_WAITING, Ordering::SeqCst);
        result
    }

    fn request_inner(&self, body: RequestBody) -> Result<ReplyData, LinkError> {
        let name = body_name(&body);
        // replies still queued are for earlier requests
        while self.replies.try_recv().is_ok() {}
        let id = self.send(body, true)?;
        let deadline = Instant::now() + self.timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.replies.recv_timeout(left) {
                Ok(r) if r.id == id => {
                    return r.result.map_err(|code| LinkError::Refused {
                        request: name,
                        code,
                    })
                }
                Ok(_) => continue, // a late reply to an earlier request, or a heartbeat's
                Err(RecvTimeoutError::Timeout) => {
                    return Err(LinkError::Timeout {
                        request: name,
                        after: self.timeout,
                    })
                }
                Err(RecvTimeoutError::Disconnected) => return Err(LinkError::Disconnected),
            }
        }
    }

    /// A request whose reply is only `Done`.
    pub fn command(&self, body: RequestBody) -> Result<(), LinkError> {
        let name = body_name(&body);
        match self.request(body)? {
            ReplyData::Done => Ok(()),
            _ => Err(LinkError::Unexpected { request: name }),
        }
    }

    /// Fire-and-forget keep-alive of the commander: the device's command timeout counts
    /// from the last `Arm`, `SetMode` or keep-alive of the client that armed or set the
    /// mode last. From any other client the device refuses it (`NotCommander`) and it keeps
    /// nothing alive. Its reply is dropped by the reader thread.
    pub fn heartbeat(&self) -> Result<(), LinkError> {
        self.send(RequestBody::Heartbeat, false).map(|_| ())
    }

    /// This client becomes the commander of the armed device, mode unchanged: its
    /// [`Client::heartbeat`]s keep the mode alive from now on (and the previous
    /// commander's no longer do).
    pub fn take_command(&self) -> Result<(), LinkError> {
        self.command(RequestBody::TakeCommand)
    }

    /// The pressures mode's service interlock: on (disarmed, idle, or already in the
    /// pressures mode) lets `SetMode(Pressures)` through; off leaves the pressures mode
    /// for idle. The device turns it off at every disarm and fault.
    pub fn set_service_mode(&self, enabled: bool) -> Result<(), LinkError> {
        self.command(RequestBody::SetServiceMode { enabled })
    }

    /// Starts handing telemetry samples to [`Client::next_telemetry`]; samples that came
    /// before are discarded.
    pub fn start_telemetry(&self) {
        while self.telemetry.try_recv().is_ok() {}
        self.shared.forward_telemetry.store(true, Ordering::SeqCst);
    }

    pub fn next_telemetry(&self, wait: Duration) -> Result<Option<Telemetry>, LinkError> {
        match self.telemetry.recv_timeout(wait) {
            Ok(t) => Ok(Some(t)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(LinkError::Disconnected),
        }
    }

    /// Fault events received so far.
    pub fn fault_events(&self) -> Vec<FaultEvent> {
        self.faults.try_iter().collect()
    }

    /// Bytes received from the device so far (frames, delimiters and any garbage).
    pub fn bytes_received(&self) -> u64 {
        self.shared.bytes_received.load(Ordering::Relaxed)
    }

    /// Frames from the device rejected as corrupted so far.
    pub fn corrupted_frames(&self) -> u64 {
        self.shared.corrupted.load(Ordering::Relaxed)
    }
}

impl Drop for Client {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Some(h) = self.reader.take() {
            let _ = h.join();
        }
    }
}

fn read_loop(
    r: &mut dyn std::io::Read,
    shared: &Shared,
    replies: Sender<Reply>,
    telemetry: Sender<Telemetry>,
    faults: Sender<FaultEvent>,
) {
    let mut decoder = FrameDecoder::<DeviceMessage>::new();
    let mut buf = [0u8; 4096];
    while !shared.stop.load(Ordering::SeqCst) {
        let n = match r.read(&mut buf) {
            Ok(0) => return, // closed: the senders drop and the client sees Disconnected
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(_) => return,
        };
        shared.bytes_received.fetch_add(n as u64, Ordering::Relaxed);
        for &b in &buf[..n] {
            match decoder.push(b) {
                None => {}
                Some(Ok(DeviceMessage::Reply(rep)))
                    if rep.id as u32 == shared.awaited.load(Ordering::SeqCst) =>
                {
                    let _ = replies.send(rep);
                }
                Some(Ok(DeviceMessage::Reply(_))) => {}
                Some(Ok(DeviceMessage::Telemetry(t)))
                    if shared.forward_telemetry.load(Ordering::Relaxed) =>
                {
                    let _ = telemetry.send(t);
                }
                Some(Ok(DeviceMessage::Telemetry(_))) => {}
                Some(Ok(DeviceMessage::FaultEvent(e))) => {
                    let _ = faults.send(e);
                }
                Some(Err(_)) => {
                    shared.corrupted.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drop_counter_counts_gaps_and_survives_wrap() {
        let mut d = DropCounter::default();
        for s in [5, 6, 7, 10, 11] {
            d.record(s);
        }
        assert_eq!((d.received, d.dropped), (5, 2));
        let mut d = DropCounter::default();
        for s in [u32::MAX - 1, u32::MAX, 0, 2] {
            d.record(s);
        }
        assert_eq!((d.received, d.dropped), (4, 1));
        // a repeated or old frame is no loss
        let mut d = DropCounter::default();
        for s in [3, 3, 2, 4] {
            d.record(s);
        }
        assert_eq!(d.dropped, 0);
    }

    #[test]
    fn device_addresses_parse_or_explain() {
        assert_eq!(
            DeviceAddress::parse("tcp://127.0.0.1:7878").unwrap(),
            DeviceAddress::Tcp("127.0.0.1:7878".into())
        );
        assert_eq!(
            DeviceAddress::parse("/dev/ttyACM0").unwrap(),
            DeviceAddress::Serial("/dev/ttyACM0".into())
        );
        let e = DeviceAddress::parse("tcp://nohost").unwrap_err();
        assert!(e.help().contains("tcp://HOST:PORT"), "{e}");
        let e = DeviceAddress::parse("udp://x:1").unwrap_err();
        assert!(e.to_string().contains("unknown scheme"), "{e}");
        assert!(DeviceAddress::parse("")
            .unwrap_err()
            .help()
            .contains("--device"));
    }
}
