//! `pamctl record FILE`: telemetry to a log-format-v1 CSV, for a duration or until Ctrl-C.
//!
//! Rows are written whole (pam-log's writer), the file is flushed at least every
//! 0.5 s and on every way out, so an interrupted recording is a valid log holding every
//! sample received. It only listens (keeps no mode alive) unless `--keep-alive` makes it the
//! commander. With `--plotjuggler HOST:PORT` the samples written also stream to
//! PlotJuggler (`crate::plotjuggler`).

use crate::LinkArgs;
use anyhow::Context;
use clap::Args;
use pam_control::State;
use pam_link::{Client, DropCounter};
use pam_log::{col, LogWriter};
use pam_protocol::{ModeKind, ReplyData, RequestBody, Telemetry};
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub struct RecordArgs {
    /// Output CSV (log format v1).
    pub file: PathBuf,
    /// Seconds to record, on the device's clock (so 10 s at 1 kHz is 10 000 samples
    /// whatever the host's scheduling); without it, until Ctrl-C.
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Telemetry every N control periods (1 = every period).
    #[arg(long, value_name = "N")]
    pub divider: Option<u16>,
    /// Metadata lines `# key = value` in the log (repeatable).
    #[arg(long = "meta", value_name = "KEY=VALUE")]
    pub meta: Vec<String>,
    /// No progress line.
    #[arg(long)]
    pub quiet: bool,
    /// At the end, print the link throughput (bytes/s received, frame size, margin to
    /// USB full-speed CDC).
    #[arg(long)]
    pub stats: bool,
    #[command(flatten)]
    pub plotjuggler: crate::plotjuggler::PlotJugglerArgs,
    /// Keep the armed device's mode alive while this runs: this pamctl takes the command
    /// (mode unchanged) and sends keep-alives. Without it, it only listens.
    #[arg(long)]
    pub keep_alive: bool,
}

/// Columns written, in order: the required ones, the force target when the recording
/// starts in force mode, then extras (mode and limited are not in the format's table:
/// readers ignore them or read them as numbers).
pub fn columns(with_force_ref: bool) -> Vec<&'static str> {
    let mut c: Vec<&str> = col::REQUIRED.to_vec();
    if with_force_ref {
        c.extend([col::FX_REF_N, col::FY_REF_N]);
    }
    c.extend(col::PRESSURES_CMD_BAR);
    c.extend([
        col::SEQ,
        col::STATE,
        col::FAULTS,
        "mode",
        col::LIMITED,
        "loop_exec_us",
        "loop_jitter_us",
    ]);
    c
}

pub fn state_code(s: State) -> f64 {
    match s {
        State::Disarmed => 0.0,
        State::Armed => 1.0,
        State::Faulted => 2.0,
    }
}

pub fn mode_code(m: ModeKind) -> f64 {
    match m {
        ModeKind::Idle => 0.0,
        ModeKind::Pressures => 1.0,
        ModeKind::Joint => 2.0,
        ModeKind::Force => 3.0,
        ModeKind::ForceFeedForward => 4.0,
        ModeKind::ForceClosedLoop => 5.0,
        ModeKind::Impedance => 6.0,
    }
}

/// One row in [`columns`] order. `t_s` is from the device clock.
pub fn row(t: &Telemetry, t_s: f64, with_force_ref: bool) -> Vec<f64> {
    let f = |x: f32| x as f64;
    let mut r = vec![
        t_s,
        f(t.alpha_rad[0]),
        f(t.alpha_rad[1]),
        f(t.force_user_n[0]),
        f(t.force_user_n[1]),
    ];
    r.extend(t.current_ma.map(f));
    if with_force_ref {
        // the target left force mode during the recording: the `mode` column says so
        r.extend(t.force_ref_n.unwrap_or([0.0; 2]).map(f));
    }
    r.extend(t.pressure_cmd_bar.map(f));
    r.extend([
        t.seq as f64,
        state_code(t.state.into()),
        t.faults as f64,
        mode_code(t.mode),
        t.limited as f64,
        t.loop_exec_us as f64,
        t.loop_jitter_us as f64,
    ]);
    // the format wants finite numbers everywhere: a non-finite value (never sent by a
    // sane device) is written as 0 rather than break the file
    for v in r.iter_mut() {
        if !v.is_finite() {
            *v = 0.0;
        }
    }
    r
}

