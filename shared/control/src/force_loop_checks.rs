//! Checks of the closed force loop, on the host and on the Cortex-M4F under QEMU: against a
//! blocked-handle plant built from the model itself (Table 5.2's second order per converter,
//! the direct model, F = J⁻ᵀ τ times a gain the controller does not know), one period of delay.

use crate::force_loop::*;
use crate::impedance::{MAX_IMPEDANCE_MASS_KG, MAX_IMPEDANCE_STIFFNESS_N_PER_M};
use crate::motion::ARM_RAMP_S;
use crate::supervisor::*;
use pam_model::checks::holds_that as holds;
use pam_model::{RobotModel, Vec2};

pub use pam_model::checks::{Check, CheckResult};

const POSE_RAD: Vec2<f32> = [0.1, -0.2];
const STIFFNESS: Vec2<f32> = [80.0, 35.0];

/// The blocked handle: four converters (second order), muscles, a force gain the model misses.
struct Plant {
    model: RobotModel<f32>,
    gain: f32,
    p_bar: [f32; 4],
    q_bar_s: [f32; 4],
    k: u32,
    /// How far the handle gives per newton, rad/N per joint (0: blocked; a hand holding
    /// it gives a little, and in impedance mode the encoders see that).
    give_rad_per_n: f32,
}

impl Plant {
    fn new(gain: f32) -> Self {
        Plant {
            model: RobotModel::thesis(),
            gain,
            p_bar: [0.1; 4],
            q_bar_s: [0.0; 4],
            k: 0,
            give_rad_per_n: 0.0,
        }
    }

    fn force_user_n(&self) -> Vec2<f32> {
        let jp = self.model.joint_pressures_bar(self.p_bar);
        let d = self.model.direct(POSE_RAD, jp);
        let tau = [d[0].0, d[1].0];
        let jt_inv = self
            .model
            .kinematics
            .jacobian(POSE_RAD)
            .transpose()
            .inverse();
        let f = jt_inv.map(|m| m.mul_vec(tau)).unwrap_or([0.0; 2]);
        [f[0] * self.gain, f[1] * self.gain]
    }

    fn sensors(&mut self) -> Sensors {
        self.k += 1;
        let d = if self.k.is_multiple_of(2) {
            0.01
        } else {
            -0.01
        };
        let f = self.force_user_n();
        let s = self.model.kinematics.user_to_sensor(POSE_RAD, f);
        let g = self.give_rad_per_n;
        Sensors {
            alpha_rad: [POSE_RAD[0] + g * f[0], POSE_RAD[1] - g * f[1]],
            force_sensor_n: [s[0] + d, s[1]],
        }
    }

    /// Holds the commanded pressures for one period (1 ms, ten sub-steps).
    fn advance(&mut self, cmd_bar: [f32; 4]) {
        let ip = self.model.params.ip;
        let (wn, z) = (ip.natural_freq_rad_s, ip.damping_ratio);
        let h = 1e-4;
        for _ in 0..10 {
            for c in 0..4 {
                let acc = wn * wn * (cmd_bar[c] - self.p_bar[c]) - 2.0 * z * wn * self.q_bar_s[c];
                self.q_bar_s[c] += acc * h;
                self.p_bar[c] += self.q_bar_s[c] * h;
            }
        }
    }
}

struct Run {
    /// Mean over the last 100 periods.
    mean_force_n: Vec2<f32>,
    peak_abs_n: f32,
    out: StepOutput,
    /// Period at which the controller faulted, if it did.
    faulted_at: Option<u32>,
}

fn run(c: &mut Controller, plant: &mut Plant, periods: u32) -> Run {
    let mut out = c.step(&plant.sensors());
    let mut sum = [0.0f32; 2];
    let mut peak: f32 = 0.0;
    let mut faulted_at = None;
    for k in 0..periods {
        plant.advance(out.pressure_bar);
        c.heartbeat();
        out = c.step(&plant.sensors());
        let f = out.force_user_n;
        peak = peak.max(f[0].abs()).max(f[1].abs());
        if k + 100 >= periods {
            sum = [sum[0] + f[0] / 100.0, sum[1] + f[1] / 100.0];
        }
        if faulted_at.is_none() && out.state == State::Faulted {
            faulted_at = Some(k);
        }
    }
    Run {
        mean_force_n: sum,
        peak_abs_n: peak,
        out,
        faulted_at,
    }
}

