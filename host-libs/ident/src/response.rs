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

use crate::lm;
use crate::trial::Prepared;
use pam_model::RobotModel;

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
    PoseGain,
    Hysteresis,
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
    /// The converters' ζ and ωn of the robot's parameters (Table 5.2): a starting point.
    pub prior_zeta_omega: (f64, f64),
}

impl Drive {
    /// The converters' set-points from the logged currents, or — without currents, or when
    /// the currents do not follow the reference (correlation < 0.5 on an axis that steps) —
    /// the force reference itself. `None` without a force reference.
    pub fn new(p: &Prepared, model: &RobotModel<f64>) -> Option<Drive> {
        let reference = p.force_ref_n.as_ref()?;
        let direction = [0, 1].map(|a| {
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
        });
        if let Some(d) = Self::from_currents(p, model, direction.clone()) {
            return Some(d);
        }
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
            prior_zeta_omega: prior(model),
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
            if crate::trial::std_dev(&reference[a]) > 1e-9
                && !(crate::diagnose::correlation(&reference[a], &commanded[a]) > 0.5)
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
            prior_zeta_omega: prior(model),
        })
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
        let c = &self.coeff[i][axis];
        match &self.force_law {
            Some(law) => {
                let l = &law[i];
                (0..self.channels())
                    .map(|k| c[k] * (l[k][0] * x[k] + l[k][1]).max(0.0))
                    .sum()
            }
            None => (0..self.channels()).map(|k| c[k] * x[k]).sum(),
        }
    }

    /// The handle force the set-points command (the response's steady state at gain 1).
    pub fn commanded(&self, axis: usize) -> Vec<f64> {
        (0..self.set.len())
            .map(|i| self.handle_force(i, axis, &self.set[i]))
            .collect()
    }
}

fn prior(model: &RobotModel<f64>) -> (f64, f64) {
    let ip = &model.params.ip;
    (ip.damping_ratio, ip.natural_freq_rad_s)
}

/// Parameters of the step-trial model. Extras at their neutral values leave the base
/// (ζ, ωn, gains) unchanged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    pub zeta: f64,
    pub omega_n_rad_s: f64,
    /// Transport delay of the set-points.
    pub delay_s: f64,
    /// Largest rates at which a channel may rise and fall: a converter's pressure (bar/s),
    /// or the commanded force of a force channel (N/s).
    pub rise_per_s: f64,
    pub fall_per_s: f64,
    /// The rate limits act on the set-points (as for force channels) instead of the
    /// converters' pressures.
    pub slew_command: bool,
    /// Set-points above `knee` are compressed toward `knee + knee_span` (tanh).
    pub knee: f64,
    pub knee_span: f64,
    /// The handle force (gain × the model's force) is compressed above `force_knee_n`
    /// toward `force_knee_n + force_span_n` (tanh).
    pub force_knee_n: f64,
    pub force_span_n: f64,
    pub gain: [f64; 2],
    /// dG/dα1, dG/dα2 per axis (pose-dependent gain, eq. 5.2).
    pub gain_slope_per_rad: [[f64; 2]; 2],
    /// Force offset that follows the direction of the last reference change (hysteresis).
    pub hysteresis_n: [f64; 2],
    /// Force offset (in the base: the load cell's tare and the pose's bias) and drift.
    pub offset_n: [f64; 2],
    pub drift_n_per_s: [f64; 2],
}

impl Response {
    pub fn base(zeta: f64, omega_n_rad_s: f64, gain: [f64; 2]) -> Self {
        Response {
            zeta,
            omega_n_rad_s,
            delay_s: 0.0,
            rise_per_s: f64::INFINITY,
            fall_per_s: f64::INFINITY,
            slew_command: false,
            knee: f64::INFINITY,
            knee_span: 1.0,
            force_knee_n: f64::INFINITY,
            force_span_n: 1.0,
            gain,
            gain_slope_per_rad: [[0.0; 2]; 2],
            hysteresis_n: [0.0; 2],
            offset_n: [0.0; 2],
            drift_n_per_s: [0.0; 2],
        }
    }

