//! pamctl against an in-process test device (pam-device over TCP, fake plant): every
//! device subcommand, the link client, error messages and exit codes.

mod cli;
mod support;

use cli::tmpdir;
use pam_link::{Client, DropCounter, LinkError};
use pam_protocol::{ErrorCode, ReplyData, RequestBody};
use std::process::{Command, Output};
use std::time::Duration;
use support::{Options, TestDevice};

fn pamctl(device: &str, args: &[&str]) -> (i32, String, String) {
    let out: Output = Command::new(env!("CARGO_BIN_EXE_pamctl"))
        .arg("--device")
        .arg(device)
        .args(args)
        .env_remove("PAMCTL_DEVICE")
        .output()
        .expect("pamctl runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn ok(device: &str, args: &[&str]) -> String {
    let (code, out, err) = pamctl(device, args);
    assert_eq!(code, 0, "pamctl {args:?} failed: {err}");
    out
}

fn fails(device: &str, args: &[&str]) -> String {
    let (code, _, err) = pamctl(device, args);
    assert_eq!(code, 1, "pamctl {args:?} should fail");
    assert!(err.starts_with("error: "), "{err}");
    err
}

#[test]
fn status_of_a_fresh_device() {
    let d = TestDevice::start(Options::default());
    let out = ok(&d.address, &["status"]);
    assert!(out.contains("device: firmware 0.9.1, protocol 9"), "{out}");
    assert!(out.contains("state: disarmed"), "{out}");
    assert!(out.contains("mode: idle"), "{out}");
    assert!(out.contains("faults: none"), "{out}");
    assert!(
        out.contains("homed: no (put the arm at the neutral pose"),
        "{out}"
    );
    assert!(out.contains("loop: 1000 µs period"), "{out}");
    // a device without a configuration store (this test's) says so; no board lines
    assert!(
        out.contains("\nconfig: thesis defaults (no flash store)\n"),
        "{out}"
    );
    assert!(
        !out.contains("stack:") && !out.contains("board checks:"),
        "{out}"
    );
    assert!(out.contains("sample: α +0.000°"), "{out}");
}

#[test]
fn no_device_given_says_how_to_give_one() {
    let out = Command::new(env!("CARGO_BIN_EXE_pamctl"))
        .arg("status")
        .env_remove("PAMCTL_DEVICE")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no device given") && err.contains("tcp://127.0.0.1:PORT"),
        "{err}"
    );
}

#[test]
fn nothing_listening_and_bad_addresses_are_clear_errors() {
    // bind then drop: a port nobody listens on
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let err = fails(&format!("tcp://127.0.0.1:{port}"), &["status"]);
    assert!(
        err.contains("cannot connect") && err.contains("emulator running"),
        "{err}"
    );
    let err = fails("tcp://localhost", &["status"]);
    assert!(err.contains("tcp://HOST:PORT"), "{err}");
    let err = fails("/dev/does-not-exist-pam", &["status"]);
    assert!(
        err.contains("cannot open serial port /dev/does-not-exist-pam"),
        "{err}"
    );
}

#[test]
fn protocol_version_mismatch_is_explained() {
    let d = TestDevice::start(Options {
        other_protocol: true,
        ..Options::default()
    });
    let err = fails(&d.address, &["status"]);
    assert!(
        err.contains("protocol version mismatch") && err.contains("pamctl speaks version 9"),
        "{err}"
    );
}

#[test]
fn schema_fingerprint_mismatch_is_refused_and_explained() {
    // same protocol version, other wire types: the device (pam-device, the firmware's own
    // service) reports another build's fingerprint in its Hello
    let d = TestDevice::start(Options {
        other_fingerprint: true,
        ..Options::default()
    });
    let ours = format!("{:#010x}", pam_protocol::SCHEMA_FINGERPRINT);
    let theirs = format!("{:#010x}", support::OTHER_FINGERPRINT);
    let err = fails(&d.address, &["status"]);
    assert!(err.contains("wire format mismatch"), "{err}");
    assert!(err.contains(&ours) && err.contains(&theirs), "{err}");
    assert!(
        err.contains("flash the firmware") && err.contains("update pamctl"),
        "{err}"
    );
    // the link client refuses it with a typed error, before any other request
    match Client::connect(&d.address, Duration::from_secs(2)) {
        Err(LinkError::Fingerprint { host, device }) => {
            assert_eq!(host, pam_protocol::SCHEMA_FINGERPRINT);
            assert_eq!(device, support::OTHER_FINGERPRINT);
        }
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("a device with another schema fingerprint was accepted"),
    }
    // the same device with the matching fingerprint is accepted
    let good = TestDevice::start(Options::default());
    let c = Client::connect(&good.address, Duration::from_secs(2)).expect("connects");
    assert_eq!(
        c.info().schema_fingerprint,
        pam_protocol::SCHEMA_FINGERPRINT
    );
}