fn closed(force_n: Vec2<f32>, gain_scale: f32) -> Mode {
    Mode::ForceClosedLoop {
        force_n,
        stiffness_nm_per_rad: STIFFNESS,
        feed_forward: false,
        gain_scale,
    }
}

fn armed(mode: Mode) -> Controller {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    c.arm().ok();
    c.set_mode(mode).ok();
    c
}

const TARGET_N: Vec2<f32> = [9.1, -4.0];

pub fn closed_loop_reaches_the_force_the_open_loop_misses() -> CheckResult {
    // the plant delivers 0.7 of what the model predicts
    let mut plant = Plant::new(0.7);
    let mut c = armed(closed([0.0; 2], 1.0));
    run(&mut c, &mut plant, 1000);
    holds(
        "closed loop accepted",
        c.set_mode(closed(TARGET_N, 1.0)).is_ok(),
    )?;
    let r = run(&mut c, &mut plant, 1000);
    holds("no fault", r.faulted_at.is_none() && r.out.faults.is_none())?;
    for a in 0..2 {
        holds(
            "closed loop within 0.1 N of the target",
            (r.mean_force_n[a] - TARGET_N[a]).abs() < 0.1,
        )?;
        // overshoot ≤ 10 % of the step on the larger axis
        holds("bounded overshoot", r.peak_abs_n <= TARGET_N[0] * 1.10)?;
    }
    let mut plant = Plant::new(0.7);
    let mut c = armed(Mode::Force {
        force_n: TARGET_N,
        stiffness_nm_per_rad: STIFFNESS,
        feed_forward: false,
    });
    let r = run(&mut c, &mut plant, 2000);
    holds(
        "the open loop misses by the plant's 30 %",
        (r.mean_force_n[0] - 0.7 * TARGET_N[0]).abs() < 0.3,
    )
}

/// A run that held a scaled target: no fault, and the step flagged it.
fn held_scaled(r: &Run) -> CheckResult {
    holds("no fault", r.faulted_at.is_none() && r.out.faults.is_none())?;
    holds(
        "flagged as scaled",
        r.out.limited.contains(pam_model::Limited::TARGET),
    )
}

/// A force `f` against a direction `d`: (|d|², f·d, f × d). Along d is f·d / |d| and across
/// it f × d / |d|; the checks compare squares, so no square root is needed on the target.
fn against(f: Vec2<f32>, d: Vec2<f32>) -> (f32, f32, f32) {
    (
        d[0] * d[0] + d[1] * d[1],
        f[0] * d[0] + f[1] * d[1],
        f[0] * d[1] - f[1] * d[0],
    )
}

/// A target beyond the muscles (a plant at 0.57 of the model, as the rig): scaled to what
/// they give, in the direction asked for, flagged, no fault (`RobotModel::reachable_force_scale`).
pub fn a_target_beyond_the_muscles_is_scaled_in_its_direction() -> CheckResult {
    let mut plant = Plant::new(0.57);
    let mut c = armed(closed([0.0; 2], 1.0));
    run(&mut c, &mut plant, 500);
    // a level first: the loop measures the plant's gain between levels
    c.set_mode(closed(TARGET_N, 1.0)).ok();
    run(&mut c, &mut plant, 1500);
    let far = [8.0 * TARGET_N[0], 8.0 * TARGET_N[1]];
    holds("accepted", c.set_mode(closed(far, 1.0)).is_ok())?;
    let r = run(&mut c, &mut plant, 2000);
    held_scaled(&r)?;
    let (n2, dot, cross) = against(r.mean_force_n, far);
    let level = 1.5 * TARGET_N[0];
    holds(
        "more than the level before",
        dot > 0.0 && dot * dot > level * level * n2,
    )?;
    holds("less than asked", dot < 0.95 * n2)?;
    holds("in the direction asked for", cross * cross < 0.09 * n2)
}

