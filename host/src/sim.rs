//! The device emulator: `pam_device::Device` — the firmware's own device service — run in
//! real time against `pam_twin`'s plant, serving the link protocol on TCP and (Linux) on a
//! pseudo-terminal.
//!
//! One real-time thread owns the device and the twin. Every period it takes the request
//! bytes the connections delivered, answers them, steps the device with the twin's raw
//! sensor readings (encoder counts through 16-bit counters, load-cell volts — the same front
//! end as on the board), holds the device's output currents on the twin for one period, and
//! queues the replies, telemetry and fault events for the connections' writer threads. It
//! sleeps to absolute deadlines (`start + k · period`): a late period is caught up at once,
//! so the device clock never drifts from the wall clock.
//!
//! Connections: replies go back to the connection that sent the request; telemetry and
//! fault events go to the newest connection that has sent anything (one client at a time;
//! a new client takes the stream over, an old one may keep sending heartbeats). If a
//! connection cannot keep up, whole frames are dropped (the telemetry `seq` shows the gap),
//! never the real-time loop.

mod conn;
pub mod flash;
pub mod inject;

use conn::{attach, push_frame, Connection};
use inject::{Board, Injection, Scheduled};
use pam_control::{Mode, SafetyConfig, State};
use pam_device::{Device, DeviceOptions, RawSensors, StepTiming};
use pam_model::{RobotModel, RobotParams, Vec2};
use pam_protocol::{
    Calibration, Config, DeviceMessage, EncoderCalibration, FrameDecoder, Request, RequestBody,
    Version,
};
use pam_twin::experiments::OperatorPath;
use pam_twin::{EffectSet, HandleCondition, Measurement, Twin, TwinConfig};
use std::io::ErrorKind;
use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender, SyncSender, TryRecvError, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What holds the handle of the emulated robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum HandleMode {
    /// Nothing touches the handle.
    Free,
    /// The handle is blocked (§5.2 set-up) whenever the device is armed in force mode, and
    /// free otherwise, so that joint mode can first bring the arm to a pose.
    Blocked,
    /// A hand holds the handle still where it is each time the device arms or the mode
    /// changes (at the joint target in joint mode).
    Held,
    /// A scripted operator: armed in joint mode, the hand holds the handle at the joint
    /// target for 3 s, then moves it along the twin's smooth random path (±4 cm,
    /// 0.1–2 Hz) around it, restarting at each new target; armed in force mode it blocks
    /// the handle; otherwise it lets go. It plays the operator of the dynamic trial.
    Operator,
}

/// Everything that defines one emulator run.
#[derive(Clone, Debug)]
pub struct SimConfig {
    pub effects: EffectSet,
    pub handle: HandleMode,
    pub seed: u64,
    /// The device's command timeout (the firmware's default is 0.1 s; separate pamctl
    /// invocations in a script need up to 1 s between them).
    pub command_timeout_s: f32,
    /// The twin's rig: the thesis's model (default) or the rig with the stiffness the
    /// thesis identified (`pam_twin::rig`).
    pub identified_rig: bool,
    /// Faults to inject at given emulated times (`inject`).
    pub injections: Vec<Scheduled>,
    /// The file that holds the emulated configuration flash (`flash`); `None`: in memory.
    pub config_flash: Option<std::path::PathBuf>,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            effects: EffectSet::none(),
            handle: HandleMode::Free,
            seed: 0,
            command_timeout_s: SafetyConfig::default_1khz().command_timeout_s,
            identified_rig: false,
            injections: Vec::new(),
            config_flash: None,
        }
    }
}

/// The firmware version the emulator reports (pamctl's own version).
pub fn emulator_version() -> Version {
    let v: Vec<u16> = env!("CARGO_PKG_VERSION")
        .split('.')
        .map(|s| s.parse().unwrap_or(0))
        .collect();
    Version {
        major: v.first().copied().unwrap_or(0),
        minor: v.get(1).copied().unwrap_or(0),
        patch: v.get(2).copied().unwrap_or(0),
    }
}

/// Width of the emulated encoder timers (the board's TIM3/TIM4 are 16-bit).
const ENCODER_COUNTER_BITS: u8 = 16;
/// Arbitrary power-on value of the encoder counters: homing must not depend on it.
const ENCODER_POWER_ON_COUNTS: i64 = 0x7A31;
/// Further behind than this (machine suspended, debugger) the loop resynchronises instead
/// of bursting through the backlog.
const MAX_CATCH_UP: Duration = Duration::from_secs(1);
/// Operator: how long the hand holds the target still before moving.
const OPERATOR_HOLD_S: f64 = 3.0;
/// Operator path length; after it the hand holds the target still.
const OPERATOR_PATH_S: f64 = 600.0;

