//! Support for the end-to-end tests: the device under test is `PAM_DEVICE` (a real board,
//! `/dev/ttyACM0`, or any `tcp://HOST:PORT`), or — when it is unset, as in CI — an emulator
//! (`pamctl sim --listen 127.0.0.1:0`) started for the test. Tests talk to it only through
//! the `pamctl` binary and the protocol client (`pam_link::Client`).

use pam_control::SafetyConfig;
use pam_link::Client;
use pam_protocol::{Config, ConfigSection, ReplyData, RequestBody};
use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::sync::{Mutex, MutexGuard};
use std::time::Duration;
use tempfile::TempDir;

/// The tests need the device's 1 kHz loop and the host's attention: one at a time.
pub fn exclusive() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|p| p.into_inner())
}

/// The pamctl binary: `PAMCTL` if set, else the one cargo built next to this test
/// (`cargo test --workspace` builds it; alone, run `cargo build -p pamctl` first).
pub fn pamctl_bin() -> PathBuf {
    if let Some(p) = std::env::var_os("PAMCTL") {
        return PathBuf::from(p);
    }
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> → target/<profile>/pamctl
    let dir = exe
        .parent()
        .and_then(|d| d.parent())
        .expect("target directory");
    let bin = dir.join(format!("pamctl{}", std::env::consts::EXE_SUFFIX));
    assert!(
        bin.exists(),
        "{} not found: run `cargo build -p pamctl` (or set PAMCTL to the binary)",
        bin.display()
    );
    bin
}

/// Runs pamctl against `device`; (exit code, stdout, stderr).
pub fn pamctl(device: &str, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(pamctl_bin())
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

/// pamctl must succeed; its stdout.
pub fn ok(device: &str, args: &[&str]) -> String {
    let (code, out, err) = pamctl(device, args);
    assert_eq!(code, 0, "pamctl {args:?} failed: {err}");
    out
}

/// The device under test.
pub struct Target {
    pub address: String,
    emulator: Option<Child>,
    /// The emulator's standard input (`--stdin-control`: fault injection) and the lines it
    /// prints after its address.
    control: Option<(Mutex<ChildStdin>, Mutex<Receiver<String>>)>,
}

impl Target {
    /// `PAM_DEVICE`, or a fresh emulator started with `sim_args`.
    pub fn acquire(sim_args: &[&str]) -> Target {
        if let Ok(d) = std::env::var("PAM_DEVICE") {
            if !d.trim().is_empty() {
                return Target {
                    address: d,
                    emulator: None,
                    control: None,
                };
            }
        }
        let mut child = Command::new(pamctl_bin())
            .args(["sim", "--listen", "127.0.0.1:0", "--stdin-control"])
            .args(sim_args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("pamctl sim starts");
        let mut stdout = BufReader::new(child.stdout.take().expect("sim stdout"));
        let mut line = String::new();
        stdout.read_line(&mut line).expect("sim prints its address");
        // keep reading what it prints so that it never writes into a closed pipe
        let (lines_tx, lines) = channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            while stdout.read_line(&mut line).is_ok_and(|n| n > 0) {
                let _ = lines_tx.send(line.trim().to_string());
                line.clear();
            }
        });
        let stdin = child.stdin.take().expect("sim stdin");
        let address = line
            .trim()
            .strip_prefix("listening on ")
            .unwrap_or_else(|| panic!("unexpected first line from pamctl sim: {line:?}"))
            .to_string();
        Target {
            address,
            emulator: Some(child),
            control: Some((Mutex::new(stdin), Mutex::new(lines))),
        }
    }

    /// Injects a fault into the emulator (`pamctl sim` fault injection, never over the
    /// link): `None` against a board. Returns the device time (µs) of the first period
    /// the fault acts in, as the emulator reports it.
    pub fn inject(&self, kind: &str) -> Option<u32> {
        let (stdin, lines) = self.control.as_ref()?;
        let lines = lines.lock().unwrap_or_else(|p| p.into_inner());
        while lines.try_recv().is_ok() {}
        writeln!(
            stdin.lock().unwrap_or_else(|p| p.into_inner()),
            "inject {kind}"
        )
        .expect("write to the emulator");
        loop {
            let line = lines
                .recv_timeout(Duration::from_secs(2))
                .unwrap_or_else(|_| panic!("the emulator did not report injecting {kind}"));
            if let Some(t) = line
                .strip_prefix("injected ")
                .and_then(|l| l.rsplit_once("time_us="))
            {
                return Some(t.1.parse().expect("time_us"));
            }
        }
    }

    pub fn is_emulator(&self) -> bool {
        self.emulator.is_some()
    }

    /// A protocol client (1 s reply timeout).
    pub fn client(&self) -> Client {
        Client::connect(&self.address, Duration::from_secs(1)).expect("connect to the device")
    }

    /// Disarmed, faults cleared, homed, telemetry at every period, and the given command
    /// timeout (the device's limits otherwise unchanged).
    pub fn prepare(&self, command_timeout_s: f32) -> SafetyConfig {
        let c = self.client();
        c.command(RequestBody::Disarm).expect("disarm");
        // a timeout fault from a previous test clears once disarmed
        let _ = c.command(RequestBody::ClearFaults);
        let mut limits = match c
            .request(RequestBody::GetConfig(ConfigSection::Limits))
            .expect("limits")
        {
            ReplyData::Config(Config::Limits(l)) => l,
            other => panic!("limits: unexpected reply {other:?}"),
        };
        limits.command_timeout_s = command_timeout_s;
        c.command(RequestBody::SetConfig(Config::Limits(limits)))
            .expect("set the command timeout");
        c.command(RequestBody::SetTelemetry { divider: 1 })
            .expect("telemetry at every period");
        // on a real board the arm must be at the neutral pose when the tests start
        c.command(RequestBody::Home).expect("home");
        limits.into()
    }
}

