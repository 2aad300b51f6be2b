//! Tuning the closed force loop from an identified plant (`pamctl tune`).
//!
//! The plant, per Cartesian axis, as a step log shows it: g·H(s)·e^(−sτ), with
//! H(s) = ωn² / (s² + 2ζωn s + ωn²) (§5.3, fitted by `pam_ident::step`), g the static gain the
//! loop sees (from a log recorded with the same `--feed-forward` setting as the loop will
//! use) and τ a transport delay on top of the loop's own (one period of computation and half
//! a period of zero-order hold).
//!
//! The tuner keeps the designed controller's structure (`ForceLoopConfig::designed`: the
//! reference model, the converter inverse, the PID's ratios) and chooses its one free
//! number, the gain scale (the same `gain_scale` the device takes over the link), on a grid:
//! the fastest predicted 5 % settling of a 9.1 N step (§5.2's step), the worst over the
//! identified gain and that gain times [`GAIN_SPREAD`] and divided by it (the step gain moves
//! with the pose, §5.3, and with the force level where a muscle nears a limit: the
//! feed-forward is never exact, and on an exact plant the tracking alone would ask for no
//! feedback at all), with
//! - overshoot ≤ [`MAX_OVERSHOOT_PCT`] at the identified gain (above it the feed-forward
//!   alone overshoots by the gain error: the bound would reject every scale),
//! - over the band, gain margin ≥ [`MIN_GAIN_MARGIN`] and phase margin ≥ [`MIN_PHASE_MARGIN_DEG`] (linear,
//!   delay included),
//! - loop gain g·scale ≤ [`MAX_LOOP_GAIN`]: the 50 bar/s slew limit is a rate saturation
//!   that the linear margins do not see; the twin ran every §5.2 pose at g·scale = 2 and
//!   faulted six of nine at 3 (docs/closed-loop.md).
//!
//! The prediction runs `pam_control::ForceLoop` itself (f32, the device's code) against the
//! linear plant, exactly discretised, at the loop's period.

use pam_control::{ForceLoop, ForceLoopConfig};
use pam_model::params::IpConverter;
use pam_model::RobotParams;
use pam_numerics::second_order::SecondOrderStep;
use thiserror::Error;

/// Most overshoot a proposal may predict, %.
pub const MAX_OVERSHOOT_PCT: f64 = 10.0;
/// Least linear gain margin of a proposal (a factor, 6 dB).
pub const MIN_GAIN_MARGIN: f64 = 2.0;
/// Least phase margin of a proposal, degrees.
pub const MIN_PHASE_MARGIN_DEG: f64 = 45.0;
/// Largest loop gain g·scale a proposal may have (the slew limit's practical bound).
pub const MAX_LOOP_GAIN: f64 = 2.0;
/// The plant-gain uncertainty the proposal must handle: g/1.4 to 1.4·g.
pub const GAIN_SPREAD: f64 = 1.4;
/// The step the prediction simulates, N (§5.2).
pub const PREDICTED_STEP_N: f64 = 9.1;

/// One axis of the plant as identified from a step log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepPlant {
    /// Static gain from the loop's command to the measured force.
    pub gain: f64,
    pub zeta: f64,
    pub omega_n_rad_s: f64,
    /// Transport delay on top of the loop's own, s.
    pub delay_s: f64,
}

/// Linear margins of L(s) = C(s)·g·H(s)·e^(−sτ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Margins {
    /// Gain margin (a factor; infinite when the phase never reaches −180°).
    pub gain_margin: f64,
    pub phase_crossover_rad_s: f64,
    pub phase_margin_deg: f64,
    pub gain_crossover_rad_s: f64,
}

/// The predicted response to a [`PREDICTED_STEP_N`] step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// 5 % settling: the last time outside ±5 % of the step around the final value, s.
    pub settling_s: f64,
    /// Largest excursion beyond the final value over the step, %.
    pub overshoot_pct: f64,
    /// Final value over the step.
    pub gain: f64,
}

