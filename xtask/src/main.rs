//! `cargo xtask <command>`: the project's jobs, with no dependency beyond cargo.
//!
//! - `test`        every test: the host suite, the model checks and the firmware's fault
//!   paths on the Cortex-M4F in QEMU, the firmware's release build; the real-time
//!   hardware-in-the-loop tests run beside the rest ([`suite`]). Prints
//!   `host: N passed, M failed` and `qemu: N passed, M failed`.
//! - `qemu-fault-paths` only the firmware's fault paths in QEMU (part of `test`).
//! - `qemu-bench`  instruction counts and f32-vs-f64 precision on the Cortex-M4F, with libm
//!   and with micromath.
//! - `bench`       criterion benchmarks on the host.
//! - `eval`        `[--quick] [--only NAME] [--list]`: the evaluation suites (pam-eval, the
//!   twin's tables, the QEMU counts); writes docs/results.md ([`eval`]).
//! - `firmware`    release build of the board firmware, with its flash and static-RAM size.
//! - `fuzz`        the cargo-fuzz targets (`cargo +nightly fuzz run`, [`fuzz`]).
//! - `soak`        `[--hours H] [--seed S]`: hours of emulated operation with random targets
//!   and injected faults, fast-forwarded (`pam_emulator::soak`), in a release build.
//! - `fault-table` `[--write]`: each fault × each mode, held and free, on the twin
//!   (`pam_emulator::soak::fault_table`); `--write` rewrites its section of hil-tests/README.md.
//!
//! Works from any directory and with `CARGO_TARGET_DIR` set, absolute or relative to where
//! `cargo xtask` runs ([`target_dir`]).

mod eval;
mod fault_table;
mod fuzz;
mod soak;
mod suite;
mod target_dir;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{exit, Command, Stdio};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let code = match args.first().map(String::as_str) {
        Some("test") => suite::test(),
        Some("qemu-bench") => qemu_bench(),
        Some("qemu-fault-paths") => match qemu_fault_paths() {
            (p, 0) if p > 0 => 0,
            _ => 1,
        },
        Some("firmware") => firmware().map(|_| 0).unwrap_or(1),
        Some("bench") => run_status(cargo_in(&root()).args(["bench", "-p", "pam-model"])),
        Some("eval") => eval::eval(&args[1..]),
        Some("fuzz") => fuzz::fuzz(&args[1..]),
        Some("soak") => soak::soak(&args[1..]),
        Some("fault-table") => fault_table::fault_table(&args[1..]),
        _ => {
            eprintln!("usage: cargo xtask <test | eval | qemu-fault-paths | qemu-bench | bench | firmware | fuzz | soak | fault-table>");
            2
        }
    };
    exit(code);
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn cargo() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())
}

/// A cargo command run in `dir`, with `CARGO_TARGET_DIR` (when set) made absolute against our
/// working directory: cargo would take a relative one relative to `dir`.
fn cargo_in(dir: &Path) -> Command {
    program_in(cargo(), dir)
}

/// The rustup proxy `cargo` from the PATH, set up as [`cargo_in`]: it takes `+nightly`, which
/// the toolchain's own cargo (`$CARGO` under `cargo xtask`) does not.
fn rustup_cargo_in(dir: &Path) -> Command {
    program_in("cargo".into(), dir)
}

fn program_in(program: String, dir: &Path) -> Command {
    let mut cmd = Command::new(program);
    cmd.current_dir(dir);
    let cwd = std::env::current_dir().unwrap_or_else(|_| root());
    let value = std::env::var_os("CARGO_TARGET_DIR");
    if let Some(t) = target_dir::absolute_target_dir(value.as_deref(), &cwd) {
        cmd.env("CARGO_TARGET_DIR", t);
    }
    cmd
}

fn run_status(cmd: &mut Command) -> i32 {
    match cmd.status() {
        Ok(s) => s.code().unwrap_or(1),
        Err(e) => {
            eprintln!("xtask: could not start {:?}: {e}", cmd.get_program());
            1
        }
    }
}

