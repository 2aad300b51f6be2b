//! Fitting the step model: grids of starts where the cost is flat or has several basins
//! (rates, knees, caps, delays), screened by cost, the best few refined by
//! Levenberg–Marquardt.

use super::grid::{knee_grid, Quantiles, Sims};
use super::params::Response;
use super::params::{lower_bounds, pack, unpack, MIN_TURN_OVER_SHARE};
use super::simulate::{peak_rate, simulate};
use super::Drive;
use super::StepExtra;
use super::Units;
use pam_ident::held_out::HeldOut;
use pam_ident::trial::Prepared;
use pam_numerics::lm;
use rayon::prelude::*;

/// Least-squares fit of the step-trial model on the rows of `axes` that are not
/// `held_out`, from `start` (the base's values; extras start from several
/// inactive-to-strong settings). The model is simulated up to the last fitted row.
pub fn fit(
    p: &Prepared,
    d: &Drive,
    start: &Response,
    extras: &[StepExtra],
    axes: &[usize],
    held_out: &HeldOut,
) -> Response {
    let n = held_out.train_end().min(p.len());
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
        return fit(p, d, &start, &mapped, axes, held_out);
    }
    // the simulation runs on every sample; residuals every ≥ 5 ms keep 1 kHz logs cheap
    let stride = ((0.005 / p.dt_s).floor() as usize).max(1);
    let rows: Vec<usize> = (0..n)
        .step_by(stride)
        .filter(|&i| !held_out.contains(i))
        .collect();
    let t = &p.t_s[..n];
    let alpha = [&p.alpha_rad[0][..n], &p.alpha_rad[1][..n]];
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
        let stage = fit(p, d, start, &first, axes, held_out);
        return fit(p, d, &stage, extras, axes, held_out);
    }
    // the fastest rate the base reaches: the scale of the rate limits' starts and floor
    let peak = if extras.contains(&StepExtra::SlewRate) {
        peak_rate(start, d, n, held_out).max(1e-6)
    } else {
        1.0
    };
    let c = Fit {
        p,
        d,
        start,
        extras,
        axes,
        held_out,
        n,
        rows,
        t,
        alpha,
    };
    let starts = c.grid_starts(peak, rates_inactive, knee_inactive);
    let lower = lower_bounds(extras, axes, 1e-3 * peak);
    // every start gets its least-squares gains and offsets (the output is linear in them),
    // then the
    // starts are screened by their cost and the best few refined
    // the gains are refitted as multipliers of `unit`: 1, or the start's gains when a
    // saturation or slew of the measured force is screened (its knee and rates are in the
    // measured newtons, after the gain; at gain 1 the grid would act on the wrong force)
    let unit =
        if extras.contains(&StepExtra::ForceSaturation) || extras.contains(&StepExtra::ForceSlew) {
            start.gain.map(|g| if g.abs() > 1e-9 { g } else { 1.0 })
        } else {
            [1.0; 2]
        };
    let starts = c.screened(starts, unit);
    c.refined(starts, &lower)
}

/// One fit of the step model: the trial, the model it starts from, what it adds, and the
/// rows it is scored on.
struct Fit<'a> {
    p: &'a Prepared,
    d: &'a Drive,
    start: &'a Response,
    extras: &'a [StepExtra],
    axes: &'a [usize],
    held_out: &'a HeldOut,
    /// Samples simulated: up to the last fitted row.
    n: usize,
    /// The rows the cost is summed over (fitted, every ≥ 5 ms).
    rows: Vec<usize>,
    t: &'a [f64],
    alpha: [&'a [f64]; 2],
}

