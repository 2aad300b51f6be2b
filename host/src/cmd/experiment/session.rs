//! One experiment session on the device: keeping the link alive, turning telemetry into
//! the rows of a trial's log, moving the arm, prompting the operator.

use super::super::record::{columns, row, Clock};
use anyhow::Context;
use pam_control::{Mode, State};
use pam_link::{fault_names, Client, DropCounter};
use pam_log::LogWriter;
use pam_model::Vec2;
use pam_protocol::RequestBody;
use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// One connected session: keeps the link alive and turns telemetry into log rows.
pub(super) struct Session<'a> {
    pub(super) client: &'a Client,
    pub(super) stop: &'a AtomicBool,
    pub(super) progress: &'a mut dyn Write,
    pub(super) yes: bool,
    pub(super) last_beat: Instant,
    /// The latest joint angles received.
    pub(super) alpha_rad: Option<Vec2<f64>>,
}

/// One trial's log being written.
pub(super) struct Trial {
    pub(super) writer: LogWriter<std::io::BufWriter<std::fs::File>>,
    pub(super) path: PathBuf,
    pub(super) with_force_ref: bool,
    pub(super) clock: Clock,
    pub(super) last_t: f64,
    pub(super) drops: DropCounter,
}

impl Session<'_> {
    pub(super) fn request(&self, body: RequestBody) -> anyhow::Result<()> {
        Ok(self.client.command(body)?)
    }

    pub(super) fn set_mode(&self, mode: Mode) -> anyhow::Result<()> {
        self.request(RequestBody::SetMode(mode.into()))
    }

    /// Runs the link for `seconds` of host time, writing rows into `trial` if given.
    /// Ends early (error) on Ctrl-C or a device fault.
    pub(super) fn run_for(
        &mut self,
        seconds: f64,
        mut trial: Option<&mut Trial>,
        label: &str,
    ) -> anyhow::Result<()> {
        let start = Instant::now();
        let mut last_progress = Instant::now() - Duration::from_secs(1);
        while start.elapsed().as_secs_f64() < seconds {
            if self.stop.load(Ordering::SeqCst) {
                return Err(anyhow::anyhow!("interrupted (Ctrl-C)"));
            }
            if self.last_beat.elapsed() >= Duration::from_millis(25) {
                self.client.heartbeat()?;
                self.last_beat = Instant::now();
            }
            while let Some(t) = self.client.next_telemetry(Duration::from_millis(5))? {
                if t.state == State::Faulted {
                    return Err(anyhow::anyhow!(
                        "the device faulted ({}); the robot is in its safe state",
                        fault_names(t.faults)
                    ));
                }
                self.alpha_rad = Some([t.alpha_rad[0] as f64, t.alpha_rad[1] as f64]);
                if let Some(tr) = trial.as_deref_mut() {
                    tr.drops.record(t.seq);
                    let t_s = tr.clock.seconds(t.time_us);
                    if t_s > tr.last_t {
                        tr.last_t = t_s;
                        tr.writer
                            .write_row(&row(&t, t_s, tr.with_force_ref))
                            .with_context(|| format!("cannot write {}", tr.path.display()))?;
                    }
                }
                if self.last_beat.elapsed() >= Duration::from_millis(25) {
                    break;
                }
            }
            if last_progress.elapsed() >= Duration::from_millis(500) {
                last_progress = Instant::now();
                let rows = trial.as_deref().map(|t| (t.writer.rows(), t.drops.dropped));
                let _ = write!(
                    self.progress,
                    "\r{label}: {:.1} / {:.1} s{}   ",
                    start.elapsed().as_secs_f64(),
                    seconds,
                    rows.map(|(r, d)| format!(", {r} samples, {d} dropped"))
                        .unwrap_or_default()
                );
                let _ = self.progress.flush();
            }
        }
        let _ = writeln!(self.progress);
        Ok(())
    }

    /// Brings the arm to `alpha` in joint mode with a smooth (cosine) ramp of the target from
    /// where it is, then lets it settle: a step of the target would swing the lightly
    /// damped arm past its range.
    pub(super) fn move_to(
        &mut self,
        alpha: Vec2<f64>,
        k: Vec2<f64>,
        settle_s: f64,
        label: &str,
    ) -> anyhow::Result<()> {
        if self.alpha_rad.is_none() {
            self.run_for(0.05, None, label)?;
        }
        let from = self.alpha_rad.context("no telemetry from the device")?;
        let ramp_s = MOVE_S_PER_RAD * (alpha[0] - from[0]).abs().max((alpha[1] - from[1]).abs());
        let steps = (ramp_s / 0.02).ceil().max(1.0) as usize;
        for i in 1..=steps {
            let w = 0.5 - 0.5 * (std::f64::consts::PI * i as f64 / steps as f64).cos();
            let a = [
                from[0] + w * (alpha[0] - from[0]),
                from[1] + w * (alpha[1] - from[1]),
            ];
            self.set_mode(joint_mode(a, k))?;
            self.run_for(ramp_s / steps as f64, None, label)?;
        }
        self.run_for(settle_s, None, label)
    }

    /// Tells the operator what to do; waits for Enter unless `--yes` or no terminal (the
    /// link stays alive meanwhile).
    pub(super) fn prompt(&mut self, message: &str) -> anyhow::Result<()> {
        let _ = writeln!(self.progress, ">>> {message}");
        if self.yes || !std::io::stdin().is_terminal() {
            return Ok(());
        }
        let _ = writeln!(self.progress, "    press Enter when ready");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let _ = std::io::stdin().lock().read_line(&mut line);
            let _ = tx.send(());
        });
        while rx.try_recv().is_err() {
            self.run_for(0.05, None, "waiting for the operator")?;
        }
        Ok(())
    }
}