/// Runs a command, echoing its stdout line by line to ours, and returns (exit code, lines).
fn run_streaming(cmd: &mut Command) -> (i32, Vec<String>) {
    let mut child = match cmd.stdout(Stdio::piped()).spawn() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("xtask: could not start {:?}: {e}", cmd.get_program());
            return (1, Vec::new());
        }
    };
    let mut lines = Vec::new();
    for line in BufReader::new(child.stdout.take().unwrap())
        .lines()
        .map_while(Result::ok)
    {
        println!("{line}");
        lines.push(line);
    }
    let code = child.wait().map(|s| s.code().unwrap_or(1)).unwrap_or(1);
    (code, lines)
}

/// Sums cargo's `test result: ok. N passed; M failed; ...` lines.
fn cargo_test_counts(lines: &[String]) -> (u64, u64) {
    let (mut passed, mut failed) = (0, 0);
    for l in lines.iter().filter(|l| l.starts_with("test result:")) {
        let num_before = |word: &str| -> u64 {
            l.split(';')
                .find(|part| part.trim_end().ends_with(word))
                .and_then(|part| {
                    part.split_whitespace()
                        .rev()
                        .nth(1)
                        .and_then(|n| n.parse().ok())
                })
                .unwrap_or(0)
        };
        passed += num_before("passed");
        failed += num_before("failed");
    }
    (passed, failed)
}

/// Makes sure `qemu-system-arm` is on the PATH (the Cortex-M4F suite runs in it).
fn ensure_qemu() -> bool {
    ensure_debian_tool("qemu-system-arm", "qemu-system-arm", "the Cortex-M4F tests")
}

/// Makes sure headless Chromium is there (the model report's screenshot test renders in it).
fn ensure_chromium() -> bool {
    ensure_debian_tool("chromium", "chromium", "the HTML report's rendering test")
}

/// Makes sure `binary` runs (`binary --version`), installing Debian's `package` when we are
/// root on a Debian-like system; otherwise says exactly what to do.
fn ensure_debian_tool(binary: &str, package: &str, needed_for: &str) -> bool {
    let found = || {
        Command::new(binary)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if found() {
        return true;
    }
    let is_root = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| o.stdout.starts_with(b"0"))
        .unwrap_or(false);
    let has_apt = Path::new("/usr/bin/apt-get").exists();
    if is_root && has_apt {
        eprintln!("xtask: {binary} not found; installing Debian's {package} package");
        let env = [("DEBIAN_FRONTEND", "noninteractive")];
        let ok = run_status(Command::new("apt-get").args(["update", "-qq"]).envs(env)) == 0
            && run_status(
                Command::new("apt-get")
                    .args(["install", "-y", "-qq", "--no-install-recommends", package])
                    .envs(env),
            ) == 0;
        if ok && found() {
            return true;
        }
    }
    eprintln!(
        "xtask: {binary} is needed for {needed_for}. Install it with\n    sudo apt-get install {package}\n(Debian/Ubuntu), then run `cargo xtask test` again."
    );
    false
}

/// Builds and runs the model checks in QEMU; returns (exit code, lines).
fn run_qemu(features: &[&str]) -> (i32, Vec<String>) {
    let mut cmd = cargo_in(&root().join("qemu-tests"));
    cmd.args(["run", "--release", "--quiet", "--bin", "pam-qemu-tests"])
        .args(features);
    run_streaming(&mut cmd)
}

/// How long the fault-path run may take: a few seconds normally; a fault path that never
/// resets the machine would otherwise hang QEMU forever.
const FAULT_PATHS_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(300);

