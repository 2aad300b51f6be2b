//! End-to-end: the device (real board or emulator) driven only through the pamctl binary
//! and the protocol client. Serialised: each needs the 1 kHz loop undisturbed.
//!
//! On the emulator the handle is blocked while the device is armed in force mode
//! (`pamctl sim --handle blocked`); on a real board block the handle before running.

use pam_control::{Faults, Mode, State};
use pam_hil_tests::{column, exclusive, mean_of_last, ok, pamctl, seq_gaps, tmp_dir, Target};
use pam_link::{Client, LinkError};
use pam_log::col;
use pam_protocol::{
    encode_frame, ErrorCode, ModeKind, ReplyData, Request, RequestBody, Telemetry, MAX_FRAME,
};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

const SIM: &[&str] = &["--handle", "blocked"];

/// Every row: commanded pressures within 0–5 bar, loop currents within 4–20 mA, armed,
/// no fault, the expected mode.
fn assert_physical(log: &pam_log::Log, mode_code: f64, what: &str) {
    assert!(!log.is_empty(), "{what}: empty log");
    for name in col::PRESSURES_CMD_BAR {
        for &p in column(log, name) {
            assert!(
                (0.0..=5.0).contains(&p),
                "{what}: {name} = {p} bar outside 0–5 bar"
            );
        }
    }
    for name in col::CURRENTS_MA {
        for &i in column(log, name) {
            assert!(
                (4.0 - 1e-4..=20.0 + 1e-4).contains(&i),
                "{what}: {name} = {i} mA outside 4–20 mA"
            );
        }
    }
    assert!(
        column(log, col::STATE).iter().all(|&s| s == 1.0),
        "{what}: not armed throughout"
    );
    assert!(
        column(log, col::FAULTS).iter().all(|&f| f == 0.0),
        "{what}: faults latched"
    );
    assert!(
        column(log, "mode").iter().all(|&m| m == mode_code),
        "{what}: mode column is not {mode_code}"
    );
}

fn record(
    device: &str,
    file: &std::path::Path,
    seconds: &str,
    extra: &[&str],
) -> (String, pam_log::Log) {
    let mut args = vec![
        "record",
        file.to_str().unwrap(),
        "--duration",
        seconds,
        "--quiet",
        // the recording is what keeps the mode it looks at alive
        "--keep-alive",
    ];
    args.extend(extra);
    let out = ok(device, &args);
    let log = pam_log::read_path(file)
        .unwrap_or_else(|e| panic!("{}: not a valid log: {e}", file.display()));
    (out, log)
}