impl Drop for Target {
    fn drop(&mut self) {
        if let Some(mut child) = self.emulator.take() {
            // Ctrl-C: the emulator stops cleanly
            let _ = Command::new("kill")
                .args(["-INT", &child.id().to_string()])
                .status();
            for _ in 0..50 {
                if let Ok(Some(_)) = child.try_wait() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// The safe state: (the converters' floor pressure, the safe loop current, 4 mA).
pub fn vent(c: &Client) -> (f32, f32) {
    match c
        .request(RequestBody::GetConfig(ConfigSection::Robot))
        .expect("robot parameters")
    {
        ReplyData::Config(Config::Robot(p)) => {
            // the converter's floor, commanded with the safe current (4 mA)
            (p.ip.output_min_bar, p.ip.current_min_ma)
        }
        other => panic!("robot parameters: unexpected reply {other:?}"),
    }
}

/// A fresh directory for a test's files; keep the guard for the whole test: it is removed
/// when the test ends, pass or fail.
pub fn tmp_dir() -> TempDir {
    tempfile::Builder::new()
        .prefix("pam-hil-")
        .tempdir()
        .expect("temp dir")
}

/// Telemetry `seq` steps other than +1.
pub fn seq_gaps(log: &pam_log::Log) -> usize {
    let seq = log.column("seq").expect("seq column");
    seq.windows(2).filter(|w| w[1] != w[0] + 1.0).count()
}
pub mod measure;

/// A log column the test needs (panics with its name when the log lacks it).
pub fn column<'a>(log: &'a pam_log::Log, name: &str) -> &'a [f64] {
    log.column(name)
        .unwrap_or_else(|| panic!("column {name} missing"))
}

/// Mean of the last `n` values (all of them when fewer).
pub fn mean_of_last(v: &[f64], n: usize) -> f64 {
    let tail = &v[v.len().saturating_sub(n)..];
    tail.iter().sum::<f64>() / tail.len().max(1) as f64
}