    /// The parameters an effect adds, named in the drive's units.
    pub fn extra_params(&self, x: StepExtra, units: Units, axes: &[usize]) -> Vec<(String, f64)> {
        let axis = ["x", "y"];
        let mut v = Vec::new();
        match (x, units) {
            (StepExtra::Delay, _) => v.push(("delay_s".into(), self.delay_s)),
            (StepExtra::SlewRate, Units::Pressure) => {
                v.push(("inflation_s".into(), FILL_SPAN_BAR / self.rise_per_s));
                v.push(("deflation_s".into(), FILL_SPAN_BAR / self.fall_per_s));
            }
            (StepExtra::CommandSlew, Units::Pressure) => {
                v.push(("command_rise_bar_per_s".into(), self.rise_per_s));
                v.push(("command_fall_bar_per_s".into(), self.fall_per_s));
            }
            (StepExtra::SlewRate | StepExtra::CommandSlew, Units::Force) => {
                v.push(("rise_n_per_s".into(), self.rise_per_s));
                v.push(("fall_n_per_s".into(), self.fall_per_s));
            }
            (StepExtra::Saturation, Units::Pressure) => {
                v.push(("knee_bar".into(), self.knee));
                v.push(("max_bar".into(), self.knee + self.knee_span));
            }
            (StepExtra::Saturation, Units::Force) => {
                v.push(("knee_n".into(), self.knee));
                v.push(("max_n".into(), self.knee + self.knee_span));
            }
            (StepExtra::ForceSaturation, _) => {
                v.push(("knee_n".into(), self.force_knee_n));
                v.push(("max_n".into(), self.force_knee_n + self.force_span_n));
            }
            (StepExtra::PoseGain, _) => {
                // relative slopes, comparable with a gain plane normalised by G
                for &a in axes {
                    for j in 0..2 {
                        v.push((
                            format!("gain_per_rad_{}_{}", j + 1, axis[a]),
                            self.gain_slope_per_rad[a][j] / self.gain[a],
                        ));
                    }
                }
            }
            (StepExtra::Hysteresis, _) => {
                for &a in axes {
                    v.push((format!("hysteresis_n_{}", axis[a]), self.hysteresis_n[a]));
                }
            }
            (StepExtra::Drift, _) => {
                for &a in axes {
                    v.push((format!("offset_n_{}", axis[a]), self.offset_n[a]));
                    v.push((format!("drift_n_per_s_{}", axis[a]), self.drift_n_per_s[a]));
                }
            }
        }
        v
    }
}

/// Number of free parameters `extras` add when `axes` are fitted.
pub fn extra_param_count(extras: &[StepExtra], axes: &[usize]) -> usize {
    extras
        .iter()
        .map(|x| match x {
            StepExtra::Delay => 1,
            StepExtra::SlewRate
            | StepExtra::CommandSlew
            | StepExtra::Saturation
            | StepExtra::ForceSaturation => 2,
            StepExtra::PoseGain => 2 * axes.len(),
            StepExtra::Hysteresis => axes.len(),
            StepExtra::Drift => axes.len(),
        })
        .sum()
}

/// The parameter vector of a fit: ζ, ωn, the gains and force offsets of `axes`, then each
/// extra's. The offset is in the base: at a blocked handle a force bias of a few hundredths
/// of a newton comes from the encoders' resolution and zero alone (the force law evaluated a
/// fraction of a count away from the true pose), so only a drift tells a load cell apart.
fn pack(r: &Response, extras: &[StepExtra], axes: &[usize]) -> Vec<f64> {
    let mut v = vec![r.zeta, r.omega_n_rad_s];
    v.extend(axes.iter().map(|&a| r.gain[a]));
    v.extend(axes.iter().map(|&a| r.offset_n[a]));
    for x in extras {
        match x {
            StepExtra::Delay => v.push(r.delay_s),
            StepExtra::SlewRate | StepExtra::CommandSlew => v.extend([r.rise_per_s, r.fall_per_s]),
            StepExtra::Saturation => v.extend([r.knee, r.knee_span]),
            StepExtra::ForceSaturation => v.extend([r.force_knee_n, r.force_span_n]),
            StepExtra::PoseGain => {
                for &a in axes {
                    v.extend(r.gain_slope_per_rad[a])
                }
            }
            StepExtra::Hysteresis => v.extend(axes.iter().map(|&a| r.hysteresis_n[a])),
            StepExtra::Drift => v.extend(axes.iter().map(|&a| r.drift_n_per_s[a])),
        }
    }
    v
}