/// Device time unwrapped (the device's µs counter wraps every 71 min).
#[derive(Default)]
pub struct Clock {
    first_us: Option<u32>,
    last_us: u32,
    elapsed_us: u64,
}

impl Clock {
    pub fn seconds(&mut self, time_us: u32) -> f64 {
        match self.first_us {
            None => {
                self.first_us = Some(time_us);
                self.last_us = time_us;
            }
            Some(_) => {
                let d = time_us.wrapping_sub(self.last_us);
                if d < u32::MAX / 2 {
                    self.elapsed_us += d as u64;
                }
                self.last_us = time_us;
            }
        }
        self.elapsed_us as f64 * 1e-6
    }
}

pub struct Summary {
    pub samples: u64,
    /// Bytes received on the link while recording.
    pub bytes: u64,
    pub dropped: u64,
    pub skipped_out_of_order: u64,
    pub seconds: f64,
}

/// Records from a connected client until `stop` is set or `duration` has passed.
pub fn record(
    client: &Client,
    args: &RecordArgs,
    device: &str,
    stop: &AtomicBool,
    progress: &mut dyn Write,
) -> anyhow::Result<Summary> {
    if let Some(d) = args.duration {
        if !(d.is_finite() && d > 0.0) {
            return Err(anyhow::anyhow!(
                "--duration {d}: give a positive number of seconds"
            ));
        }
    }
    let mut meta_owned: Vec<(String, String)> = Vec::new();
    for m in &args.meta {
        let (k, v) = m
            .split_once('=')
            .ok_or_else(|| anyhow::anyhow!("--meta `{m}`: write KEY=VALUE"))?;
        meta_owned.push((k.trim().to_string(), v.trim().to_string()));
    }
    if let Some(div) = args.divider {
        client.command(RequestBody::SetTelemetry {
            divider: div.max(1),
        })?;
    }
    let status = match client.request(RequestBody::GetStatus)? {
        ReplyData::Status(s) => s,
        _ => {
            return Err(anyhow::anyhow!(
                "the device answered status with the wrong kind of reply"
            ))
        }
    };
    if status.telemetry_divider == 0 {
        client.command(RequestBody::SetTelemetry { divider: 1 })?;
    }
    let divider = status.telemetry_divider.max(1) as u32;
    let with_force_ref = matches!(
        status.mode,
        pam_protocol::wire::Mode::Force { .. } | pam_protocol::wire::Mode::ForceClosedLoop { .. }
    );
    let info = client.info();
    meta_owned.extend([
        ("device".to_string(), device.to_string()),
        (
            "firmware".to_string(),
            format!(
                "{}.{}.{}",
                info.firmware_version.major,
                info.firmware_version.minor,
                info.firmware_version.patch
            ),
        ),
        ("protocol".to_string(), info.protocol_version.to_string()),
        (
            "params_hash".to_string(),
            format!("{:08x}", info.params_hash),
        ),
        (
            "sample_period_s".to_string(),
            format!("{}", status.period_us as f64 * 1e-6 * divider as f64),
        ),
    ]);
    let meta: Vec<(&str, &str)> = meta_owned
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    let mut plot = args.plotjuggler.open()?;
    let cols = columns(with_force_ref);
    let mut writer = LogWriter::create(&args.file, &cols, &meta)
        .with_context(|| format!("cannot create {}", args.file.display()))?;

    let mut keep_alive = super::keep_alive::KeepAlive::start(client, args.keep_alive)?;
    client.start_telemetry();
    let mut drops = DropCounter::default();
    let mut clock = Clock::default();
    let mut last_t = f64::NEG_INFINITY;
    let mut skipped = 0u64;
    let start = Instant::now();
    let bytes_at_start = client.bytes_received();
    // the device clock ends a timed recording; this guards against a device that stalls
    let wall_limit = args.duration.map(|d| d + 2.0 + 0.5 * d);
    let mut last_progress = Instant::now();
    let mut result = Ok(());
    loop {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        if let Some(limit) = wall_limit {
            if start.elapsed().as_secs_f64() >= limit {
                result = Err(anyhow::anyhow!(
                    "the device's clock did not reach {} s within {limit:.1} s of host time: \
                     the telemetry stalled; the file holds every sample received",
                    args.duration.unwrap_or(0.0)
                ));
                break;
            }
        }
        if let Err(e) = keep_alive.tick(client) {
            result = Err(e.into());
            break;
        }
        match client.next_telemetry(Duration::from_millis(10)) {
            Ok(Some(t)) => {
                drops.record(t.seq);
                let t_s = clock.seconds(t.time_us);
                if args.duration.is_some_and(|d| t_s >= d - 1e-9) {
                    break;
                }
                if t_s <= last_t {
                    skipped += 1; // the format needs strictly increasing time
                    continue;
                }
                last_t = t_s;
                if let Some(p) = plot.as_mut() {
                    p.offer(&t);
                }
                if let Err(e) = writer.write_row(&row(&t, t_s, with_force_ref)) {
                    result = Err(anyhow::anyhow!("cannot write {}: {e}", args.file.display()));
                    break;
                }
            }
            Ok(None) => {}
            Err(e) => {
                result = Err(anyhow::anyhow!("{e}; the file holds every sample received"));
                break;
            }
        }
        if last_progress.elapsed() >= Duration::from_millis(500) {
            last_progress = Instant::now();
            let _ = writer.flush();
            if !args.quiet {
                let secs = start.elapsed().as_secs_f64();
                let _ = write!(
                    progress,
                    "\rrecording {}: {} samples, {:.0} samples/s, {} dropped, {:.1} s   ",
                    args.file.display(),
                    writer.rows(),
                    writer.rows() as f64 / secs.max(1e-9),
                    drops.dropped,
                    secs
                );
                let _ = progress.flush();
            }
        }
    }
    // drain what already arrived: Ctrl-C loses nothing received
    while let Ok(Some(t)) = client.next_telemetry(Duration::ZERO) {
        let t_s = clock.seconds(t.time_us);
        if args.duration.is_some_and(|d| t_s >= d - 1e-9) {
            break;
        }
        drops.record(t.seq);
        if t_s > last_t {
            last_t = t_s;
            if writer.write_row(&row(&t, t_s, with_force_ref)).is_err() {
                break;
            }
        }
    }
    let samples = writer.rows();
    writer
        .finish()
        .with_context(|| format!("cannot write {}", args.file.display()))?;
    if !args.quiet {
        let _ = writeln!(progress);
    }
    result?;
    Ok(Summary {
        samples,
        bytes: client.bytes_received() - bytes_at_start,
        dropped: drops.dropped,
        skipped_out_of_order: skipped,
        seconds: start.elapsed().as_secs_f64(),
    })
}

