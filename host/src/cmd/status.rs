//! `pamctl status`: what the device is doing.

use crate::LinkArgs;
use pam_control::{Mode, State};
use pam_protocol::{
    ConfigOrigin, CpuFaultKind, ReplyData, RequestBody, Status, Telemetry, BOARD_CHECK_ADC_DUAL,
    BOARD_CHECK_OUTPUT_STAGE, BOARD_CHECK_VDDA,
};
use std::io::Write;
use std::time::Duration;

pub fn describe_mode(mode: &Mode) -> String {
    match mode {
        Mode::Idle => "idle".into(),
        Mode::Pressures { pressure_bar: p } => format!(
            "pressures {:.2}, {:.2}, {:.2}, {:.2} bar",
            p[0], p[1], p[2], p[3]
        ),
        Mode::Joint {
            alpha_rad,
            torque_nm,
            stiffness_nm_per_rad,
        } => format!(
            "joint α {:+.2}°, {:+.2}°; τ {:+.2}, {:+.2} N·m; K {:.1}, {:.1} N·m/rad",
            alpha_rad[0].to_degrees(),
            alpha_rad[1].to_degrees(),
            torque_nm[0],
            torque_nm[1],
            stiffness_nm_per_rad[0],
            stiffness_nm_per_rad[1]
        ),
        Mode::Force {
            force_n,
            stiffness_nm_per_rad,
            feed_forward,
        } => format!(
            "force ({:+.2}, {:+.2}) N, K {:.1}, {:.1} N·m/rad, gain-plane feed-forward {}",
            force_n[0],
            force_n[1],
            stiffness_nm_per_rad[0],
            stiffness_nm_per_rad[1],
            if *feed_forward { "on" } else { "off" }
        ),
        Mode::ForceClosedLoop {
            force_n,
            stiffness_nm_per_rad,
            feed_forward,
            gain_scale,
        } => format!(
            "force ({:+.2}, {:+.2}) N closed loop (gain ×{:.2}), K {:.1}, {:.1} N·m/rad, \
             gain-plane feed-forward {}",
            force_n[0],
            force_n[1],
            gain_scale,
            stiffness_nm_per_rad[0],
            stiffness_nm_per_rad[1],
            if *feed_forward { "on" } else { "off" }
        ),
        Mode::Impedance {
            target_user_m,
            stiffness_n_per_m,
            damping_n_s_per_m,
            ..
        } => format!(
            "impedance about ({:+.3}, {:+.3}) m, K {:.0}, {:.0} N/m, B {:.1}, {:.1} N·s/m",
            target_user_m[0],
            target_user_m[1],
            stiffness_n_per_m[0],
            stiffness_n_per_m[1],
            damping_n_s_per_m[0],
            damping_n_s_per_m[1]
        ),
    }
}

pub fn state_name(s: State) -> &'static str {
    match s {
        State::Disarmed => "disarmed",
        State::Armed => "armed",
        State::Faulted => "FAULTED",
    }
}

pub fn describe_sample(t: &Telemetry) -> String {
    format!(
        "α {:+.3}°, {:+.3}°  force ({:+.2}, {:+.2}) N  currents {:.2}, {:.2}, {:.2}, {:.2} mA  \
         pressures {:.2}, {:.2}, {:.2}, {:.2} bar  loop {} µs (jitter {} µs){}",
        t.alpha_rad[0].to_degrees(),
        t.alpha_rad[1].to_degrees(),
        t.force_user_n[0],
        t.force_user_n[1],
        t.current_ma[0],
        t.current_ma[1],
        t.current_ma[2],
        t.current_ma[3],
        t.pressure_cmd_bar[0],
        t.pressure_cmd_bar[1],
        t.pressure_cmd_bar[2],
        t.pressure_cmd_bar[3],
        t.loop_exec_us,
        t.loop_jitter_us,
        describe_limited(t.limited)
    )
}

/// Telemetry's `limited` byte in words, "" when nothing was limited, else `  [what, …]`.
pub fn describe_limited(bits: u8) -> String {
    use pam_model::Limited;
    const WORDS: [(u8, &str); 7] = [
        (Limited::TARGET.0, "target scaled to the muscles"),
        (Limited::TORQUE.0, "torque clamped"),
        (Limited::STIFFNESS.0, "stiffness not attainable"),
        (Limited::PRESSURE.0, "pressure clamped"),
        (Limited::INVALID_INPUT.0, "invalid input"),
        (Limited::SINGULAR.0, "singular"),
        (pam_protocol::LIMITED_OUTPUT, "slew or converter range"),
    ];
    let words: Vec<&str> = WORDS
        .iter()
        .filter(|(bit, _)| bits & bit != 0)
        .map(|(_, w)| *w)
        .collect();
    if words.is_empty() {
        String::new()
    } else {
        format!("  [{}]", words.join(", "))
    }
}