#[test]
fn each_mode_then_ten_seconds_at_1khz_without_gaps() {
    let _serial = exclusive();
    let target = Target::acquire(SIM);
    // separate pamctl processes follow each other within the timeout
    target.prepare(1.0);
    let (vent_bar, vent_ma) = pam_hil_tests::vent(&target.client());
    let d = target.address.as_str();
    let dir = tmp_dir();
    ok(d, &["arm"]);

    // idle: vented (the I/P converters' floor, commanded by its loop current)
    ok(d, &["set", "idle"]);
    let (_, log) = record(d, &dir.path().join("idle.csv"), "0.5", &[]);
    assert_physical(&log, 0.0, "idle");
    for (i, p) in col::CURRENTS_MA.iter().zip(col::PRESSURES_CMD_BAR) {
        assert!(
            column(&log, i)
                .iter()
                .all(|&v| (v - vent_ma as f64).abs() < 1e-3),
            "idle: {i} not {vent_ma} mA"
        );
        assert!(
            column(&log, p)
                .iter()
                .all(|&v| (v - vent_bar as f64).abs() < 1e-4),
            "idle: {p} not {vent_bar} bar"
        );
    }

    // force, first, at the neutral pose: the handle is blocked there and the measured force
    // follows the reference
    ok(d, &["set", "force", "--force-n", "10,0"]);
    let (_, log) = record(d, &dir.path().join("force.csv"), "1.5", &[]);
    assert_physical(&log, 3.0, "force");
    assert!(column(&log, col::FX_REF_N).iter().all(|&f| f == 10.0));
    let fx = mean_of_last(column(&log, col::FX_N), 500);
    let fy = mean_of_last(column(&log, col::FY_N), 500);
    eprintln!("force mode, blocked handle: measured ({fx:.2}, {fy:.2}) N for (10, 0) N");
    // open loop (thesis §5.2: gains 0.6–1.3 per axis, cross-talk a few N)
    assert!(
        (5.0..=15.0).contains(&fx) && fy.abs() < 5.0,
        "force: measured ({fx:.2}, {fy:.2}) N for (10, 0) N"
    );

    // pressures: the command reaches the targets after the tensioning ramp (1 s from
    // idle, `pam_control::motion::ARM_RAMP_S`) and stays there; a service mode: its
    // interlock goes on from idle
    ok(d, &["set", "idle"]);
    ok(d, &["set", "pressures", "1.0,2.0,3.0,2.5", "--service"]);
    let (_, log) = record(d, &dir.path().join("pressures.csv"), "2", &[]);
    assert_physical(&log, 1.0, "pressures");
    for (name, want) in col::PRESSURES_CMD_BAR.iter().zip([1.0, 2.0, 3.0, 2.5]) {
        let p = mean_of_last(column(&log, name), 300);
        assert!(
            (p - want).abs() < 0.01,
            "pressures: {name} settles at {p}, want {want}"
        );
    }
    // the loop current follows the I/P law's slope: more pressure, more current
    let i: Vec<f64> = col::CURRENTS_MA
        .iter()
        .map(|n| mean_of_last(column(&log, n), 300))
        .collect();
    assert!(
        i[0] < i[1] && i[1] < i[3] && i[3] < i[2],
        "pressures: currents {i:?} not ordered like the pressures"
    );

    // joint: free handle, the arm goes toward the target and nothing pushes back. The
    // pressures mode above leaves the arm wherever its imbalance pushed it, and the joint
    // target is shaped at 0.15 rad/s from there: 4 s cover the joints' range
    ok(d, &["set", "joint", "--alpha-deg", "5,-5"]);
    let (_, log) = record(d, &dir.path().join("joint.csv"), "4", &[]);
    assert_physical(&log, 2.0, "joint");
    let a1 = mean_of_last(column(&log, col::ALPHA1_RAD), 300).to_degrees();
    let a2 = mean_of_last(column(&log, col::ALPHA2_RAD), 300).to_degrees();
    assert!(
        a1 > 1.0 && a2 < -1.0,
        "joint: arm at ({a1:.2}°, {a2:.2}°), target (5°, −5°)"
    );
    for name in [col::FX_N, col::FY_N] {
        let f = mean_of_last(column(&log, name), 300);
        assert!(
            f.abs() < 3.0,
            "joint, free handle: {name} = {f:.2} N, nothing holds the handle"
        );
    }

    // ten seconds at 1 kHz, with the link throughput
    let file = dir.path().join("ten_seconds.csv");
    let (out, log) = record(d, &file, "10", &["--stats"]);
    assert!(
        (9_999..=10_001).contains(&log.len()),
        "{} rows in 10 s at 1 kHz",
        log.len()
    );
    assert_eq!(seq_gaps(&log), 0, "sequence gaps in the 10 s recording");
    assert!(out.contains("0 dropped on the link"), "{out}");
    assert_physical(&log, 2.0, "10 s in joint mode");
    let t = column(&log, col::T_S);
    assert!((t[1] - t[0] - 0.001).abs() < 1e-9 && (t[t.len() - 1] - 9.999).abs() < 2e-3);
    let rate: f64 = out
        .split("bytes/s")
        .next()
        .and_then(|s| s.rsplit(' ').nth(1))
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no throughput in {out}"));
    eprintln!(
        "{}",
        out.lines().find(|l| l.starts_with("link:")).unwrap_or("")
    );
    // every sample arrived: at least one minimal frame per sample, at most the largest
    assert!(
        rate > 1000.0 * 40.0 && rate < 1000.0 * pam_protocol::TELEMETRY_FRAME_MAX as f64 * 1.1,
        "{rate} bytes/s"
    );
    ok(d, &["disarm"]);
}

