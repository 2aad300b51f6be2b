//! The plant's static gain, measured by the closed force loop itself.
//!
//! The loop is designed for a plant g·H(s) with g = 1 (the model) and checked over
//! g = 0.43–1.75 (docs/closed-loop.md, "Design from the identified plant"); away from 1 its
//! crossover moves with g, and at the identified rig's 0.57 (Table 5.2) its slowest pole falls
//! from −26 to −11 /s: the integral then supplies the missing 43 % of every step at that rate.
//! The gain plane (eq. 5.2) corrects g with a table identified offline; this measures it in
//! place from what the loop already knows at a steady level: the force is the reference (the
//! integral made it so) and the command's steady share is the feed-forward plus the integral.
//! Between two steady levels at least [`GAIN_LEVER_MIN_N`] apart, g = ΔF·Δu / |Δu|² (both
//! axes, least squares: the 0.57 is the muscles', common to both), and the loop divides its
//! command by it, as the plane does — the loop gain is the design's again. Incremental, so an
//! offset the integral holds (a preload, a load-cell zero) is not mistaken for gain.

use pam_model::{Real, Vec2};

/// Range of the estimate: a factor 2 either way around the model, the practical gain margin
/// of the design (×2 still works at every pose, ×3 does not: docs/closed-loop.md, "Margins").
pub const PLANT_GAIN_MIN: f32 = 0.5;
pub const PLANT_GAIN_MAX: f32 = 2.0;
/// Least change of the steady force between two levels that is measured, N (the load cell's
/// noise is 0.15 N; a 4 N lever measures g to about 1 %).
pub const GAIN_LEVER_MIN_N: f32 = 4.0;
/// How long the level must be steady before it is measured, s: past the reference model's
/// settling (0.12–0.15 s) and the rig's slowest pole (−11 /s, 5 % in 0.27 s).
pub const STEADY_S: f32 = 0.3;
/// Largest filtered error (per axis) and model-to-reference distance of a steady level, N.
pub const STEADY_ERROR_N: f32 = 0.2;
/// Bandwidth of the error filter that decides "steady", rad/s (the noise's 0.15 N falls to
/// about 0.01 N).
pub const STEADY_FILTER_RAD_S: f32 = 10.0;

/// Within a step: the least change of the nominal plant's force since the last level over
/// which the measured one is divided, N (as `COMPLIANCE_FORCE_MIN_N`).
pub const RATIO_LEVER_MIN_N: f32 = 2.0;
/// Within a step: how long the ratio of the measured force's change to the nominal plant's
/// (H of the loop's own command) must hold still before it is taken as the gain, s.
pub const RATIO_HOLD_S: f32 = 0.04;
/// How still: the ratio's spread over that time, relative. A plant that is g·H keeps the
/// ratio at g from the first newton; one that is not (flow-limited converters, a delay, a
/// hand) moves it, and is left to the steady levels.
pub const RATIO_SPREAD: f32 = 0.1;
/// Bandwidth of the ratio's filter, rad/s (the noise's share of the ratio, 0.15 N over the
/// lever, falls below 1 %).
pub const RATIO_FILTER_RAD_S: f32 = 40.0;

/// The estimate and the last steady level it is measured from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantGain {
    gain: f32,
    error_filt_n: Vec2<f32>,
    steady_s: f32,
    measured: bool,
    level: Option<(Vec2<f32>, Vec2<f32>)>,
    /// the nominal plant's response H·u to the command sent, and its rate
    nominal_n: Vec2<f32>,
    nominal_rate_n_s: Vec2<f32>,
    nominal_started: bool,
    /// the nominal response at the last level
    nominal_level_n: Vec2<f32>,
    ratio: f32,
    ratio_min: f32,
    ratio_max: f32,
    /// the gain before this step's ratio was taken (restored if the ratio then moves)
    gain_before: f32,
    ratio_s: f32,
    ratio_done: bool,
    /// this step's force followed the nominal plant at a steady ratio: a plant g·H
    follows: bool,
    /// the reference left a measured level and has not reached the next one
    stepping: bool,
}

impl Default for PlantGain {
    fn default() -> Self {
        Self::new()
    }
}