#[test]
fn arm_needs_home_and_each_mode_is_set() {
    let d = TestDevice::start(Options::default());
    let err = fails(&d.address, &["arm"]);
    assert!(
        err.contains("not homed") && err.contains("pamctl home"),
        "{err}"
    );
    ok(&d.address, &["tare"]);
    ok(&d.address, &["home"]);
    ok(&d.address, &["arm"]);
    // the pressures mode is a service mode, and pamctl says how to turn it on
    let err = fails(&d.address, &["set", "pressures", "1,2,3,2.5"]);
    assert!(
        err.contains("ServiceModeOff") && err.contains("--service"),
        "{err}"
    );
    let out = ok(
        &d.address,
        &[
            "set",
            "pressures",
            "1,2,3,2.5",
            "--service",
            "--hold",
            "0.2",
        ],
    );
    assert!(
        out.contains("mode set: pressures 1.00, 2.00, 3.00, 2.50 bar"),
        "{out}"
    );
    let out = ok(&d.address, &["status"]);
    assert!(
        out.contains("state: armed") && out.contains("mode: pressures"),
        "{out}"
    );
    let out = ok(
        &d.address,
        &[
            "set",
            "joint",
            "--alpha-deg",
            "5,-3",
            "--torque-nm",
            "2,1",
            "--hold",
            "0.1",
        ],
    );
    assert!(out.contains("mode set: joint α +5.00°, -3.00°"), "{out}");
    let out = ok(
        &d.address,
        &[
            "set",
            "force",
            "--force-n",
            "9.1,-4",
            "--feed-forward",
            "--hold",
            "0.1",
        ],
    );
    assert!(out.contains("gain-plane feed-forward on"), "{out}");
    // a stiffness the joint cannot reach is clamped, and pamctl says so
    let out = ok(
        &d.address,
        &["set", "joint", "--stiffness-nm-per-rad", "400,400"],
    );
    assert!(
        out.contains("warning: the target is beyond what the robot can do"),
        "{out}"
    );
    // tare and home are refused while armed
    assert!(fails(&d.address, &["home"]).contains("WrongState"));
    ok(&d.address, &["set", "idle"]);
    ok(&d.address, &["disarm"]);
    let out = ok(&d.address, &["status"]);
    assert!(out.contains("state: disarmed"), "{out}");
}

#[test]
fn out_of_range_target_is_refused_and_nothing_changes() {
    let d = TestDevice::start(Options::default());
    ok(&d.address, &["set", "pressures", "1,1,1,1", "--service"]);
    let err = fails(&d.address, &["set", "pressures", "1,2,9,1"]);
    assert!(
        err.contains("OutOfRange") && err.contains("nothing was changed"),
        "{err}"
    );
    let out = ok(&d.address, &["status"]);
    assert!(
        out.contains("mode: pressures 1.00, 1.00, 1.00, 1.00 bar"),
        "{out}"
    );
    // the host only checks the shape of the input
    let err = fails(&d.address, &["set", "pressures", "1,2"]);
    assert!(err.contains("takes 4 comma-separated values"), "{err}");
}

#[test]
fn silence_times_out_into_a_fault_that_clears_on_command() {
    let d = TestDevice::start(Options::default());
    ok(&d.address, &["home"]);
    ok(&d.address, &["arm"]);
    std::thread::sleep(Duration::from_millis(2000)); // the test device's timeout is 1 s
    let out = ok(&d.address, &["status"]);
    assert!(
        out.contains("state: FAULTED") && out.contains("faults: command timeout"),
        "{out}"
    );
    let err = fails(&d.address, &["arm"]);
    assert!(err.contains("WrongState"), "{err}");
    let out = ok(&d.address, &["fault", "clear"]);
    assert!(out.contains("faults cleared"), "{out}");
    let out = ok(&d.address, &["status"]);
    assert!(
        out.contains("state: disarmed") && out.contains("faults: none"),
        "{out}"
    );
}

