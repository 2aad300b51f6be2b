//! The model loop's model of a force-step trial (§5.3), built where the rig's effects act.
//!
//! The logged I/P currents give each converter's set-point through the converter law (eq.
//! 2.2). Each converter regulates its muscle's pressure as the second order of Table 5.2
//! (one ζ, ωn for all four), and the handle force at the blocked handle is the model's
//! muscle forces (eq. 3.1, linear in pressure at a fixed pose) through the pulleys (eq. 3.2)
//! and J⁻ᵀ, times a gain per axis (≈ 1 when the model's force law is right). The catalog's
//! step effects then have the rig's units: a transport delay of the set-points (s), fill
//! times of flow-limited converters over Table 5.1's 0 ↔ 5 bar (s), a saturation knee and
//! maximum of the delivered pressure (bar).
//!
//! A log without currents has only the force reference: it then drives two channels in
//! newtons (the thesis's own second-order fit, §5.3), and the same effects come out in N/s
//! and N.

use pam_ident::trial::Prepared;
use pam_model::RobotModel;

mod fit;
mod grid;
mod params;
mod simulate;
mod starts;
#[cfg(test)]
mod tests;

pub use fit::fit;
pub use params::{extra_param_count, Response};
pub use simulate::simulate;

/// Pressure span of Table 5.1's fill times (full inflation 0 → 5 bar, deflation 5 → 0).
pub const FILL_SPAN_BAR: f64 = 5.0;

/// What an effect adds to the step-trial model (the base ζ, ωn and gains are always free).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepExtra {
    Delay,
    SlewRate,
    /// The same rise and fall limits on the set-points themselves (the command slews
    /// before the converters), not on the converters' flow.
    CommandSlew,
    Saturation,
    /// The handle force's magnitude saturates (knee and maximum in N of the measured force).
    ForceSaturation,
    /// One channel (a converter, or a force axis without currents) cannot deliver more
    /// than a cap: its set-points above it are compressed (which channel: a grid).
    ChannelCap,
    /// The handle force slews at limited rates (N/s, up and down), whatever the drive.
    ForceSlew,
    PoseGain,
    Hysteresis,
    /// Each channel's force loses a share of its level in the direction its level last
    /// moved: a muscle's hysteresis grows with its pressure (the braid's friction).
    ChannelHysteresis,
    Drift,
}

/// Integration step of the converters: a set-point is held over a whole sample, so a
/// 50 ms log is integrated in 2 ms steps and a 1 kHz log in 1 ms steps.
const MAX_SUBSTEP_S: f64 = 0.002;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Units {
    /// Four converter channels, set-points in bar.
    Pressure,
    /// Two force channels (x, y), set-points in N.
    Force,
}

/// What drives a step trial, computed once per trial.
#[derive(Clone, Debug)]
pub struct Drive {
    pub units: Units,
    /// Set-point of each channel at each sample, held over the sample.
    pub set: Vec<[f64; 4]>,
    /// Handle force per unit of each channel's force at each sample:
    /// f_a = Σ_k coeff[a][k]·F_k(x_k).
    pub coeff: Vec<[[f64; 4]; 2]>,
    /// The muscle force law per channel at each sample, F_k = max(0, A·x_k + B) (eq. 3.1;
    /// a cable cannot push). `None` for force channels, F_k = x_k.
    pub force_law: Option<Vec<[[f64; 2]; 4]>>,
    /// Sign of the last change of each axis's force reference (−1, 0, 1) at each sample.
    pub direction: [Vec<f64>; 2],
    pub dt_s: f64,
    /// The interval from each sample to the next (s) when the log's sampling is uneven (a
    /// loop with jitter, lost frames): the simulation then steps each interval as it was.
    /// `None` for an even log, which is stepped at `dt_s`.
    pub intervals_s: Option<Vec<f64>>,
    /// The converters' ζ and ωn of the robot's parameters (Table 5.2): a starting point.
    pub prior_zeta_omega: (f64, f64),
    /// The converters' own lag, a dead time the base may carry (s): a fit of a delay
    /// explores from there. 0 until the model loop sets it.
    pub own_lag_s: f64,
}

