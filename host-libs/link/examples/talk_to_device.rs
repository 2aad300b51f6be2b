//! Talk to a device: connect, read what it says in the handshake, and print a few telemetry
//! frames. The device is a board on a serial port or the emulator over TCP:
//!
//! ```sh
//! cargo run -p pamctl -- sim &     # the emulator, serving tcp://127.0.0.1:7878
//! cargo run -p pam-link --example talk_to_device -- tcp://127.0.0.1:7878
//! cargo run -p pam-link --example talk_to_device -- /dev/ttyACM0   # a board
//! ```
//!
//! Every error is a [`pam_link::LinkError`] whose `help()` says what to check.

use std::time::Duration;

use pam_link::{Client, LinkError};

fn main() {
    let device = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "tcp://127.0.0.1:7878".into());
    if let Err(e) = talk(&device) {
        eprintln!("error: {e}\n  help: {}", e.help());
        std::process::exit(1);
    }
}

fn talk(device: &str) -> Result<(), LinkError> {
    // the handshake checks the protocol version and the schema fingerprint
    let client = Client::connect(device, Duration::from_secs(2))?;
    println!("connected: {:?}", client.info());
    client.start_telemetry();
    for _ in 0..5 {
        match client.next_telemetry(Duration::from_millis(500))? {
            Some(frame) => println!("{frame:?}"),
            None => println!("no telemetry within 0.5 s"),
        }
    }
    for event in client.fault_events() {
        println!("fault event: {event:?}");
    }
    Ok(())
}
