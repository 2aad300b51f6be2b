//! Scripted versions of the thesis protocols, run with the real controller
//! (`pam_control::Controller`, f32) in the loop, written in log format v1.
//!
//! - [`dynamic_trial`]: §4.2 — joint mode at a Table 4.1 point, zero torque, K_low or K_high;
//!   an operator moves the handle for 90 s along a smooth random path (multi-sine, 0.1–2 Hz,
//!   ±4 cm: the 8 cm square of Fig. 4.2b), seeded.
//! - [`static_trial`]: §4.2 — the same set-up, the handle held 5 s at each of 9 points (centre,
//!   corners and edge midpoints of the 8 cm square).
//! - [`force_step_test`]: §5.2 — handle blocked at one of the nine poses, force mode, steps of
//!   9.1 N from 0 to 27.3 N then down to −27.3 N, along X then Y; the stiffness is the highest
//!   of the minimum stiffnesses that deliver ±27.3 N along either axis.
//!
//! The loop: at each period the controller reads the previous sample, its currents are held
//! by the twin over the period, and one log row is written per period with the sample and
//! the currents computed from it.

use std::fmt;

use pam_control::{Controller, Mode, SafetyConfig, Sensors, State};
use pam_log::{col, Log};
use pam_model::{RobotModel, RobotParams, Vec2};

use crate::plant::{HandleCondition, Measurement, Twin, TwinConfig};
use crate::rng::Rng;

// The thesis's protocols (Table 4.1's points and stiffness levels, §5.2's poses, steps and
// stiffness, the static trial's holds) live in pam-model; re-exported for the twin's users.
pub use pam_model::protocols::{
    static_points, step_levels, step_test_stiffness, trial_stiffness, StiffnessLevel,
};
pub use pam_model::thesis::{STEP_MAX_N, STEP_N, STEP_POSES_DEG, TABLE_4_1_POINTS_DEG};

/// What every experiment shares.
#[derive(Clone, Debug)]
pub struct ExperimentConfig {
    /// The plant (true parameters, effects, sensors, seed).
    pub twin: TwinConfig,
    /// What the controller believes (defaults to the plant's parameters).
    pub controller_params: RobotParams<f64>,
    /// Loop and logging period: 1 ms by default; the thesis sampled at 50 ms.
    pub period_s: f64,
    /// Settling time before logging starts (the thesis logged "after steady state").
    pub settle_s: f64,
    /// Operator path amplitude (peak, per axis) for dynamic trials.
    pub path_amplitude_m: f64,
    pub path_band_hz: (f64, f64),
    /// Gain-plane feed-forward in force mode. Off by default: the thesis's step gains
    /// (Table 5.2, Fig. 5.4–5.5) were measured with the uncorrected command, and §5.4 then
    /// proposes the correction from them.
    pub feed_forward: bool,
    /// Force mode with the load cell in the loop (`Mode::ForceClosedLoop`). Off by default.
    pub closed_loop: bool,
    /// Multiplier of the closed loop's designed feedback gains (1 = the design).
    pub gain_scale: f64,
    /// Hold time of each force level.
    pub step_hold_s: f64,
}

impl ExperimentConfig {
    pub fn new(twin: TwinConfig) -> Self {
        ExperimentConfig {
            controller_params: twin.params,
            twin,
            period_s: 0.001,
            settle_s: 3.0,
            path_amplitude_m: 0.04,
            path_band_hz: (0.1, 2.0),
            feed_forward: false,
            closed_loop: false,
            gain_scale: 1.0,
            step_hold_s: 1.5,
        }
    }
    pub fn thesis() -> Self {
        Self::new(TwinConfig::thesis())
    }
}

#[derive(Debug)]
pub struct ExperimentError {
    pub message: String,
    /// What was logged up to the failure.
    pub partial_log: Option<Log>,
}

impl fmt::Display for ExperimentError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for ExperimentError {}

fn err(message: impl Into<String>) -> ExperimentError {
    ExperimentError {
        message: message.into(),
        partial_log: None,
    }
}

fn deg2rad(a: [f64; 2]) -> Vec2<f64> {
    [a[0].to_radians(), a[1].to_radians()]
}

/// A smooth random operator path: per axis a sum of sines log-spaced over the band with
/// random phases and amplitudes ∝ 1/√f (slow motions are larger), scaled to the peak
/// amplitude, faded in and out over 2 s.
#[derive(Clone, Debug)]
pub struct OperatorPath {
    pub centre_user_m: Vec2<f64>,
    /// (frequency rad/s, amplitude m, phase rad) per axis.
    components: [Vec<(f64, f64, f64)>; 2],
    duration_s: f64,
    fade_s: f64,
}

