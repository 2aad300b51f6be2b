pub mod arm;
pub mod commission;
pub mod config;
pub mod disarm;
pub mod experiment;
pub mod fault;
pub mod home;
pub mod ident;
pub mod keep_alive;
pub mod model;
pub mod model_loop;
pub mod ports;
pub mod record;
pub mod set;
pub mod sim;
pub mod simulate;
pub mod status;
pub mod tare;
pub mod tune;
pub mod watch;

use crate::LinkArgs;
use pam_link::{Client, LinkError};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

/// Connects to `--device` with the handshake.
pub fn connect(link: &LinkArgs) -> anyhow::Result<Client> {
    let device = link.device.as_deref().ok_or(LinkError::NoDevice)?;
    Ok(Client::connect(
        device,
        Duration::from_millis(link.timeout_ms.max(1)),
    )?)
}

/// Set by Ctrl-C (installed on first use; later uses share it).
pub fn interrupted() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        // if a handler already exists (embedding program), Ctrl-C just is not caught here
        let _ = ctrlc::set_handler(move || f.store(true, Ordering::SeqCst));
        flag
    })
    .clone()
}

/// Says the command worked.
pub fn done(out: &mut dyn std::io::Write, what: &str) -> anyhow::Result<()> {
    Ok(writeln!(out, "{what}")?)
}
