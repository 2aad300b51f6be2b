pub mod arm;
pub mod config;
pub mod disarm;
pub mod experiment;
pub mod fault;
pub mod home;
pub mod ident;
pub mod model;
pub mod model_loop;
pub mod ports;
pub mod record;
pub mod set;
pub mod sim;
pub mod simulate;
pub mod status;
pub mod tare;
pub mod watch;

use crate::link::{transport::no_device_message, Client};
use crate::LinkArgs;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

/// Connects to `--device` with the handshake.
pub fn connect(link: &LinkArgs) -> Result<Client, String> {
    let device = link.device.as_deref().ok_or_else(no_device_message)?;
    Client::connect(device, Duration::from_millis(link.timeout_ms.max(1)))
        .map_err(|e| e.to_string())
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

/// Names of the latched fault bits (`pam_control::Faults`).
pub fn fault_names(bits: u16) -> String {
    use pam_control::Faults;
    const NAMES: [(Faults, &str); 16] = [
        (Faults::COMMAND_TIMEOUT, "command timeout"),
        (Faults::NON_FINITE, "non-finite sensor value"),
        (Faults::ANGLE_OUT_OF_RANGE, "angle out of range"),
        (Faults::ENCODER_JUMP, "encoder jump"),
        (Faults::LOADCELL_SATURATED, "load cell saturated"),
        (Faults::LOADCELL_STUCK, "load cell stuck"),
        (Faults::OUTPUT_NON_FINITE, "non-finite output"),
        (Faults::WATCHDOG_RESET, "watchdog reset"),
        (Faults::OUTPUT_OPEN_LOOP, "output current loop open"),
        (Faults::CPU_FAULT, "CPU fault exception (last run)"),
        (Faults::LOOP_OVERRUN, "control loop overrun"),
        (Faults::STACK_LOW, "stack high-water mark near its end"),
        (Faults::ESTOP, "emergency stop"),
        (
            Faults::STATIC_IMBALANCE,
            "joint at rest with an unbalanced torque (encoder or converter)",
        ),
        (
            Faults::CONTROL_UNSTABLE,
            "closed loop unstable (oscillation or persistent force error)",
        ),
        (
            Faults::SELF_CHECK,
            "self-check (configuration defaults or board check: see status)",
        ),
    ];
    if bits == 0 {
        return "none".into();
    }
    let mut names: Vec<String> = NAMES
        .iter()
        .filter(|(f, _)| Faults(bits).contains(*f))
        .map(|(_, n)| n.to_string())
        .collect();
    let known = NAMES.iter().fold(0, |a, (f, _)| a | f.0);
    if bits & !known != 0 {
        names.push(format!("unknown bits {:#06x}", bits & !known));
    }
    names.join(", ")
}

/// Says the command worked.
pub fn done(out: &mut dyn std::io::Write, what: &str) -> Result<(), String> {
    writeln!(out, "{what}").map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::fault_names;
    use pam_control::Faults;

    #[test]
    fn the_firmware_faults_have_names() {
        assert_eq!(
            fault_names(Faults::CPU_FAULT.with(Faults::LOOP_OVERRUN).0),
            "CPU fault exception (last run), control loop overrun"
        );
        assert_eq!(
            fault_names(Faults::STACK_LOW.0),
            "stack high-water mark near its end"
        );
        assert_eq!(fault_names(Faults::ESTOP.0), "emergency stop");
        assert!(fault_names(Faults::STATIC_IMBALANCE.0).starts_with("joint at rest"));
        assert_eq!(
            fault_names(Faults::CONTROL_UNSTABLE.0),
            "closed loop unstable (oscillation or persistent force error)"
        );
        assert!(fault_names(Faults::SELF_CHECK.0).starts_with("self-check"));
        assert_eq!(
            fault_names(0x8000 | 0x4000),
            format!("{}, {}", fault_names(0x4000), fault_names(0x8000))
        );
        assert_eq!(fault_names(0), "none");
    }
}