fn status(c: &Client) -> pam_protocol::Status {
    match c.request(RequestBody::GetStatus).expect("status") {
        ReplyData::Status(s) => s,
        other => panic!("status: unexpected {other:?}"),
    }
}

/// Telemetry until `done` says so (or `limit`), feeding the command timeout meanwhile.
fn wait_for(
    c: &Client,
    limit: Duration,
    heartbeat: bool,
    mut done: impl FnMut(&Telemetry) -> bool,
) -> Telemetry {
    let start = Instant::now();
    let mut last_beat = Instant::now();
    while start.elapsed() < limit {
        if heartbeat && last_beat.elapsed() > Duration::from_millis(20) {
            c.heartbeat().expect("heartbeat");
            last_beat = Instant::now();
        }
        if let Some(t) = c
            .next_telemetry(Duration::from_millis(10))
            .expect("telemetry")
        {
            if done(&t) {
                return t;
            }
        }
    }
    panic!("condition not reached within {limit:?}");
}

#[test]
fn silent_host_brings_the_device_to_its_safe_state_within_the_timeout() {
    let _serial = exclusive();
    let target = Target::acquire(SIM);
    // the firmware's own default timeout
    let limits = target.prepare(0.1);
    let c = target.client();
    let (vent, vent_ma) = pam_hil_tests::vent(&c);
    c.command(RequestBody::Arm).expect("arm");
    let p_set = 2.5f32;
    c.set_service_mode(true).expect("service mode");
    c.command(RequestBody::SetMode(
        Mode::Pressures {
            pressure_bar: [p_set; 4],
        }
        .into(),
    ))
    .expect("pressures");
    c.start_telemetry();
    wait_for(&c, Duration::from_secs(2), true, |t| {
        t.pressure_cmd_bar.iter().all(|&p| (p - p_set).abs() < 1e-3)
    });

    // the host falls silent: only listens from now on
    c.command(RequestBody::Heartbeat).expect("last request");
    c.start_telemetry();
    let first = wait_for(&c, Duration::from_secs(1), false, |_| true);
    let t0_us = first.time_us;
    let mut fault_at_us = None;
    let safe = wait_for(&c, Duration::from_secs(3), false, |t| {
        if t.state == State::Faulted && fault_at_us.is_none() {
            fault_at_us = Some(t.time_us);
        }
        // nothing may change before the timeout
        if t.time_us.wrapping_sub(t0_us) < (limits.command_timeout_s * 0.9e6) as u32 {
            assert_eq!(t.state, State::Armed, "faulted before the timeout");
            assert!(t.pressure_cmd_bar.iter().all(|&p| (p - p_set).abs() < 1e-3));
        }
        t.pressure_cmd_bar.iter().all(|&p| p <= vent + 1e-4)
            && t.current_ma.iter().all(|&i| i <= vent_ma + 1e-3)
    });
    let fault_s = fault_at_us.expect("faulted").wrapping_sub(t0_us) as f64 * 1e-6;
    let safe_s = safe.time_us.wrapping_sub(t0_us) as f64 * 1e-6;
    let allowed_s = limits.command_timeout_s as f64
        + (p_set - vent) as f64 / limits.timeout_ramp_bar_per_s as f64;
    eprintln!("timeout fault after {fault_s:.3} s, vented ({vent_ma:.2} mA) after {safe_s:.3} s; allowed {allowed_s:.3} s");
    // the first sample seen lags the last request by the link latency: a few ms of slack
    assert!(
        fault_s <= limits.command_timeout_s as f64 + 0.01,
        "fault after {fault_s} s"
    );
    assert!(
        safe_s <= allowed_s + 0.01,
        "safe state after {safe_s} s, allowed {allowed_s} s"
    );
    assert!(
        safe.faults & Faults::COMMAND_TIMEOUT.0 != 0,
        "fault bits {:#x}",
        safe.faults
    );
    let events = c.fault_events();
    assert!(
        events
            .iter()
            .any(|e| e.bits & Faults::COMMAND_TIMEOUT.0 != 0),
        "no fault event: {events:?}"
    );
    // and it stays safe until the host clears it
    let later = wait_for(&c, Duration::from_secs(1), false, |t| {
        t.time_us.wrapping_sub(safe.time_us) > 200_000
    });
    assert_eq!(later.state, State::Faulted);
    assert!(later.current_ma.iter().all(|&i| i <= vent_ma + 1e-3));
    // the host comes back: disarm cuts the loops to 4 mA, then the fault clears
    c.command(RequestBody::Disarm).expect("disarm");
    c.command(RequestBody::ClearFaults).expect("clear");
    assert_eq!(status(&c).state, State::Disarmed);
    c.start_telemetry();
    let t = wait_for(&c, Duration::from_secs(1), true, |_| true);
    assert!(
        t.current_ma.iter().all(|&i| i == 4.0),
        "disarmed: {:?} mA",
        t.current_ma
    );
}