pub fn run(args: RecordArgs, link: &LinkArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let stop = super::interrupted();
    let client = super::connect(link)?;
    let s = record(
        &client,
        &args,
        link.device.as_deref().unwrap_or(""),
        &stop,
        &mut std::io::stderr(),
    )?;
    writeln!(
        out,
        "recorded {} samples in {:.2} s to {} ({} dropped on the link{})",
        s.samples,
        s.seconds,
        args.file.display(),
        s.dropped,
        if s.skipped_out_of_order > 0 {
            format!(", {} out of order skipped", s.skipped_out_of_order)
        } else {
            String::new()
        }
    )?;
    if args.stats {
        writeln!(out, "{}", throughput(&s))?;
    }
    Ok(())
}

/// USB full-speed CDC-ACM's practical sustained rate (bulk: 19 × 64 B per 1 ms frame at
/// most, 1.216 MB/s; stacks typically sustain about 1 MB/s).
pub const USB_FS_CDC_PRACTICAL_BYTES_PER_S: f64 = 1.0e6;

/// The link throughput line of `record --stats`.
pub fn throughput(s: &Summary) -> String {
    let rate = s.bytes as f64 / s.seconds.max(1e-9);
    format!(
        "link: {} bytes in {:.2} s = {:.0} bytes/s ({:.1} bytes per sample, {:.0} samples/s); \
         {:.1} % of USB full-speed CDC's ~1 MB/s, a margin of {:.1}x",
        s.bytes,
        s.seconds,
        rate,
        s.bytes as f64 / (s.samples.max(1) as f64),
        s.samples as f64 / s.seconds.max(1e-9),
        100.0 * rate / USB_FS_CDC_PRACTICAL_BYTES_PER_S,
        USB_FS_CDC_PRACTICAL_BYTES_PER_S / rate.max(1e-9),
    )
}
