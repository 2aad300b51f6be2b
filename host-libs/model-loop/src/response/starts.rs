//! The starts of a step fit: grids for each extra whose cost is flat or has several basins
//! where it starts (rates, knees, caps, slews, a channel's hysteresis, delays).

use super::fit::Fit;
use super::grid::{knee_grid, Quantiles, Sims};
use super::params::{extra_index, Bounds, Response, MIN_TURN_OVER_SHARE};
use super::simulate::{peak_rate, simulate};
use super::StepExtra;

impl Fit<'_> {
    /// Starts for the converters' rate limits.
    pub(super) fn rate_starts(
        &self,
        starts: Vec<Response>,
        peak: f64,
        rates_inactive: bool,
    ) -> Vec<Response> {
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
    pub(super) fn saturation_starts(
        &self,
        starts: Vec<Response>,
        knee_inactive: bool,
    ) -> Vec<Response> {
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
    pub(super) fn channel_cap_starts(&self, starts: Vec<Response>) -> Vec<Response> {
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

    /// The bounds of the saturations that follow the levels of the log, packed (lower,
    /// upper). A saturation levels off within the levels it acts on: a span wider than them
    /// bends every level alike, a curvature of the muscles' force in their pressure, not a
    /// supply that runs out. One channel's cap sits at or above the lowest level that channel
    /// is driven to: below every level it compresses all of them alike, which is that
    /// channel's own gain (the converters differ by a few per cent).
    pub(super) fn level_bounds(&self, s: &Response) -> (Bounds, Bounds) {
        let (mut lower, mut upper) = (Vec::new(), Vec::new());
        let range = |c: usize| -> (f64, f64) {
            let scale = self.d.channel_scale(s, c);
            self.d.set[..self.n]
                .iter()
                .map(|v| (scale * v[c]).abs())
                .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        if let Some(i) = extra_index(self.extras, self.axes, StepExtra::Saturation) {
            // the levels of the channels driven (a force log's second channel may be idle)
            let (lo, hi) = (0..self.d.channels())
                .map(range)
                .filter(|&(_, hi)| hi > 0.0)
                .fold((f64::INFINITY, 0.0f64), |(a, b), (lo, hi)| {
                    (a.min(lo), b.max(hi))
                });
            if hi > lo {
                upper.push((i + 1, hi - lo));
            }
        }
        let cap = extra_index(self.extras, self.axes, StepExtra::ChannelCap);
        if let (Some(i), Some(c)) = (cap, s.cap_channel) {
            let (lo, hi) = range(c);
            if hi > lo {
                lower.push((i, lo));
                upper.push((i + 1, hi - lo));
            }
        }
        (lower, upper)
    }

    /// Starts for a saturation of the measured force.
    pub(super) fn force_saturation_starts(&self, starts: Vec<Response>) -> Vec<Response> {
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
    pub(super) fn force_slew_starts(&self, starts: Vec<Response>) -> Vec<Response> {
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
    pub(super) fn channel_hysteresis_starts(&self, starts: Vec<Response>) -> Vec<Response> {
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
        // a loss of 2 % of the force law's slope; the output is linear in it, so the
        // refinement finds its size from any start, and only the turn-over needs a grid
        let loss = 0.02 * per_level;
        if starts.len() > 1 {
            // beside another extra's grid, one middle start each: a grid on a grid made a
            // combined fit screen hundreds of starts (minutes for one log)
            return starts
                .into_iter()
                .map(|s| Response {
                    channel_hysteresis: loss,
                    channel_turn_share: 0.03,
                    ..s
                })
                .collect();
        }
        [MIN_TURN_OVER_SHARE, 0.03, 0.1, 0.3]
            .iter()
            .flat_map(|&share| {
                starts.iter().map(move |s| Response {
                    channel_hysteresis: loss,
                    channel_turn_share: share,
                    ..*s
                })
            })
            .collect()
    }

    /// Starts for a dead time.
    pub(super) fn delay_starts(&self, starts: Vec<Response>) -> Vec<Response> {
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
}