fn unpack(v: &[f64], extras: &[StepExtra], axes: &[usize], template: &Response) -> Response {
    let mut r = *template;
    let mut it = v.iter().copied();
    let mut next = || it.next().unwrap_or(0.0);
    r.zeta = next();
    r.omega_n_rad_s = next();
    for &a in axes {
        r.gain[a] = next();
    }
    for &a in axes {
        r.offset_n[a] = next();
    }
    for x in extras {
        match x {
            StepExtra::Delay => r.delay_s = next(),
            StepExtra::SlewRate | StepExtra::CommandSlew => {
                r.rise_per_s = next();
                r.fall_per_s = next();
            }
            StepExtra::Saturation => {
                r.knee = next();
                r.knee_span = next();
            }
            StepExtra::ForceSaturation => {
                r.force_knee_n = next();
                r.force_span_n = next();
            }
            StepExtra::PoseGain => {
                for &a in axes {
                    r.gain_slope_per_rad[a] = [next(), next()];
                }
            }
            StepExtra::Hysteresis => {
                for &a in axes {
                    r.hysteresis_n[a] = next();
                }
            }
            StepExtra::Drift => {
                for &a in axes {
                    r.drift_n_per_s[a] = next();
                }
            }
        }
    }
    r
}

/// Lower bounds of the packed parameters (ζ, ωn, delay, rates and the saturation's span
/// stay physical).
fn lower_bounds(extras: &[StepExtra], axes: &[usize], rate_floor: f64) -> Vec<(usize, f64)> {
    let mut v = vec![(0, 0.02), (1, 0.1)];
    let mut i = 2 + 2 * axes.len();
    for x in extras {
        match x {
            StepExtra::Delay => v.push((i, 0.0)),
            StepExtra::SlewRate | StepExtra::CommandSlew => {
                v.extend([(i, rate_floor), (i + 1, rate_floor)])
            }
            StepExtra::Saturation | StepExtra::ForceSaturation => {
                v.extend([(i, 0.0), (i + 1, 1e-3)])
            }
            _ => {}
        }
        i += extra_param_count(&[*x], axes);
    }
    v
}

#[inline]
fn saturate(s: f64, knee: f64, span: f64) -> f64 {
    if s.abs() > knee {
        s.signum() * (knee + span * ((s.abs() - knee) / span).tanh())
    } else {
        s
    }
}