/// Where the configuration came from, and whether it was changed since.
pub fn describe_config(s: &Status) -> String {
    let origin = match s.config {
        ConfigOrigin::Flash => "from flash",
        ConfigOrigin::DefaultsNoRecord => "thesis defaults (no record in flash)",
        ConfigOrigin::DefaultsCorrupt => "thesis defaults: the record in flash is CORRUPT",
        ConfigOrigin::DefaultsOtherVersion => {
            "thesis defaults: the record in flash is of ANOTHER FIRMWARE VERSION"
        }
        ConfigOrigin::DefaultsRefused => "thesis defaults: the device REFUSED the record in flash",
        ConfigOrigin::DefaultsNoStorage => "thesis defaults (no flash store)",
    };
    let unsaved = if s.config_unsaved {
        "; changed since (`pamctl config persist` keeps it)"
    } else {
        ""
    };
    format!("{origin}{unsaved}")
}

/// Whether the pressures mode may be set.
pub fn describe_service_mode(s: &Status) -> &'static str {
    if s.service_mode {
        "ON: the pressures mode may be set (off at the next disarm or fault)"
    } else {
        "off (`pamctl set pressures --service` turns it on)"
    }
}

/// The board's self-report: VDDA, stack, board checks, the last CPU fault.
pub fn describe_board(s: &Status) -> Vec<String> {
    let mut lines = Vec::new();
    let mut checks = Vec::new();
    if s.board_checks & BOARD_CHECK_VDDA != 0 {
        checks.push("VDDA out of range");
    }
    if s.board_checks & BOARD_CHECK_ADC_DUAL != 0 {
        checks.push("ADC dual mode not set");
    }
    if s.board_checks & BOARD_CHECK_OUTPUT_STAGE != 0 {
        checks.push("output stage not safe in reset (board revision)");
    }
    if s.board_checks & !(BOARD_CHECK_VDDA | BOARD_CHECK_ADC_DUAL | BOARD_CHECK_OUTPUT_STAGE) != 0 {
        checks.push("unknown");
    }
    if !checks.is_empty() {
        lines.push(format!("board checks: FAILING: {}", checks.join(", ")));
    }
    if let Some(v) = s.vdda_v {
        lines.push(format!("vdda: {v:.3} V"));
    }
    if let Some(st) = s.stack {
        lines.push(format!(
            "stack: {} of {} B used at most ({} B free)",
            st.used_max_bytes,
            st.size_bytes,
            st.size_bytes.saturating_sub(st.used_max_bytes)
        ));
    }
    if let Some(f) = s.last_cpu_fault {
        let kind = match f.kind {
            CpuFaultKind::HardFault => "HardFault",
            CpuFaultKind::MemManage => "MemManage",
            CpuFaultKind::BusFault => "BusFault",
            CpuFaultKind::UsageFault => "UsageFault",
            CpuFaultKind::UnexpectedInterrupt => "unexpected interrupt",
        };
        lines.push(format!(
            "last run ended in: {kind} at pc {:#010x} (address {:#010x})",
            f.pc, f.address
        ));
    }
    lines
}

pub fn run(link: &LinkArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let client = super::connect(link)?;
    let info = *client.info();
    client.start_telemetry();
    let s = match client.request(RequestBody::GetStatus)? {
        ReplyData::Status(s) => s,
        _ => {
            return Err(anyhow::anyhow!(
                "the device answered status with the wrong kind of reply"
            ))
        }
    };
    let sample = client
        .next_telemetry(Duration::from_millis(200))
        .ok()
        .flatten();
    let w = |out: &mut dyn Write, line: String| writeln!(out, "{line}");
    let v = info.firmware_version;
    w(
        out,
        format!(
            "device: firmware {}.{}.{}, protocol {} (schema {:08x}), parameters hash {:08x}",
            v.major,
            v.minor,
            v.patch,
            info.protocol_version,
            info.schema_fingerprint,
            info.params_hash
        ),
    )?;
    w(out, format!("state: {}", state_name(s.state.into())))?;
    w(out, format!("mode: {}", describe_mode(&s.mode.into())))?;
    w(out, format!("faults: {}", pam_link::fault_names(s.faults)))?;
    w(
        out,
        format!(
            "homed: {}{}",
            if s.homed { "yes" } else { "no" },
            if s.homed {
                ""
            } else {
                " (put the arm at the neutral pose and run `pamctl home`)"
            }
        ),
    )?;
    w(
        out,
        format!(
            "loop: {} µs period, telemetry every {} period(s)",
            s.period_us, s.telemetry_divider
        ),
    )?;
    w(
        out,
        format!("service interlock: {}", describe_service_mode(&s)),
    )?;
    w(out, format!("config: {}", describe_config(&s)))?;
    for line in describe_board(&s) {
        w(out, line)?;
    }
    match sample {
        Some(t) => w(out, format!("sample: {}", describe_sample(&t)))?,
        None => w(
            out,
            "sample: none (telemetry off: `pamctl record` turns it on)".into(),
        )?,
    }
    Ok(())
}

#[cfg(test)]
mod limited_tests {
    use super::describe_limited;

    #[test]
    fn the_limited_byte_in_words() {
        assert_eq!(describe_limited(0), "");
        assert_eq!(
            describe_limited(0x20 | 0x02 | 0x80),
            "  [target scaled to the muscles, stiffness not attainable, slew or converter range]"
        );
        assert_eq!(describe_limited(0x01), "  [torque clamped]");
    }
}