/// Only the commander keeps the arm alive: watching does not, unless `--keep-alive` makes
/// the watcher the commander.
#[test]
fn watching_keeps_the_arm_alive_only_with_keep_alive() {
    let d = TestDevice::start(Options::default());
    ok(&d.address, &["home"]);
    ok(&d.address, &["arm"]);
    ok(&d.address, &["set", "joint", "--alpha-deg", "2,0"]);
    ok(&d.address, &["watch", "--seconds", "2", "--plain"]);
    let out = ok(&d.address, &["status"]);
    assert!(
        out.contains("state: FAULTED") && out.contains("faults: command timeout"),
        "a watcher kept the arm alive: {out}"
    );
    ok(&d.address, &["fault", "clear"]);
    ok(&d.address, &["arm"]);
    ok(&d.address, &["set", "joint", "--alpha-deg", "2,0"]);
    ok(
        &d.address,
        &["watch", "--seconds", "2", "--plain", "--keep-alive"],
    );
    let out = ok(&d.address, &["status"]);
    assert!(
        out.contains("state: armed") && out.contains("faults: none"),
        "--keep-alive did not hold the mode: {out}"
    );
    ok(&d.address, &["disarm"]);
}

#[test]
fn config_get_set_save_load() {
    let d = TestDevice::start(Options::default());
    let out = ok(&d.address, &["config", "get", "limits"]);
    assert!(
        out.contains("[limits]") && out.contains("command_timeout_s = 1.0"),
        "{out}"
    );
    assert!(!out.contains("[robot]"));
    let dir = tmpdir("config");
    let saved = dir.path().join("saved.toml");
    ok(&d.address, &["config", "save", saved.to_str().unwrap()]);
    let text = std::fs::read_to_string(&saved).unwrap();
    assert!(
        text.contains("[robot.ip]")
            && text.contains("[calibration.load_cell]")
            && text.contains("[limits]"),
        "{text}"
    );
    let robot_at = text.find("[robot").unwrap();
    assert!(
        robot_at < text.find("[calibration").unwrap()
            && text.find("[calibration").unwrap() < text.find("[limits]").unwrap()
    );
    assert!(text.contains("gain_bar_per_ma = 0.32667"), "{text}");

    let out = ok(
        &d.address,
        &[
            "config",
            "set",
            "limits.command_timeout_s=0.5",
            "robot.joints.0.pulley_radius_m=0.071",
        ],
    );
    assert!(
        out.contains("[robot] applied") && out.contains("[limits] applied"),
        "{out}"
    );
    assert!(
        !out.contains("[calibration]"),
        "untouched sections are not sent: {out}"
    );
    let out = ok(&d.address, &["config", "get", "all"]);
    assert!(
        out.contains("command_timeout_s = 0.5") && out.contains("pulley_radius_m = 0.071"),
        "{out}"
    );

    // the device refuses, nothing changes
    let err = fails(&d.address, &["config", "set", "limits.period_s=0.02"]);
    assert!(
        err.contains("[limits]") && err.contains("OutOfRange"),
        "{err}"
    );
    let err = fails(&d.address, &["config", "set", "robot.pressure.max_bar=7"]);
    assert!(err.contains("OutOfRange"), "{err}");
    let out = ok(&d.address, &["config", "get", "limits"]);
    assert!(out.contains("period_s = 0.001"), "{out}");
    let err = fails(&d.address, &["config", "set", "limits.no_such_key=1"]);
    assert!(err.contains("no `no_such_key`"), "{err}");

    // loading the saved file restores it
    ok(&d.address, &["config", "load", saved.to_str().unwrap()]);
    let out = ok(&d.address, &["config", "get", "all"]);
    assert_eq!(out, text);

    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[limits]\ncommand_timeout_s = \"soon\"\n").unwrap();
    let err = fails(&d.address, &["config", "load", bad.to_str().unwrap()]);
    assert!(
        err.contains("bad.toml") && err.contains("command_timeout_s"),
        "{err}"
    );
}

fn seq_gaps(log: &pam_log::Log) -> usize {
    let seq = log.column("seq").unwrap();
    seq.windows(2).filter(|w| w[1] != w[0] + 1.0).count()
}

