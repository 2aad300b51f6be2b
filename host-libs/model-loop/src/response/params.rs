//! The step model's parameters: the response, the extras' parameters packed for the
//! fit, their bounds, and their names in reports.

use super::StepExtra;
use super::Units;
use super::FILL_SPAN_BAR;

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
    /// The one channel whose set-points are compressed above `cap` toward `cap + cap_span`
    /// (tanh); `None`: no channel is capped.
    pub cap_channel: Option<usize>,
    pub cap: f64,
    pub cap_span: f64,
    /// Largest rates at which the handle force may rise and fall (N/s, measured force).
    pub force_rise_n_per_s: f64,
    pub force_fall_n_per_s: f64,
    pub gain: [f64; 2],
    /// dG/dα1, dG/dα2 per axis (pose-dependent gain, eq. 5.2).
    pub gain_slope_per_rad: [[f64; 2]; 2],
    /// Force offset that follows the direction of the last reference change (hysteresis).
    pub hysteresis_n: [f64; 2],
    /// Each channel's force less this times its level and its direction state (N per bar
    /// for converters, a share for force channels): the direction state turns over a small
    /// share of the channel's span after its level reverses.
    pub channel_hysteresis: f64,
    /// The change of level over which the direction state turns over, as a share of each
    /// channel's span of set-points.
    pub channel_turn_share: f64,
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
            cap_channel: None,
            cap: f64::INFINITY,
            cap_span: 1.0,
            force_rise_n_per_s: f64::INFINITY,
            force_fall_n_per_s: f64::INFINITY,
            gain,
            gain_slope_per_rad: [[0.0; 2]; 2],
            hysteresis_n: [0.0; 2],
            channel_hysteresis: 0.0,
            channel_turn_share: 0.02,
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
            (StepExtra::ChannelCap, units) => {
                let (unit, first) = match units {
                    Units::Pressure => ("bar", "muscle"),
                    Units::Force => ("n", "axis"),
                };
                v.push((
                    first.into(),
                    self.cap_channel.map_or(0.0, |c| c as f64 + 1.0),
                ));
                v.push((format!("cap_{unit}"), self.cap));
                v.push((format!("max_{unit}"), self.cap + self.cap_span));
            }
            (StepExtra::ForceSlew, _) => {
                v.push(("force_rise_n_per_s".into(), self.force_rise_n_per_s));
                v.push(("force_fall_n_per_s".into(), self.force_fall_n_per_s));
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
            (StepExtra::ChannelHysteresis, Units::Pressure) => {
                v.push(("hysteresis_n_per_bar".into(), self.channel_hysteresis));
                v.push(("turn_over_share".into(), self.channel_turn_share));
            }
            (StepExtra::ChannelHysteresis, Units::Force) => {
                v.push(("hysteresis_share".into(), self.channel_hysteresis));
                v.push(("turn_over_share".into(), self.channel_turn_share));
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
            | StepExtra::ForceSaturation
            | StepExtra::ChannelCap
            | StepExtra::ForceSlew
            | StepExtra::ChannelHysteresis => 2,
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
pub(super) fn pack(r: &Response, extras: &[StepExtra], axes: &[usize]) -> Vec<f64> {
    let mut v = vec![r.zeta, r.omega_n_rad_s];
    v.extend(axes.iter().map(|&a| r.gain[a]));
    v.extend(axes.iter().map(|&a| r.offset_n[a]));
    for x in extras {
        match x {
            StepExtra::Delay => v.push(r.delay_s),
            StepExtra::SlewRate | StepExtra::CommandSlew => v.extend([r.rise_per_s, r.fall_per_s]),
            StepExtra::Saturation => v.extend([r.knee, r.knee_span]),
            StepExtra::ForceSaturation => v.extend([r.force_knee_n, r.force_span_n]),
            StepExtra::ChannelCap => v.extend([r.cap, r.cap_span]),
            StepExtra::ForceSlew => v.extend([r.force_rise_n_per_s, r.force_fall_n_per_s]),
            StepExtra::PoseGain => {
                for &a in axes {
                    v.extend(r.gain_slope_per_rad[a])
                }
            }
            StepExtra::Hysteresis => v.extend(axes.iter().map(|&a| r.hysteresis_n[a])),
            StepExtra::ChannelHysteresis => v.extend([r.channel_hysteresis, r.channel_turn_share]),
            StepExtra::Drift => v.extend(axes.iter().map(|&a| r.drift_n_per_s[a])),
        }
    }
    v
}

pub(super) fn unpack(
    v: &[f64],
    extras: &[StepExtra],
    axes: &[usize],
    template: &Response,
) -> Response {
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
            StepExtra::ChannelCap => {
                r.cap = next();
                r.cap_span = next();
            }
            StepExtra::ForceSlew => {
                r.force_rise_n_per_s = next();
                r.force_fall_n_per_s = next();
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
            StepExtra::ChannelHysteresis => {
                r.channel_hysteresis = next();
                r.channel_turn_share = next();
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

/// The smallest change of a channel's level, as a share of its span, over which a channel's
/// hysteresis may turn over.
pub const MIN_TURN_OVER_SHARE: f64 = 0.01;

/// The largest change of a channel's level, as a share of its span, over which a
/// channel's hysteresis may turn over. A loop that turns over more slowly does not close
/// within the channel's own levels: its term is then a curvature of the force in the
/// level's travel (a muscle's force–length law a second order does not hold), not a loss in
/// the direction the level moved.
pub const MAX_TURN_OVER_SHARE: f64 = 0.5;

/// Bounds on packed parameters: (index, bound).
pub(super) type Bounds = Vec<(usize, f64)>;

/// Upper bounds of the packed parameters: a channel's hysteresis turns over within its
/// levels.
pub(super) fn upper_bounds(extras: &[StepExtra], axes: &[usize]) -> Bounds {
    extra_index(extras, axes, StepExtra::ChannelHysteresis)
        .map(|i| (i + 1, MAX_TURN_OVER_SHARE))
        .into_iter()
        .collect()
}

/// Where `extra`'s parameters start in the packed vector, when it is fitted.
pub(super) fn extra_index(extras: &[StepExtra], axes: &[usize], extra: StepExtra) -> Option<usize> {
    let at = extras.iter().position(|&x| x == extra)?;
    Some(2 + 2 * axes.len() + extra_param_count(&extras[..at], axes))
}

/// Lower bounds of the packed parameters (ζ, ωn, delay, rates and the saturation's span
/// stay physical).
pub(super) fn lower_bounds(extras: &[StepExtra], axes: &[usize], rate_floor: f64) -> Bounds {
    let mut v = vec![(0, 0.02), (1, 0.1)];
    let mut i = 2 + 2 * axes.len();
    for x in extras {
        match x {
            StepExtra::Delay => v.push((i, 0.0)),
            // the braid's friction opposes the level's motion, and turns over a change of
            // the level larger than a converter's repeatability (about 1 % of its span): a
            // state that turns within it follows the converters' ringing, a term in the
            // pressure's velocity that stands in for their dynamics
            StepExtra::ChannelHysteresis => v.extend([(i, 0.0), (i + 1, MIN_TURN_OVER_SHARE)]),
            StepExtra::SlewRate | StepExtra::CommandSlew => {
                v.extend([(i, rate_floor), (i + 1, rate_floor)])
            }
            StepExtra::Saturation | StepExtra::ForceSaturation | StepExtra::ChannelCap => {
                v.extend([(i, 0.0), (i + 1, 1e-3)])
            }
            // a tenth of a newton per second: slower than any step trial could show
            StepExtra::ForceSlew => v.extend([(i, 0.1), (i + 1, 0.1)]),
            _ => {}
        }
        i += extra_param_count(&[*x], axes);
    }
    v
}
