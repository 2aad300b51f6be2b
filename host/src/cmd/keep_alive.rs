//! `--keep-alive` of `watch` and `record`: the listener explicitly becomes the commander of
//! the armed device (mode unchanged) and sends its keep-alives while it runs. Without it they
//! only listen, and the mode lives as long as the client that armed or set it keeps talking.

use pam_link::{Client, LinkError};
use pam_protocol::ErrorCode;
use std::time::{Duration, Instant};

/// Keep-alives every this often: well inside the shortest command timeout a script allows.
const PERIOD: Duration = Duration::from_millis(25);

pub struct KeepAlive {
    last: Option<Instant>,
}

impl KeepAlive {
    /// Takes the command if `enabled` and the device is armed (a disarmed device has no mode
    /// to keep alive: nothing is taken).
    pub fn start(client: &Client, enabled: bool) -> Result<KeepAlive, LinkError> {
        if !enabled {
            return Ok(KeepAlive { last: None });
        }
        match client.take_command() {
            Ok(()) => Ok(KeepAlive {
                last: Some(Instant::now()),
            }),
            Err(LinkError::Refused {
                code: ErrorCode::WrongState,
                ..
            }) => Ok(KeepAlive { last: None }),
            Err(e) => Err(e),
        }
    }

    /// A keep-alive if one is due.
    pub fn tick(&mut self, client: &Client) -> Result<(), LinkError> {
        if let Some(last) = &mut self.last {
            if last.elapsed() >= PERIOD {
                client.heartbeat()?;
                *last = Instant::now();
            }
        }
        Ok(())
    }
}
