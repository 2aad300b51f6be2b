//! Simulation of a step trial: the (delayed, rate-limited, saturated) set-points through
//! each converter's second order to the handle force.

use super::params::Response;
use super::Drive;
use super::Units;
use super::MAX_SUBSTEP_S;
use pam_ident::held_out::HeldOut;
use pam_numerics::second_order::SecondOrderStep;

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
    // the channel count as a constant keeps the channels' states in registers (measured:
    // the step fits spend most of their time here)
    match d.channels() {
        2 => simulate_channels::<2>(r, d, t_s, alpha, n, out),
        _ => simulate_channels::<4>(r, d, t_s, alpha, n, out),
    }
}

fn simulate_channels<const K: usize>(
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
    let plan = Plan::<K>::new(r, d, n);
    let mut state = State::<K>::at_rest(&plan, r, d);
    let t0 = t_s[0];
    for i in 0..n {
        let mut forces = d.channel_forces(i, &state.x);
        if plan.channel_hysteresis {
            for k in 0..K {
                forces[k] -= r.channel_hysteresis * state.x[k] * state.z[k];
            }
        }
        for a in 0..2 {
            let force = plan.handle_force(r, d, alpha, i, a, &forces, &mut state.slewed[a]);
            out[a][i] = force + state.hx[a] + r.offset_n[a] + r.drift_n_per_s[a] * (t_s[i] - t0);
        }
        plan.advance(r, d, t_s, i, &mut state);
    }
}

/// What a simulation of the channels computes once, before the samples: the sub-steps,
/// the shaped set-points, the delay's taps and which limits are on.
struct Plan<const K: usize> {
    n: usize,
    rise: f64,
    fall: f64,
    /// A rate limit on the channels.
    limited: bool,
    /// Sub-steps per sample, their length and the second order's step over one (an even log).
    sub: usize,
    h: f64,
    phi: SecondOrderStep,
    /// Each sample's set-points, scaled, saturated and capped: a delayed sub-step reads two.
    shaped: Vec<[f64; K]>,
    /// The rate limit acts on the command (force channels, or a slew on the input) rather
    /// than on the channel's own rate.
    slew_the_command: bool,
    /// Sub-step m of an even log reads the delayed interval [i + offset_m, i + offset_m +
    /// 1/sub): samples i + ⌊offset_m⌋ and the next, the first with a weight of m alone.
    taps: Vec<(isize, f64)>,
    hysteresis: bool,
    /// A hysteresis of each channel's force in proportion to its level, and the change of
    /// level over which each channel's direction state turns over.
    channel_hysteresis: bool,
    turn_over: [f64; K],
    force_limited: bool,
    force_span: f64,
    /// A slew limit on the handle force: its largest rise and fall per second.
    force_slewed: bool,
    force_rates: (f64, f64),
    /// The gain of each axis when it does not depend on the pose.
    constant_gain: [Option<f64>; 2],
    force_channels: bool,
}

/// The channels' state between samples.
struct State<const K: usize> {
    x: [f64; K],
    v: [f64; K],
    /// The rate-limited command of each channel.
    driven: [f64; K],
    /// The hysteresis offset of each axis and its rate: it goes through the same regulation.
    hx: [f64; 2],
    hv: [f64; 2],
    /// Each channel's direction state (−1 after a fall, 1 after a rise, Dahl's law between).
    z: [f64; K],
    /// The last slew-limited handle force of each axis.
    slewed: [Option<f64>; 2],
    /// An uneven log's delayed set-points are looked up by time, from this row on.
    delayed_from: usize,
}

impl<const K: usize> State<K> {
    /// Each channel at rest at its first set-point.
    fn at_rest(plan: &Plan<K>, r: &Response, d: &Drive) -> Self {
        let x: [f64; K] = std::array::from_fn(|c| plan.set_at(0, c));
        State {
            x,
            v: [0.0; K],
            driven: x,
            hx: [0, 1].map(|a| r.hysteresis_n[a] * d.direction[a][0]),
            hv: [0.0; 2],
            z: [0.0; K],
            slewed: [None; 2],
            delayed_from: 0,
        }
    }
}

