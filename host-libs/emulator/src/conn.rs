//! The emulator's connections: a reader and a writer thread per client (TCP or the pty),
//! and the frames queued to them.

use crate::inject::Injection;
use pam_protocol::{encode_frame, DeviceMessage, FrameDecoder, Request, MAX_FRAME};
use std::io::{ErrorKind, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, Sender, SyncSender};
use std::sync::Arc;

/// What the connections tell the real-time loop.
pub(crate) enum Event {
    Opened {
        conn: u64,
        out: SyncSender<Vec<u8>>,
    },
    Bytes {
        conn: u64,
        bytes: Vec<u8>,
    },
    Closed {
        conn: u64,
    },
    /// A fault to inject now (from the emulator's owner, never from a connection).
    Inject(Injection),
}

/// Frames queued per connection before frames are dropped (≈ 0.5 s of telemetry at 1 kHz).
pub(super) const WRITE_QUEUE: usize = 512;

/// Reader and writer threads of one connection.
pub(super) fn attach(
    conn: u64,
    mut reader: Box<dyn Read + Send>,
    mut writer: Box<dyn Write + Send>,
    events: &Sender<Event>,
    stop: &Arc<AtomicBool>,
) {
    let (out, queue): (SyncSender<Vec<u8>>, Receiver<Vec<u8>>) = sync_channel(WRITE_QUEUE);
    if events.send(Event::Opened { conn, out }).is_err() {
        return;
    }
    let ev = events.clone();
    let stop_r = stop.clone();
    std::thread::spawn(move || {
        let mut buf = [0u8; 1024];
        while !stop_r.load(Ordering::SeqCst) {
            match reader.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => {
                    if ev
                        .send(Event::Bytes {
                            conn,
                            bytes: buf[..n].to_vec(),
                        })
                        .is_err()
                    {
                        break;
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::Interrupted | ErrorKind::WouldBlock | ErrorKind::TimedOut
                    ) => {}
                Err(_) => break,
            }
        }
        let _ = ev.send(Event::Closed { conn });
    });
    std::thread::spawn(move || {
        // ends when the real-time loop drops the sender (connection closed or stop)
        while let Ok(bytes) = queue.recv() {
            if writer
                .write_all(&bytes)
                .and_then(|_| writer.flush())
                .is_err()
            {
                break;
            }
        }
    });
}

/// Frames for one connection, encoded back to back.
pub(super) fn push_frame(buf: &mut Vec<u8>, msg: &DeviceMessage) {
    let mut frame = [0u8; MAX_FRAME];
    if let Ok(n) = encode_frame(msg, &mut frame) {
        buf.extend_from_slice(&frame[..n]);
    }
}

pub(super) struct Connection {
    pub id: u64,
    pub out: SyncSender<Vec<u8>>,
    pub decoder: FrameDecoder<Request>,
}