impl Drive {
    /// The converters' set-points from the logged currents, or — without currents, or when
    /// the currents do not follow the reference (correlation < 0.5 on an axis that steps) —
    /// the force reference itself. `None` without a force reference.
    pub fn new(p: &Prepared, model: &RobotModel<f64>) -> Option<Drive> {
        let direction = Self::directions(p)?;
        if let Some(d) = Self::from_currents(p, model, direction.clone()) {
            return Some(d);
        }
        Self::from_reference(p, model, direction)
    }

    /// Both views a step trial allows: the converters' set-points from the currents (when
    /// they follow the reference) and the reference itself. The model loop fits its base
    /// with each and keeps the one the data prefers.
    pub fn candidates(p: &Prepared, model: &RobotModel<f64>) -> Vec<Drive> {
        let Some(direction) = Self::directions(p) else {
            return Vec::new();
        };
        let mut v = Vec::new();
        if let Some(d) = Self::from_currents(p, model, direction.clone()) {
            v.push(d);
        }
        v.extend(Self::from_reference(p, model, direction));
        v
    }

    /// Sign of the last change of each axis's reference at each sample.
    fn directions(p: &Prepared) -> Option<[Vec<f64>; 2]> {
        let reference = p.force_ref_n.as_ref()?;
        Some([0, 1].map(|a| {
            let r = &reference[a];
            let mut d = 0.0;
            let mut out = Vec::with_capacity(r.len());
            for i in 0..r.len() {
                if i > 0 && (r[i] - r[i - 1]).abs() > 1e-9 {
                    d = (r[i] - r[i - 1]).signum();
                }
                out.push(d);
            }
            out
        }))
    }