impl<const K: usize> Plan<K> {
    fn new(r: &Response, d: &Drive, n: usize) -> Self {
        let (rise, fall) = (r.rise_per_s.max(1e-9), r.fall_per_s.max(1e-9));
        let limited = rise.is_finite() || fall.is_finite();
        // the linear second order is stepped exactly (its transition matrix over a
        // sub-step), so only a rate limit, which clamps within the step, and a delay, which
        // moves the set-point's change into the sample, need short sub-steps
        // a delay of whole samples (the converters' own lag on a 1–5 ms grid) keeps the
        // changes at the samples: no sub-steps (measured: the step fits' time doubled when
        // the base carried that lag with sub-steps)
        let samples = r.delay_s / d.dt_s;
        let whole = (samples - samples.round()).abs() < 1e-9;
        let sub = if limited || (r.delay_s > 0.0 && !whole) {
            ((d.dt_s / MAX_SUBSTEP_S).ceil() as usize).max(1)
        } else {
            1
        };
        let h = d.dt_s / sub as f64;
        let span = r.knee_span.abs().max(1e-6);
        let sat = |s: f64| saturate(s, r.knee, span);
        // Force channels carry the measured force's scale (gain × reference), so that their
        // rate limit and saturation are in the measured newtons; converter channels are bar.
        let force_channels = d.units == Units::Force;
        let cap_span = r.cap_span.abs().max(1e-6);
        let scale: [f64; K] = std::array::from_fn(|c| d.channel_scale(r, c));
        let shaped: Vec<[f64; K]> = d.set[..n]
            .iter()
            .map(|set| {
                std::array::from_fn(|c| {
                    let s = sat(scale[c] * set[c]);
                    if r.cap_channel == Some(c) {
                        saturate(s, r.cap, cap_span)
                    } else {
                        s
                    }
                })
            })
            .collect();
        let delay = r.delay_s.max(0.0) / d.dt_s;
        let frac = 1.0 / sub as f64;
        let taps: Vec<(isize, f64)> = (0..sub)
            .map(|m| {
                let offset = m as f64 * frac - delay;
                let fl = offset.floor();
                (fl as isize, ((fl + 1.0 - offset) / frac).min(1.0))
            })
            .collect();
        let widths = if r.channel_hysteresis != 0.0 {
            turn_over(&shaped, r.channel_turn_share)
        } else {
            [1.0; K]
        };
        Plan {
            n,
            rise,
            fall,
            limited,
            sub,
            h,
            phi: SecondOrderStep::new(r.omega_n_rad_s, r.zeta, h),
            shaped,
            // Rate limits: a converter's flow limits how fast its pressure moves; without
            // the converters (force channels) the limit is on the commanded force, as in
            // §5.3's black-box view
            slew_the_command: force_channels || r.slew_command,
            taps,
            hysteresis: r.hysteresis_n != [0.0; 2],
            channel_hysteresis: r.channel_hysteresis != 0.0,
            turn_over: widths,
            force_limited: r.force_knee_n.is_finite(),
            force_span: r.force_span_n.abs().max(1e-6),
            force_slewed: r.force_rise_n_per_s.is_finite() || r.force_fall_n_per_s.is_finite(),
            force_rates: (
                r.force_rise_n_per_s.max(1e-9),
                r.force_fall_n_per_s.max(1e-9),
            ),
            // without a pose dependence the gain is a constant: a force channel's factor is
            // then exactly 1 (g / g), and the division per sample (a tenth of a step fit's
            // time, measured) is left out
            constant_gain: [0, 1].map(|a| {
                (r.gain_slope_per_rad[a] == [0.0; 2]).then(|| {
                    if force_channels {
                        1.0
                    } else {
                        r.gain[a]
                    }
                })
            }),
            force_channels,
        }
    }