/// A proposed gain scale with its margins and predicted step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Proposal {
    pub gain_scale: f64,
    pub kp: f64,
    pub ki_per_s: f64,
    pub kd_s: f64,
    /// At the identified gain.
    pub margins: Margins,
    /// At the identified gain.
    pub prediction: Prediction,
    /// The slowest over the gain band (identified ÷ and × [`GAIN_SPREAD`]).
    pub worst_in_band: Prediction,
    /// The least gain and phase margins over the band.
    pub margins_in_band: Margins,
    /// The designed gains (scale 1) on the same plant, for comparison.
    pub designed: Prediction,
}

#[derive(Debug, Error, PartialEq)]
pub enum TuneError {
    #[error("the identified plant is not usable: {0}")]
    BadPlant(String),
    #[error("no gain scale in {lo}–{hi} meets the overshoot and margin bounds on this plant (gain {gain:.3}, delay {delay_ms:.1} ms)")]
    NoGain {
        lo: f64,
        hi: f64,
        gain: f64,
        delay_ms: f64,
    },
}

/// The gain scales tried: 0.1 to [`pam_control::MAX_GAIN_SCALE`] (what the device accepts)
/// in steps of 0.05.
fn grid() -> impl Iterator<Item = f64> {
    (2..=100)
        .map(|i| i as f64 * 0.05)
        .filter(|s| *s <= pam_control::MAX_GAIN_SCALE as f64)
}

impl StepPlant {
    fn check(&self) -> Result<(), TuneError> {
        let ok = self.gain.is_finite()
            && self.gain > 0.05
            && self.zeta.is_finite()
            && self.zeta > 0.0
            && self.omega_n_rad_s.is_finite()
            && self.omega_n_rad_s > 0.0
            && self.delay_s.is_finite()
            && self.delay_s >= 0.0;
        if ok {
            Ok(())
        } else {
            Err(TuneError::BadPlant(format!("{self:?}")))
        }
    }
}

/// The converter law the loop's feed-forward inverts: the controller's (Table 5.2).
fn controller_ip() -> IpConverter<f32> {
    RobotParams::<f32>::thesis().ip
}

/// Margins of the designed loop scaled by `gain_scale` on `plant` at `period_s`.
pub fn margins(
    cfg: &ForceLoopConfig,
    gain_scale: f64,
    plant: &StepPlant,
    period_s: f64,
) -> Margins {
    let (kp, ki, kd, wf) = (
        cfg.kp as f64 * gain_scale,
        cfg.ki_per_s as f64 * gain_scale,
        cfg.kd_s as f64 * gain_scale,
        cfg.derivative_filter_rad_s as f64,
    );
    let (wn, zeta, g) = (plant.omega_n_rad_s, plant.zeta, plant.gain);
    let tau = 1.5 * period_s + plant.delay_s;
    // L(jω) in polar form: |L|, arg L (unwrapped by construction: each factor's phase is
    // continuous in ω)
    let l = |w: f64| {
        let h_re = wn * wn - w * w;
        let h_im = 2.0 * zeta * wn * w;
        let h_mag = wn * wn / h_re.hypot(h_im);
        let h_ph = -h_im.atan2(h_re);
        // C = kp + ki/(jω) + kd·wf·jω/(jω + wf)
        let d_den = wf * wf + w * w;
        let c_re = kp + kd * wf * w * w / d_den;
        let c_im = -ki / w + kd * wf * wf * w / d_den;
        let c_mag = c_re.hypot(c_im);
        let c_ph = c_im.atan2(c_re);
        (g * h_mag * c_mag, h_ph + c_ph - w * tau)
    };
    let pi = std::f64::consts::PI;
    let mut m = Margins {
        gain_margin: f64::INFINITY,
        phase_crossover_rad_s: f64::NAN,
        phase_margin_deg: f64::NAN,
        gain_crossover_rad_s: f64::NAN,
    };
    let n = 20_000;
    let w_at = |i: usize| 0.01 * (1e6f64).powf(i as f64 / n as f64);
    let (mut prev_mag, mut prev_ph) = l(w_at(0));
    for i in 1..=n {
        let w = w_at(i);
        let (mag, ph) = l(w);
        if prev_ph > -pi && ph <= -pi && m.gain_margin.is_infinite() {
            m.gain_margin = 1.0 / mag;
            m.phase_crossover_rad_s = w;
        }
        if prev_mag > 1.0 && mag <= 1.0 && m.gain_crossover_rad_s.is_nan() {
            m.gain_crossover_rad_s = w;
            m.phase_margin_deg = (ph + pi).to_degrees();
        }
        prev_mag = mag;
        prev_ph = ph;
    }
    m
}

