//! `pamctl watch`: a live view of the telemetry — angles, forces, pressures and currents,
//! mode, state, faults, loop time and jitter, dropped frames — with small live plots.
//!
//! On a terminal it is a ratatui screen (`watch/tui.rs`; Ctrl-C, q or Esc stop it);
//! otherwise, or with `--plain`, it prints one summary line per refresh; `--once` prints the
//! full view once as text.
//! It only listens (keeps no mode alive) unless `--keep-alive` makes it the commander. With
//! `--plotjuggler HOST:PORT` it also streams the telemetry to PlotJuggler (`crate::plotjuggler`).

use super::status::state_name;
use crate::LinkArgs;
use anyhow::Context;
use clap::Args;
use pam_link::{fault_names, Client, DropCounter};
use pam_protocol::{ModeKind, ReplyData, RequestBody, Telemetry};
use std::collections::VecDeque;
use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

mod tui;

#[derive(Args, Debug)]
pub struct WatchArgs {
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    pub seconds: Option<f64>,
    /// Print the full view once (after a short collection) and exit.
    #[arg(long)]
    pub once: bool,
    /// One summary line per refresh instead of the live view (the default when stdout is
    /// not a terminal).
    #[arg(long)]
    pub plain: bool,
    /// Refresh period, ms (plain lines: every 10 refreshes at most once per second).
    #[arg(long, default_value_t = 100, value_name = "MS")]
    pub refresh_ms: u64,
    /// Seconds of history in the plots.
    #[arg(long, default_value_t = 5.0, value_name = "SECONDS")]
    pub window: f64,
    #[command(flatten)]
    pub plotjuggler: crate::plotjuggler::PlotJugglerArgs,
    /// Keep the armed device's mode alive while this runs: this pamctl takes the command
    /// (mode unchanged) and sends keep-alives. Without it, it only listens.
    #[arg(long)]
    pub keep_alive: bool,
}

/// Width of a plot in characters.
const PLOT_WIDTH: usize = 60;

/// What the view shows, updated per sample.
pub struct View {
    pub last: Option<Telemetry>,
    pub drops: DropCounter,
    /// (device time s, value) per plotted signal.
    history: Vec<VecDeque<(f64, f64)>>,
    window_s: f64,
    /// Loop timing over the last second of samples.
    recent_timing: VecDeque<(f64, u16, u16)>,
    first_us: Option<u32>,
    elapsed_us: u64,
    last_us: u32,
    pub samples: u64,
}

const SIGNALS: [(&str, &str); 8] = [
    ("α1", "°"),
    ("α2", "°"),
    ("Fx", "N"),
    ("Fy", "N"),
    ("p1", "bar"),
    ("p2", "bar"),
    ("p3", "bar"),
    ("p4", "bar"),
];

impl View {
    pub fn new(window_s: f64) -> View {
        View {
            last: None,
            drops: DropCounter::default(),
            history: vec![VecDeque::new(); SIGNALS.len()],
            window_s: window_s.max(0.1),
            recent_timing: VecDeque::new(),
            first_us: None,
            elapsed_us: 0,
            last_us: 0,
            samples: 0,
        }
    }

    pub fn push(&mut self, t: &Telemetry) {
        self.drops.record(t.seq);
        self.samples += 1;
        match self.first_us {
            None => self.first_us = Some(t.time_us),
            Some(_) => {
                let d = t.time_us.wrapping_sub(self.last_us);
                if d < u32::MAX / 2 {
                    self.elapsed_us += d as u64;
                }
            }
        }
        self.last_us = t.time_us;
        let now = self.elapsed_us as f64 * 1e-6;
        let values = [
            (t.alpha_rad[0] as f64).to_degrees(),
            (t.alpha_rad[1] as f64).to_degrees(),
            t.force_user_n[0] as f64,
            t.force_user_n[1] as f64,
            t.pressure_cmd_bar[0] as f64,
            t.pressure_cmd_bar[1] as f64,
            t.pressure_cmd_bar[2] as f64,
            t.pressure_cmd_bar[3] as f64,
        ];
        for (h, v) in self.history.iter_mut().zip(values) {
            h.push_back((now, v));
            while h.front().is_some_and(|(t0, _)| now - t0 > self.window_s) {
                h.pop_front();
            }
        }
        self.recent_timing
            .push_back((now, t.loop_exec_us, t.loop_jitter_us));
        while self
            .recent_timing
            .front()
            .is_some_and(|(t0, _, _)| now - t0 > 1.0)
        {
            self.recent_timing.pop_front();
        }
        self.last = Some(*t);
    }