#[test]
fn record_for_a_duration_writes_a_valid_log_without_gaps() {
    let d = TestDevice::start(Options::default());
    let dir = tmpdir("record");
    let file = dir.path().join("rec.csv");
    let out = ok(
        &d.address,
        &[
            "record",
            file.to_str().unwrap(),
            "--duration",
            "1",
            "--meta",
            "experiment=static",
            "--quiet",
        ],
    );
    assert!(out.contains("0 dropped"), "{out}");
    let log = pam_log::read_path(&file).expect("valid log v1");
    assert!(
        (700..=1100).contains(&log.len()),
        "{} rows in 1 s",
        log.len()
    );
    assert_eq!(seq_gaps(&log), 0);
    assert_eq!(log.meta("experiment"), Some("static"));
    assert_eq!(log.meta("sample_period_s"), Some("0.001"));
    let t = log.column("t_s").unwrap();
    assert!((t[1] - t[0] - 0.001).abs() < 1e-9);
    assert!(log.column("i1_ma").unwrap().iter().all(|&i| i == 4.0));
    assert!(
        log.column("fx_ref_n").is_none(),
        "no force target, no reference columns"
    );
}

#[test]
fn record_in_force_mode_has_the_force_reference() {
    let d = TestDevice::start(Options::default());
    ok(&d.address, &["set", "force", "--force-n", "5,-2"]);
    let dir = tmpdir("force");
    let file = dir.path().join("force.csv");
    ok(
        &d.address,
        &[
            "record",
            file.to_str().unwrap(),
            "--duration",
            "0.3",
            "--divider",
            "2",
            "--quiet",
        ],
    );
    let log = pam_log::read_path(&file).unwrap();
    assert!(log.column("fx_ref_n").unwrap().iter().all(|&f| f == 5.0));
    assert_eq!(log.meta("sample_period_s"), Some("0.002"));
    let t = log.column("t_s").unwrap();
    assert!((t[1] - t[0] - 0.002).abs() < 1e-9);
}

#[test]
fn ctrl_c_ends_a_recording_with_a_valid_file() {
    let d = TestDevice::start(Options::default());
    let dir = tmpdir("ctrl-c");
    let file = dir.path().join("ctrlc.csv");
    let child = Command::new(env!("CARGO_BIN_EXE_pamctl"))
        .args(["--device", &d.address, "record", file.to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // interrupt once the recording is under way, past its first progress tick (0.5 s)
    let started = std::time::Instant::now();
    while std::fs::read_to_string(&file).map_or(0, |t| t.lines().count()) < 700 {
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "recording never started"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("samples/s") && stderr.contains("dropped"),
        "progress line: {stderr} / stdout {stdout}"
    );
    let log = pam_log::read_path(&file).expect("valid after Ctrl-C");
    assert!(log.len() > 100, "{} rows", log.len());
    assert!(
        stdout.contains(&format!("recorded {} samples", log.len())),
        "{stdout}"
    );
    assert_eq!(seq_gaps(&log), 0);
}

#[test]
fn corrupted_telemetry_is_rejected_and_counted_as_dropped() {
    let d = TestDevice::start(Options {
        corrupt_every: Some(50),
        ..Options::default()
    });
    let client = Client::connect(&d.address, Duration::from_secs(1)).unwrap();
    client.start_telemetry();
    let mut drops = DropCounter::default();
    while drops.received < 400 {
        if let Some(t) = client.next_telemetry(Duration::from_secs(1)).unwrap() {
            drops.record(t.seq);
        }
    }
    assert!(drops.dropped >= 6, "{drops:?}");
    assert!(
        drops.dropped <= client.corrupted_frames(),
        "{drops:?} vs {}",
        client.corrupted_frames()
    );
}

#[test]
fn garbage_on_the_link_gets_a_malformed_reply_and_the_link_recovers() {
    let d = TestDevice::start(Options::default());
    let client = Client::connect(&d.address, Duration::from_secs(1)).unwrap();
    client.send_raw(&[0x13, 0x37, 0xFF, 0x42, 0x00]).unwrap();
    match client.request(RequestBody::GetStatus) {
        Ok(ReplyData::Status(s)) => assert_eq!(s.faults, 0),
        other => panic!("{other:?}"),
    }
    let e = client
        .request(RequestBody::SetTelemetry { divider: 2 })
        .and_then(|_| client.request(RequestBody::Arm))
        .unwrap_err();
    assert!(matches!(
        e,
        pam_link::LinkError::Refused {
            code: ErrorCode::NotHomed,
            ..
        }
    ));
}

#[test]
fn ports_lists_or_says_none() {
    let out = Command::new(env!("CARGO_BIN_EXE_pamctl"))
        .arg("ports")
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