impl OperatorPath {
    pub fn new(
        centre_user_m: Vec2<f64>,
        amplitude_m: f64,
        band_hz: (f64, f64),
        duration_s: f64,
        seed: u64,
    ) -> Self {
        let mut rng = Rng::derive(seed, "operator_path");
        let n = 12;
        let (f_lo, f_hi) = (band_hz.0.max(1e-3), band_hz.1.max(band_hz.0.max(1e-3)));
        let mut components: [Vec<(f64, f64, f64)>; 2] = [Vec::new(), Vec::new()];
        for axis in 0..2 {
            for k in 0..n {
                // log-spaced, jittered so the two axes differ
                let u = (k as f64 + rng.uniform()) / n as f64;
                let f = f_lo * (f_hi / f_lo).powf(u);
                let a = 1.0 / f.sqrt();
                components[axis].push((
                    std::f64::consts::TAU * f,
                    a,
                    std::f64::consts::TAU * rng.uniform(),
                ));
            }
        }
        let mut path = OperatorPath {
            centre_user_m,
            components,
            duration_s,
            fade_s: 2.0f64.min(duration_s / 4.0),
        };
        // scale each axis so its peak over the trial is the amplitude
        for axis in 0..2 {
            let mut peak: f64 = 0.0;
            let steps = (duration_s / 0.005).ceil() as usize;
            for i in 0..=steps {
                peak = peak.max(path.raw(axis, i as f64 * 0.005).0.abs());
            }
            if peak > 0.0 {
                for c in path.components[axis].iter_mut() {
                    c.1 *= amplitude_m / peak;
                }
            }
        }
        path
    }

    fn raw(&self, axis: usize, t: f64) -> (f64, f64) {
        let mut x = 0.0;
        let mut v = 0.0;
        for &(w, a, ph) in &self.components[axis] {
            let (s, c) = (w * t + ph).sin_cos();
            x += a * s;
            v += a * w * c;
        }
        (x, v)
    }

    /// Raised-cosine fade in/out and its derivative.
    fn window(&self, t: f64) -> (f64, f64) {
        let f = self.fade_s;
        let pi = std::f64::consts::PI;
        if t <= 0.0 || t >= self.duration_s {
            (0.0, 0.0)
        } else if t < f {
            (
                0.5 - 0.5 * (pi * t / f).cos(),
                0.5 * pi / f * (pi * t / f).sin(),
            )
        } else if t > self.duration_s - f {
            let u = self.duration_s - t;
            (
                0.5 - 0.5 * (pi * u / f).cos(),
                -0.5 * pi / f * (pi * u / f).sin(),
            )
        } else {
            (1.0, 0.0)
        }
    }

    /// Target position and velocity at time `t` from the start of the motion.
    pub fn at(&self, t: f64) -> (Vec2<f64>, Vec2<f64>) {
        let (w, dw) = self.window(t);
        let mut p = self.centre_user_m;
        let mut v = [0.0; 2];
        for axis in 0..2 {
            let (x, dx) = self.raw(axis, t);
            p[axis] += w * x;
            v[axis] = w * dx + dw * x;
        }
        (p, v)
    }
}

/// The controller, the twin and the log, stepping together.
pub(crate) struct Rig {
    pub(crate) twin: Twin,
    pub(crate) ctl: Controller,
    period_s: f64,
    last: Measurement,
    log: Log,
    with_ref: bool,
    with_hand_ref: bool,
    seq: u64,
    t0: Option<f64>,
    /// Largest |dp/dt| over the channels during the last period (bar/s).
    pressure_rate_bar_s: f64,
}

fn columns(with_ref: bool, with_hand_ref: bool) -> Vec<&'static str> {
    let mut c = vec![
        col::T_S,
        col::ALPHA1_RAD,
        col::ALPHA2_RAD,
        col::FX_N,
        col::FY_N,
        col::I1_MA,
        col::I2_MA,
        col::I3_MA,
        col::I4_MA,
    ];
    if with_ref {
        c.extend([col::FX_REF_N, col::FY_REF_N]);
    }
    c.extend(col::PRESSURES_BAR);
    c.extend(col::PRESSURES_CMD_BAR);
    if with_hand_ref {
        c.extend(["hand_x_ref_m", "hand_y_ref_m"]);
    }
    c.extend([col::SEQ, col::STATE, col::FAULTS]);
    c
}