/// A stiff virtual spring far from its target asks for more than the muscles give: the
/// impedance mode scales the force, its direction kept, and flags it
/// (`impedance::reachable_impedance_force_n`); joint by joint the force would turn.
pub fn a_spring_force_beyond_the_muscles_keeps_its_direction() -> CheckResult {
    let model = RobotModel::<f32>::thesis();
    let x = model.kinematics.forward_user(POSE_RAD);
    // 15 cm down and to the right at 3000 N/m: 670 N asked, bounded to 100 N per axis as a
    // force request is, and beyond the muscles at this pose still
    let d = [0.1, -0.11];
    let mut plant = Plant::new(1.0);
    plant.give_rad_per_n = 1e-5;
    let mut c = armed(Mode::Impedance {
        target_user_m: [x[0] + d[0], x[1] + d[1]],
        stiffness_n_per_m: [3000.0, 3000.0],
        damping_n_s_per_m: [5.0, 5.0],
        mass_kg: [0.0, 0.0],
    });
    let r = run(&mut c, &mut plant, 2000);
    held_scaled(&r)?;
    let (n2, dot, cross) = against(r.mean_force_n, d);
    // along the spring's direction: at least 10 N, less than the bound, within 0.5 N of it
    holds("toward the target", dot > 0.0 && dot * dot > 100.0 * n2)?;
    holds("less than asked", dot * dot < 100.0 * 100.0 * n2)?;
    holds("in the spring's direction", cross * cross < 0.25 * n2)
}

/// A loop designed with twenty times the gains (a wrong design, far past the margin no
/// accepted `gain_scale` can reach) oscillates: the guard latches and vents.
pub fn bad_gains_are_caught_by_the_guard_and_vented() -> CheckResult {
    let mut plant = Plant::new(1.0);
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    let mut cfg = ForceLoopConfig::designed();
    cfg.kp *= 20.0;
    cfg.ki_per_s *= 20.0;
    cfg.kd_s *= 20.0;
    holds("gains set", c.set_force_loop_config(cfg).is_ok())?;
    holds("armed", c.arm().is_ok())?;
    holds("settle at zero", c.set_mode(closed([0.0; 2], 0.05)).is_ok())?;
    run(&mut c, &mut plant, 1000);
    holds(
        "the step accepted",
        c.set_mode(closed(TARGET_N, 1.0)).is_ok(),
    )?;
    let r = run(&mut c, &mut plant, 3000);
    let at = r.faulted_at;
    holds(
        "the guard latched",
        r.out.faults.contains(Faults::CONTROL_UNSTABLE),
    )?;
    holds("within a second", at.is_some_and(|k| k < 1000))?;
    holds(
        "vented",
        r.out.current_ma.iter().all(|&i| i == 4.0) && r.out.state == State::Faulted,
    )?;
    // the oscillation was stopped within about one swing beyond the guard's bound
    let bound = c.force_loop_config().guard_error_max_n;
    holds(
        "force bounded before the trip",
        r.peak_abs_n < TARGET_N[0] + 1.5 * bound,
    )?;
    holds(
        "re-arm refused while latched",
        c.arm() == Err(Reject::WrongState),
    )
}

pub fn a_force_the_plant_cannot_give_is_a_persistent_error() -> CheckResult {
    // a load cell that reads nothing (but dithers): the error stays at the target
    let mut plant = Plant::new(0.0);
    let mut c = armed(closed([0.0; 2], 1.0));
    // the tensioning ramp, then the loop running
    run(&mut c, &mut plant, (ARM_RAMP_S * 1000.0) as u32 + 200);
    holds("accepted", c.set_mode(closed([20.0, 0.0], 1.0)).is_ok())?;
    let cfg = *c.force_loop_config();
    let r = run(&mut c, &mut plant, 2000);
    let k = r.faulted_at.unwrap_or(u32::MAX);
    holds("latched", r.out.faults.contains(Faults::CONTROL_UNSTABLE))?;
    // the error passes `guard_error_n` once the reference model does: about 0.2 s after the
    // step at a hand's gains, which the loop keeps as long as it has seen no block (a cell
    // that reads nothing shows no force)
    holds(
        "after guard_time_s of large error, not before",
        k as f32 >= cfg.guard_time_s * 1000.0 + 150.0
            && (k as f32) < cfg.guard_time_s * 1000.0 + 250.0,
    )?;
    holds("integral bounded", {
        let i = c.force_loop().integral_n();
        i[0].abs() <= cfg.integral_limit_n && i[1].abs() <= cfg.integral_limit_n
    })
}