    /// Two force channels driven by the reference (the thesis's own view in §5.3).
    fn from_reference(
        p: &Prepared,
        model: &RobotModel<f64>,
        direction: [Vec<f64>; 2],
    ) -> Option<Drive> {
        let reference = p.force_ref_n.as_ref()?;
        let n = p.len();
        Some(Drive {
            units: Units::Force,
            set: (0..n)
                .map(|i| [reference[0][i], reference[1][i], 0.0, 0.0])
                .collect(),
            coeff: vec![[[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]; n],
            force_law: None,
            direction,
            dt_s: p.dt_s,
            intervals_s: uneven_intervals(&p.t_s, p.dt_s),
            prior_zeta_omega: prior(model),
            own_lag_s: 0.0,
        })
    }

    fn from_currents(
        p: &Prepared,
        model: &RobotModel<f64>,
        direction: [Vec<f64>; 2],
    ) -> Option<Drive> {
        let cur = p.current_ma.as_ref()?;
        let n = p.len();
        let (mut set, mut coeff, mut law) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        let mut commanded = [Vec::with_capacity(n), Vec::with_capacity(n)];
        for i in 0..n {
            let s = [0, 1, 2, 3].map(|c| model.params.ip.pressure_bar(cur[c][i]));
            let alpha = [p.alpha_rad[0][i], p.alpha_rad[1][i]];
            let jinv_t = model.kinematics.jacobian(alpha).transpose().inverse()?.0;
            // joint torque per newton of each channel's muscle, τ = R (F2 − F1) (eq. 3.2)
            let mut dtau = [[0.0; 4]; 2];
            let mut ab = [[0.0; 2]; 4];
            for (j, dt) in dtau.iter_mut().enumerate() {
                let pose = model.pose(j, alpha[j]);
                let r = model.params.joints[j].pulley_radius_m;
                let map = model.params.joints[j].channel_of_muscle;
                for m in 0..2 {
                    let k = (map[m] & 3) as usize;
                    dt[k] = if m == 0 { -r } else { r };
                    ab[k] = [pose.muscles[m].a_n_per_bar, pose.muscles[m].b_n];
                }
            }
            let mut c = [[0.0; 4]; 2];
            for a in 0..2 {
                for k in 0..4 {
                    c[a][k] = jinv_t[a][0] * dtau[0][k] + jinv_t[a][1] * dtau[1][k];
                }
                commanded[a].push(
                    (0..4)
                        .map(|k| c[a][k] * (ab[k][0] * s[k] + ab[k][1]).max(0.0))
                        .sum::<f64>(),
                );
            }
            set.push(s);
            coeff.push(c);
            law.push(ab);
        }
        let reference = p.force_ref_n.as_ref()?;
        for a in 0..2 {
            if pam_numerics::stats::std_dev(&reference[a]) > 1e-9
                && !(pam_numerics::stats::correlation(&reference[a], &commanded[a]) > 0.5)
            {
                return None;
            }
        }
        Some(Drive {
            units: Units::Pressure,
            set,
            coeff,
            force_law: Some(law),
            direction,
            dt_s: p.dt_s,
            intervals_s: uneven_intervals(&p.t_s, p.dt_s),
            prior_zeta_omega: prior(model),
            own_lag_s: 0.0,
        })
    }

    /// A channel's set-point scale in the simulation: force channels carry the measured
    /// force's gain (their rate limits and saturation are in measured newtons), converter
    /// channels are bar.
    pub(super) fn channel_scale(&self, r: &Response, c: usize) -> f64 {
        match self.units {
            Units::Force => r.gain[c],
            Units::Pressure => 1.0,
        }
    }

    /// Four converters, or two force channels.
    pub fn channels(&self) -> usize {
        match self.units {
            Units::Pressure => 4,
            Units::Force => 2,
        }
    }

    /// The handle force at sample `i` with the channels at `x`.
    #[inline]
    fn handle_force(&self, i: usize, axis: usize, x: &[f64; 4]) -> f64 {
        self.axis_force(i, axis, &self.channel_forces(i, x))
    }

    /// Each channel's force at sample `i` with the channels at `x` (F_k of [`Drive::coeff`]);
    /// `K` the drive's channel count (or more, the rest unused).
    #[inline]
    pub(super) fn channel_forces<const K: usize>(&self, i: usize, x: &[f64; K]) -> [f64; K] {
        match &self.force_law {
            Some(law) => {
                let l = &law[i];
                std::array::from_fn(|k| (l[k][0] * x[k] + l[k][1]).max(0.0))
            }
            None => *x,
        }
    }

    /// Axis `axis`'s handle force from the channels' forces at sample `i`. Force channels
    /// are the axes themselves (their coefficients are the identity).
    #[inline]
    pub(super) fn axis_force<const K: usize>(&self, i: usize, axis: usize, f: &[f64; K]) -> f64 {
        match self.units {
            Units::Force => f[axis],
            Units::Pressure => {
                let c = &self.coeff[i][axis];
                (0..self.channels().min(K)).map(|k| c[k] * f[k]).sum()
            }
        }
    }

    /// The handle force the set-points command (the response's steady state at gain 1).
    pub fn commanded(&self, axis: usize) -> Vec<f64> {
        (0..self.set.len())
            .map(|i| self.handle_force(i, axis, &self.set[i]))
            .collect()
    }
}

/// Each sample's interval to the next (the last repeats the one before), when the sampling
/// is uneven ([`pam_numerics::interp::is_uneven`]).
pub(crate) fn uneven_intervals(t_s: &[f64], dt_s: f64) -> Option<Vec<f64>> {
    if t_s.len() < 2 || !pam_numerics::interp::is_uneven(t_s, dt_s) {
        return None;
    }
    let mut h: Vec<f64> = t_s.windows(2).map(|w| w[1] - w[0]).collect();
    h.push(*h.last().expect("two samples or more"));
    Some(h)
}

fn prior(model: &RobotModel<f64>) -> (f64, f64) {
    let ip = &model.params.ip;
    (ip.damping_ratio, ip.natural_freq_rad_s)
}