impl Rig {
    pub(crate) fn new(
        cfg: &ExperimentConfig,
        alpha_start_rad: Vec2<f64>,
        with_ref: bool,
        with_hand_ref: bool,
    ) -> Result<Self, ExperimentError> {
        if !(cfg.period_s.is_finite() && cfg.period_s > 0.0 && cfg.period_s <= 0.1) {
            return Err(err(format!(
                "period {} s is outside (0, 0.1] s",
                cfg.period_s
            )));
        }
        cfg.twin
            .params
            .validate()
            .map_err(|e| err(format!("plant parameters: {e:?}")))?;
        cfg.controller_params
            .validate()
            .map_err(|e| err(format!("controller parameters: {e:?}")))?;
        let mut twin_cfg = cfg.twin.clone();
        twin_cfg.initial_alpha_rad = alpha_start_rad;
        let mut twin = Twin::new(twin_cfg);
        let model32 = RobotModel::<f32>::new(cfg.controller_params.cast());
        // The supervisor's own limits, at this loop period. `SafetyConfig::validate` accepts
        // 1–10 ms (the firmware's range); the thesis's 50 ms loop is simulated on purpose, so
        // the config is built directly.
        let mut safety = SafetyConfig::default_1khz();
        safety.period_s = cfg.period_s as f32;
        let ctl = Controller::new(model32, safety);
        let last = twin.step(
            1e-9,
            [cfg.twin.params.ip.current_min_ma; 4],
            &HandleCondition::Free,
        );
        let log = Log::new(&columns(with_ref, with_hand_ref));
        Ok(Rig {
            twin,
            ctl,
            period_s: cfg.period_s,
            last,
            log,
            with_ref,
            with_hand_ref,
            seq: 0,
            t0: None,
            pressure_rate_bar_s: f64::INFINITY,
        })
    }

    pub(crate) fn arm(&mut self, mode: Mode) -> Result<(), ExperimentError> {
        self.ctl
            .arm()
            .map_err(|e| err(format!("controller refused to arm: {e:?}")))?;
        self.set_mode(mode)
    }

    fn set_mode(&mut self, mode: Mode) -> Result<(), ExperimentError> {
        self.ctl
            .set_mode(mode)
            .map_err(|e| err(format!("controller refused mode {mode:?}: {e:?}")))
    }

    /// One period. `handle_at(offset_s)` says what holds the handle at `offset_s` into the
    /// period: the hand is updated every millisecond even when the loop runs at 50 ms (a real
    /// hand moves continuously). `record` adds a log row.
    pub(crate) fn period(
        &mut self,
        handle_at: impl Fn(f64) -> HandleCondition,
        force_ref: Option<Vec2<f64>>,
        hand_ref: Option<Vec2<f64>>,
        record: bool,
    ) -> Result<(), ExperimentError> {
        let m = self.last;
        let sensors = Sensors {
            alpha_rad: [m.alpha_rad[0] as f32, m.alpha_rad[1] as f32],
            force_sensor_n: [m.force_sensor_n[0] as f32, m.force_sensor_n[1] as f32],
        };
        self.ctl.heartbeat();
        let out = self.ctl.step(&sensors);
        if out.state == State::Faulted {
            return Err(ExperimentError {
                message: format!(
                    "controller faulted at t = {:.3} s: faults 0x{:04x}",
                    m.t_s, out.faults.0
                ),
                partial_log: Some(self.log.clone()),
            });
        }
        let currents = out.current_ma.map(|c| c as f64);
        if record {
            let t0 = *self.t0.get_or_insert(m.t_s);
            let mut row = vec![
                m.t_s - t0,
                m.alpha_rad[0],
                m.alpha_rad[1],
                m.force_user_n[0],
                m.force_user_n[1],
            ];
            row.extend(currents);
            if self.with_ref {
                let r = force_ref.unwrap_or([0.0; 2]);
                row.extend(r);
            }
            row.extend(m.pressure_bar);
            row.extend(out.pressure_bar.map(|p| p as f64));
            if self.with_hand_ref {
                row.extend(hand_ref.unwrap_or([f64::NAN; 2]));
            }
            let state = match out.state {
                State::Disarmed => 0.0,
                State::Armed => 1.0,
                State::Faulted => 2.0,
            };
            row.extend([self.seq as f64, state, out.faults.0 as f64]);
            self.log.push_row(&row);
            self.seq += 1;
        }
        let sub = (self.period_s / 0.001).round().max(1.0) as usize;
        let h = self.period_s / sub as f64;
        let before = self.last.pressure_bar;
        for k in 0..sub {
            self.last = self.twin.step(h, currents, &handle_at(k as f64 * h));
        }
        self.pressure_rate_bar_s = (0..4)
            .map(|c| (self.last.pressure_bar[c] - before[c]).abs() / self.period_s)
            .fold(0.0, f64::max);
        Ok(())
    }