#[test]
fn out_of_range_target_is_refused_and_the_state_is_unchanged() {
    let _serial = exclusive();
    let target = Target::acquire(SIM);
    target.prepare(1.0);
    let c = target.client();
    c.command(RequestBody::Arm).expect("arm");
    let joint = Mode::Joint {
        alpha_rad: [0.05, -0.05],
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [60.0, 27.0],
    };
    c.command(RequestBody::SetMode(joint.into()))
        .expect("joint");
    let before = status(&c);
    for bad in [
        Mode::Pressures {
            pressure_bar: [6.0, 1.0, 1.0, 1.0],
        },
        Mode::Pressures {
            pressure_bar: [f32::NAN, 1.0, 1.0, 1.0],
        },
        Mode::Joint {
            alpha_rad: [0.0; 2],
            torque_nm: [0.0; 2],
            stiffness_nm_per_rad: [1.0e6, 27.0],
        },
        Mode::Force {
            force_n: [1000.0, 0.0],
            stiffness_nm_per_rad: [60.0, 27.0],
            feed_forward: false,
        },
    ] {
        // armed in the joint mode, the pressures mode is refused by its service interlock
        // before its values are looked at
        let expected = match bad {
            Mode::Pressures { .. } => ErrorCode::ServiceModeOff,
            _ => ErrorCode::OutOfRange,
        };
        match c.request(RequestBody::SetMode(bad.into())) {
            Err(LinkError::Refused { code, .. }) if code == expected => {}
            other => panic!("{bad:?}: expected {expected:?}, got {other:?}"),
        }
        assert_eq!(status(&c), before, "a refused target changed the state");
    }
    c.start_telemetry();
    let t = wait_for(&c, Duration::from_secs(1), true, |_| true);
    assert_eq!((t.mode, t.state), (ModeKind::Joint, State::Armed.into()));
    drop(c);

    // the same through the command line: a clear error, non-zero exit, nothing changed
    let (code, _, err) = pamctl(
        &target.address,
        &["set", "joint", "--stiffness-nm-per-rad", "1e6,27"],
    );
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("OutOfRange") && err.contains("nothing was changed"),
        "{err}"
    );
    // the pressures mode while armed in another: refused by its interlock, and pamctl says
    // how to turn it on
    let (code, _, err) = pamctl(&target.address, &["set", "pressures", "1,1,1,1"]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("ServiceModeOff") && err.contains("--service"),
        "{err}"
    );
    let out = ok(&target.address, &["status"]);
    assert!(
        out.contains("state: armed") && out.contains("mode: joint α +2.86°, -2.86°"),
        "{out}"
    );
    ok(&target.address, &["disarm"]);
}

