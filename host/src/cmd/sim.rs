//! `pamctl sim`: the device emulator (the `pam-emulator` library) on TCP and a pseudo-terminal.

use anyhow::Context;
use clap::Args;
use pam_emulator::{Emulator, HandleMode, Injection, Miswire, Scheduled, SimConfig};
use pam_twin::EffectSet;
use std::io::Write;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub struct SimArgs {
    /// TCP address to serve (port 0: a free port, printed as `listening on tcp://HOST:PORT`).
    #[arg(long, default_value = "127.0.0.1:7878", value_name = "HOST:PORT")]
    pub listen: String,
    /// Also serve on a pseudo-terminal (Linux), printed as `pty: /dev/pts/N`.
    #[arg(long)]
    pub pty: bool,
    /// A twin effect, `id` or `id:param=value,...` (repeatable; `pamctl sim --list-effects`).
    #[arg(long = "with", value_name = "EFFECT")]
    pub with: Vec<String>,
    /// What holds the handle.
    #[arg(long, value_enum, default_value_t = HandleMode::Free)]
    pub handle: HandleMode,
    /// Seed of the twin's noise, effects and operator path.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The device's command timeout, s (firmware default 0.1; at most 1).
    #[arg(long, value_name = "SECONDS")]
    pub command_timeout_s: Option<f32>,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    pub seconds: Option<f64>,
    /// Simulate the rig as the thesis measured it (0.57 of the model's muscle force, Table 5.2,
    /// and a parallel joint stiffness, Fig. 4.3: docs/closed-loop.md) instead of its model.
    #[arg(long)]
    pub identified_rig: bool,
    /// Inject a fault at a time of the emulated clock, `KIND@SECONDS` (repeatable): a plant
    /// fault (encoder_stuck:joint=1, encoder_unplugged:joint=2, encoder_jump:joint=1,counts=400,
    /// loadcell_saturated:channel=x, loadcell_frozen, converter_stuck:channel=1,
    /// converter_open:channel=3), a board one (estop, estop_release, overrun:periods=5), or
    /// handle_release (whatever holds the handle lets go of it).
    /// Each is reported as `injected KIND at time_us=N`. Never possible over the link.
    #[arg(long = "inject", value_name = "KIND@SECONDS")]
    pub inject: Vec<String>,
    /// Read `inject KIND` lines from standard input and inject each at the next period
    /// (for tests that must choose the moment).
    #[arg(long)]
    pub stdin_control: bool,
    /// Keep the emulated configuration flash in FILE (created on the first persist): what
    /// `pamctl config persist` wrote is there when the emulator starts again. Without it
    /// the flash is in memory and starts erased.
    #[arg(long, value_name = "FILE")]
    pub config_flash: Option<std::path::PathBuf>,
    /// Wire the emulated rig wrong (repeatable), to try `pamctl commission` against it:
    /// swap_channels:A,B, swap_joint1_muscles, encoder_inverted:joint=N,
    /// encoder_counts:joint=N,scale=S, loadcell_rotated:deg=D, loadcell_inverted:axis=x|z,
    /// loadcell_gain:axis=x|z,scale=S, loadcell_axes_swapped, tare_offset:x=N,z=N,
    /// encoder_zero:joint=N,deg=D, slow_converter:channel=N,tau=S.
    #[arg(long = "miswire", value_name = "KIND")]
    pub miswire: Vec<String>,
    /// List the twin's effects and their parameters, then exit.
    #[arg(long)]
    pub list_effects: bool,
}

pub fn run(args: SimArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    if args.list_effects {
        for e in pam_twin::effects::catalog() {
            writeln!(out, "{}", pam_twin::effects::describe(e.as_ref()))?;
        }
        return Ok(());
    }
    if let Some(s) = args.seconds {
        if !(s.is_finite() && s > 0.0) {
            return Err(anyhow::anyhow!(
                "--seconds {s}: give a positive number of seconds"
            ));
        }
    }
    let effects = EffectSet::parse_list(&args.with).context("--with")?;
    let injections = args
        .inject
        .iter()
        .map(|t| Scheduled::parse(t))
        .collect::<Result<Vec<_>, _>>()
        .context("--inject")?;
    let miswiring = args
        .miswire
        .iter()
        .map(|t| Miswire::parse(t))
        .collect::<Result<Vec<_>, _>>()?;
    let mut config = SimConfig {
        miswiring,
        injections,
        effects,
        handle: args.handle,
        seed: args.seed,
        identified_rig: args.identified_rig,
        config_flash: args.config_flash.clone(),
        ..SimConfig::default()
    };
    if let Some(t) = args.command_timeout_s {
        config.command_timeout_s = t;
    }
    let stop = super::interrupted();
    let mut emulator = Emulator::start(config.clone())?;
    let address = emulator.listen_tcp(&args.listen)?;
    writeln!(out, "listening on tcp://{address}")?;
    if args.pty {
        #[cfg(target_os = "linux")]
        {
            let path = emulator.open_pty()?;
            writeln!(out, "pty: {path}")?;
        }
        #[cfg(not(target_os = "linux"))]
        return Err(anyhow::anyhow!(
            "--pty: pseudo-terminals are only supported on Linux"
        ));
    }
    let effects = config.effects.specs();
    writeln!(
        out,
        "emulating the robot: 1 kHz device loop, handle {:?}, effects: {}, miswired: {}, command timeout {} s; Ctrl-C stops",
        config.handle,
        if effects.is_empty() { "none".to_string() } else { effects.join(" ") },
        if args.miswire.is_empty() { "no".to_string() } else { args.miswire.join(" ") },
        config.command_timeout_s
    )?;
    out.flush()?;
    let commands = args.stdin_control.then(stdin_commands);
    let started = Instant::now();
    let mut last_report = Instant::now();
    let mut late_reported = 0;
    while !stop.load(Ordering::SeqCst)
        && args
            .seconds
            .is_none_or(|s| started.elapsed().as_secs_f64() < s)
    {
        std::thread::sleep(Duration::from_millis(20));
        if let Some(commands) = &commands {
            for line in commands.try_iter() {
                match line.trim().strip_prefix("inject ").map(Injection::parse) {
                    Some(Ok(injection)) => emulator.inject(injection)?,
                    Some(Err(e)) => eprintln!("sim: {e}"),
                    None => eprintln!("sim: unknown command {line:?} (inject KIND)"),
                }
            }
        }
        for report in emulator.injected() {
            writeln!(out, "{report}")?;
            out.flush()?;
        }
        // tell about late periods as they happen, at most every 10 s
        let late = emulator.stats.late.load(Ordering::Relaxed);
        if late > late_reported && last_report.elapsed() >= Duration::from_secs(10) {
            eprintln!(
                "sim: {} late periods so far (caught up): {}",
                late,
                emulator.stats.summary()
            );
            late_reported = late;
            last_report = Instant::now();
        }
    }
    let summary = emulator.stats.summary();
    emulator.stop();
    eprintln!("sim stopped: {summary}");
    Ok(())
}

/// Lines of standard input, read on a thread of their own (ends at end of input).
fn stdin_commands() -> std::sync::mpsc::Receiver<String> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::stdin().lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}