/// Timing of the real-time loop, shared with whoever wants to report it.
#[derive(Default, Debug)]
pub struct LoopStats {
    pub periods: AtomicU64,
    /// Periods that started one period or more after their deadline (caught up).
    pub late: AtomicU64,
    /// Times the loop gave up catching up (more than 1 s behind).
    pub resyncs: AtomicU64,
    pub max_jitter_us: AtomicU64,
    pub max_exec_us: AtomicU64,
    pub exec_us_total: AtomicU64,
    /// Frames dropped because a connection did not take them in time.
    pub frames_dropped: AtomicU64,
    pub bytes_sent: AtomicU64,
}

impl LoopStats {
    pub fn summary(&self) -> String {
        let n = self.periods.load(Ordering::Relaxed);
        format!(
            "{} periods, {} late (caught up), {} resyncs, jitter max {} µs, step {:.1} µs mean / {} µs max, \
             {} frames dropped at the link, {} bytes sent",
            n,
            self.late.load(Ordering::Relaxed),
            self.resyncs.load(Ordering::Relaxed),
            self.max_jitter_us.load(Ordering::Relaxed),
            self.exec_us_total.load(Ordering::Relaxed) as f64 / n.max(1) as f64,
            self.max_exec_us.load(Ordering::Relaxed),
            self.frames_dropped.load(Ordering::Relaxed),
            self.bytes_sent.load(Ordering::Relaxed),
        )
    }
}

/// What the connections tell the real-time loop.
enum Event {
    Opened {
        conn: u64,
        out: SyncSender<Vec<u8>>,
    },
    Bytes {
        conn: u64,
        bytes: Vec<u8>,
    },
    Closed {
        conn: u64,
    },
    /// A fault to inject now (from the emulator's owner, never from a connection).
    Inject(Injection),
}

/// A running emulator. Dropping it stops it.
pub struct Emulator {
    events: Sender<Event>,
    stop: Arc<AtomicBool>,
    next_conn: Arc<AtomicU64>,
    pub stats: Arc<LoopStats>,
    threads: Vec<JoinHandle<()>>,
    /// `injected KIND at time_us=N`, one per injection applied.
    injected: Receiver<String>,
}

impl Emulator {
    /// Starts the real-time loop (no connection yet).
    pub fn start(config: SimConfig) -> Result<Emulator, String> {
        let (events, rx) = channel();
        let stop = Arc::new(AtomicBool::new(false));
        let stats = Arc::new(LoopStats::default());
        let (reports, injected) = channel();
        let plant = Plant::new(&config, reports)?;
        let rt = {
            let stop = stop.clone();
            let stats = stats.clone();
            std::thread::Builder::new()
                .name("pam-sim-rt".into())
                .spawn(move || real_time_loop(plant, rx, &stop, &stats))
                .map_err(|e| format!("cannot start the real-time thread: {e}"))?
        };
        Ok(Emulator {
            events,
            stop,
            next_conn: Arc::new(AtomicU64::new(1)),
            stats,
            threads: vec![rt],
            injected,
        })
    }

    /// Injects a fault at the next period (see [`inject`]).
    pub fn inject(&self, injection: Injection) -> Result<(), String> {
        self.events
            .send(Event::Inject(injection))
            .map_err(|_| "the emulator has stopped".to_string())
    }

    /// Reports of the injections applied since the last call.
    pub fn injected(&self) -> Vec<String> {
        self.injected.try_iter().collect()
    }

    /// Serves TCP on `address` (port 0: any free port); returns the bound address.
    pub fn listen_tcp(&mut self, address: &str) -> Result<std::net::SocketAddr, String> {
        let listener = TcpListener::bind(address).map_err(|e| {
            format!("cannot listen on {address}: {e} (is another emulator using the port?)")
        })?;
        let local = listener.local_addr().map_err(|e| e.to_string())?;
        listener
            .set_nonblocking(true)
            .map_err(|e| format!("cannot listen on {address}: {e}"))?;
        let (events, stop, next_conn) = (
            self.events.clone(),
            self.stop.clone(),
            self.next_conn.clone(),
        );
        let t = std::thread::Builder::new()
            .name("pam-sim-accept".into())
            .spawn(move || {
                while !stop.load(Ordering::SeqCst) {
                    match listener.accept() {
                        Ok((s, _)) => {
                            s.set_nonblocking(false).ok();
                            s.set_nodelay(true).ok();
                            let Ok(w) = s.try_clone() else { continue };
                            let conn = next_conn.fetch_add(1, Ordering::SeqCst);
                            attach(conn, Box::new(s), Box::new(w), &events, &stop);
                        }
                        Err(e) if e.kind() == ErrorKind::WouldBlock => {
                            std::thread::sleep(Duration::from_millis(20))
                        }
                        Err(_) => std::thread::sleep(Duration::from_millis(20)),
                    }
                }
            })
            .map_err(|e| e.to_string())?;
        self.threads.push(t);
        Ok(local)
    }