/// Builds and runs the firmware's fault paths in QEMU (`qemu-tests/src/bin/fault_paths.rs`:
/// several boots through faults and watchdog resets); returns (passed, failed). A build
/// failure, a crash, a missing summary or a run past [`FAULT_PATHS_TIMEOUT`] counts as a
/// failure.
fn qemu_fault_paths() -> (u64, u64) {
    let dir = root().join("qemu-tests");
    if run_status(cargo_in(&dir).args(["build", "--release", "--quiet", "--bin", "fault_paths"]))
        != 0
    {
        eprintln!("xtask: the fault-path tests did not build");
        return (0, 1);
    }
    // QEMU itself, not `cargo run`: a run past the timeout must be able to kill it (the
    // arguments are those of qemu-tests/.cargo/config.toml's runner)
    let elf = match target_dir::target_directory(cargo_in(&dir)) {
        Ok(t) => t.join("thumbv7em-none-eabihf/release/fault_paths"),
        Err(e) => {
            eprintln!("xtask: qemu-tests' target directory: {e}");
            return (0, 1);
        }
    };
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args(["-cpu", "cortex-m4", "-machine", "mps2-an386", "-nographic"])
        .args([
            "-icount",
            "shift=0",
            "-semihosting-config",
            "enable=on,target=native",
        ])
        .arg("-kernel")
        .arg(&elf);
    let mut child = match cmd.stdout(Stdio::piped()).spawn() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("xtask: could not start the fault-path tests: {e}");
            return (0, 1);
        }
    };
    let stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut lines = Vec::new();
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            println!("{line}");
            lines.push(line);
        }
        lines
    });
    let started = std::time::Instant::now();
    let code = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status.code().unwrap_or(1),
            Ok(None) if started.elapsed() > FAULT_PATHS_TIMEOUT => {
                eprintln!("xtask: the fault-path tests ran past {FAULT_PATHS_TIMEOUT:?}: stopped");
                let _ = child.kill();
                let _ = child.wait();
                break 1;
            }
            Ok(None) => std::thread::sleep(std::time::Duration::from_millis(100)),
            Err(_) => break 1,
        }
    };
    let lines = reader.join().unwrap_or_default();
    match qemu_counts(&lines) {
        Some((p, f)) if code == 0 || f > 0 => (p, f),
        Some((p, _)) => (p, 1),
        None => (0, 1),
    }
}

fn qemu_counts(lines: &[String]) -> Option<(u64, u64)> {
    let l = lines.iter().rev().find(|l| l.starts_with("qemu: "))?;
    let mut nums = l
        .split(|c: char| !c.is_ascii_digit())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<u64>());
    Some((nums.next()?.ok()?, nums.next()?.ok()?))
}

fn qemu_bench() -> i32 {
    if !ensure_qemu() {
        return 1;
    }
    let mut summary = Vec::new();
    for (label, features) in [
        ("libm + own f32 sincos (default)", &[][..]),
        ("micromath", &["--features", "micromath"][..]),
    ] {
        println!("== Cortex-M4F, f32 transcendental functions: {label}");
        let (_, lines) = run_qemu(features);
        summary.extend(
            lines
                .into_iter()
                .filter(|l| {
                    l.starts_with("bench") || l.starts_with("precision") || l.starts_with("qemu:")
                })
                .map(|l| format!("[{label}] {l}")),
        );
    }
    println!("\n== summary");
    for l in &summary {
        println!("{l}");
    }
    0
}

/// Flash and static-RAM budget of the firmware.
const FLASH_LIMIT_BYTES: u64 = 128 * 1024;
const RAM_LIMIT_BYTES: u64 = 32 * 1024;

/// Builds the firmware in release mode and checks its size against the budget.
fn firmware() -> Result<(), ()> {
    let dir = root().join("firmware");
    if run_status(cargo_in(&dir).args(["build", "--release", "--quiet"])) != 0 {
        eprintln!("xtask: firmware build failed");
        return Err(());
    }
    // <target dir>/<triple>/release: firmware/target/… by default, CARGO_TARGET_DIR/… if set
    let target = target_dir::target_directory(cargo_in(&dir))
        .map_err(|e| eprintln!("xtask: firmware's target directory: {e}"))?;
    let elf = target.join("thumbv7em-none-eabihf/release/pam-firmware");
    let bytes =
        std::fs::read(&elf).map_err(|e| eprintln!("xtask: cannot read {}: {e}", elf.display()))?;
    let (flash, ram) = elf32_sizes(&bytes).map_err(|e| {
        eprintln!(
            "xtask: {} is not a 32-bit little-endian ELF: {e}",
            elf.display()
        )
    })?;
    println!(
        "firmware: flash {flash} B ({:.1} KiB of {} KiB), static RAM {ram} B ({:.1} KiB of {} KiB)",
        flash as f64 / 1024.0,
        FLASH_LIMIT_BYTES / 1024,
        ram as f64 / 1024.0,
        RAM_LIMIT_BYTES / 1024
    );
    if flash > FLASH_LIMIT_BYTES || ram > RAM_LIMIT_BYTES {
        eprintln!("xtask: firmware over its size budget");
        return Err(());
    }
    Ok(())
}