#[test]
fn corrupted_frame_is_rejected_and_the_link_recovers() {
    let _serial = exclusive();
    let target = Target::acquire(SIM);
    target.prepare(1.0);
    let c = target.client();
    c.command(RequestBody::Arm).expect("arm");
    c.command(RequestBody::SetMode(Mode::Idle.into()))
        .expect("idle");
    // the request below sets the pressures mode: its service interlock goes on from idle
    c.set_service_mode(true).expect("service mode");
    let before = status(&c);

    // a valid pressures request with one byte flipped in flight
    let mut frame = [0u8; MAX_FRAME];
    let request = Request {
        id: 999,
        body: RequestBody::SetMode(
            Mode::Pressures {
                pressure_bar: [3.0; 4],
            }
            .into(),
        ),
        session: c.info().session,
    };
    let n = encode_frame(&request, &mut frame).unwrap();
    frame[n / 2] ^= 0x40;
    if frame[n / 2] == 0 {
        frame[n / 2] = 0x41;
    }
    c.send_raw(&frame[..n]).unwrap();
    // and line noise without a delimiter, then one
    c.send_raw(&[0x13, 0x37, 0xFF, 0x01, 0x80, 0x7E]).unwrap();
    c.send_raw(&[0x00]).unwrap();

    // the link works at once and nothing was applied
    let after = status(&c);
    assert_eq!(after, before, "the corrupted request changed the state");
    c.start_telemetry();
    let t = wait_for(&c, Duration::from_secs(1), true, |t| t.time_us > 0);
    assert_eq!(t.mode, ModeKind::Idle);
    assert!(
        t.pressure_cmd_bar.iter().all(|&p| p < 0.2),
        "{:?}",
        t.pressure_cmd_bar
    );
    // and the uncorrupted request is carried out
    let mut frame = [0u8; MAX_FRAME];
    let n = encode_frame(&request, &mut frame).unwrap();
    c.send_raw(&frame[..n]).unwrap();
    let t = wait_for(&c, Duration::from_secs(1), true, |t| {
        t.mode == ModeKind::Pressures
    });
    assert_eq!(t.state, State::Armed);
    c.command(RequestBody::Disarm).expect("disarm");
}