pub fn gain_scale_outside_its_range_is_refused() -> CheckResult {
    let mut c = armed(Mode::Idle);
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY, MAX_GAIN_SCALE * 1.01] {
        holds(
            "refused",
            c.set_mode(closed([1.0, 0.0], bad)) == Err(Reject::OutOfRange),
        )?;
        holds("nothing changed", c.mode() == Mode::Idle)?;
    }
    holds("1 accepted", c.set_mode(closed([1.0, 0.0], 1.0)).is_ok())?;
    let mut bad = ForceLoopConfig::designed();
    bad.kp = -1.0;
    c.disarm();
    holds(
        "negative gain refused",
        c.set_force_loop_config(bad) == Err(Reject::OutOfRange),
    )?;
    c.arm().ok();
    holds(
        "config refused while armed",
        c.set_force_loop_config(ForceLoopConfig::designed()) == Err(Reject::WrongState),
    )
}

pub fn reference_rate_limit_anti_windup_and_bumpless_entry() -> CheckResult {
    let cfg = ForceLoopConfig::designed();
    let ip = RobotModel::<f32>::thesis().params.ip;
    let dt = 0.001;
    let mut fl = ForceLoop::new();
    // entry with the target at the measured force: the command is that force (no jump)
    let o = fl.step(&cfg, &ip, [3.0, -2.0], [3.0, -2.0], 1.0, false, dt);
    holds(
        "bumpless entry",
        (o.command_n[0] - 3.0).abs() < 1e-4 && (o.command_n[1] + 2.0).abs() < 1e-4,
    )?;
    for _ in 0..10 {
        fl.step(&cfg, &ip, [50.0, 0.0], [3.0, -2.0], 1.0, false, dt);
    }
    // ten periods: the reference moved at most force_rate · 10 ms
    let o = fl.step(&cfg, &ip, [50.0, 0.0], [3.0, -2.0], 1.0, false, dt);
    holds(
        "rate-limited reference",
        o.model_n[0] <= 3.0 + cfg.force_rate_n_per_s * 0.011,
    )?;
    // anti-windup: a saturated command freezes an integral that would grow
    let mut fl = ForceLoop::new();
    fl.step(&cfg, &ip, [0.0; 2], [0.0; 2], 1.0, false, dt);
    for _ in 0..100 {
        fl.step(&cfg, &ip, [0.0; 2], [-5.0, 0.0], 1.0, true, dt);
    }
    holds("frozen while saturated", fl.integral_n()[0] == 0.0)?;
    for _ in 0..100 {
        fl.step(&cfg, &ip, [0.0; 2], [-5.0, 0.0], 1.0, false, dt);
    }
    let grown = fl.integral_n()[0];
    holds("integrates when free", grown > 5.0)?;
    for _ in 0..10 {
        fl.step(&cfg, &ip, [0.0; 2], [5.0, 0.0], 1.0, true, dt);
    }
    holds(
        "may shrink while saturated",
        fl.integral_n()[0] < grown && fl.integral_n()[0].is_finite(),
    )
}