    fn timing(&self) -> (u16, u16, u16) {
        let exec_max = self.recent_timing.iter().map(|x| x.1).max().unwrap_or(0);
        let jitter_max = self.recent_timing.iter().map(|x| x.2).max().unwrap_or(0);
        let exec_last = self.last.map(|t| t.loop_exec_us).unwrap_or(0);
        (exec_last, exec_max, jitter_max)
    }

    /// One line: everything but the plots.
    pub fn summary(&self) -> String {
        let Some(t) = self.last else {
            return "waiting for telemetry…".into();
        };
        let (exec, exec_max, jitter_max) = self.timing();
        format!(
            "t {:.3} s  {} {}  α ({:+.2}°, {:+.2}°)  F ({:+.2}, {:+.2}) N  p {:.2} {:.2} {:.2} {:.2} bar  \
             i {:.2} {:.2} {:.2} {:.2} mA  faults: {}  loop {} µs (max {}) jitter max {} µs  dropped {}",
            self.elapsed_us as f64 * 1e-6,
            state_name(t.state.into()),
            mode_name(t.mode),
            (t.alpha_rad[0] as f64).to_degrees(),
            (t.alpha_rad[1] as f64).to_degrees(),
            t.force_user_n[0],
            t.force_user_n[1],
            t.pressure_cmd_bar[0],
            t.pressure_cmd_bar[1],
            t.pressure_cmd_bar[2],
            t.pressure_cmd_bar[3],
            t.current_ma[0],
            t.current_ma[1],
            t.current_ma[2],
            t.current_ma[3],
            fault_names(t.faults),
            exec,
            exec_max,
            jitter_max,
            self.drops.dropped
        )
    }

    /// The full view as text, one string per line: the header, then a sparkline per signal.
    pub fn render(&self, device: &str) -> Vec<String> {
        let mut lines = self.header(device);
        if self.last.is_none() {
            return lines;
        }
        lines.push(String::new());
        for row in self.rows() {
            lines.push(format!(
                "{}{}  {}",
                row.label(),
                sparkline(row.history, PLOT_WIDTH),
                row.range()
            ));
        }
        lines
    }

    /// Everything above the plots, one string per line.
    pub fn header(&self, device: &str) -> Vec<String> {
        let mut lines = vec![
            format!("pamctl watch — {device}   (Ctrl-C to stop)"),
            String::new(),
        ];
        let Some(t) = self.last else {
            lines.push("waiting for telemetry…".into());
            return lines;
        };
        let (exec, exec_max, jitter_max) = self.timing();
        lines.push(format!(
            "state {}   mode {}{}   faults: {}",
            state_name(t.state.into()),
            mode_name(t.mode),
            match t.force_ref_n {
                Some(f) => format!(" (target {:+.2}, {:+.2} N)", f[0], f[1]),
                None => String::new(),
            },
            fault_names(t.faults)
        ));
        lines.push(format!(
            "device time {:.3} s   samples {}   dropped {}   loop {} µs (max {} µs over 1 s)   jitter max {} µs{}",
            self.elapsed_us as f64 * 1e-6,
            self.samples,
            self.drops.dropped,
            exec,
            exec_max,
            jitter_max,
            super::status::describe_limited(t.limited)
        ));
        lines.push(format!(
            "currents {:6.2} {:6.2} {:6.2} {:6.2} mA",
            t.current_ma[0], t.current_ma[1], t.current_ma[2], t.current_ma[3]
        ));
        lines
    }