    pub(crate) fn periods(&self, seconds: f64) -> usize {
        (seconds / self.period_s).round().max(0.0) as usize
    }

    pub(crate) fn finish(
        mut self,
        cfg: &ExperimentConfig,
        experiment: &str,
        extra: &[(&str, String)],
    ) -> Log {
        self.log.set_meta("experiment", experiment);
        for (k, v) in extra {
            self.log.set_meta(k, v);
        }
        self.log.set_meta("sample_period_s", self.period_s);
        self.log.set_meta("seed", cfg.twin.seed);
        self.log
            .set_meta("effects", cfg.twin.effects.specs().join(" "));
        self.log.set_meta("source", "pam-twin");
        self.log
    }
}

pub(crate) fn point_alpha(point: usize) -> Result<Vec2<f64>, ExperimentError> {
    if !(1..=5).contains(&point) {
        return Err(err(format!(
            "point {point} is not one of the five Table 4.1 points (1–5)"
        )));
    }
    Ok(deg2rad(TABLE_4_1_POINTS_DEG[point - 1]))
}

/// §4.2 dynamic trial at a Table 4.1 point (1–5).
pub fn dynamic_trial(
    cfg: &ExperimentConfig,
    point: usize,
    level: StiffnessLevel,
    duration_s: f64,
) -> Result<Log, ExperimentError> {
    let alpha = point_alpha(point)?;
    if !(duration_s.is_finite() && duration_s > 0.0) {
        return Err(err(format!("duration {duration_s} s must be positive")));
    }
    let (mut rig, centre, k) = settle_at_point(cfg, alpha, level)?;
    let path = OperatorPath::new(
        centre,
        cfg.path_amplitude_m,
        cfg.path_band_hz,
        duration_s,
        cfg.twin.seed,
    );
    let n = rig.periods(duration_s);
    for i in 0..n {
        let t = i as f64 * cfg.period_s;
        let hand = |off: f64| {
            let (p, v) = path.at(t + off);
            HandleCondition::moved(p, v)
        };
        rig.period(hand, None, Some(path.at(t).0), true)?;
    }
    Ok(rig.finish(
        cfg,
        "dynamic",
        &[
            ("point", point.to_string()),
            ("stiffness", level.name().into()),
            ("k_joint_nm_per_rad", format!("{:.3} {:.3}", k[0], k[1])),
            ("x0_user_m", format!("{:.6} {:.6}", centre[0], centre[1])),
        ],
    ))
}

/// The start of a static or dynamic trial (§4.2): joint mode at the point with the trial's
/// stiffness and zero torque, the hand holding the handle there for the settling time.
/// Returns the rig, the point in the user frame and the joint stiffness.
fn settle_at_point(
    cfg: &ExperimentConfig,
    alpha: Vec2<f64>,
    level: StiffnessLevel,
) -> Result<(Rig, Vec2<f64>, Vec2<f64>), ExperimentError> {
    let model = RobotModel::new(cfg.controller_params);
    let k = trial_stiffness(&model, alpha, level);
    let mut rig = Rig::new(cfg, alpha, false, true)?;
    let centre = rig.twin.model().kinematics.forward_user(alpha);
    rig.arm(Mode::Joint {
        alpha_rad: [alpha[0] as f32, alpha[1] as f32],
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [k[0] as f32, k[1] as f32],
    })?;
    let hold = HandleCondition::held_at(centre);
    for _ in 0..rig.periods(cfg.settle_s) {
        rig.period(|_| hold, None, None, false)?;
    }
    Ok((rig, centre, k))
}