/// A handle that does not move (blocked, within the encoder's dead band) while the force rises
/// by `BLOCK_FORCE_N` gets the design's gains, and a hand's until then; one that gives way
/// 1 mm per newton (a relaxed hand) lowers the proportional and derivative action, and the
/// integral, toward `compliant_gain_scale`.
pub fn a_compliant_handle_gets_gentler_gains() -> CheckResult {
    let cfg = ForceLoopConfig::designed();
    let ip = RobotModel::<f32>::thesis().params.ip;
    let dt = 0.001;
    // the first command after entry with a 1 N error is kp·e (+ the integral's first period)
    let first = |handle_m: Vec2<f32>| {
        let mut fl = ForceLoop::new();
        fl.observe_handle(&cfg, [0.1, 0.2], [0.0; 2], dt);
        fl.observe_handle(&cfg, handle_m, [-10.0, 0.0], dt);
        let o = fl.step(&cfg, &ip, [-10.0, 0.0], [-10.0, 0.0], 1.0, false, dt);
        let o2 = fl.step(&cfg, &ip, [-10.0, 0.0], [-11.0, 0.0], 1.0, false, dt);
        (fl.compliance_m_per_n(), o2.command_n[0] - o.command_n[0])
    };
    let (c_blocked, d_blocked) = first([0.1 + 0.25e-3, 0.2]);
    holds("blocked: no compliance", c_blocked == 0.0)?;
    let (c_hand, d_hand) = first([0.1 + 10.3e-3, 0.2]);
    holds("relaxed hand: 1 mm/N", (c_hand - 1e-3).abs() < 1e-5)?;
    let s = cfg.compliant_gain_scale;
    let expect = s + (1.0 - s) / (1.0 + c_hand / cfg.compliance_ref_m_per_n);
    // the P, I and D parts of a 1 N error step scale with it
    holds(
        "gains scaled",
        d_blocked > 0.0 && ((d_hand / d_blocked) - expect).abs() < 0.02,
    )?;
    // until a block is seen the gains are a hand's: a force change short of BLOCK_FORCE_N at
    // a still handle leaves them there, one beyond it gives the block's
    let mut fl = ForceLoop::new();
    holds(
        "not observed: a block",
        fl.gains_compliance_m_per_n() == 0.0,
    )?;
    fl.observe_handle(&cfg, [0.1, 0.2], [0.0; 2], dt);
    fl.observe_handle(&cfg, [0.1, 0.2], [0.9 * BLOCK_FORCE_N, 0.0], dt);
    holds(
        "undecided: a hand's gains",
        fl.compliance_m_per_n() == 0.0
            && fl.gains_compliance_m_per_n() == UNDECIDED_COMPLIANCE_M_PER_N,
    )?;
    fl.observe_handle(&cfg, [0.1, 0.2], [1.1 * BLOCK_FORCE_N, 0.0], dt);
    holds("a block seen", fl.gains_compliance_m_per_n() == 0.0)?;
    // forgotten over about a second once the handle is back where it started
    let mut fl = ForceLoop::new();
    fl.observe_handle(&cfg, [0.0; 2], [0.0; 2], dt);
    fl.observe_handle(&cfg, [10.5e-3, 0.0], [10.0, 0.0], dt);
    for _ in 0..1000 {
        fl.observe_handle(&cfg, [0.0; 2], [10.0, 0.0], dt);
    }
    holds(
        "decays",
        fl.compliance_m_per_n() < 0.4e-3 && fl.compliance_m_per_n() > 0.3e-3,
    )
}

/// Against a relaxed hand (1 mm/N) the reference is slower and does not overshoot, also when
/// the hand is recognised only mid-step, and the feed-forward keeps (almost) none of the gain
/// plane's correction, which the feedback still gets; at a block both are the design's.
pub fn a_compliant_handle_gets_a_gentler_reference_and_feed_forward() -> CheckResult {
    let cfg = ForceLoopConfig::designed();
    let model = RobotModel::<f32>::thesis();
    let ip = model.params.ip;
    let dt = 0.001;
    // model force after `n` periods of a 10 N step; the hand is seen after `seen_at`
    let reference = |seen_at: u32, n: u32| {
        let mut fl = ForceLoop::new();
        fl.observe_handle(&cfg, [0.0; 2], [0.0; 2], dt);
        let (mut peak, mut o) = (
            0.0f32,
            fl.step(&cfg, &ip, [0.0; 2], [0.0; 2], 1.0, false, dt),
        );
        for i in 0..n {
            let handle_m = if i >= seen_at { 10.3e-3 } else { 0.0 };
            fl.observe_handle(&cfg, [handle_m, 0.0], [10.0, 0.0], dt);
            o = fl.step(&cfg, &ip, [10.0, 0.0], o.model_n, 1.0, false, dt);
            peak = peak.max(o.model_n[0]);
        }
        (o.model_n[0], peak, fl, o)
    };
    let (blocked, _, fl_blocked, o_blocked) = reference(u32::MAX, 100);
    let (held, _, fl_held, o_held) = reference(0, 100);
    holds(
        "slower against a hand",
        held < 0.5 * blocked && blocked > 8.0,
    )?;
    let (_, peak, _, _) = reference(40, 1000);
    holds("recognised mid-step: no overshoot", peak <= 10.0 + 1e-3)?;
    holds(
        "the plane's share",
        fl_blocked.plane_weight(&cfg) == 1.0 && fl_held.plane_weight(&cfg) < 0.01,
    )?;
    let plane = &model.params.gain_plane;
    let alpha = POSE_RAD;
    let g = plane.gain(0, alpha);
    // at a block all of the command is divided by G; against the hand the feed-forward is not
    let (c_blocked, _) = fl_blocked.through_plane(&cfg, &o_blocked, plane, alpha);
    holds(
        "block: through the plane",
        (c_blocked[0] - o_blocked.command_n[0] / g).abs() < 1e-3,
    )?;
    let (c_held, _) = fl_held.through_plane(&cfg, &o_held, plane, alpha);
    let ff = o_held.feed_forward_n[0];
    let feedback = o_held.command_n[0] - ff;
    holds(
        "hand: feed-forward as it is, feedback through the plane",
        (c_held[0] - (ff + feedback / g)).abs() < 0.01 * ff.abs() + 1e-3 && g < 0.9,
    )
}