/// (flash, static RAM) of an ELF32 image: flash is every allocated section with contents
/// (code, read-only data, the initial values of .data); RAM is every allocated writable
/// section (.data, .bss, .uninit). The stack is not counted: it takes what RAM is left.
fn elf32_sizes(b: &[u8]) -> Result<(u64, u64), object::Error> {
    use object::elf::{SHF_ALLOC, SHF_WRITE, SHT_NOBITS};
    use object::read::elf::{ElfFile32, SectionHeader};
    let file = ElfFile32::<object::LittleEndian>::parse(b)?;
    let endian = file.endian();
    let (mut flash, mut ram) = (0u64, 0u64);
    for h in file.elf_section_table().iter() {
        let (kind, flags, size) = (h.sh_type(endian), h.sh_flags(endian), h.sh_size(endian));
        if !flags.contains(SHF_ALLOC) {
            continue;
        }
        if kind != SHT_NOBITS {
            flash += u64::from(size);
        }
        if flags.contains(SHF_WRITE) {
            ram += u64::from(size);
        }
    }
    Ok((flash, ram))
}

#[cfg(test)]
mod tests {
    use super::elf32_sizes;

    /// A little-endian ELF32 header followed by its section headers (no section data).
    fn elf32(sections: &[(u32, u32, u32)]) -> Vec<u8> {
        let mut b = vec![0u8; 52];
        b[..7].copy_from_slice(b"\x7fELF\x01\x01\x01");
        let put16 =
            |b: &mut Vec<u8>, o: usize, v: u16| b[o..o + 2].copy_from_slice(&v.to_le_bytes());
        put16(&mut b, 16, 2); // ET_EXEC
        put16(&mut b, 18, 40); // EM_ARM
        b[20..24].copy_from_slice(&1u32.to_le_bytes()); // EV_CURRENT
        b[32..36].copy_from_slice(&52u32.to_le_bytes()); // e_shoff
        put16(&mut b, 40, 52); // e_ehsize
        put16(&mut b, 46, 40); // e_shentsize
                               // the null section first, the section-name table last
        let count = sections.len() + 2;
        put16(&mut b, 48, count as u16);
        put16(&mut b, 50, count as u16 - 1);
        b.extend_from_slice(&[0u8; 40]);
        let names_at = (52 + 40 * count) as u32;
        for (kind, flags, size, offset) in sections
            .iter()
            .map(|&(k, f, s)| (k, f, s, 0))
            .chain([(3, 0, 1, names_at)])
        {
            let mut h = [0u8; 40];
            h[4..8].copy_from_slice(&kind.to_le_bytes());
            h[8..12].copy_from_slice(&flags.to_le_bytes());
            h[16..20].copy_from_slice(&offset.to_le_bytes());
            h[20..24].copy_from_slice(&size.to_le_bytes());
            b.extend_from_slice(&h);
        }
        b.push(0); // the (empty) names
        b
    }

    #[test]
    fn flash_is_allocated_contents_and_ram_the_writable_sections() {
        const PROGBITS: u32 = 1;
        const NOBITS: u32 = 8;
        const WRITE: u32 = 1;
        const ALLOC: u32 = 2;
        const EXEC: u32 = 4;
        let image = elf32(&[
            (PROGBITS, ALLOC | EXEC, 1000), // .text
            (PROGBITS, ALLOC, 200),         // .rodata
            (PROGBITS, ALLOC | WRITE, 8),   // .data: in flash and in RAM
            (NOBITS, ALLOC | WRITE, 16),    // .bss: RAM only
            (PROGBITS, 0, 5000),            // .debug_info: neither
        ]);
        assert_eq!(elf32_sizes(&image).unwrap(), (1208, 24));
        assert!(
            elf32_sizes(b"not an ELF file at all, just some bytes that are long enough").is_err()
        );
    }
}