    /// One row per plotted signal.
    pub fn rows(&self) -> impl Iterator<Item = Row<'_>> {
        SIGNALS
            .iter()
            .zip(&self.history)
            .map(|(&(name, unit), history)| Row {
                name,
                unit,
                history,
            })
    }
}

/// One plotted signal: its name and unit, and its history in the window.
pub struct Row<'a> {
    pub name: &'static str,
    pub unit: &'static str,
    pub history: &'a VecDeque<(f64, f64)>,
}

impl Row<'_> {
    /// Name, latest value and unit, padded to a fixed width.
    pub fn label(&self) -> String {
        let now = self.history.back().map(|x| x.1).unwrap_or(0.0);
        format!("{:>3} {now:+8.2} {:<3} ", self.name, self.unit)
    }

    /// `[lo … hi]` over the window.
    pub fn range(&self) -> String {
        let (lo, hi) = self
            .history
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x.1), hi.max(x.1))
            });
        format!("[{lo:+.2} … {hi:+.2}]")
    }
}

pub fn mode_name(m: ModeKind) -> &'static str {
    match m {
        ModeKind::Idle => "idle",
        ModeKind::Pressures => "pressures",
        ModeKind::Joint => "joint",
        ModeKind::Force => "force",
        ModeKind::ForceFeedForward => "force+ff",
        ModeKind::ForceClosedLoop => "force closed loop",
        ModeKind::Impedance => "impedance",
    }
}

/// The history in at most `width` columns (mean per column), each scaled to 0..=`top`
/// over the columns' own range (a flat signal: all 0).
pub fn columns(h: &VecDeque<(f64, f64)>, width: usize, top: u64) -> Vec<u64> {
    if h.is_empty() || width == 0 {
        return Vec::new();
    }
    let per = h.len().div_ceil(width).max(1);
    let cols: Vec<f64> = h
        .iter()
        .map(|x| x.1)
        .collect::<Vec<_>>()
        .chunks(per)
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .collect();
    let lo = cols.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = cols.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let span = hi - lo;
    cols.iter()
        .map(|&v| {
            if span < 1e-9 {
                0
            } else {
                (((v - lo) / span) * top as f64)
                    .round()
                    .clamp(0.0, top as f64) as u64
            }
        })
        .collect()
}

/// The history as `width` block characters (mean per column), scaled to its own range.
pub fn sparkline(h: &VecDeque<(f64, f64)>, width: usize) -> String {
    const BLOCKS: [char; 8] = ['▁', '▂', '▃', '▄', '▅', '▆', '▇', '█'];
    let cols = columns(h, width, 7);
    let mut s: String = cols.iter().map(|&c| BLOCKS[c as usize]).collect();
    for _ in cols.len()..width {
        s.push(' ');
    }
    s
}

/// Collects telemetry into `view` until `stop`, the duration, or (with `once`) a short
/// collection; draws through `draw` at each refresh.
pub fn watch(
    client: &Client,
    args: &WatchArgs,
    stop: &AtomicBool,
    mut draw: impl FnMut(&View) -> anyhow::Result<()>,
) -> anyhow::Result<View> {
    if let Some(s) = args.seconds {
        if !(s.is_finite() && s > 0.0) {
            return Err(anyhow::anyhow!(
                "--seconds {s}: give a positive number of seconds"
            ));
        }
    }
    if let ReplyData::Status(s) = client.request(RequestBody::GetStatus)? {
        if s.telemetry_divider == 0 {
            client.command(RequestBody::SetTelemetry { divider: 1 })?;
        }
    }
    let mut view = View::new(args.window);
    let mut plot = args.plotjuggler.open()?;
    let mut keep_alive = super::keep_alive::KeepAlive::start(client, args.keep_alive)?;
    client.start_telemetry();
    let limit = if args.once { Some(0.5) } else { args.seconds };
    let refresh = Duration::from_millis(args.refresh_ms.max(10));
    let start = Instant::now();
    let mut last_draw = Instant::now();
    while !stop.load(Ordering::SeqCst) && limit.is_none_or(|l| start.elapsed().as_secs_f64() < l) {
        keep_alive.tick(client)?;
        let batch = Instant::now();
        while let Some(t) = client.next_telemetry(Duration::from_millis(5))? {
            view.push(&t);
            if let Some(p) = plot.as_mut() {
                p.offer(&t);
            }
            // back to the clock now and then, however fast the samples come
            if batch.elapsed() >= Duration::from_millis(25) {
                break;
            }
        }
        if !args.once && last_draw.elapsed() >= refresh {
            last_draw = Instant::now();
            draw(&view)?;
        }
    }
    Ok(view)
}