pub fn impedance_renders_the_spring_force_and_refuses_out_of_range() -> CheckResult {
    // the blocked plant holds the handle 2 cm left of the target: the virtual spring pulls
    // with K·2 cm, and the load cell must read it
    let model = RobotModel::<f32>::thesis();
    let x = model.kinematics.forward_user(POSE_RAD);
    let target = [x[0] + 0.02, x[1] - 0.01];
    let k = [300.0, 500.0];
    let mut plant = Plant::new(0.7);
    plant.give_rad_per_n = 1e-5;
    let mut c = armed(Mode::Impedance {
        target_user_m: target,
        stiffness_n_per_m: k,
        damping_n_s_per_m: [5.0, 5.0],
        mass_kg: [0.0, 0.0],
    });
    let r = run(&mut c, &mut plant, 2000);
    holds("no fault", r.faulted_at.is_none())?;
    holds(
        "spring force rendered",
        (r.mean_force_n[0] - 6.0).abs() < 0.1 && (r.mean_force_n[1] + 5.0).abs() < 0.1,
    )?;
    let none = [0.0, 0.0];
    for bad in [
        ([0.5, 0.0], [100.0, 100.0], [5.0, 5.0], none),
        ([0.0, 0.0], [-1.0, 100.0], [5.0, 5.0], none),
        (
            [0.0, 0.0],
            [100.0, MAX_IMPEDANCE_STIFFNESS_N_PER_M * 1.01],
            [5.0, 5.0],
            none,
        ),
        ([0.0, 0.0], [100.0, 100.0], [f32::NAN, 5.0], none),
        ([0.0, 0.0], [100.0, 100.0], [5.0, 5.0], [-0.1, 0.0]),
        (
            [0.0, 0.0],
            [100.0, 100.0],
            [5.0, 5.0],
            [0.0, MAX_IMPEDANCE_MASS_KG * 1.01],
        ),
        ([0.0, 0.0], [100.0, 100.0], [5.0, 5.0], [f32::INFINITY, 0.0]),
    ] {
        let m = Mode::Impedance {
            target_user_m: bad.0,
            stiffness_n_per_m: bad.1,
            damping_n_s_per_m: bad.2,
            mass_kg: bad.3,
        };
        holds("refused", c.set_mode(m) == Err(Reject::OutOfRange))?;
    }
    Ok(())
}

pam_model::register_checks!(
    closed_loop_reaches_the_force_the_open_loop_misses,
    a_target_beyond_the_muscles_is_scaled_in_its_direction,
    a_spring_force_beyond_the_muscles_keeps_its_direction,
    bad_gains_are_caught_by_the_guard_and_vented,
    a_force_the_plant_cannot_give_is_a_persistent_error,
    gain_scale_outside_its_range_is_refused,
    reference_rate_limit_anti_windup_and_bumpless_entry,
    a_compliant_handle_gets_gentler_gains,
    a_compliant_handle_gets_a_gentler_reference_and_feed_forward,
    impedance_renders_the_spring_force_and_refuses_out_of_range,
);