/// §4.2 static trial: 5 s at each of the nine points, 1.5 s smooth moves between them.
pub fn static_trial(
    cfg: &ExperimentConfig,
    point: usize,
    level: StiffnessLevel,
) -> Result<Log, ExperimentError> {
    let alpha = point_alpha(point)?;
    let (mut rig, centre, k) = settle_at_point(cfg, alpha, level)?;
    let points = static_points(centre, 0.04);
    let (move_s, hold_s) = (1.5, 5.0);
    let mut from = centre;
    for &to in &points {
        // minimum-jerk-like cosine move
        let n_move = rig.periods(move_s);
        let along = |t: f64| {
            let s = (t / move_s).clamp(0.0, 1.0);
            let w = 0.5 - 0.5 * (std::f64::consts::PI * s).cos();
            let dw = if t < move_s {
                0.5 * std::f64::consts::PI * (std::f64::consts::PI * s).sin() / move_s
            } else {
                0.0
            };
            let p = [
                from[0] + w * (to[0] - from[0]),
                from[1] + w * (to[1] - from[1]),
            ];
            (p, [dw * (to[0] - from[0]), dw * (to[1] - from[1])])
        };
        for i in 0..n_move {
            let t = i as f64 * cfg.period_s;
            rig.period(
                |off| {
                    let (p, v) = along(t + off);
                    HandleCondition::moved(p, v)
                },
                None,
                Some(along(t).0),
                true,
            )?;
        }
        for _ in 0..rig.periods(hold_s) {
            rig.period(|_| HandleCondition::held_at(to), None, Some(to), true)?;
        }
        from = to;
    }
    Ok(rig.finish(
        cfg,
        "static",
        &[
            ("point", point.to_string()),
            ("stiffness", level.name().into()),
            ("k_joint_nm_per_rad", format!("{:.3} {:.3}", k[0], k[1])),
            ("x0_user_m", format!("{:.6} {:.6}", centre[0], centre[1])),
        ],
    ))
}

/// The force mode of the configuration: open loop, or closed loop with its gain scale.
pub fn force_mode(cfg: &ExperimentConfig, force_n: Vec2<f32>, stiffness: Vec2<f32>) -> Mode {
    if cfg.closed_loop {
        Mode::ForceClosedLoop {
            force_n,
            stiffness_nm_per_rad: stiffness,
            feed_forward: cfg.feed_forward,
            gain_scale: cfg.gain_scale as f32,
        }
    } else {
        Mode::Force {
            force_n,
            stiffness_nm_per_rad: stiffness,
            feed_forward: cfg.feed_forward,
        }
    }
}

/// §5.2 force-step test at `pose_deg` (blocked handle): the X sequence then the Y sequence,
/// one log with `fx_ref_n`, `fy_ref_n`.
pub fn force_step_test(cfg: &ExperimentConfig, pose_deg: [f64; 2]) -> Result<Log, ExperimentError> {
    let alpha = deg2rad(pose_deg);
    let model = RobotModel::new(cfg.controller_params);
    for j in 0..2 {
        let jp = &cfg.controller_params.joints[j];
        if !(alpha[j] >= jp.alpha_min_rad && alpha[j] <= jp.alpha_max_rad) {
            return Err(err(format!(
                "pose {pose_deg:?}° is outside joint {}'s range",
                j + 1
            )));
        }
    }
    let k = step_test_stiffness(&model, alpha);
    let mut rig = Rig::new(cfg, alpha, true, false)?;
    // the block is in place before the arm is armed: the first sample the controller sees
    // already carries whatever the vented rig presses on it (a rig with a parallel
    // stiffness preloads the block away from its rest)
    rig.last = rig.twin.step(
        1e-9,
        [cfg.twin.params.ip.current_min_ma; 4],
        &HandleCondition::Blocked,
    );
    let stiffness = [k[0] as f32, k[1] as f32];
    let ff = cfg.feed_forward;
    let mode = |f: [f64; 2]| force_mode(cfg, [f[0] as f32, f[1] as f32], stiffness);
    rig.arm(mode([0.0; 2]))?;
    let blocked = HandleCondition::Blocked;
    for _ in 0..rig.periods(cfg.settle_s) {
        rig.period(|_| blocked, Some([0.0; 2]), None, false)?;
    }
    // as an experimenter would: the test starts once the pressures have settled (slow,
    // flow-limited converters need longer than `settle_s`), at most a minute later
    for _ in 0..rig.periods(60.0) {
        if rig.pressure_rate_bar_s < 0.01 {
            break;
        }
        rig.period(|_| blocked, Some([0.0; 2]), None, false)?;
    }
    for axis in 0..2 {
        for level in step_levels() {
            let mut f = [0.0f64; 2];
            f[axis] = level;
            rig.set_mode(mode(f))?;
            for _ in 0..rig.periods(cfg.step_hold_s) {
                rig.period(|_| blocked, Some(f), None, true)?;
            }
        }
    }
    Ok(rig.finish(
        cfg,
        "force_step",
        &[
            ("pose_deg", format!("{} {}", pose_deg[0], pose_deg[1])),
            ("k_joint_nm_per_rad", format!("{:.3} {:.3}", k[0], k[1])),
            ("feed_forward", ff.to_string()),
            ("closed_loop", cfg.closed_loop.to_string()),
            ("gain_scale", cfg.gain_scale.to_string()),
        ],
    ))
}
