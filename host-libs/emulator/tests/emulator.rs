//! The emulator library in-process: the twin is in the loop, the device front end reads its
//! sensors, connections come and go, the pseudo-terminal serves the same protocol.

use pam_control::{Mode, State};
use pam_emulator::{Emulator, HandleMode, SimConfig};
use pam_link::Client;
use pam_protocol::{ReplyData, RequestBody};
use std::time::{Duration, Instant};

fn connect(address: &str) -> Client {
    Client::connect(address, Duration::from_secs(1)).expect("connect")
}

/// One emulator at a time: each needs its 1 kHz loop.
fn exclusive() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock().unwrap_or_else(|p| p.into_inner())
}

fn start(handle: HandleMode) -> (Emulator, String) {
    let config = SimConfig {
        handle,
        command_timeout_s: 1.0,
        ..SimConfig::default()
    };
    let mut e = Emulator::start(config).expect("emulator");
    let addr = e.listen_tcp("127.0.0.1:0").expect("listen");
    (e, format!("tcp://{addr}"))
}

/// Keeps the link alive for `seconds`; the last sample.
fn run(c: &Client, seconds: f64) -> pam_protocol::Telemetry {
    c.start_telemetry();
    let start = Instant::now();
    let mut last = None;
    let mut beat = Instant::now() - Duration::from_secs(1);
    while start.elapsed().as_secs_f64() < seconds {
        if beat.elapsed() > Duration::from_millis(20) {
            c.heartbeat().unwrap();
            beat = Instant::now();
        }
        if let Some(t) = c.next_telemetry(Duration::from_millis(10)).unwrap() {
            last = Some(t);
        }
    }
    last.expect("telemetry")
}

#[test]
fn unequal_pressures_turn_the_twin_and_the_encoders_see_it() {
    let _serial = exclusive();
    let (emu, address) = start(HandleMode::Free);
    let c = connect(&address);
    c.command(RequestBody::Home).unwrap();
    c.set_service_mode(true).unwrap();
    c.command(RequestBody::Arm).unwrap();
    let still = run(&c, 0.2);
    assert!(
        still.alpha_rad.iter().all(|a| a.abs() < 1e-3),
        "{:?}",
        still.alpha_rad
    );
    // joint 1's pair (channels 0, 1): one muscle at 2.1 bar, the other vented (the pressures
    // mode's largest imbalance), reached as the tensioning ramp ends (1 s). The free arm
    // swings (the twin's arm is lightly damped): look at the largest excursion.
    c.command(RequestBody::SetMode(
        Mode::Pressures {
            pressure_bar: [2.1, 0.1, 1.5, 1.5],
        }
        .into(),
    ))
    .unwrap();
    c.start_telemetry();
    let start = Instant::now();
    let mut largest: f32 = 0.0;
    while start.elapsed() < Duration::from_millis(1800) {
        c.heartbeat().unwrap();
        while let Some(t) = c.next_telemetry(Duration::ZERO).unwrap() {
            largest = largest.max(t.alpha_rad[0].abs());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    // the twin moved and the device's encoder front end saw it move
    assert!(largest > 0.05, "joint 1 moved at most {largest} rad");
    assert!(emu.stats.periods.load(std::sync::atomic::Ordering::Relaxed) > 800);
}

#[test]
fn a_new_connection_takes_the_stream_over_and_the_old_one_still_gets_replies() {
    let _serial = exclusive();
    let (_emu, address) = start(HandleMode::Free);
    let first = connect(&address);
    first.start_telemetry();
    assert!(first
        .next_telemetry(Duration::from_millis(500))
        .unwrap()
        .is_some());
    let second = connect(&address);
    second.start_telemetry();
    assert!(second
        .next_telemetry(Duration::from_millis(500))
        .unwrap()
        .is_some());
    // the old client still talks to the device
    assert!(matches!(
        first.request(RequestBody::GetStatus),
        Ok(ReplyData::Status(_))
    ));
    drop(second);
    // a dropped connection does not stop the device: a third one works
    let third = connect(&address);
    assert!(
        matches!(third.request(RequestBody::GetStatus), Ok(ReplyData::Status(s)) if s.state == State::Disarmed)
    );
    // garbage from a raw socket does not hurt either
    use std::io::Write;
    let mut raw = std::net::TcpStream::connect(address.trim_start_matches("tcp://")).unwrap();
    raw.write_all(&[0xFF; 2000]).unwrap();
    drop(raw);
    let fourth = connect(&address);
    assert!(matches!(
        fourth.request(RequestBody::GetStatus),
        Ok(ReplyData::Status(_))
    ));
}

#[test]
fn blocked_handle_in_force_mode_measures_the_commanded_force() {
    let _serial = exclusive();
    let (_emu, address) = start(HandleMode::Blocked);
    let c = connect(&address);
    c.command(RequestBody::Home).unwrap();
    c.command(RequestBody::Arm).unwrap();
    c.command(RequestBody::SetMode(
        Mode::Force {
            force_n: [0.0, -8.0],
            stiffness_nm_per_rad: [60.0, 27.0],
            feed_forward: false,
        }
        .into(),
    ))
    .unwrap();
    // the tensioning ramp (1 s) ends on the mode's command
    let t = run(&c, 1.8);
    assert!(
        (t.force_user_n[1] + 8.0).abs() < 2.0 && t.force_user_n[0].abs() < 2.0,
        "{:?}",
        t.force_user_n
    );
    assert!(
        t.alpha_rad.iter().all(|a| a.abs() < 1e-3),
        "blocked, yet moved: {:?}",
        t.alpha_rad
    );
}

#[cfg(target_os = "linux")]
#[test]
fn the_pseudo_terminal_serves_the_same_protocol() {
    let _serial = exclusive();
    let (mut emu, _) = start(HandleMode::Free);
    let path = emu.open_pty().expect("pty");
    assert!(path.starts_with("/dev/"), "{path}");
    let c = connect(&path);
    assert_eq!(c.info().protocol_version, pam_protocol::PROTOCOL_VERSION);
    c.command(RequestBody::Home).unwrap();
    let t = run(&c, 0.3);
    assert_eq!(t.state, State::Disarmed);
}
