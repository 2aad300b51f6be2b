//! Simulation of a step trial: the (delayed, rate-limited, saturated) set-points through
//! each converter's second order to the handle force.

use super::*;

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
    let cap_span = r.cap_span.abs().max(1e-6);
    let set_at = |j: usize, c: usize| {
        let s = sat(d.channel_scale(r, c) * d.set[j.min(n - 1)][c]);
        if r.cap_channel == Some(c) {
            saturate(s, r.cap, cap_span)
        } else {
            s
        }
    };
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
pub(super) fn peak_rate(r: &Response, d: &Drive, n: usize) -> f64 {
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