impl PlantGain {
    pub const fn new() -> Self {
        PlantGain {
            gain: 1.0,
            error_filt_n: [0.0; 2],
            steady_s: 0.0,
            measured: false,
            level: None,
            nominal_n: [0.0; 2],
            nominal_rate_n_s: [0.0; 2],
            nominal_started: false,
            nominal_level_n: [0.0; 2],
            ratio: 0.0,
            ratio_min: 0.0,
            ratio_max: 0.0,
            gain_before: 1.0,
            ratio_s: 0.0,
            ratio_done: false,
            follows: false,
            stepping: false,
        }
    }

    /// The plant's static gain as last measured (1 until a second steady level).
    pub fn gain(&self) -> f32 {
        self.gain
    }

    /// One period. `force_n`: the reference model's force; `integral_n`: the loop's integral
    /// (before the division by the gain); `error_n`: model − measured; `settled`: the
    /// reference is at its target, nothing clamped the command, the handle is blocked.
    /// Returns the factor the integral must be multiplied by around the model's force,
    /// (m + I)·k − m, so that the command stays where it was (bumpless), if the gain changed.
    pub fn observe(
        &mut self,
        force_n: Vec2<f32>,
        reference_n: Vec2<f32>,
        integral_n: Vec2<f32>,
        error_n: Vec2<f32>,
        settled: bool,
        dt_s: f32,
    ) -> Option<f32> {
        let wf = STEADY_FILTER_RAD_S * dt_s;
        let a = wf / (1.0 + wf);
        let mut steady = settled;
        for i in 0..2 {
            self.error_filt_n[i] += a * (error_n[i] - self.error_filt_n[i]);
            steady &= self.error_filt_n[i].abs() < STEADY_ERROR_N
                && (reference_n[i] - force_n[i]).abs() < STEADY_ERROR_N;
        }
        if !steady {
            self.steady_s = 0.0;
            self.measured = false;
            return None;
        }
        self.steady_s += dt_s;
        self.stepping = false;
        self.ratio_s = 0.0;
        self.ratio_done = false;
        self.follows = false;
        if self.measured || self.steady_s < STEADY_S {
            return None;
        }
        self.measured = true;
        // the level: the force reached (the reference), the command that holds it
        let f = reference_n;
        let u = [
            (force_n[0] + integral_n[0]) / self.gain,
            (force_n[1] + integral_n[1]) / self.gain,
        ];
        let Some((f0, u0)) = self.level else {
            self.level = Some((f, u));
            self.nominal_level_n = self.nominal_n;
            return None;
        };
        let df = [f[0] - f0[0], f[1] - f0[1]];
        let du = [u[0] - u0[0], u[1] - u0[1]];
        if df[0] * df[0] + df[1] * df[1] < GAIN_LEVER_MIN_N * GAIN_LEVER_MIN_N {
            return None;
        }
        self.level = Some((f, u));
        self.nominal_level_n = self.nominal_n;
        let g = (df[0] * du[0] + df[1] * du[1]) / (du[0] * du[0] + du[1] * du[1]);
        // NaN (no command change) keeps the estimate
        if !(g > 0.0) {
            return None;
        }
        let g = g.clamp_to(PLANT_GAIN_MIN, PLANT_GAIN_MAX);
        let k = g / self.gain;
        self.gain = g;
        Some(k)
    }

