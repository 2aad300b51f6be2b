//! The plant's static gain, measured by the closed force loop itself (issue 14).
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

use pam_model::Vec2;

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

/// The estimate and the last steady level it is measured from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantGain {
    gain: f32,
    error_filt_n: Vec2<f32>,
    steady_s: f32,
    measured: bool,
    level: Option<(Vec2<f32>, Vec2<f32>)>,
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
            return None;
        };
        let df = [f[0] - f0[0], f[1] - f0[1]];
        let du = [u[0] - u0[0], u[1] - u0[1]];
        if df[0] * df[0] + df[1] * df[1] < GAIN_LEVER_MIN_N * GAIN_LEVER_MIN_N {
            return None;
        }
        self.level = Some((f, u));
        let g = (df[0] * du[0] + df[1] * du[1]) / (du[0] * du[0] + du[1] * du[1]);
        // NaN (no command change) keeps the estimate
        if !(g > 0.0) {
            return None;
        }
        let g = g.max(PLANT_GAIN_MIN).min(PLANT_GAIN_MAX);
        let k = g / self.gain;
        self.gain = g;
        Some(k)
    }
}