    /// Serves the link on a new pseudo-terminal; returns the path clients open
    /// (e.g. `/dev/pts/7`, used as `--device /dev/pts/7`).
    #[cfg(target_os = "linux")]
    pub fn open_pty(&mut self) -> Result<String, String> {
        use nix::sys::termios;
        let pty = nix::pty::openpty(None, None)
            .map_err(|e| format!("cannot open a pseudo-terminal: {e}"))?;
        let path = nix::unistd::ttyname(&pty.slave)
            .map_err(|e| format!("cannot name the pseudo-terminal: {e}"))?
            .display()
            .to_string();
        // raw: no echo, no line discipline touching the binary frames
        let mut t = termios::tcgetattr(&pty.slave).map_err(|e| e.to_string())?;
        termios::cfmakeraw(&mut t);
        termios::tcsetattr(&pty.slave, termios::SetArg::TCSANOW, &t).map_err(|e| e.to_string())?;
        let master = std::fs::File::from(pty.master);
        let writer = master.try_clone().map_err(|e| e.to_string())?;
        // the emulator keeps the slave open so that the master never sees a hang-up
        // between two clients
        let slave = pty.slave;
        let conn = self.next_conn.fetch_add(1, Ordering::SeqCst);
        attach(
            conn,
            Box::new(master),
            Box::new(writer),
            &self.events,
            &self.stop,
        );
        std::mem::forget(slave);
        Ok(path)
    }

    /// Stops the real-time loop and the listeners.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// The twin and what holds its handle.
struct Plant {
    device: Device,
    twin: Twin,
    last: Measurement,
    handle_mode: HandleMode,
    model: RobotModel<f64>,
    /// Operator path around (0, 0); the centre is added. Built only for the operator.
    path: Option<OperatorPath>,
    /// Condition chosen at the last arm/mode change, and when that was (plant time).
    hold_point: Vec2<f64>,
    since_s: f64,
    last_mode: (State, Mode),
    t_s: f64,
    /// The emulated board: injected failures, E-stop, loop timing.
    board: Board,
    /// Scheduled injections not applied yet, latest first.
    schedule: Vec<Scheduled>,
    reports: Sender<String>,
    /// Loop currents driven in the last period.
    last_currents_ma: [f64; 4],
    /// The configuration flash (persist, restore, erase; read at start).
    store: pam_config_store::ConfigStore<flash::SimFlash>,
}

impl Plant {
    fn new(config: &SimConfig, reports: Sender<String>) -> Result<Plant, String> {
        let mut twin_cfg = if config.identified_rig {
            TwinConfig::identified_rig()
        } else {
            TwinConfig::thesis()
        };
        twin_cfg.effects = config.effects.clone();
        twin_cfg.seed = config.seed;
        let counts_per_rev = twin_cfg.sensors.encoder_counts_per_rev;
        let mut twin = Twin::new(twin_cfg);
        let mut safety = SafetyConfig::default_1khz();
        safety.command_timeout_s = config.command_timeout_s;
        safety.validate().map_err(|_| {
            format!(
                "command timeout {} s is outside the device's range (0–1 s]",
                config.command_timeout_s
            )
        })?;
        let mut device = Device::new(
            RobotParams::thesis(),
            safety,
            DeviceOptions {
                firmware_version: emulator_version(),
                encoder_counter_bits: ENCODER_COUNTER_BITS,
            },
        );
        // the rig's calibration: the twin's encoder resolution
        let mut cal: Calibration = device.calibration();
        for (enc, counts) in cal.encoder.iter_mut().zip(counts_per_rev) {
            *enc = EncoderCalibration {
                counts_per_rev: counts.max(1),
                sign: 1,
            };
        }
        let reply = device.handle(&Request {
            id: 0,
            body: RequestBody::SetConfig(Config::Calibration(cal)),
        });
        reply
            .result
            .map_err(|e| format!("the device refused the emulator's calibration: {e:?}"))?;
        // like the firmware's boot: the record in flash, if there is a good one
        let mut store = flash::store(config.config_flash.clone())?;
        device.boot_config(store.load());
        let last = twin.step(1e-6, [4.0; 4], &HandleCondition::Free);
        let model = *twin.model();
        let path = (config.handle == HandleMode::Operator)
            .then(|| OperatorPath::new([0.0; 2], 0.04, (0.1, 2.0), OPERATOR_PATH_S, config.seed));
        let hold_point = twin.state().handle_user_m;
        let last_mode = (device.controller().state(), device.controller().mode());
        let mut schedule = config.injections.clone();
        schedule.sort_by(|a, b| b.at_s.total_cmp(&a.at_s));
        let board = Board::new(device.period_us());
        Ok(Plant {
            device,
            twin,
            last,
            handle_mode: config.handle,
            model,
            path,
            hold_point,
            since_s: 0.0,
            last_mode,
            t_s: 0.0,
            board,
            schedule,
            reports,
            last_currents_ma: [4.0; 4],
            store,
        })
    }

