//! End-to-end, closed-loop force mode (issue 14): through pamctl and the protocol, on the
//! emulator with a blocked handle (on a board: block the handle first).

use pam_control::{Faults, Mode, State, MAX_GAIN_SCALE};
use pam_hil_tests::{exclusive, ok, pamctl, tmp, Target};
use pam_log::col;
use pam_protocol::{ModeKind, RequestBody};
use std::time::{Duration, Instant};

const SIM: &[&str] = &["--handle", "blocked"];

fn column<'a>(log: &'a pam_log::Log, name: &str) -> &'a [f64] {
    log.column(name)
        .unwrap_or_else(|| panic!("column {name} missing"))
}

fn mean_of_last(v: &[f64], n: usize) -> f64 {
    let tail = &v[v.len().saturating_sub(n)..];
    tail.iter().sum::<f64>() / tail.len().max(1) as f64
}

#[test]
fn closed_loop_force_step_reaches_the_target() {
    let _serial = exclusive();
    let target = Target::acquire(SIM);
    target.prepare(1.0);
    let d = target.address.as_str();
    ok(d, &["arm"]);
    // away from the neutral force, so that the step is a real one
    let out = ok(d, &["set", "force", "--force-n", "9.1,-4", "--closed-loop"]);
    assert!(out.contains("closed loop"), "{out}");
    let file = tmp("closed_loop.csv");
    let args = [
        "record",
        file.to_str().unwrap(),
        "--duration",
        "1.5",
        "--quiet",
    ];
    ok(d, &args);
    let log = pam_log::read_path(&file).expect("a valid log");
    assert!(
        column(&log, "mode").iter().all(|&m| m == 5.0),
        "mode code 5"
    );
    assert!(column(&log, col::FAULTS).iter().all(|&f| f == 0.0));
    assert!(column(&log, col::STATE).iter().all(|&s| s == 1.0));
    assert!(column(&log, col::FX_REF_N)
        .iter()
        .all(|&f| (f - 9.1).abs() < 1e-4));
    let fx = mean_of_last(column(&log, col::FX_N), 300);
    let fy = mean_of_last(column(&log, col::FY_N), 300);
    eprintln!("closed loop, blocked handle: measured ({fx:.3}, {fy:.3}) N for (9.1, −4) N");
    // the open loop's tolerance in e2e.rs is ±5 N; closed, the load cell's noise
    assert!(
        (fx - 9.1).abs() < 0.2 && (fy + 4.0).abs() < 0.2,
        "closed loop: measured ({fx:.3}, {fy:.3}) N for (9.1, −4) N"
    );
    for name in col::CURRENTS_MA {
        assert!(column(&log, name)
            .iter()
            .all(|&i| (4.0 - 1e-4..=20.0 + 1e-4).contains(&i)));
    }
    ok(d, &["disarm"]);
}

#[test]
fn bad_gains_are_caught_by_the_guard_over_the_link() {
    let _serial = exclusive();
    let target = Target::acquire(SIM);
    target.prepare(1.0);
    let c = target.client();
    let (_, vent_ma) = pam_hil_tests::vent(&c);
    let closed = |force_n: [f32; 2], gain_scale: f32| {
        RequestBody::SetMode(
            Mode::ForceClosedLoop {
                force_n,
                stiffness_nm_per_rad: [60.0, 27.0],
                feed_forward: false,
                gain_scale,
            }
            .into(),
        )
    };
    c.command(RequestBody::Arm).expect("arm");
    c.command(closed([0.0; 2], 1.0)).expect("closed loop");
    c.start_telemetry();
    // settle at zero force with the designed gains…
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(1000) {
        c.heartbeat().expect("heartbeat");
        std::thread::sleep(Duration::from_millis(20));
        while let Ok(Some(_)) = c.next_telemetry(Duration::ZERO) {}
    }
    // …then step with the most the device accepts: twenty times the designed gains
    c.command(closed([9.1, 0.0], MAX_GAIN_SCALE))
        .expect("bad gains accepted");
    let mut peak_n: f32 = 0.0;
    let mut faulted_at = None;
    let t0 = Instant::now();
    let mut last_beat = Instant::now();
    let mut last = None;
    while t0.elapsed() < Duration::from_secs(3) {
        if last_beat.elapsed() > Duration::from_millis(20) {
            c.heartbeat().expect("heartbeat");
            last_beat = Instant::now();
        }
        if let Ok(Some(t)) = c.next_telemetry(Duration::from_millis(10)) {
            if t.state == State::Faulted && faulted_at.is_none() {
                faulted_at = Some(t0.elapsed());
            }
            if faulted_at.is_none() {
                peak_n = peak_n
                    .max(t.force_user_n[0].abs())
                    .max(t.force_user_n[1].abs());
            }
            let done = faulted_at.is_some_and(|f| t0.elapsed() > f + Duration::from_millis(100));
            last = Some(t);
            if done {
                break;
            }
        }
    }
    eprintln!("bad gains: fault after {faulted_at:?}, peak {peak_n:.1} N before it");
    let t = last.expect("telemetry");
    assert!(
        faulted_at.is_some_and(|f| f < Duration::from_millis(1500)),
        "{faulted_at:?}"
    );
    assert!(
        t.faults & Faults::CONTROL_UNSTABLE.0 != 0,
        "{:#x}",
        t.faults
    );
    assert_eq!(t.mode, ModeKind::ForceClosedLoop);
    assert!(
        t.current_ma.iter().all(|&i| i <= vent_ma + 1e-3),
        "vented: {:?}",
        t.current_ma
    );
    // stopped within about one swing beyond the guard's 25 N error bound
    assert!(peak_n < 9.1 + 1.5 * 25.0, "peak {peak_n} N");
    assert!(
        c.fault_events()
            .iter()
            .any(|e| e.bits & Faults::CONTROL_UNSTABLE.0 != 0),
        "a fault event"
    );
    c.command(RequestBody::Disarm).expect("disarm");
    // the host refuses nothing itself: the device refuses a gain scale beyond its range
    let (code, _, stderr) = pamctl(
        &target.address,
        &[
            "set",
            "force",
            "--force-n",
            "1,0",
            "--closed-loop",
            "--gain-scale",
            "21",
        ],
    );
    assert_ne!(code, 0);
    assert!(!stderr.is_empty());
}