impl Fit<'_> {
    /// The starts of the nonlinear fit: the start itself, times a grid for each extra whose
    /// cost is flat or has several basins where it starts (rates, knees, caps, delays).
    fn grid_starts(&self, peak: f64, rates_inactive: bool, knee_inactive: bool) -> Vec<Response> {
        let starts = vec![*self.start];
        let starts = self.rate_starts(starts, peak, rates_inactive);
        let starts = self.saturation_starts(starts, knee_inactive);
        let starts = self.channel_cap_starts(starts);
        let starts = self.force_saturation_starts(starts);
        let starts = self.force_slew_starts(starts);
        let starts = self.channel_hysteresis_starts(starts);
        self.delay_starts(starts)
    }

    /// Starts for the converters' rate limits.
    fn rate_starts(&self, starts: Vec<Response>, peak: f64, rates_inactive: bool) -> Vec<Response> {
        let d = self.d;
        let start = self.start;
        let extras = self.extras;
        let held_out = self.held_out;
        let n = self.n;
        let mut starts = starts;
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
            let peak_own = peak_rate(&own, d, n, held_out).max(1e-6);
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

        starts
    }

    /// Starts for the converters' saturation: a grid of knees and spans.
    fn saturation_starts(&self, starts: Vec<Response>, knee_inactive: bool) -> Vec<Response> {
        let n = self.n;
        let d = self.d;
        let extras = self.extras;
        let mut starts = starts;
        if extras.contains(&StepExtra::Saturation) && knee_inactive {
            // knees at quantiles of the set-points, from just active to strong (held-out
            // steps included: their levels lie within the fitted ones', `HeldOut`)
            let all = Quantiles::of(
                d.set[..n]
                    .iter()
                    .flat_map(|s| s[..d.channels()].iter().map(|v| v.abs()))
                    .collect(),
            );
            let q = |f: f64| all.at(f);
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

        starts
    }

    /// Starts for one channel's cap.
    fn channel_cap_starts(&self, starts: Vec<Response>) -> Vec<Response> {
        let n = self.n;
        let d = self.d;
        let start = self.start;
        let extras = self.extras;
        let mut starts = starts;
        if extras.contains(&StepExtra::ChannelCap) && start.cap_channel.is_none() {
            // which channel, and where its cap sits: knees at quantiles of that channel's own
            // set-points (a cap reached only by its largest commands, or by most of them)
            let mut v = Vec::new();
            for c in 0..d.channels() {
                let scale = d.channel_scale(start, c);
                let own = Quantiles::of(d.set[..n].iter().map(|s| (scale * s[c]).abs()).collect());
                let q = |f: f64| own.at(f);
                let top = q(1.0);
                if !(top > 0.0) {
                    continue;
                }
                v.extend(knee_grid(
                    &starts,
                    [0.99, 0.95, 0.9, 0.8, 0.65, 0.5, 0.3].map(q),
                    &[0.1, 0.35, 1.0],
                    top,
                    |r, knee, span| {
                        r.cap_channel = Some(c);
                        r.cap = knee;
                        r.cap_span = span;
                    },
                ));
            }
            if !v.is_empty() {
                starts = v;
            }
        }

        starts
    }

    /// Starts for a saturation of the measured force.
    fn force_saturation_starts(&self, starts: Vec<Response>) -> Vec<Response> {
        let p = self.p;
        let start = self.start;
        let extras = self.extras;
        let axes = self.axes;
        let rows: &[usize] = &self.rows;
        let mut starts = starts;
        if extras.contains(&StepExtra::ForceSaturation) && !start.force_knee_n.is_finite() {
            // knees at quantiles of the measured force's magnitude (a force saturation acts on
            // the largest steps only), spans from sharp to soft
            let all = Quantiles::of(
                axes.iter()
                    .flat_map(|&a| rows.iter().map(move |&i| (a, i)))
                    .map(|(a, i)| (p.force_n[a][i] - start.offset_n[a]).abs())
                    .collect(),
            );
            if let Some(&top) = all.0.last() {
                let q = |f: f64| all.at(f);
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

        starts
    }

    /// Starts for rate limits of the measured force.
    fn force_slew_starts(&self, starts: Vec<Response>) -> Vec<Response> {
        let p = self.p;
        let d = self.d;
        let start = self.start;
        let extras = self.extras;
        let axes = self.axes;
        let held_out = self.held_out;
        let n = self.n;
        let t = self.t;
        let alpha = self.alpha;
        let mut starts = starts;
        let mut sims = Sims::new(n);
        if extras.contains(&StepExtra::ForceSlew) && !start.force_rise_n_per_s.is_finite() {
            // the cost is flat while the limit is inactive: start at fractions of the fastest
            // rate the start's handle force reaches, alike and unlike up and down
            simulate(start, d, t, alpha, n, &mut sims.unit);
            let peak = axes
                .iter()
                .flat_map(|&a| {
                    let u = &sims.unit[a];
                    (1..n)
                        .filter(|&i| !held_out.contains(i))
                        .map(move |i| (u[i] - u[i - 1]).abs())
                })
                .fold(0.0, f64::max)
                / p.dt_s;
            if peak > 0.0 {
                let mut v = Vec::new();
                for f in [0.5, 0.25, 0.12, 0.06, 0.03] {
                    for (fr, ff) in [(f, f), (f, f * 0.5), (f * 0.5, f)] {
                        for s in &starts {
                            let mut q = *s;
                            q.force_rise_n_per_s = fr * peak;
                            q.force_fall_n_per_s = ff * peak;
                            v.push(q);
                        }
                    }
                }
                starts = v;
            }
        }

        starts
    }

    /// Starts for a hysteresis of each channel: the change over which it turns over, from
    /// a converter's repeatability to more than the largest step's overshoot.
    fn channel_hysteresis_starts(&self, starts: Vec<Response>) -> Vec<Response> {
        if !self.extras.contains(&StepExtra::ChannelHysteresis)
            || self.start.channel_hysteresis != 0.0
        {
            return starts;
        }
        // the force per unit of level: the force law's slope (N/bar), or 1 for force channels
        let per_level = match &self.d.force_law {
            Some(law) => {
                let k = law.len().max(1) as f64 * 4.0;
                law.iter().flatten().map(|l| l[0].abs()).sum::<f64>() / k
            }
            None => 1.0,
        };
        let mut v = Vec::new();
        for share in [MIN_TURN_OVER_SHARE, 0.03, 0.1, 0.3] {
            for loss in [0.01, 0.04] {
                for s in &starts {
                    v.push(Response {
                        channel_hysteresis: loss * per_level,
                        channel_turn_share: share,
                        ..*s
                    });
                }
            }
        }
        v
    }

    /// Starts for a dead time.
    fn delay_starts(&self, starts: Vec<Response>) -> Vec<Response> {
        let d = self.d;
        let start = self.start;
        let extras = self.extras;
        let mut starts = starts;
        if extras.contains(&StepExtra::Delay) && start.delay_s <= d.own_lag_s {
            // a dead time hides in a base whose dynamics slowed down to absorb it: start at
            // several delays, with the base's dynamics and with the converters' own (a start
            // with a longer delay is a fitted one, refined from where it is)
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

        starts
    }

    /// The cost of `r` with each axis's gain (a multiple of `unit`) and offset solved by least
    /// squares, the output being linear in them; the residuals are written when asked for.
    fn project(
        &self,
        r: &Response,
        unit: Option<[f64; 2]>,
        fallback: &Response,
        sims: &mut Sims,
        mut res: Option<&mut [f64]>,
    ) -> (f64, Response) {
        let p = self.p;
        let d = self.d;
        let axes = self.axes;
        let n = self.n;
        let t = self.t;
        let alpha = self.alpha;
        let rows: &[usize] = &self.rows;
        let mut r = *r;
        r.offset_n = [0.0; 2];
        let Some(unit) = unit else {
            // the gains as they are: only the offsets, each the mean remainder
            simulate(&r, d, t, alpha, n, &mut sims.unit);
            let (mut cost, mut j) = (0.0, 0);
            for &a in axes {
                let o = rows
                    .iter()
                    .map(|&i| p.force_n[a][i] - sims.unit[a][i])
                    .sum::<f64>()
                    / rows.len().max(1) as f64;
                r.offset_n[a] = o;
                for &i in rows {
                    let e = sims.unit[a][i] + o - p.force_n[a][i];
                    cost += e * e;
                    if let Some(res) = res.as_deref_mut() {
                        res[j] = e;
                        j += 1;
                    }
                }
            }
            return (cost, r);
        };
        r.gain = unit;
        simulate(&r, d, t, alpha, n, &mut sims.unit);
        // what does not scale with the gain: the hysteresis offset (simulated through the
        // regulation) and the drift
        let hysteresis = r.hysteresis_n != [0.0; 2];
        if hysteresis {
            r.gain = [0.0; 2];
            for z in &mut sims.zero {
                z.resize(n, 0.0);
            }
            simulate(&r, d, t, alpha, n, &mut sims.zero);
        }
        let mut cost = 0.0;
        let (mut gain, mut offset) = (fallback.gain, fallback.offset_n);
        let mut j = 0;
        for &a in axes {
            let zero = |i: usize| {
                if hysteresis {
                    sims.zero[a][i]
                } else {
                    r.drift_n_per_s[a] * (t[i] - t[0])
                }
            };
            // y − rest = G·f + offset, least squares in (G, offset)
            let (mut sf, mut sff, mut sy, mut sfy, mut m) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for &i in rows {
                let f = sims.unit[a][i] - zero(i);
                let y = p.force_n[a][i] - zero(i);
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
            gain[a] = g * unit[a];
            offset[a] = o;
            for &i in rows {
                let e = zero(i) + g * (sims.unit[a][i] - zero(i)) + o - p.force_n[a][i];
                cost += e * e;
                if let Some(res) = res.as_deref_mut() {
                    res[j] = e;
                    j += 1;
                }
            }
        }
        r.gain = gain;
        r.offset_n = offset;
        (cost, r)
    }

    /// The best few starts by their cost, each with its least-squares gains and offsets.
    fn screened(&self, starts: Vec<Response>, unit: [f64; 2]) -> Vec<Response> {
        let start = self.start;
        let n = self.n;
        let mut starts = starts;
        let screen = |sims: &mut Sims, r: &Response| -> (f64, Response) {
            let mut r = *r;
            let slopes = r.gain_slope_per_rad;
            r.gain_slope_per_rad = [[0.0; 2]; 2];
            let (cost, mut r) = self.project(&r, Some(unit), start, sims, None);
            r.gain_slope_per_rad = slopes;
            (cost, r)
        };
        let keep = 3;
        if starts.len() > keep {
            // the starts on both cores (each thread its own buffers); the order of `scored`
            // is the starts' and the sort is stable, so the result does not depend on the
            // threads
            let mut scored: Vec<(f64, Response)> = starts
                .par_iter()
                .map_init(|| Sims::new(n), screen)
                .collect();
            scored.sort_by(|a, b| a.0.total_cmp(&b.0));
            starts = scored.into_iter().take(keep).map(|s| s.1).collect();
        }

        starts
    }

    /// The kept starts refined by Levenberg–Marquardt; the best of them.
    fn refined(&self, starts: Vec<Response>, lower: &[(usize, f64)]) -> Response {
        let d = self.d;
        let start = self.start;
        let extras = self.extras;
        let axes = self.axes;
        let n = self.n;
        let rows: &[usize] = &self.rows;
        let n_res = rows.len() * axes.len();
        // the output is linear in each axis's offset, and in its gain unless a limit in the
        // measured newtons, shared by the axes, scales with it (force channels carry the gain
        // into their rate limits and saturation; converter channels only into the force-side
        // ones): the linear parameters are solved by least squares inside every evaluation
        // (variable projection), so the Jacobian has only the nonlinear columns
        let force_side = |x: &StepExtra| {
            matches!(
                x,
                StepExtra::ForceSaturation | StepExtra::ForceSlew | StepExtra::PoseGain
            ) || (d.units == Units::Force
                && matches!(
                    x,
                    StepExtra::SlewRate
                        | StepExtra::CommandSlew
                        | StepExtra::Saturation
                        | StepExtra::ChannelCap
                ))
        };
        let start_limited = start.force_knee_n.is_finite()
            || start.force_rise_n_per_s.is_finite()
            || start.force_fall_n_per_s.is_finite()
            || start.gain_slope_per_rad != [[0.0; 2]; 2]
            || (d.units == Units::Force
                && (start.rise_per_s.is_finite()
                    || start.fall_per_s.is_finite()
                    || start.knee.is_finite()
                    || start.cap_channel.is_some()));
        let linear_gains = !extras.iter().any(force_side) && !start_limited;
        let na = axes.len();
        let linear = if linear_gains {
            2..2 + 2 * na
        } else {
            2 + na..2 + 2 * na
        };
        let unit_gain = linear_gains.then_some([1.0; 2]);
        let lower_nl: Vec<(usize, f64)> = lower
            .iter()
            .filter(|(i, _)| !linear.contains(i))
            .map(|&(i, lo)| (if i >= linear.end { i - linear.len() } else { i }, lo))
            .collect();
        // each start is its own template: a grid start carries the capped channel, a choice
        // that is not among the packed parameters
        // the kept starts refined side by side (their Jacobians are parallel too); the best
        // is chosen in the starts' order, as a serial loop would
        let refined: Vec<Option<(f64, Response)>> = starts
            .par_iter()
            .map(|&s0| {
                let full = pack(&s0, extras, axes);
                let init: Vec<f64> = full
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| !linear.contains(i))
                    .map(|(_, v)| *v)
                    .collect();
                let expand = |v: &[f64]| -> Response {
                    let mut f = v[..linear.start].to_vec();
                    f.extend(std::iter::repeat_n(0.0, linear.len()));
                    f.extend_from_slice(&v[linear.start..]);
                    unpack(&f, extras, axes, &s0)
                };
                let report = lm::minimize(&init, &lower_nl, n_res, 30, |v, res| {
                    // each evaluation its own buffers: the Jacobian's columns run in parallel
                    self.project(&expand(v), unit_gain, &s0, &mut Sims::new(n), Some(res));
                });
                // a start whose simulation is not finite drops out; one that ran out of its
                // 30 iterations stays a candidate: the starts compete on their cost, and the
                // loop's decisions rest on the scores of the one kept
                report.is_finite().then(|| {
                    self.project(
                        &expand(&report.theta),
                        unit_gain,
                        &s0,
                        &mut Sims::new(n),
                        None,
                    )
                })
            })
            .collect();
        let mut best: Option<(f64, Response)> = None;
        for fitted in refined.into_iter().flatten() {
            if best.as_ref().is_none_or(|b| fitted.0 < b.0) {
                best = Some(fitted);
            }
        }
        match best {
            Some((_, r)) => r,
            None => *start,
        }
    }
}
