//! The PlotJuggler stream: `pamctl watch` and `pamctl record` with `--plotjuggler` send
//! datagrams that PlotJuggler's UDP Server (JSON parser) reads — each one JSON object
//! within its 2048-byte buffer, a numeric `timestamp` in seconds that increases, the
//! nested numeric fields the layout in docs/plotjuggler.xml plots — at the asked rate.
//! A UDP listener in the test stands in for PlotJuggler.

use pam_hil_tests::{column, exclusive, ok, pamctl_bin, seq_gaps, tmp_dir, Target};
use serde_json::Value;
use std::net::UdpSocket;
use std::process::{Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

/// PlotJuggler's UDP server reads at most this many bytes per datagram.
const PLOTJUGGLER_DATAGRAM_BYTES: usize = 2048;

/// The series docs/plotjuggler.xml plots, as JSON pointers into a message.
const FIELDS: [&str; 16] = [
    "/alpha_deg/j1",
    "/alpha_deg/j2",
    "/force_n/x",
    "/force_n/y",
    "/pressure_bar/ch1",
    "/pressure_bar/ch2",
    "/pressure_bar/ch3",
    "/pressure_bar/ch4",
    "/current_ma/ch1",
    "/current_ma/ch2",
    "/current_ma/ch3",
    "/current_ma/ch4",
    "/state",
    "/mode",
    "/faults",
    "/loop_us/exec",
];

/// A listener standing in for PlotJuggler: every datagram with its arrival time.
fn listen() -> (String, Receiver<(Instant, Vec<u8>)>) {
    let socket = UdpSocket::bind("127.0.0.1:0").expect("bind a UDP port");
    let addr = socket.local_addr().unwrap().to_string();
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let mut buf = vec![0u8; 65536];
        while let Ok(n) = socket.recv(&mut buf) {
            if tx.send((Instant::now(), buf[..n].to_vec())).is_err() {
                break;
            }
        }
    });
    (addr, rx)
}

/// The datagrams received until none came for 300 ms.
fn drain(rx: &Receiver<(Instant, Vec<u8>)>) -> Vec<(Instant, Vec<u8>)> {
    let mut v = Vec::new();
    while let Ok(d) = rx.recv_timeout(Duration::from_millis(300)) {
        v.push(d);
    }
    v
}

/// Parses and checks every datagram; the messages.
fn check_messages(what: &str, datagrams: &[(Instant, Vec<u8>)]) -> Vec<Value> {
    assert!(!datagrams.is_empty(), "{what}: no datagram received");
    let mut last = f64::NEG_INFINITY;
    let mut messages = Vec::new();
    for (i, (_, bytes)) in datagrams.iter().enumerate() {
        assert!(
            bytes.len() <= PLOTJUGGLER_DATAGRAM_BYTES,
            "{what}: datagram {i} is {} bytes, more than PlotJuggler reads",
            bytes.len()
        );
        let v: Value = serde_json::from_slice(bytes).unwrap_or_else(|e| {
            panic!(
                "{what}: datagram {i} is not JSON ({e}): {}",
                String::from_utf8_lossy(bytes)
            )
        });
        assert!(v.is_object(), "{what}: datagram {i} is not a JSON object");
        let ts = v["timestamp"]
            .as_f64()
            .unwrap_or_else(|| panic!("{what}: datagram {i} has no numeric timestamp: {v}"));
        assert!(
            ts > last,
            "{what}: timestamp {ts} after {last} (datagram {i})"
        );
        last = ts;
        for f in FIELDS {
            assert!(
                v.pointer(f)
                    .is_some_and(|x| x.as_f64().is_some_and(f64::is_finite)),
                "{what}: datagram {i} lacks a finite number at {f}: {v}"
            );
        }
        messages.push(v);
    }
    messages
}

/// The curve names of the saved layout (`<curve name="/alpha_deg/j1" …/>`).
fn layout_curves() -> Vec<String> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/plotjuggler.xml");
    let xml = std::fs::read_to_string(path).expect("docs/plotjuggler.xml");
    xml.split("<curve name=\"")
        .skip(1)
        .map(|rest| rest.split('"').next().unwrap_or_default().to_string())
        .collect()
}

/// Messages per second by their timestamps (the device's clock).
fn rate_by_timestamp(m: &[Value]) -> f64 {
    let first = m[0]["timestamp"].as_f64().unwrap();
    let last = m[m.len() - 1]["timestamp"].as_f64().unwrap();
    (m.len() - 1) as f64 / (last - first)
}