    /// A request frame, the storage requests with the emulated flash.
    fn handle_frame(
        &mut self,
        frame: Result<Request, pam_protocol::DecodeError>,
    ) -> pam_protocol::Reply {
        match &frame {
            Ok(request) => self.device.handle_with_store(&mut self.store, request),
            Err(_) => self.device.handle_frame(frame),
        }
    }

    /// Applies `injection` from the coming period on and reports it.
    fn inject(&mut self, injection: Injection, device_time_us: u64) {
        self.board
            .inject(injection, &self.last, self.last_currents_ma);
        let _ = self.reports.send(format!(
            "injected {injection:?} at time_us={}",
            device_time_us as u32
        ));
    }

    fn raw_sensors(&self) -> RawSensors {
        let seen = self.board.sensors(self.last);
        let counts = seen
            .encoder_counts
            .map(|c| (c + ENCODER_POWER_ON_COUNTS) as u32);
        RawSensors {
            encoder_counts: counts,
            loadcell_volts: seen.loadcell_v.map(|v| v as f32),
        }
    }

    /// What holds the handle during the coming period.
    fn handle_condition(&mut self) -> HandleCondition {
        let state = self.device.controller().state();
        let mode = self.device.controller().mode();
        if (state, mode) != self.last_mode {
            self.last_mode = (state, mode);
            self.since_s = self.t_s;
            self.hold_point = match mode {
                Mode::Joint { alpha_rad, .. } => self
                    .model
                    .kinematics
                    .forward_user([alpha_rad[0] as f64, alpha_rad[1] as f64]),
                Mode::Impedance { target_user_m, .. } => {
                    [target_user_m[0] as f64, target_user_m[1] as f64]
                }
                _ => self.twin.state().handle_user_m,
            };
        }
        let armed = state == State::Armed;
        let force = matches!(mode, Mode::Force { .. } | Mode::ForceClosedLoop { .. });
        // the operator moves the handle about the joint or the impedance target
        let joint = matches!(mode, Mode::Joint { .. } | Mode::Impedance { .. });
        match self.handle_mode {
            HandleMode::Free => HandleCondition::Free,
            HandleMode::Blocked if armed && force => HandleCondition::Blocked,
            HandleMode::Blocked => HandleCondition::Free,
            HandleMode::Held if armed => HandleCondition::held_at(self.hold_point),
            HandleMode::Held => HandleCondition::Free,
            HandleMode::Operator if armed && force => HandleCondition::Blocked,
            HandleMode::Operator if armed && joint => {
                let t = self.t_s - self.since_s - OPERATOR_HOLD_S;
                match &self.path {
                    Some(path) if t > 0.0 => {
                        let (p, v) = path.at(t);
                        let c = self.hold_point;
                        HandleCondition::moved([c[0] + p[0], c[1] + p[1]], v)
                    }
                    _ => HandleCondition::held_at(self.hold_point),
                }
            }
            HandleMode::Operator => HandleCondition::Free,
        }
    }
}

fn real_time_loop(mut plant: Plant, events: Receiver<Event>, stop: &AtomicBool, stats: &LoopStats) {
    let mut conns: Vec<Connection> = Vec::new();
    // the newest connection that has sent anything gets the telemetry
    let mut streaming: Option<u64> = None;
    let start = Instant::now();
    let mut deadline = start;
    let mut device_time_us: u64 = 0;
    let mut last_exec_us: u16 = 0;
    let mut replies: Vec<(u64, Vec<u8>)> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let period_us = plant.device.period_us().max(1) as u64;
        let period = Duration::from_micros(period_us);
        let now = Instant::now();
        if now < deadline {
            std::thread::sleep(deadline - now);
        }
        let began = Instant::now();
        let mut behind = began.saturating_duration_since(deadline);
        if behind > MAX_CATCH_UP {
            stats.resyncs.fetch_add(1, Ordering::Relaxed);
            deadline = began;
            behind = Duration::ZERO;
        }
        if behind >= period {
            stats.late.fetch_add(1, Ordering::Relaxed);
        }
        let jitter_us = behind.as_micros().min(u16::MAX as u128) as u16;
        stats
            .max_jitter_us
            .fetch_max(jitter_us as u64, Ordering::Relaxed);

        // 1. requests
        loop {
            match events.try_recv() {
                Ok(Event::Opened { conn, out }) => conns.push(Connection {
                    id: conn,
                    out,
                    decoder: FrameDecoder::new(),
                }),
                Ok(Event::Closed { conn }) => {
                    conns.retain(|c| c.id != conn);
                    if streaming == Some(conn) {
                        streaming = None;
                    }
                }
                Ok(Event::Bytes { conn, bytes }) => {
                    let Some(c) = conns.iter_mut().find(|c| c.id == conn) else {
                        continue;
                    };
                    if streaming.is_none_or(|s| s < conn) {
                        streaming = Some(conn);
                    }
                    let mut out = Vec::new();
                    for b in bytes {
                        if let Some(frame) = c.decoder.push(b) {
                            let reply = plant.handle_frame(frame);
                            push_frame(&mut out, &DeviceMessage::Reply(reply));
                        }
                    }
                    if !out.is_empty() {
                        replies.push((conn, out));
                    }
                }
                Ok(Event::Inject(injection)) => plant.inject(injection, device_time_us),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }

        while plant
            .schedule
            .last()
            .is_some_and(|s| s.at_s <= plant.t_s + 1e-9)
        {
            if let Some(s) = plant.schedule.pop() {
                plant.inject(s.injection, device_time_us);
            }
        }

        // 2. the device's control period (inside the emulated board), then the plant over
        // the same period
        plant.board.before_step(&mut plant.device);
        let raw = plant.raw_sensors();
        let step_clock = inject::StepClock::start();
        let result = plant.device.step(
            raw,
            StepTiming {
                time_us: device_time_us as u32,
                loop_exec_us: last_exec_us,
                loop_jitter_us: jitter_us,
            },
        );
        let step_us = step_clock.elapsed_us();
        let stall_us = plant.board.stall_us(period_us as u32);
        if stall_us > 0 {
            std::thread::sleep(Duration::from_micros(stall_us as u64));
        }
        let board_exec_us = step_us + stall_us;
        let driven_ma = plant.board.after_step(
            &mut plant.device,
            device_time_us as u32,
            board_exec_us,
            period_us as u32,
            result.current_ma,
        );
        let handle = plant.handle_condition();
        let period_s = period_us as f64 * 1e-6;
        plant.last_currents_ma = driven_ma.map(|c| c as f64);
        let at_converters = plant.board.converter_currents(plant.last_currents_ma);
        plant.last = plant.twin.step(period_s, at_converters, &handle);
        plant.t_s += period_s;
        device_time_us += period_us;

        // 3. output
        let mut stream = Vec::new();
        if let Some(e) = result.fault_event {
            push_frame(&mut stream, &DeviceMessage::FaultEvent(e));
        }
        if let Some(t) = result.telemetry {
            push_frame(&mut stream, &DeviceMessage::Telemetry(t));
        }
        if let Some(s) = streaming {
            if !stream.is_empty() {
                replies.push((s, stream));
            }
        }
        for (conn, bytes) in replies.drain(..) {
            let Some(c) = conns.iter().find(|c| c.id == conn) else {
                continue;
            };
            let n = bytes.len() as u64;
            match c.out.try_send(bytes) {
                Ok(()) => {
                    stats.bytes_sent.fetch_add(n, Ordering::Relaxed);
                }
                Err(TrySendError::Full(_)) => {
                    stats.frames_dropped.fetch_add(1, Ordering::Relaxed);
                }
                Err(TrySendError::Disconnected(_)) => {}
            }
        }

        let exec_us = began.elapsed().as_micros().min(u16::MAX as u128) as u16;
        last_exec_us = exec_us;
        stats
            .exec_us_total
            .fetch_add(exec_us as u64, Ordering::Relaxed);
        stats
            .max_exec_us
            .fetch_max(exec_us as u64, Ordering::Relaxed);
        stats.periods.fetch_add(1, Ordering::Relaxed);
        deadline += period;
    }
}