pub fn run(args: WatchArgs, link: &LinkArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let client = super::connect(link)?;
    let device = link.device.clone().unwrap_or_default();
    let stop = super::interrupted();
    let live = !args.once && !args.plain && std::io::stdout().is_terminal();
    if args.once {
        let view = watch(&client, &args, &stop, |_| Ok(()))?;
        for l in view.render(&device) {
            writeln!(out, "{l}")?;
        }
        return Ok(());
    }
    if live {
        // the alternate screen in raw mode; restored also on an error or a panic
        let mut terminal = ratatui::try_init().context("cannot set up the terminal")?;
        let result = watch(&client, &args, &stop, |v| {
            terminal.draw(|f| tui::draw(f, v, &device))?;
            if tui::stop_key_pressed()? {
                stop.store(true, Ordering::SeqCst);
            }
            Ok(())
        });
        ratatui::restore();
        let view = result?;
        writeln!(out, "{}", view.summary())?;
        return Ok(());
    }
    let mut last_line = Instant::now() - Duration::from_secs(1);
    let view = watch(&client, &args, &stop, |v| {
        if last_line.elapsed() >= Duration::from_secs(1) {
            last_line = Instant::now();
            writeln!(out, "{}", v.summary())?;
        }
        Ok(())
    })?;
    Ok(writeln!(out, "{}", view.summary())?)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use pam_control::State;

    pub(super) fn sample(seq: u32, alpha1_deg: f32) -> Telemetry {
        Telemetry {
            seq,
            time_us: seq * 1000,
            alpha_rad: [alpha1_deg.to_radians(), 0.0],
            force_user_n: [1.5, -2.0],
            force_ref_n: None,
            current_ma: [4.0, 5.0, 6.0, 7.0],
            pressure_cmd_bar: [0.1, 0.5, 1.0, 1.5],
            mode: ModeKind::Joint,
            state: State::Armed.into(),
            faults: 0,
            limited: 0,
            loop_exec_us: 12,
            loop_jitter_us: seq as u16 % 50,
        }
    }

    #[test]
    fn view_shows_values_drops_and_a_rising_plot() {
        let mut v = View::new(5.0);
        for s in (0..100).chain(103..200) {
            v.push(&sample(s, s as f32 * 0.1));
        }
        assert_eq!(v.drops.dropped, 3);
        let lines = v.render("tcp://x:1");
        let text = lines.join("\n");
        assert!(text.contains("state armed   mode joint"), "{text}");
        assert!(text.contains("dropped 3"), "{text}");
        assert!(text.contains("jitter max 49 µs"), "{text}");
        let a1 = lines
            .iter()
            .find(|l| l.trim_start().starts_with("α1"))
            .unwrap();
        assert!(a1.contains("+19.90"), "{a1}");
        // a ramp: the plot starts at the bottom and ends at the top
        let plot: Vec<char> = sparkline(&v.history[0], 20).chars().collect();
        assert_eq!((plot[0], plot[19]), ('▁', '█'));
        assert!(
            v.summary().contains("α (+19.90°, +0.00°)"),
            "{}",
            v.summary()
        );
    }

    #[test]
    fn flat_signal_and_empty_history_plot_without_panicking() {
        let mut h = VecDeque::new();
        assert_eq!(sparkline(&h, 4), "    ");
        h.extend([(0.0, 2.0), (0.1, 2.0)]);
        assert_eq!(sparkline(&h, 4), "▁▁  ");
    }
}