/// Joint-target ramp speed for [`Session::move_to`]: 10 s per radian (≈ 5.7°/s).
const MOVE_S_PER_RAD: f64 = 10.0;

pub(super) fn open_trial(
    client: &Client,
    dir: &Path,
    name: &str,
    with_force_ref: bool,
    meta: &[(&str, String)],
) -> anyhow::Result<Trial> {
    let path = dir.join(name);
    let info = client.info();
    let mut all: Vec<(&str, String)> = meta.to_vec();
    all.extend([
        ("source", "pamctl experiment".to_string()),
        (
            "firmware",
            format!(
                "{}.{}.{}",
                info.firmware_version.major,
                info.firmware_version.minor,
                info.firmware_version.patch
            ),
        ),
        ("params_hash", format!("{:08x}", info.params_hash)),
        (
            "sample_period_s",
            format!("{}", info.period_us as f64 * 1e-6),
        ),
    ]);
    let meta_ref: Vec<(&str, &str)> = all.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let writer = LogWriter::create(&path, &columns(with_force_ref), &meta_ref)
        .with_context(|| format!("cannot create {}", path.display()))?;
    Ok(Trial {
        writer,
        path,
        with_force_ref,
        clock: Clock::default(),
        last_t: f64::NEG_INFINITY,
        drops: DropCounter::default(),
    })
}

pub(super) fn close_trial(trial: Trial, out: &mut dyn Write) -> anyhow::Result<PathBuf> {
    let (rows, dropped, path) = (trial.writer.rows(), trial.drops.dropped, trial.path.clone());
    trial
        .writer
        .finish()
        .with_context(|| format!("cannot write {}", path.display()))?;
    writeln!(
        out,
        "wrote {} ({rows} samples, {dropped} dropped on the link)",
        path.display()
    )?;
    Ok(path)
}

fn joint_mode(alpha: Vec2<f64>, k: Vec2<f64>) -> Mode {
    Mode::Joint {
        alpha_rad: [alpha[0] as f32, alpha[1] as f32],
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [k[0] as f32, k[1] as f32],
    }
}
