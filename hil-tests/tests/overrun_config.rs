//! The count of consecutive missed periods that latches `LOOP_OVERRUN` is part of the safety
//! configuration: set through `pamctl config set`, checked by the device (1–100),
//! and used by the emulated board's loop timing, the firmware's own
//! (`pam_firmware_logic::cycle_stats`). Persisting it is in `tests/config_flash.rs`.

use pam_control::{Faults, Mode, State};
use pam_hil_tests::measure::measure;
use pam_hil_tests::{exclusive, ok, pamctl, Target};
use pam_protocol::RequestBody;
use std::time::Duration;

fn limits(t: &Target) -> String {
    ok(&t.address, &["config", "get", "limits"])
        .split_whitespace()
        .collect()
}

#[test]
fn the_configured_count_of_missed_periods_decides_the_overrun_fault() {
    let _serial = exclusive();
    let target = Target::acquire(&["--handle", "blocked"]);
    if !target.is_emulator() {
        eprintln!("skipped: the overrun is injected into the emulator");
        return;
    }
    target.prepare(1.0);
    let a = &target.address;
    assert!(
        limits(&target).contains("overrun_fault_periods=3"),
        "the default"
    );

    // out of its range: refused by the device, nothing changed
    for bad in ["0", "101"] {
        let (code, _, err) = pamctl(
            a,
            &[
                "config",
                "set",
                &format!("limits.overrun_fault_periods={bad}"),
            ],
        );
        assert_ne!(code, 0, "{bad} accepted");
        assert!(err.to_lowercase().contains("range"), "{bad}: {err}");
    }
    assert!(limits(&target).contains("overrun_fault_periods=3"));

    // 8 allowed: 5 stalled periods in a row are no fault
    ok(a, &["config", "set", "limits.overrun_fault_periods=8"]);
    assert!(limits(&target).contains("overrun_fault_periods=8"));
    let c = target.client();
    c.command(RequestBody::Arm).expect("arm");
    let mode = Mode::Joint {
        alpha_rad: [0.05, -0.05],
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [60.0, 27.0],
    };
    c.command(RequestBody::SetMode(mode.into())).expect("mode");
    c.start_telemetry();
    let t0 = target.inject("overrun:periods=5").expect("emulator");
    let mut seen_after = 0;
    let start = std::time::Instant::now();
    let mut last_beat = start;
    while seen_after < 300 && start.elapsed() < Duration::from_secs(5) {
        // heartbeats every 20 ms however fast the telemetry comes
        if last_beat.elapsed() > Duration::from_millis(20) {
            c.heartbeat().expect("heartbeat");
            last_beat = std::time::Instant::now();
        }
        let Some(t) = c
            .next_telemetry(Duration::from_millis(5))
            .expect("telemetry")
        else {
            continue;
        };
        if t.time_us >= t0 {
            seen_after += 1;
            assert_eq!(t.state, State::Armed, "faults {:#06x}", t.faults);
        }
    }
    assert!(
        seen_after >= 300,
        "only {seen_after} samples after the stall"
    );

    // 4 allowed, set while armed: the same 5 stalls latch the fault at the fourth
    ok(a, &["config", "set", "limits.overrun_fault_periods=4"]);
    let m = measure(
        &c,
        500,
        |_| target.inject("overrun:periods=5").expect("emulator"),
        true,
        Faults::LOOP_OVERRUN,
        Duration::from_secs(3),
        100,
    );
    eprintln!("{}", m.row("loop overrun, count 4 (5 steps of 2 periods)"));
    assert!(m.faults & Faults::LOOP_OVERRUN.0 != 0);
    assert_eq!(m.raised_periods, 4, "the fourth missed period latches");
    assert_eq!(m.safe_periods, m.raised_periods);
    assert_eq!(m.gaps_before, 0);
    c.command(RequestBody::Disarm).expect("disarm");
    ok(a, &["config", "set", "limits.overrun_fault_periods=3"]);
}