    /// Within a step, at a block: the measured force's change since the last level against
    /// the nominal plant's (H of the commands sent, [`PlantGain::drive`]). Where their ratio
    /// holds still for [`RATIO_HOLD_S`] it is the gain (a plant g·H). `[m, i]`: the model's
    /// force and the integral. Returns the new integral if the gain changed by more than
    /// half the spread: a weaker plant keeps the command, (m + I)/g, where it was (the
    /// higher loop gain raises it); a stronger one gets at once the command that holds the
    /// force, u₀ + (m − F₀)/g, the integral g·u₀ − F₀ — the command never jumps up.
    pub fn track(
        &mut self,
        measured_n: Vec2<f32>,
        [m, i]: [Vec2<f32>; 2],
        blocked: bool,
        dt_s: f32,
    ) -> Option<Vec2<f32>> {
        let (f0, _) = self.level?;
        if !blocked {
            // clamped or held: not the plant g·H, this step
            self.ratio_done = true;
        }
        if self.ratio_done || self.steady_s > 0.0 {
            return None;
        }
        let dy = [
            self.nominal_n[0] - self.nominal_level_n[0],
            self.nominal_n[1] - self.nominal_level_n[1],
        ];
        let dy_sq = dy[0] * dy[0] + dy[1] * dy[1];
        if dy_sq < RATIO_LEVER_MIN_N * RATIO_LEVER_MIN_N {
            self.ratio_s = 0.0;
            return None;
        }
        let df = [measured_n[0] - f0[0], measured_n[1] - f0[1]];
        let r = (df[0] * dy[0] + df[1] * dy[1]) / dy_sq;
        if self.ratio_s == 0.0 {
            self.ratio = r;
        }
        let wf = RATIO_FILTER_RAD_S * dt_s;
        self.ratio += wf / (1.0 + wf) * (r - self.ratio);
        self.ratio_s += dt_s;
        // the filter's own transient is not spread
        if self.ratio_s < 1.0 / RATIO_FILTER_RAD_S {
            self.ratio_min = self.ratio;
            self.ratio_max = self.ratio;
            return None;
        }
        // watched for as long again after it was taken, then left to the level
        if self.ratio_s > 2.0 * RATIO_HOLD_S + 1.0 / RATIO_FILTER_RAD_S {
            self.ratio_done = true;
            return None;
        }
        self.ratio_min = self.ratio_min.min(self.ratio);
        self.ratio_max = self.ratio_max.max(self.ratio);
        // once taken, only a ratio that moves by twice the spread undoes it (the taut-cable
        // inverse's floor bends the rig's ratio by about the spread within a step)
        let spread = if self.follows { 2.0 } else { 1.0 } * RATIO_SPREAD;
        if self.ratio_max - self.ratio_min > spread * self.ratio_max.abs() {
            // not a plant g·H: wait for the level; if it looked like one at first (a ramp
            // of flow-limited converters can, for a while), the gain taken from it goes
            self.ratio_done = true;
            let taken = self.follows && self.gain != self.gain_before;
            self.follows = false;
            if !taken {
                return None;
            }
            let k = self.gain_before / self.gain;
            self.gain = self.gain_before;
            return Some(Self::bumpless_integral(m, i, k));
        }
        if self.follows || self.ratio_s < RATIO_HOLD_S + 1.0 / RATIO_FILTER_RAD_S {
            return None;
        }
        if !(PLANT_GAIN_MIN..=PLANT_GAIN_MAX).contains(&self.ratio) {
            // outside the range the design covers: not taken within a step (a slow plant's
            // ramp starts low), the level decides
            self.ratio_done = true;
            return None;
        }
        self.follows = true;
        self.gain_before = self.gain;
        // within the range (checked above)
        let g = self.ratio;
        if (g - self.gain).abs() < 0.5 * RATIO_SPREAD * self.gain {
            return None;
        }
        let k = g / self.gain;
        self.gain = g;
        if k < 1.0 {
            // a weaker plant: the command stays (bumpless), the raised gain brings it up
            return Some(Self::bumpless_integral(m, i, k));
        }
        // a stronger plant: at once the command that holds the force at this gain, the
        // level's plus the step's change (what it has in excess would go into the handle)
        let u0 = self.level.map(|l| l.1).unwrap_or([0.0; 2]);
        Some([g * u0[0] - f0[0], g * u0[1] - f0[1]])
    }

    /// The integral that keeps the command where it was when the gain changes by `k`:
    /// the command is (m + I)/g, so (m + I')/(k·g) = (m + I)/g gives I' = (m + I)·k − m.
    pub fn bumpless_integral(model_n: Vec2<f32>, integral_n: Vec2<f32>, k: f32) -> Vec2<f32> {
        [
            (model_n[0] + integral_n[0]) * k - model_n[0],
            (model_n[1] + integral_n[1]) * k - model_n[1],
        ]
    }

