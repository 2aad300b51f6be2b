//! The device's latched fault bits in words, for telemetry and status read over the link.

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
