//! Fitting the step model: grids of starts where the cost is flat or has several basins
//! (rates, knees, caps, delays), screened by cost, the best few refined by
//! Levenberg–Marquardt.

use super::grid::Sims;
use super::params::Response;
use super::params::{lower_bounds, pack, unpack, upper_bounds, Bounds};
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
    let upper = upper_bounds(extras, axes);
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
    c.refined(starts, &lower, &upper)
}

/// One fit of the step model: the trial, the model it starts from, what it adds, and the
/// rows it is scored on.
pub(super) struct Fit<'a> {
    pub(super) p: &'a Prepared,
    pub(super) d: &'a Drive,
    pub(super) start: &'a Response,
    pub(super) extras: &'a [StepExtra],
    pub(super) axes: &'a [usize],
    pub(super) held_out: &'a HeldOut,
    /// Samples simulated: up to the last fitted row.
    pub(super) n: usize,
    /// The rows the cost is summed over (fitted, every ≥ 5 ms).
    pub(super) rows: Vec<usize>,
    pub(super) t: &'a [f64],
    pub(super) alpha: [&'a [f64]; 2],
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
    fn refined(
        &self,
        starts: Vec<Response>,
        lower: &[(usize, f64)],
        upper: &[(usize, f64)],
    ) -> Response {
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
        let nonlinear = |bounds: &[(usize, f64)]| -> Bounds {
            bounds
                .iter()
                .filter(|(i, _)| !linear.contains(i))
                .map(|&(i, b)| (if i >= linear.end { i - linear.len() } else { i }, b))
                .collect()
        };
        // the bounds that follow the levels depend on the start (its capped channel, and the
        // gain that scales force channels); they replace the fixed ones at their indices
        let bounds_of = |s0: &Response| -> (Bounds, Bounds) {
            let (lo_s, hi_s) = self.level_bounds(s0);
            let merged = |fixed: &[(usize, f64)], own: Bounds| {
                let mut v: Bounds = fixed
                    .iter()
                    .copied()
                    .filter(|&(i, _)| own.iter().all(|&(j, _)| j != i))
                    .collect();
                v.extend(own);
                nonlinear(&v)
            };
            (merged(lower, lo_s), merged(upper, hi_s))
        };
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
                let (lower_nl, upper_nl) = bounds_of(&s0);
                let report =
                    lm::minimize_within(&init, &lower_nl, &upper_nl, n_res, 30, |v, res| {
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