    /// Advances the nominal plant H (the converters' identified second order, Table 5.2) by
    /// the command sent this period (after the division by the gain), N.
    pub fn drive(&mut self, command_n: Vec2<f32>, wn_rad_s: f32, zeta: f32, dt_s: f32) {
        if !self.nominal_started {
            self.nominal_n = command_n;
            self.nominal_started = true;
        }
        for i in 0..2 {
            let acc = wn_rad_s * wn_rad_s * (command_n[i] - self.nominal_n[i])
                - 2.0 * zeta * wn_rad_s * self.nominal_rate_n_s[i];
            self.nominal_rate_n_s[i] += acc * dt_s;
            self.nominal_n[i] += self.nominal_rate_n_s[i] * dt_s;
        }
    }

    /// The reference moved (a new target); a step from a measured level begins.
    pub fn begin_step(&mut self) {
        self.stepping = self.level.is_some();
    }

    /// Between a measured level and the next steady one, the step's force not (yet) known to
    /// follow the nominal plant g·H: whether it closes the error by itself is the plant's
    /// doing, not the loop's (the integral waits while it does).
    pub fn undecided_step(&self) -> bool {
        self.stepping && !self.follows
    }

    /// This step's force followed the nominal plant at a steady ratio (a plant g·H), until
    /// the next level: what closes the error is then the loop's own doing.
    pub fn follows(&self) -> bool {
        self.follows
    }
}

#[cfg(test)]
mod tests {
    use crate::{ForceLoop, ForceLoopConfig};
    use pam_model::RobotModel;

    /// A blocked handle behind converters H (Table 5.2) and a static gain `g`, one period of
    /// delay; `rate_n_s` bounds how fast the force can follow its command (a flow limit).
    /// Steps 0 → 9.1 N after a second at 0; returns the measured gain after the step's first
    /// 0.2 s and after 1 s, and the integral's peak.
    fn run(g: f32, rate_n_s: f32) -> (f32, f32, f32) {
        let cfg = ForceLoopConfig::designed();
        let ip = RobotModel::<f32>::thesis().params.ip;
        let (wn, z) = (ip.natural_freq_rad_s, ip.damping_ratio);
        let dt = 0.001;
        let mut fl = ForceLoop::new();
        let (mut x, mut v, mut u_prev) = (0.0f32, 0.0f32, 0.0f32);
        let (mut g_early, mut peak) = (0.0, 0.0f32);
        for k in 0..2000 {
            let target = if k < 1000 { 0.0 } else { 9.1 };
            let o = fl.step(&cfg, &ip, [target, 0.0], [g * x, 0.0], 1.0, false, dt);
            // the converters, their output rate-limited
            let acc = wn * wn * (u_prev - x) - 2.0 * z * wn * v;
            v = (v + acc * dt).clamp(-rate_n_s, rate_n_s);
            x += v * dt;
            u_prev = o.command_n[0];
            if k == 1200 {
                g_early = fl.plant_gain();
            }
            if k >= 1000 {
                peak = peak.max(fl.integral_n()[0].abs());
            }
        }
        (g_early, fl.plant_gain(), peak)
    }

    #[test]
    fn a_weaker_plant_is_measured_within_the_first_step() {
        let (early, late, _) = run(0.57, f32::INFINITY);
        assert!((early - 0.57).abs() < 0.03, "within the step: {early}");
        assert!((late - 0.57).abs() < 0.01, "at the level: {late}");
        let (early, late, _) = run(1.0, f32::INFINITY);
        assert!(early == 1.0 && (late - 1.0).abs() < 0.01, "{early} {late}");
        let (_, late, _) = run(1.75, f32::INFINITY);
        assert!((late - 1.75).abs() < 0.02, "at the level: {late}");
    }

    #[test]
    fn a_flow_limited_plant_is_not_taken_for_a_weaker_one_nor_winds_the_integral_up() {
        let (early, late, peak) = run(1.0, 40.0);
        assert!(early == 1.0, "within the step: {early}");
        assert!((late - 1.0).abs() < 0.02, "at the level: {late}");
        // 10.9 N without the wait (a step of 9.1 N)
        assert!(peak < 2.0, "integral peak {peak} N");
    }
}
