//! The host link: USB CDC-ACM carrying `pam-protocol` frames (COBS(postcard ‖ CRC) ‖ 0x00).
//!
//! * Requests in: bytes → `FrameDecoder<Request>` → `Device::handle_frame` (inside the
//!   device's critical section, one request long) → the reply goes to the writer; the
//!   storage requests through [`config_flash::handle`] (flash work outside that section).
//! * Out: replies first, then fault events, then telemetry, each encoded as a
//!   `DeviceMessage` and written in packets of at most 64 bytes. The control task fills the
//!   telemetry and fault channels with `try_send` and never waits for this task.
//!
//! Everything here runs in the thread-mode executor: a slow or absent host can only make
//! telemetry drop (counted, and visible to the host as gaps in `seq`), never delay the loop.

use embassy_futures::select::{select, select3, Either3};
use embassy_stm32::usb::Driver;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_usb::class::cdc_acm::{CdcAcmClass, Receiver, Sender};
use embassy_usb::driver::EndpointError;
use embassy_usb::UsbDevice;
use pam_control::Faults;
use pam_protocol::{encode_frame, DeviceMessage, FrameDecoder, Reply, Request, MAX_FRAME};

use crate::board::UsbPeripheral;
use crate::config_flash::{self, Store};
use crate::control::{with_device, FAULT_EVENTS, TELEMETRY};

/// Full-speed bulk packet size.
pub const USB_PACKET_BYTES: usize = 64;

/// USB identity, shared with the host (`pamctl ports` recognises it).
pub use pam_protocol::{USB_PID, USB_VID};

type UsbDriver = Driver<'static, UsbPeripheral>;

/// Replies from the reader to the writer. One in flight is enough: the reader handles one
/// request at a time and waits here if the writer is busy (USB flow control, not drops).
static REPLIES: Channel<CriticalSectionRawMutex, Reply, 2> = Channel::new();

/// Runs the USB device stack (enumeration, control requests).
#[embassy_executor::task]
pub async fn usb_task(mut usb: UsbDevice<'static, UsbDriver>) -> ! {
    usb.run().await
}

/// Serves one host session after another.
#[embassy_executor::task]
pub async fn link_task(class: CdcAcmClass<'static, UsbDriver>, mut store: Option<Store>) -> ! {
    let (mut tx, mut rx) = class.split();
    loop {
        rx.wait_connection().await;
        defmt::info!("link: host connected");
        // Nothing from a previous session may leak into this one.
        while REPLIES.try_receive().is_ok() {}
        let _ = select(
            read_requests(&mut rx, store.as_mut()),
            write_messages(&mut tx),
        )
        .await;
        defmt::info!("link: host disconnected");
    }
}

/// Bytes in → frames → device → replies. Returns when the host goes away.
async fn read_requests(
    rx: &mut Receiver<'static, UsbDriver>,
    mut store: Option<&mut Store>,
) -> EndpointError {
    let mut decoder = FrameDecoder::<Request>::new();
    let mut packet = [0u8; USB_PACKET_BYTES];
    loop {
        let n = match rx.read_packet(&mut packet).await {
            Ok(n) => n,
            Err(e) => return e,
        };
        for &byte in packet.iter().take(n) {
            if let Some(frame) = decoder.push(byte) {
                // A frame arriving before main installed the device cannot happen (the
                // link starts after it); answer nothing rather than invent a reply.
                // Storage requests do their flash work outside the device's lock.
                let reply = match &frame {
                    Ok(request) => config_flash::handle(store.as_deref_mut(), request),
                    Err(_) => None,
                }
                .or_else(|| {
                    with_device(|device| {
                        // A failing board check (an output stage unsafe in reset, …) is
                        // latched again before every request: a `clear` followed by `arm`
                        // between two control steps cannot arm such a board.
                        if device.board_health().board_checks != 0 {
                            device.raise(Faults::SELF_CHECK);
                        }
                        device.handle_frame(frame)
                    })
                });
                if let Some(reply) = reply {
                    REPLIES.send(reply).await;
                }
            }
        }
    }
}

/// Replies, fault events and telemetry out, in that order of precedence.
async fn write_messages(tx: &mut Sender<'static, UsbDriver>) -> EndpointError {
    let mut frame = [0u8; MAX_FRAME];
    loop {
        let message = match select3(
            REPLIES.receive(),
            FAULT_EVENTS.receive(),
            TELEMETRY.receive(),
        )
        .await
        {
            Either3::First(reply) => DeviceMessage::Reply(reply),
            Either3::Second(event) => DeviceMessage::FaultEvent(event),
            Either3::Third(sample) => DeviceMessage::Telemetry(sample),
        };
        let Ok(len) = encode_frame(&message, &mut frame) else {
            // Every message fits MAX_FRAME by construction (pam-protocol's tests); if one
            // ever did not, dropping it is the only option that does not corrupt the stream.
            defmt::warn!("link: message too large for a frame, dropped");
            continue;
        };
        for chunk in frame[..len].chunks(USB_PACKET_BYTES) {
            if let Err(e) = tx.write_packet(chunk).await {
                return e;
            }
        }
        // a bulk transfer that ends on a full packet is only complete after a zero-length
        // one: without it the host's driver holds the frame until the next packet arrives
        if len % USB_PACKET_BYTES == 0 {
            if let Err(e) = tx.write_packet(&[]).await {
                return e;
            }
        }
    }
}