#[test]
fn ctrl_c_during_record_leaves_a_valid_csv_with_everything_received() {
    let _serial = exclusive();
    let target = Target::acquire(SIM);
    target.prepare(1.0);
    let dir = tmp_dir();
    let file = dir.path().join("interrupted.csv");
    let child = Command::new(pam_hil_tests::pamctl_bin())
        .args([
            "--device",
            &target.address,
            "record",
            file.to_str().unwrap(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("pamctl record");
    // wait until the recording is under way (rows on disk), then Ctrl-C
    let start = Instant::now();
    while std::fs::metadata(&file).map(|m| m.len()).unwrap_or(0) < 50_000 {
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "the recording did not start"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let log = pam_log::read_path(&file).expect("a valid log after Ctrl-C");
    assert!(log.len() > 300, "{} rows", log.len());
    assert!(
        stdout.contains(&format!("recorded {} samples", log.len())),
        "{stdout}"
    );
    assert_eq!(seq_gaps(&log), 0);
}

/// A `pamctl experiment step` at pose 0 on the emulator, each level held `hold_s`, with
/// `extra` arguments, into a fresh directory: the serialising guard, the target and the
/// directory (all held for the test; the directory is removed when it ends, pass or fail)
/// and pamctl's output. `None` on a real board, where the operator must block the handle:
/// run it by hand there.
fn step_experiment(
    hold_s: &str,
    extra: &[&str],
) -> Option<(std::sync::MutexGuard<'static, ()>, Target, TempDir, String)> {
    let serial = exclusive();
    let target = Target::acquire(SIM);
    if !target.is_emulator() {
        eprintln!(
            "skipped on PAM_DEVICE: `pamctl experiment step` needs the handle blocked by hand"
        );
        return None;
    }
    target.prepare(1.0);
    let dir = tmp_dir();
    let mut args = vec![
        "experiment",
        "step",
        "--pose",
        "0",
        "--hold-s",
        hold_s,
        "--settle-s",
        "0.3",
        "--yes",
        "--out",
        dir.path().to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let out = ok(&target.address, &args);
    Some((serial, target, dir, out))
}

#[test]
fn force_step_experiment_writes_one_log_that_follows_the_reference() {
    let Some((_serial, _target, dir, out)) = step_experiment("0.25", &["--repeats", "2"]) else {
        return;
    };
    assert!(out.contains("1 log(s)"), "{out}");
    let log = pam_log::read_path(dir.path().join("step_pose0.csv")).expect("a valid log");
    assert_eq!(log.meta("experiment"), Some("force_step"));
    assert_eq!(log.meta("repeats"), Some("2"));
    assert_eq!(log.meta("pose_deg"), Some("0 0"));
    assert_eq!(seq_gaps(&log), 0);
    let (fx, fy) = (column(&log, col::FX_N), column(&log, col::FY_N));
    let (rx, ry) = (column(&log, col::FX_REF_N), column(&log, col::FY_REF_N));
    // twice 2 axes × 13 levels, each ending settled near its reference (blocked handle)
    let mut levels = 0;
    for i in 1..log.len() {
        let end_of_level = rx[i] != rx[i - 1] || ry[i] != ry[i - 1];
        if end_of_level {
            levels += 1;
            let (ex, ey) = (fx[i - 1] - rx[i - 1], fy[i - 1] - ry[i - 1]);
            assert!(
                ex.abs() < 4.0 && ey.abs() < 4.0,
                "level ({}, {}) N: measured ({:.2}, {:.2}) N",
                rx[i - 1],
                ry[i - 1],
                fx[i - 1],
                fy[i - 1]
            );
        }
    }
    // the staircase's 24 steps, twice
    assert!(levels >= 47, "{levels} level changes");
    assert!(
        rx.iter().chain(ry).any(|&f| (f - 27.3).abs() < 1e-3)
            && rx.iter().chain(ry).any(|&f| (f + 27.3).abs() < 1e-3)
    );
}

#[test]
fn force_steps_at_both_co_contractions_make_the_pair_the_model_loop_decides() {
    // half-second holds: each log's 24 steps then last the 10 s the model loop needs
    let Some((_serial, target, dir, out)) = step_experiment("0.5", &["--co-contraction", "both"])
    else {
        return;
    };
    assert!(out.contains("2 log(s)"), "{out}");
    let (low_path, high_path) = (
        dir.path().join("step_pose0.csv"),
        dir.path().join("step_pose0_high.csv"),
    );
    let low = pam_log::read_path(&low_path).expect("a valid log");
    let high = pam_log::read_path(&high_path).expect("a valid log");
    assert_eq!(low.meta("co_contraction"), Some("low"));
    assert_eq!(high.meta("co_contraction"), Some("high"));
    let k = |l: &pam_log::Log| -> Vec<f64> {
        l.meta("k_joint_nm_per_rad")
            .unwrap()
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect()
    };
    let (kl, kh) = (k(&low), k(&high));
    assert!(kh[0] >= kl[0] && kh[1] >= kl[1] && (kh[0] > kl[0] || kh[1] > kl[1]));
    // the same staircase, followed at the higher co-contraction too
    for l in [&low, &high] {
        assert!(column(l, col::FX_REF_N)
            .iter()
            .any(|f| (f - 27.3).abs() < 1e-3));
        assert!(column(l, col::FY_REF_N)
            .iter()
            .any(|f| (f + 27.3).abs() < 1e-3));
    }
    let (fx, rx) = (column(&high, col::FX_N), column(&high, col::FX_REF_N));
    assert!((fx[fx.len() - 1] - rx[rx.len() - 1]).abs() < 4.0);
    // the model loop reads them as a pair: the currents are higher in the second
    let json = ok(
        &target.address,
        &[
            "model",
            "diagnose",
            low_path.to_str().unwrap(),
            high_path.to_str().unwrap(),
            "--json",
        ],
    );
    let v: serde_json::Value = serde_json::from_str(&json).expect("JSON");
    let pair = &v["family_or_spread"];
    assert_eq!(pair["decided"], serde_json::Value::Bool(true), "{pair}");
    let sum = |i: usize| -> f64 {
        pair["logs"][i]["mean_current_ma"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .sum()
    };
    assert!(sum(1) > sum(0), "{pair}");
}