/// Simulates rows [0, n) of both axes into `out`. Each channel starts at rest at its first
/// set-point; the set-point over a sub-step is the (delayed) held set-point averaged over
/// it, so the output is smooth in the delay.
pub fn simulate(
    r: &Response,
    d: &Drive,
    t_s: &[f64],
    alpha: [&[f64]; 2],
    n: usize,
    out: &mut [Vec<f64>; 2],
) {
    let n = n.min(d.set.len());
    if n == 0 {
        return;
    }
    let k = d.channels();
    let sub = ((d.dt_s / MAX_SUBSTEP_S).ceil() as usize).max(1);
    let h = d.dt_s / sub as f64;
    let wn2 = r.omega_n_rad_s * r.omega_n_rad_s;
    let c2 = 2.0 * r.zeta * r.omega_n_rad_s;
    let (rise, fall) = (r.rise_per_s.max(1e-9), r.fall_per_s.max(1e-9));
    let limited = rise.is_finite() || fall.is_finite();
    let span = r.knee_span.abs().max(1e-6);
    let force_limited = r.force_knee_n.is_finite();
    let force_span = r.force_span_n.abs().max(1e-6);
    let sat = |s: f64| saturate(s, r.knee, span);
    // Force channels carry the measured force's scale (gain × reference), so that their
    // rate limit and saturation are in the measured newtons; converter channels are bar.
    let force_channels = d.units == Units::Force;
    let scale = |c: usize| if force_channels { r.gain[c] } else { 1.0 };
    let set_at = |j: usize, c: usize| sat(scale(c) * d.set[j.min(n - 1)][c]);
    let mut x = [0.0; 4];
    let mut v = [0.0; 4];
    for (c, xc) in x.iter_mut().enumerate().take(k) {
        *xc = set_at(0, c);
    }
    // Rate limits: a converter's flow limits how fast its pressure moves; without the
    // converters (force channels) the limit is on the commanded force, as in §5.3's
    // black-box view
    let slew_the_command = force_channels || r.slew_command;
    let mut driven = x;
    // the hysteresis offset goes through the same regulation
    let mut hx = [0, 1].map(|a| r.hysteresis_n[a] * d.direction[a][0]);
    let mut hv = [0.0; 2];
    let delay = r.delay_s.max(0.0) / d.dt_s;
    let t0 = t_s[0];
    let frac = 1.0 / sub as f64;
    for i in 0..n {
        for a in 0..2 {
            let g = r.gain[a]
                + r.gain_slope_per_rad[a][0] * alpha[0][i]
                + r.gain_slope_per_rad[a][1] * alpha[1][i];
            let f = d.handle_force(i, a, &x);
            let g = if force_channels {
                // x already carries the gain; only its pose dependence is left
                if r.gain[a].abs() > 1e-12 {
                    g / r.gain[a]
                } else {
                    1.0
                }
            } else {
                g
            };
            let mut force = g * f;
            if force_limited {
                force = saturate(force, r.force_knee_n, force_span);
            }
            out[a][i] = force + hx[a] + r.offset_n[a] + r.drift_n_per_s[a] * (t_s[i] - t0);
        }
        for m in 0..sub {
            // the delayed sub-step [lo, lo + frac) in samples, spanning at most two samples
            let lo = i as f64 + m as f64 * frac - delay;
            let (j, w_first) = if lo <= 0.0 {
                (0, 1.0)
            } else {
                let j = lo.floor();
                (j as usize, ((j + 1.0 - lo) / frac).min(1.0))
            };
            for c in 0..k {
                let mut s = if w_first >= 1.0 {
                    set_at(j, c)
                } else {
                    w_first * set_at(j, c) + (1.0 - w_first) * set_at(j + 1, c)
                };
                if limited && slew_the_command {
                    s = s.clamp(driven[c] - fall * h, driven[c] + rise * h);
                    driven[c] = s;
                }
                v[c] += h * (wn2 * (s - x[c]) - c2 * v[c]);
                if limited && !slew_the_command {
                    v[c] = v[c].clamp(-fall, rise);
                }
                x[c] += h * v[c];
            }
            for a in 0..2 {
                let target = r.hysteresis_n[a] * d.direction[a][j.min(n - 1)];
                hv[a] += h * (wn2 * (target - hx[a]) - c2 * hv[a]);
                hx[a] += h * hv[a];
            }
        }
    }
}

/// The fastest rate any channel reaches under `r` (for the rate limits' starting values).
fn peak_rate(r: &Response, d: &Drive, n: usize) -> f64 {
    let n = n.min(d.set.len());
    let sub = ((d.dt_s / MAX_SUBSTEP_S).ceil() as usize).max(1);
    let h = d.dt_s / sub as f64;
    let wn2 = r.omega_n_rad_s * r.omega_n_rad_s;
    let c2 = 2.0 * r.zeta * r.omega_n_rad_s;
    let mut x = [0.0; 4];
    let mut v = [0.0; 4];
    x[..d.channels()].copy_from_slice(&d.set[0][..d.channels()]);
    let mut peak: f64 = 0.0;
    for i in 0..n {
        for _ in 0..sub {
            for c in 0..d.channels() {
                v[c] += h * (wn2 * (d.set[i][c] - x[c]) - c2 * v[c]);
                x[c] += h * v[c];
                peak = peak.max(v[c].abs());
            }
        }
    }
    peak
}