#[test]
fn watch_and_record_stream_plotjuggler_json_at_the_asked_rate() {
    let _serial = exclusive();
    let target = Target::acquire(&[]);
    target.prepare(1.0);
    let d = target.address.as_str();
    let (addr, rx) = listen();

    // watch: 2 s at 200 Hz
    let started = Instant::now();
    ok(
        d,
        &[
            "watch",
            "--plain",
            "--seconds",
            "2",
            "--plotjuggler",
            &addr,
            "--plotjuggler-hz",
            "200",
        ],
    );
    let watch_s = started.elapsed().as_secs_f64();
    let datagrams = drain(&rx);
    let messages = check_messages("watch", &datagrams);
    let by_ts = rate_by_timestamp(&messages);
    let arrival_s = datagrams
        .last()
        .unwrap()
        .0
        .duration_since(datagrams[0].0)
        .as_secs_f64();
    let by_arrival = (datagrams.len() - 1) as f64 / arrival_s;
    eprintln!(
        "watch: {} datagrams, {by_ts:.1} Hz by timestamp, {by_arrival:.1} Hz by arrival \
         ({watch_s:.2} s of pamctl)",
        datagrams.len()
    );
    assert!(
        (190.0..=210.0).contains(&by_ts),
        "watch: {by_ts:.1} Hz by timestamp for 200 Hz"
    );
    assert!(
        (160.0..=240.0).contains(&by_arrival),
        "watch: {by_arrival:.1} Hz by arrival for 200 Hz"
    );
    assert!(
        (340..=420).contains(&datagrams.len()),
        "watch: {} datagrams in 2 s at 200 Hz",
        datagrams.len()
    );
    // disarmed, no fault
    assert!(messages
        .iter()
        .all(|m| m["state"] == 0.0 && m["faults"] == 0));
    // every curve of the saved layout is a series of the stream (the force target only
    // exists in the force modes)
    let curves = layout_curves();
    assert!(curves.len() >= 16, "layout: {curves:?}");
    for c in &curves {
        assert!(
            messages[0].pointer(c).is_some() || c.starts_with("/force_ref_n/"),
            "layout curve {c} is not in the stream: {}",
            messages[0]
        );
    }
    let last_watch_ts = messages.last().unwrap()["timestamp"].as_f64().unwrap();

    // record: 1 s at 50 Hz; the log keeps every sample
    let dir = tmp_dir();
    let file = dir.path().join("plotjuggler_record.csv");
    ok(
        d,
        &[
            "record",
            file.to_str().unwrap(),
            "--duration",
            "1",
            "--quiet",
            "--plotjuggler",
            &addr,
            "--plotjuggler-hz",
            "50",
        ],
    );
    let log = pam_log::read_path(&file).expect("a valid log");
    let rows = column(&log, pam_log::col::T_S).len();
    let datagrams = drain(&rx);
    let messages = check_messages("record", &datagrams);
    let by_ts = rate_by_timestamp(&messages);
    eprintln!(
        "record: {rows} rows in the log, {} datagrams, {by_ts:.1} Hz by timestamp",
        datagrams.len()
    );
    assert!(rows >= 990, "record: {rows} rows in 1 s at 1 kHz");
    assert!(
        (48..=51).contains(&datagrams.len()),
        "record: {} datagrams in 1 s of device time at 50 Hz",
        datagrams.len()
    );
    assert!(
        (47.5..=52.5).contains(&by_ts),
        "record: {by_ts:.1} Hz by timestamp for 50 Hz"
    );
    // a second stream continues PlotJuggler's time axis
    let first_record_ts = messages[0]["timestamp"].as_f64().unwrap();
    assert!(
        first_record_ts > last_watch_ts,
        "record's first timestamp {first_record_ts} is not after watch's last {last_watch_ts}"
    );
}

#[test]
fn ctrl_c_during_a_streamed_record_keeps_every_sample_received() {
    let _serial = exclusive();
    let target = Target::acquire(&[]);
    target.prepare(1.0);
    let (addr, rx) = listen();
    let dir = tmp_dir();
    let file = dir.path().join("plotjuggler_interrupted.csv");
    let child = Command::new(pamctl_bin())
        .args([
            "--device",
            &target.address,
            "record",
            file.to_str().unwrap(),
        ])
        .args(["--quiet", "--plotjuggler", &addr])
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
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let log = pam_log::read_path(&file).expect("a valid log after Ctrl-C");
    assert!(log.len() > 300, "{} rows", log.len());
    assert!(
        stdout.contains(&format!("recorded {} samples", log.len())),
        "{stdout}"
    );
    assert_eq!(seq_gaps(&log), 0);
    // the stream ran alongside: about one datagram per 5 rows at the default 200 Hz
    let datagrams = drain(&rx);
    check_messages("interrupted record", &datagrams);
    let per_row = datagrams.len() as f64 / log.len() as f64;
    assert!(
        (0.18..=0.22).contains(&per_row),
        "{} datagrams for {} rows",
        datagrams.len(),
        log.len()
    );
}