/// The designed loop scaled by `gain_scale` on `plant`, stepped by [`PREDICTED_STEP_N`]
/// from rest, simulated for 1.5 s (§5.2's hold) at `period_s`.
pub fn predict(
    cfg: &ForceLoopConfig,
    gain_scale: f64,
    plant: &StepPlant,
    period_s: f64,
) -> Prediction {
    let ip = controller_ip();
    let dt = period_s;
    let n = (1.5 / dt).round() as usize;
    let delay_n = (plant.delay_s / dt).round() as usize;
    let (wn, zeta) = (plant.omega_n_rad_s, plant.zeta);
    // exact discretisation of y'' + 2ζωn y' + ωn² y = ωn² g u over one period (ZOH)
    let phi = SecondOrderStep::new(wn, zeta, dt);
    let mut lp = ForceLoop::new();
    let (mut y, mut yd) = (0.0f64, 0.0f64);
    let mut queue = std::collections::VecDeque::from(vec![0.0f64; delay_n]);
    let mut ys = Vec::with_capacity(n);
    for _ in 0..n {
        ys.push(y);
        let out = lp.step(
            cfg,
            &ip,
            [PREDICTED_STEP_N as f32, 0.0],
            [y as f32, 0.0],
            gain_scale as f32,
            false,
            dt as f32,
        );
        queue.push_back(out.command_n[0] as f64);
        let u = queue.pop_front().unwrap_or(0.0);
        let target = plant.gain * u;
        let e = y - target;
        let (ne, nyd) = phi.step(e, yd);
        yd = nyd;
        y = ne + target;
    }
    let fin = ys[n - n / 5..].iter().sum::<f64>() / (n / 5) as f64;
    let band = 0.05 * PREDICTED_STEP_N;
    let last_out = ys.iter().rposition(|v| (v - fin).abs() > band);
    let peak = ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    Prediction {
        settling_s: last_out.map_or(0.0, |i| (i + 1) as f64 * dt),
        overshoot_pct: ((peak - fin) / fin.abs().max(1e-9) * 100.0).max(0.0),
        gain: fin / PREDICTED_STEP_N,
    }
}