/// Least-squares fit of the step-trial model on rows [0, fit_end) of `axes`, from `start`
/// (the base's values; extras start from several inactive-to-strong settings).
pub fn fit(
    p: &Prepared,
    d: &Drive,
    start: &Response,
    extras: &[StepExtra],
    axes: &[usize],
    fit_end: usize,
) -> Response {
    let n = fit_end.min(p.len());
    if n < 4 || axes.is_empty() {
        return *start;
    }
    // a command slew is the rate limits acting on the set-points: the same parameters
    if extras.contains(&StepExtra::CommandSlew) {
        let mapped: Vec<StepExtra> = extras
            .iter()
            .map(|x| match x {
                StepExtra::CommandSlew => StepExtra::SlewRate,
                other => *other,
            })
            .collect();
        let start = Response {
            slew_command: true,
            ..*start
        };
        return fit(p, d, &start, &mapped, axes, fit_end);
    }
    // the simulation runs on every sample; residuals every ≥ 5 ms keep 1 kHz logs cheap
    let stride = ((0.005 / p.dt_s).floor() as usize).max(1);
    let rows: Vec<usize> = (0..n).step_by(stride).collect();
    let t = &p.t_s[..n];
    let alpha = [&p.alpha_rad[0][..n], &p.alpha_rad[1][..n]];
    let mut buf = [vec![0.0; n], vec![0.0; n]];

    // two extras with their own grids: the rates first, then the saturation's wider grid
    // from there
    let rates_inactive = !(start.rise_per_s.is_finite() || start.fall_per_s.is_finite());
    let knee_inactive = !start.knee.is_finite();
    if extras.contains(&StepExtra::SlewRate)
        && extras.contains(&StepExtra::Saturation)
        && rates_inactive
        && knee_inactive
    {
        let first: Vec<StepExtra> = extras
            .iter()
            .copied()
            .filter(|x| *x != StepExtra::Saturation)
            .collect();
        let stage = fit(p, d, start, &first, axes, fit_end);
        return fit(p, d, &stage, extras, axes, fit_end);
    }
    // the fastest rate the base reaches: the scale of the rate limits' starts and floor
    let peak = if extras.contains(&StepExtra::SlewRate) {
        peak_rate(start, d, n).max(1e-6)
    } else {
        1.0
    };
    let mut starts = vec![*start];
    if extras.contains(&StepExtra::SlewRate) && rates_inactive {
        // the cost is flat where a limit is inactive: start at fractions of the fastest
        // rate the base reaches, alike and unlike up and down, with the base's dynamics and
        // with the converters' own (a base fitted without the limit has slowed itself down)
        let (zeta0, omega0) = d.prior_zeta_omega;
        let own = Response {
            zeta: zeta0,
            omega_n_rad_s: omega0,
            ..*start
        };
        let peak_own = peak_rate(&own, d, n).max(1e-6);
        let mut v = Vec::new();
        for fast in [false, true] {
            // down to 1 %: a converter that needs 20 s to fill never reaches its set-point
            let pairs = [0.7, 0.35, 0.15, 0.06, 0.025, 0.01]
                .into_iter()
                .flat_map(|f: f64| [(f, f), (f, f * 0.5), (f * 0.5, f)]);
            for (fr, ff) in pairs {
                for s in &starts {
                    let mut q = *s;
                    if fast {
                        q.zeta = zeta0;
                        q.omega_n_rad_s = omega0;
                    }
                    let pk = if fast { peak_own } else { peak };
                    q.rise_per_s = fr * pk;
                    q.fall_per_s = ff * pk;
                    v.push(q);
                }
            }
        }
        starts = v;
    }
    if extras.contains(&StepExtra::Saturation) && knee_inactive {
        // knees at quantiles of the set-points, from just active to strong
        let mut all: Vec<f64> = d.set[..n]
            .iter()
            .flat_map(|s| s[..d.channels()].iter().map(|v| v.abs()))
            .collect();
        all.sort_by(f64::total_cmp);
        let q = |f: f64| all[((all.len() - 1) as f64 * f) as usize];
        let top = q(1.0);
        // the cost has several basins in (knee, span): a grid, screened below
        // (and below the lowest set-point: a supply that caps every command)
        let knees = [0.99, 0.95, 0.9, 0.8, 0.65, 0.5, 0.35, 0.2, 0.05]
            .into_iter()
            .map(q)
            .chain([0.8, 0.5].map(|f| f * q(0.0)));
        starts = knee_grid(
            &starts,
            knees,
            &[0.1, 0.2, 0.35, 0.6, 1.0, 1.7, 3.0],
            top,
            |r, knee, span| {
                r.knee = knee;
                r.knee_span = span;
            },
        );
    }
    if extras.contains(&StepExtra::ForceSaturation) && !start.force_knee_n.is_finite() {
        // knees at quantiles of the measured force's magnitude (a force saturation acts on
        // the largest steps only), spans from sharp to soft
        let mut all: Vec<f64> = axes
            .iter()
            .flat_map(|&a| rows.iter().map(move |&i| (a, i)))
            .map(|(a, i)| (p.force_n[a][i] - start.offset_n[a]).abs())
            .collect();
        all.sort_by(f64::total_cmp);
        if let Some(&top) = all.last() {
            let q = |f: f64| all[((all.len() - 1) as f64 * f) as usize];
            starts = knee_grid(
                &starts,
                [0.97, 0.9, 0.8, 0.65, 0.5, 0.3].map(q),
                &[0.05, 0.2, 0.6, 2.0],
                top,
                |r, knee, span| {
                    r.force_knee_n = knee;
                    r.force_span_n = span;
                },
            );
        }
    }
    if extras.contains(&StepExtra::Delay) && start.delay_s == 0.0 {
        // a dead time hides in a base whose dynamics slowed down to absorb it: start at
        // several delays, with the base's dynamics and with the converters' own
        let (zeta0, omega0) = d.prior_zeta_omega;
        let mut v = Vec::new();
        for delay in [0.0, 0.01, 0.025, 0.045, 0.07, 0.1, 0.14] {
            for own in [false, true] {
                for s in &starts {
                    let mut r = *s;
                    r.delay_s = delay;
                    if own {
                        r.zeta = zeta0;
                        r.omega_n_rad_s = omega0;
                    }
                    v.push(r);
                }
            }
        }
        starts = v;
    }
    let lower = lower_bounds(extras, axes, 1e-3 * peak);
    // every start gets its least-squares gains and offsets (the output is linear in them),
    // then the
    // starts are screened by their cost and the best few refined
    let mut buf0 = [vec![0.0; n], vec![0.0; n]];
    let mut screen = |r: &Response| -> (f64, Response) {
        let mut r = *r;
        let slopes = r.gain_slope_per_rad;
        r.gain_slope_per_rad = [[0.0; 2]; 2];
        r.offset_n = [0.0; 2];
        r.gain = [1.0; 2];
        simulate(&r, d, t, alpha, n, &mut buf);
        r.gain = [0.0; 2];
        simulate(&r, d, t, alpha, n, &mut buf0);
        let mut cost = 0.0;
        let (mut gain, mut offset) = (start.gain, start.offset_n);
        for &a in axes {
            // y − rest = G·f + offset, least squares in (G, offset)
            let (mut sf, mut sff, mut sy, mut sfy, mut m) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for &i in &rows {
                let f = buf[a][i] - buf0[a][i];
                let y = p.force_n[a][i] - buf0[a][i];
                sf += f;
                sff += f * f;
                sy += y;
                sfy += f * y;
                m += 1.0;
            }
            let det = m * sff - sf * sf;
            let (g, o) = if det.abs() > 1e-12 * (m * sff).max(1e-300) {
                ((m * sfy - sf * sy) / det, (sff * sy - sf * sfy) / det)
            } else {
                (1.0, 0.0)
            };
            gain[a] = g;
            offset[a] = o;
            for &i in &rows {
                cost += (buf0[a][i] + g * (buf[a][i] - buf0[a][i]) + o - p.force_n[a][i]).powi(2);
            }
        }
        r.gain = gain;
        r.offset_n = offset;
        r.gain_slope_per_rad = slopes;
        (cost, r)
    };
    let keep = 3;
    if starts.len() > keep {
        let mut scored: Vec<(f64, Response)> = starts.iter().map(&mut screen).collect();
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        starts = scored.into_iter().take(keep).map(|s| s.1).collect();
    }
    let n_res = rows.len() * axes.len();
    let mut best: Option<(Vec<f64>, f64)> = None;
    for s0 in starts {
        let init = pack(&s0, extras, axes);
        let (theta, cost) = lm::minimize(&init, &lower, n_res, 30, |v, res| {
            let q = unpack(v, extras, axes, start);
            simulate(&q, d, t, alpha, n, &mut buf);
            let mut j = 0;
            for &a in axes {
                for &i in &rows {
                    res[j] = buf[a][i] - p.force_n[a][i];
                    j += 1;
                }
            }
        });
        if best.as_ref().is_none_or(|b| cost < b.1) {
            best = Some((theta, cost));
        }
    }
    match best {
        Some((theta, _)) => unpack(&theta, extras, axes, start),
        None => *start,
    }
}

