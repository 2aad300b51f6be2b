//! `cargo xtask test`: every test of the project, arranged so that a two-core machine is
//! busy all the time.
//!
//! The hardware-in-the-loop tests (pam-hil-tests) run the emulator in real time: for about
//! four minutes they mostly wait on the 1 kHz loop and use little of the processor. The
//! rest of the host suite, the Cortex-M4F suites in QEMU and the firmware's release build
//! use all of it and never wait. So the real-time tests run in the background at normal
//! priority while the rest runs beside them at a lower priority (`renice`), which keeps the
//! emulator's loop on time: the scheduler gives a niced process the processor only when the
//! real-time tests leave it. The real-time tests' output is printed once they end.

use std::io::{BufRead, BufReader, Read};
use std::process::{Child, Command, Stdio};
use std::thread::JoinHandle;

use crate::{
    cargo_in, cargo_test_counts, ensure_chromium, ensure_qemu, firmware, qemu_counts,
    qemu_fault_paths, root, run_qemu, run_status, run_streaming,
};

/// The package whose tests run the emulator in real time.
const REAL_TIME_PACKAGE: &str = "pam-hil-tests";

/// How much lower the processor-bound work runs than the real-time tests (`nice` steps).
const BACKGROUND_NICENESS: &str = "10";

pub fn test() -> i32 {
    // Installed before the host suite so the report's rendering test finds it; when it is
    // missing that test fails and says how to install it.
    ensure_chromium();
    println!("== host: build every test (cargo test --workspace --no-run)");
    if run_status(cargo_in(&root()).args(["test", "--workspace", "--no-run"])) != 0 {
        println!();
        println!("host: 0 passed, 1 failed (the build failed)");
        return 1;
    }

    println!("== hardware-in-the-loop: cargo test -p {REAL_TIME_PACKAGE} (real time, in the background; its output follows the rest)");
    // --no-fail-fast: a failing test binary must not hide the tests of the others from the
    // counts
    let real_time = Captured::spawn(cargo_in(&root()).args([
        "test",
        "--no-fail-fast",
        "-p",
        REAL_TIME_PACKAGE,
    ]));
    lower_own_priority();

    println!("== host: cargo test --workspace --exclude {REAL_TIME_PACKAGE}");
    let (host_code, host_lines) = run_streaming(cargo_in(&root()).args([
        "test",
        "--no-fail-fast",
        "--workspace",
        "--exclude",
        REAL_TIME_PACKAGE,
    ]));
    let (mut host_passed, mut host_failed) = cargo_test_counts(&host_lines);
    if host_code != 0 && host_failed == 0 {
        host_failed = 1; // a crash or a build failure: count it, never report green
    }

    let (qemu_passed, qemu_failed) = qemu_suites();

    println!("== firmware: release build for the NUCLEO-G474RE");
    let firmware_ok = firmware().is_ok();

    println!("== hardware-in-the-loop: waiting for cargo test -p {REAL_TIME_PACKAGE}");
    let (rt_code, rt_lines) = real_time.finish();
    for line in &rt_lines {
        println!("{line}");
    }
    let (rt_passed, mut rt_failed) = cargo_test_counts(&rt_lines);
    if rt_code != 0 && rt_failed == 0 {
        rt_failed = 1;
    }
    host_passed += rt_passed;
    host_failed += rt_failed;

    println!();
    if !firmware_ok {
        println!("firmware: build or size check FAILED");
    }
    println!("host: {host_passed} passed, {host_failed} failed");
    println!("qemu: {qemu_passed} passed, {qemu_failed} failed");
    i32::from(!(host_failed == 0 && qemu_failed == 0 && firmware_ok))
}

/// The model checks and the firmware's fault paths on the Cortex-M4F: (passed, failed).
fn qemu_suites() -> (u64, u64) {
    println!("== qemu: model checks on Cortex-M4F (mps2-an386)");
    let (mut passed, mut failed) = if ensure_qemu() {
        let (code, lines) = run_qemu(&[]);
        match qemu_counts(&lines) {
            Some((p, f)) if code == 0 || f > 0 => (p, f),
            Some((p, _)) => (p, 1),
            None => (0, 1),
        }
    } else {
        (0, 1)
    };
    println!("== qemu: the firmware's fault paths on Cortex-M4 (mps2-an386)");
    let (fault_passed, fault_failed) = if ensure_qemu() {
        qemu_fault_paths()
    } else {
        (0, 1)
    };
    passed += fault_passed;
    failed += fault_failed;
    (passed, failed)
}

/// Lowers this process's priority; what it starts from now on inherits it. Without
/// `renice` everything still runs, only with the real-time tests less protected.
fn lower_own_priority() {
    let pid = std::process::id().to_string();
    let lowered = Command::new("renice")
        .args(["-n", BACKGROUND_NICENESS, "-p", &pid])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !lowered {
        eprintln!("xtask: renice not available; the real-time tests share the processor evenly");
    }
}

/// A command running in the background with its stdout and stderr gathered, in order, into
/// lines.
struct Captured {
    child: Option<Child>,
    reader: Option<JoinHandle<Vec<String>>>,
}

impl Captured {
    fn spawn(cmd: &mut Command) -> Self {
        let spawned = std::io::pipe().and_then(|(reader, writer)| {
            let child = cmd.stdout(writer.try_clone()?).stderr(writer).spawn()?;
            Ok((reader, child))
        });
        // the command holds the pipe's writing ends; ours are dropped once it is started,
        // so the reader sees the end of the output when the command ends
        cmd.stdout(Stdio::null()).stderr(Stdio::null());
        match spawned {
            Ok((reader, child)) => Self {
                child: Some(child),
                reader: Some(std::thread::spawn(move || read_lines(reader))),
            },
            Err(e) => {
                eprintln!("xtask: could not start {:?}: {e}", cmd.get_program());
                Self {
                    child: None,
                    reader: None,
                }
            }
        }
    }

    /// Waits for the command: (exit code, its output's lines).
    fn finish(mut self) -> (i32, Vec<String>) {
        let Some(mut child) = self.child.take() else {
            return (1, Vec::new());
        };
        let code = child.wait().map(|s| s.code().unwrap_or(1)).unwrap_or(1);
        let lines = self
            .reader
            .take()
            .and_then(|r| r.join().ok())
            .unwrap_or_default();
        (code, lines)
    }
}

fn read_lines(reader: impl Read) -> Vec<String> {
    BufReader::new(reader)
        .lines()
        .map_while(Result::ok)
        .collect()
}