    #[inline]
    fn set_at(&self, j: usize, c: usize) -> f64 {
        self.shaped[j.min(self.n - 1)][c]
    }

    /// The handle force of axis `a` at sample `i` from the channels' forces: the gain (with
    /// its pose dependence), the force saturation and the force slew limit.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn handle_force(
        &self,
        r: &Response,
        d: &Drive,
        alpha: [&[f64]; 2],
        i: usize,
        a: usize,
        forces: &[f64; K],
        slewed: &mut Option<f64>,
    ) -> f64 {
        let f = d.axis_force(i, a, forces);
        let g = if let Some(g) = self.constant_gain[a] {
            g
        } else if self.force_channels {
            let g = r.gain[a]
                + r.gain_slope_per_rad[a][0] * alpha[0][i]
                + r.gain_slope_per_rad[a][1] * alpha[1][i];
            // x already carries the gain; only its pose dependence is left
            if r.gain[a].abs() > 1e-12 {
                g / r.gain[a]
            } else {
                1.0
            }
        } else {
            r.gain[a]
                + r.gain_slope_per_rad[a][0] * alpha[0][i]
                + r.gain_slope_per_rad[a][1] * alpha[1][i]
        };
        let mut force = g * f;
        if self.force_limited {
            force = saturate(force, r.force_knee_n, self.force_span);
        }
        if self.force_slewed {
            // the largest change since the previous sample, up and down
            let since = match (d.intervals_s.as_deref(), i) {
                (Some(iv), 1..) => iv[i - 1],
                _ => d.dt_s,
            };
            let (up, down) = (self.force_rates.0 * since, self.force_rates.1 * since);
            if let Some(prev) = *slewed {
                force = bounded(force, prev - down, prev + up);
            }
            *slewed = Some(force);
        }
        force
    }

    /// Steps the channels and the hysteresis offset over sample `i`'s interval, in
    /// sub-steps, each reading its delayed set-point.
    #[inline]
    fn advance(&self, r: &Response, d: &Drive, t_s: &[f64], i: usize, st: &mut State<K>) {
        // an uneven log: each interval is stepped as it was, with its own sub-steps
        let uneven = d.intervals_s.as_deref();
        let (h, sub, phi) = match uneven {
            None => (self.h, self.sub, self.phi),
            Some(iv) => {
                let sub = if self.limited || r.delay_s > 0.0 {
                    ((iv[i] / MAX_SUBSTEP_S).ceil() as usize).max(1)
                } else {
                    1
                };
                let h = iv[i] / sub as f64;
                (h, sub, SecondOrderStep::new(r.omega_n_rad_s, r.zeta, h))
            }
        };
        let n = self.n;
        // the state and the plan's switches in locals for the sub-steps: read through `st`
        // and `self`, every sub-step loads and stores them again (measured: 7 % more
        // instructions per simulation, and the simulation is most of a step fit)
        let (mut x, mut v, mut driven) = (st.x, st.v, st.driven);
        let (mut hx, mut hv, mut z) = (st.hx, st.hv, st.z);
        let (limited, slew_the_command, hysteresis) =
            (self.limited, self.slew_the_command, self.hysteresis);
        let (rise, fall) = (self.rise, self.fall);
        for m in 0..sub {
            // the delayed sub-step, spanning at most two samples (before the first sample:
            // the first set-point): sample j with weight w_first, the rest from j + 1
            let (j, w_first) = match uneven {
                None => {
                    let (tap, w) = self.taps[m];
                    let first = i as isize + tap;
                    if first < 0 || (first == 0 && w >= 1.0) {
                        (0, 1.0)
                    } else {
                        (first as usize, w)
                    }
                }
                Some(_) => {
                    let from = t_s[i] + m as f64 * h - r.delay_s.max(0.0);
                    delayed_sample(t_s, n, from, h, &mut st.delayed_from)
                }
            };
            for c in 0..K {
                let mut s = if w_first >= 1.0 {
                    self.set_at(j, c)
                } else {
                    w_first * self.set_at(j, c) + (1.0 - w_first) * self.set_at(j + 1, c)
                };
                if limited && slew_the_command {
                    s = bounded(s, driven[c] - fall * h, driven[c] + rise * h);
                    driven[c] = s;
                }
                let (e, vc) = phi.step(x[c] - s, v[c]);
                v[c] = if limited && !slew_the_command {
                    bounded(vc, -fall, rise)
                } else {
                    vc
                };
                let before = x[c];
                x[c] = if v[c] == vc { s + e } else { x[c] + h * v[c] };
                if self.channel_hysteresis {
                    z[c] = dahl(z[c], x[c] - before, self.turn_over[c]);
                }
            }
            if hysteresis {
                for a in 0..2 {
                    let target = r.hysteresis_n[a] * d.direction[a][j.min(n - 1)];
                    let (e, va) = phi.step(hx[a] - target, hv[a]);
                    hx[a] = target + e;
                    hv[a] = va;
                }
            }
        }
        (st.x, st.v, st.driven) = (x, v, driven);
        (st.hx, st.hv, st.z) = (hx, hv, z);
    }
}