/// Every start at every (knee, span) of a saturation's grid: spans as fractions of the room
/// between the knee and the top value (at least 0.1 % of the top), the saturation's two
/// parameters written by `set`; knees outermost, then spans, then the starts.
fn knee_grid(
    starts: &[Response],
    knees: impl IntoIterator<Item = f64>,
    span_fractions: &[f64],
    top: f64,
    set: impl Fn(&mut Response, f64, f64),
) -> Vec<Response> {
    let mut v = Vec::new();
    for knee in knees {
        for span_f in span_fractions {
            for s in starts {
                let mut r = *s;
                set(
                    &mut r,
                    knee,
                    ((top - knee) * span_f).max(1e-3 * top.max(1e-3)),
                );
                v.push(r);
            }
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn force_drive(set: Vec<f64>, dt: f64) -> (Drive, Vec<f64>) {
        let n = set.len();
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let mut dir = vec![0.0; n];
        for i in 1..n {
            dir[i] = if set[i] != set[i - 1] {
                (set[i] - set[i - 1]).signum()
            } else {
                dir[i - 1]
            };
        }
        (
            Drive {
                units: Units::Force,
                set: set.iter().map(|&s| [s, 0.0, 0.0, 0.0]).collect(),
                coeff: vec![[[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]; n],
                force_law: None,
                direction: [dir, vec![0.0; n]],
                dt_s: dt,
                prior_zeta_omega: (0.42, 23.04),
            },
            t,
        )
    }

    /// The unlimited model is the second order of Table 5.2: overshoot e^{−πζ/√(1−ζ²)}.
    #[test]
    fn base_is_the_second_order() {
        let dt = 0.001;
        let set: Vec<f64> = (0..3000)
            .map(|i| if i < 100 { 0.0 } else { 10.0 })
            .collect();
        let (d, t) = force_drive(set, dt);
        let zero = vec![0.0; t.len()];
        let mut out = [vec![0.0; t.len()], vec![0.0; t.len()]];
        let r = Response::base(0.42, 23.04, [1.0, 1.0]);
        simulate(&r, &d, &t, [&zero, &zero], t.len(), &mut out);
        let peak = out[0].iter().cloned().fold(f64::MIN, f64::max);
        let expected = (-std::f64::consts::PI * 0.42 / (1.0f64 - 0.42 * 0.42).sqrt()).exp();
        assert!(((peak - 10.0) / 10.0 - expected).abs() < 0.01, "{peak}");
        assert!((out[0][2999] - 10.0).abs() < 1e-3);
    }

    /// A rate limit makes a large step a ramp at that rate; a saturation caps the level.
    #[test]
    fn rate_limit_and_saturation_act_on_the_channels() {
        let dt = 0.001;
        let set: Vec<f64> = (0..4000)
            .map(|i| if i < 100 { 0.0 } else { 10.0 })
            .collect();
        let (d, t) = force_drive(set, dt);
        let zero = vec![0.0; t.len()];
        let mut out = [vec![0.0; t.len()], vec![0.0; t.len()]];
        let mut r = Response::base(0.42, 23.04, [1.0, 1.0]);
        r.rise_per_s = 5.0;
        simulate(&r, &d, &t, [&zero, &zero], t.len(), &mut out);
        // halfway through the ramp: 1 s after the step at 5 units/s
        assert!((out[0][1100] - 5.0).abs() < 0.3, "{}", out[0][1100]);
        r.rise_per_s = f64::INFINITY;
        r.knee = 4.0;
        r.knee_span = 2.0;
        simulate(&r, &d, &t, [&zero, &zero], t.len(), &mut out);
        let expected = 4.0 + 2.0 * (6.0f64 / 2.0).tanh();
        assert!((out[0][3999] - expected).abs() < 1e-3, "{}", out[0][3999]);
    }

    /// The fit recovers a delay, rate limits and a saturation from noiseless responses:
    /// each alone, and the rates with the saturation (fitted in two stages).
    #[test]
    fn fit_recovers_the_extras() {
        let dt = 0.002;
        let mut set = Vec::new();
        for k in 0..16 {
            let level = [0.0, 8.0, -8.0, 16.0, 12.0, -12.0, 20.0, -20.0][k % 8];
            set.extend(std::iter::repeat_n(level, 750));
        }
        let (d, t) = force_drive(set, dt);
        let n = t.len();
        let zero = vec![0.0; n];
        let mut full = Response::base(0.42, 23.04, [0.9, 1.0]);
        full.delay_s = 0.03;
        full.rise_per_s = 40.0;
        full.fall_per_s = 25.0;
        full.knee = 10.0;
        full.knee_span = 3.0;
        let base = Response::base(0.42, 23.04, [0.9, 1.0]);
        let cases: [(&[StepExtra], Response); 4] = [
            (
                &[StepExtra::Delay],
                Response {
                    delay_s: 0.03,
                    ..base
                },
            ),
            (
                &[StepExtra::SlewRate],
                Response {
                    rise_per_s: 40.0,
                    fall_per_s: 25.0,
                    ..base
                },
            ),
            (
                &[StepExtra::Saturation],
                Response {
                    knee: 10.0,
                    knee_span: 3.0,
                    ..base
                },
            ),
            (
                &[StepExtra::SlewRate, StepExtra::Saturation],
                Response {
                    delay_s: 0.0,
                    ..full
                },
            ),
        ];
        for (extras, truth) in cases {
            let mut y = [vec![0.0; n], vec![0.0; n]];
            simulate(&truth, &d, &t, [&zero, &zero], n, &mut y);
            let trial = crate::Trial {
                t_s: t.clone(),
                alpha_rad: [zero.clone(), zero.clone()],
                force_n: [y[0].clone(), zero.clone()],
                force_ref_n: Some([d.set.iter().map(|s| s[0]).collect(), zero.clone()]),
                current_ma: None,
            };
            let p = trial
                .prepare(&RobotModel::thesis(), Default::default())
                .unwrap();
            let start = Response::base(0.6, 18.0, [1.0, 1.0]);
            let f = fit(&p, &d, &start, extras, &[0], n);
            let mut checks = vec![("zeta", f.zeta, 0.42), ("gain", f.gain[0], 0.9)];
            if extras.contains(&StepExtra::Delay) {
                checks.push(("delay", f.delay_s, 0.03));
            }
            if extras.contains(&StepExtra::SlewRate) {
                checks.push(("rise", f.rise_per_s, 40.0));
                checks.push(("fall", f.fall_per_s, 25.0));
            }
            if extras.contains(&StepExtra::Saturation) {
                checks.push(("knee", f.knee, 10.0));
                checks.push(("max", f.knee + f.knee_span, 13.0));
            }
            for (name, got, want) in checks {
                assert!(
                    (got - want).abs() < 0.05 * want,
                    "{extras:?} {name}: {got} vs {want}; {f:?}"
                );
            }
        }
    }
}