/// The fastest gain scale within the bounds of the module's documentation.
pub fn propose(plant: &StepPlant, period_s: f64) -> Result<Proposal, TuneError> {
    plant.check()?;
    if !(period_s.is_finite() && period_s > 0.0 && period_s <= 0.01) {
        return Err(TuneError::BadPlant(format!(
            "loop period {period_s} s outside (0, 10 ms]"
        )));
    }
    let cfg = ForceLoopConfig::designed();
    let band = [1.0 / GAIN_SPREAD, 1.0, GAIN_SPREAD].map(|f| StepPlant {
        gain: plant.gain * f,
        ..*plant
    });
    let mut best: Option<Proposal> = None;
    for s in grid() {
        if plant.gain * s > MAX_LOOP_GAIN + 1e-9 {
            break;
        }
        let ms = band.map(|p| margins(&cfg, s, &p, period_s));
        let least = Margins {
            gain_margin: ms
                .iter()
                .map(|m| m.gain_margin)
                .fold(f64::INFINITY, f64::min),
            phase_margin_deg: ms
                .iter()
                .map(|m| m.phase_margin_deg)
                .fold(f64::INFINITY, f64::min),
            ..ms[2]
        };
        if !(least.gain_margin >= MIN_GAIN_MARGIN && least.phase_margin_deg >= MIN_PHASE_MARGIN_DEG)
        {
            continue;
        }
        let ps = band.map(|p| predict(&cfg, s, &p, period_s));
        if ps[1].overshoot_pct > MAX_OVERSHOOT_PCT || ps.iter().any(|p| (p.gain - 1.0).abs() > 0.01)
        {
            continue;
        }
        let worst = *ps
            .iter()
            .max_by(|a, b| a.settling_s.total_cmp(&b.settling_s))
            .expect("three plants");
        if best.is_none_or(|b| worst.settling_s < b.worst_in_band.settling_s - 1e-9) {
            best = Some(Proposal {
                gain_scale: s,
                kp: cfg.kp as f64 * s,
                ki_per_s: cfg.ki_per_s as f64 * s,
                kd_s: cfg.kd_s as f64 * s,
                margins: ms[1],
                prediction: ps[1],
                worst_in_band: worst,
                margins_in_band: least,
                designed: predict(&cfg, 1.0, plant, period_s),
            });
        }
    }
    best.ok_or(TuneError::NoGain {
        lo: 0.1,
        hi: 5.0,
        gain: plant.gain,
        delay_ms: plant.delay_s * 1e3,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table_5_2(gain: f64) -> StepPlant {
        StepPlant {
            gain,
            zeta: 0.42,
            omega_n_rad_s: 23.04,
            delay_s: 0.0,
        }
    }

    /// The margins agree with docs/closed-loop.md's table (from the example's finer sweep).
    #[test]
    fn margins_of_the_design_match_the_documented_ones() {
        let cfg = ForceLoopConfig::designed();
        let m = margins(&cfg, 1.0, &table_5_2(1.0), 0.001);
        assert!((m.gain_margin - 17.1).abs() < 0.3, "{m:?}");
        assert!((m.phase_margin_deg - 62.0).abs() < 1.0, "{m:?}");
        let slow = margins(
            &cfg,
            1.0,
            &StepPlant {
                delay_s: 0.040,
                ..table_5_2(1.0)
            },
            0.001,
        );
        assert!(
            slow.gain_margin < 1.0,
            "41.5 ms is unstable at the design: {slow:?}"
        );
    }

    /// A weaker plant gets a larger scale, a delayed one a smaller one, and every proposal
    /// meets its bounds; a plant no scale can handle is an error.
    #[test]
    fn proposals_follow_the_plant_and_keep_their_bounds() {
        let base = propose(&table_5_2(1.0), 0.001).unwrap();
        let weak = propose(&table_5_2(0.57), 0.001).unwrap();
        let delayed = propose(
            &StepPlant {
                delay_s: 0.01,
                ..table_5_2(1.0)
            },
            0.001,
        )
        .unwrap();
        assert!(weak.gain_scale > base.gain_scale, "{weak:?} {base:?}");
        assert!(delayed.gain_scale < base.gain_scale, "{delayed:?} {base:?}");
        for p in [base, weak, delayed] {
            assert!(p.prediction.overshoot_pct <= MAX_OVERSHOOT_PCT);
            assert!(p.margins_in_band.gain_margin >= MIN_GAIN_MARGIN);
            assert!(p.margins_in_band.phase_margin_deg >= MIN_PHASE_MARGIN_DEG);
            assert!(p.worst_in_band.settling_s >= p.prediction.settling_s);
        }
        assert!(matches!(
            propose(
                &StepPlant {
                    delay_s: 0.3,
                    ..table_5_2(1.0)
                },
                0.001
            ),
            Err(TuneError::NoGain { .. })
        ));
        assert!(matches!(
            propose(&table_5_2(f64::NAN), 0.001),
            Err(TuneError::BadPlant(_))
        ));
    }
}