/// Dahl's direction state after a change `dx` of the level: it moves toward the sign of
/// the change, turning over a change of `width`.
#[inline]
fn dahl(z: f64, dx: f64, width: f64) -> f64 {
    let s = if dx > 0.0 { 1.0 } else { -1.0 };
    (z + dx / width * (1.0 - z * s)).clamp(-1.0, 1.0)
}

/// The change of level over which each channel's direction state turns over: `share` of the
/// span of its set-points.
fn turn_over<const K: usize>(shaped: &[[f64; K]], share: f64) -> [f64; K] {
    std::array::from_fn(|c| {
        let (lo, hi) = shaped
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
                (lo.min(s[c]), hi.max(s[c]))
            });
        (share.abs() * (hi - lo)).max(1e-6)
    })
}

/// The sample whose held set-point covers the start of the interval [from, from + h) of an
/// unevenly sampled log, and the share of the interval before the next sample's; `at` is
/// where the previous search ended (the intervals only move forward).
#[inline]
fn delayed_sample(t_s: &[f64], n: usize, from: f64, h: f64, at: &mut usize) -> (usize, f64) {
    if from < t_s[0] {
        return (0, 1.0);
    }
    while *at + 1 < n && t_s[*at + 1] <= from {
        *at += 1;
    }
    let j = *at;
    if j + 1 >= n || from + h <= t_s[j + 1] {
        (j, 1.0)
    } else {
        (j, ((t_s[j + 1] - from) / h).clamp(0.0, 1.0))
    }
}

/// `v` within [lo, hi]. Bounds that are NaN or crossed (a trial step of the fit whose rates
/// overflowed) give NaN, which the fit's cost rejects, rather than a panic.
fn bounded(v: f64, lo: f64, hi: f64) -> f64 {
    if lo <= hi {
        v.clamp(lo, hi)
    } else {
        f64::NAN
    }
}

/// The fastest rate any channel reaches under `r` in the rows that are not `held_out` (for
/// the rate limits' starting values).
pub(super) fn peak_rate(r: &Response, d: &Drive, n: usize, held_out: &HeldOut) -> f64 {
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
        let fitted = !held_out.contains(i);
        for _ in 0..sub {
            for c in 0..d.channels() {
                v[c] += h * (wn2 * (d.set[i][c] - x[c]) - c2 * v[c]);
                x[c] += h * v[c];
                if fitted {
                    peak = peak.max(v[c].abs());
                }
            }
        }
    }
    peak
}
