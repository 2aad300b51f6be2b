use super::*;
use pam_ident::held_out::HeldOut;

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
            intervals_s: None,
            prior_zeta_omega: (0.42, 23.04),
            own_lag_s: 0.0,
        },
        t,
    )
}

/// A drive of `d`'s rows at `rows` only (a log sampled there), simulated at those times.
fn at_rows(d: &Drive, t: &[f64], rows: &[usize]) -> (Drive, Vec<f64>) {
    let pick = |v: &Vec<f64>| rows.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    let t_rows: Vec<f64> = rows.iter().map(|&i| t[i]).collect();
    let dt = (t_rows[t_rows.len() - 1] - t_rows[0]) / (rows.len() - 1) as f64;
    (
        Drive {
            set: rows.iter().map(|&i| d.set[i]).collect(),
            coeff: rows.iter().map(|&i| d.coeff[i]).collect(),
            direction: [pick(&d.direction[0]), pick(&d.direction[1])],
            dt_s: dt,
            intervals_s: uneven_intervals(&t_rows, dt),
            ..d.clone()
        },
        t_rows,
    )
}

/// An unevenly sampled log (intervals of 14–26 ms, every step at a logged row) is simulated
/// at its own times: it follows a 1 ms simulation of the same drive at those times, with a
/// delay and a rate limit; and evenly spaced rows give the even path's numbers.
#[test]
fn uneven_rows_are_simulated_at_their_times() {
    let dt = 0.001;
    let mut rows = vec![0usize];
    let gaps = [14, 26, 19, 22, 17, 25, 15, 21, 18, 23];
    while *rows.last().unwrap() < 5900 {
        let next = rows.last().unwrap() + gaps[rows.len() % gaps.len()];
        rows.push(next);
    }
    // steps of the set-point at logged rows
    let (s1, s2) = (rows[40], rows[150]);
    let set: Vec<f64> = (0..6000)
        .map(|i| match i {
            _ if i < s1 => 0.0,
            _ if i < s2 => 10.0,
            _ => -4.0,
        })
        .collect();
    let (fine, t) = force_drive(set, dt);
    let mut r = Response::base(0.42, 23.04, [1.0, 1.0]);
    r.delay_s = 0.031;
    r.rise_per_s = 40.0;
    let want = simulate_x(&r, &fine, &t);
    let (d, t_rows) = at_rows(&fine, &t, &rows);
    assert!(d.intervals_s.is_some());
    let worst = worst_at(&simulate_x(&r, &d, &t_rows), &want, &rows);
    // the yardstick: evenly sampled rows at the mean period, against the same reference
    // (sub-steps of 1.75–2 ms against 1 ms ones differ under a rate limit and a delay)
    let even_rows: Vec<usize> = (0..300).map(|k| 20 * k).collect();
    let set_even: Vec<f64> = (0..6000)
        .map(|i| match i {
            _ if i < 800 => 0.0,
            _ if i < 3000 => 10.0,
            _ => -4.0,
        })
        .collect();
    let (fine_even, _) = force_drive(set_even, dt);
    let (de, te) = at_rows(&fine_even, &t, &even_rows);
    let yardstick = worst_at(
        &simulate_x(&r, &de, &te),
        &simulate_x(&r, &fine_even, &t),
        &even_rows,
    );
    assert!(
        worst < 0.1 && worst < 2.0 * yardstick,
        "worst {worst} on steps of 10 and 14, evenly sampled {yardstick}"
    );
    // the same rows taken as evenly spaced are wrong by far more (what the loop did)
    let even = Drive {
        intervals_s: None,
        ..d.clone()
    };
    let worst_even = worst_at(&simulate_x(&r, &even, &t_rows), &want, &rows);
    assert!(worst_even > 10.0 * worst, "{worst_even} against {worst}");
    // even rows through the uneven path: the even path's numbers
    let (d, t_even) = at_rows(&fine, &t, &(0..300).map(|k| 20 * k).collect::<Vec<_>>());
    assert!(d.intervals_s.is_none());
    let forced = Drive {
        intervals_s: Some(vec![0.02; 300]),
        ..d.clone()
    };
    let (a, b) = (
        simulate_x(&r, &d, &t_even),
        simulate_x(&r, &forced, &t_even),
    );
    for k in 0..300 {
        assert!((a[k] - b[k]).abs() < 1e-6, "row {k}: {} {}", a[k], b[k]);
    }
}

/// The x axis of `d` simulated under `r` at the times `t` (at rest in y and at α = 0).
fn simulate_x(r: &Response, d: &Drive, t: &[f64]) -> Vec<f64> {
    let n = t.len();
    let zero = vec![0.0; n];
    let mut out = [vec![0.0; n], vec![0.0; n]];
    simulate(r, d, t, [&zero, &zero], n, &mut out);
    let [x, _] = out;
    x
}

/// The largest difference between `got` (one value per row) and `want` at those rows.
fn worst_at(got: &[f64], want: &[f64], rows: &[usize]) -> f64 {
    rows.iter()
        .zip(got)
        .map(|(&i, g)| (g - want[i]).abs())
        .fold(0.0, f64::max)
}

/// The x-axis response of `truth` to the force drive `d` as a prepared trial (noiseless).
fn x_axis_trial(truth: &Response, d: &Drive, t: &[f64]) -> Prepared {
    let zero = vec![0.0; t.len()];
    let trial = pam_ident::Trial {
        t_s: t.to_vec(),
        alpha_rad: [zero.clone(), zero.clone()],
        force_n: [simulate_x(truth, d, t), zero.clone()],
        force_ref_n: Some([d.set.iter().map(|s| s[0]).collect(), zero.clone()]),
        current_ma: None,
    };
    trial
        .prepare(&RobotModel::thesis(), Default::default())
        .unwrap()
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
        let p = x_axis_trial(&truth, &d, &t);
        let start = Response::base(0.6, 18.0, [1.0, 1.0]);
        let f = fit(&p, &d, &start, extras, &[0], &HeldOut::nothing(n));
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

/// A force drive at 2 ms through eight levels twice, 1.5 s each: rises and falls of every
/// size, each level reached from above and from below.
fn eight_levels_twice() -> (Drive, Vec<f64>) {
    let mut set = Vec::new();
    for k in 0..16 {
        let level = [4.0, 12.0, 8.0, 20.0, 14.0, 6.0, 18.0, 10.0][k % 8];
        set.extend(std::iter::repeat_n(level, 750));
    }
    force_drive(set, 0.002)
}

/// `extra` fitted to `truth`'s x-axis response to [`eight_levels_twice`] (noiseless, every
/// row fitted), from a base away from the truth's.
fn fit_eight_levels(truth: &Response, extra: StepExtra) -> Response {
    let (d, t) = eight_levels_twice();
    let p = x_axis_trial(truth, &d, &t);
    fit(
        &p,
        &d,
        &Response::base(0.6, 18.0, [1.0, 1.0]),
        &[extra],
        &[0],
        &HeldOut::nothing(t.len()),
    )
}

/// A hysteresis of each channel in proportion to its level: a step settles short by that
/// share of the level it reaches, in the direction it came from; the fit recovers the share.
#[test]
fn fit_recovers_a_hysteresis_in_proportion_to_the_level() {
    let (d, t) = eight_levels_twice();
    let n = t.len();
    // a converter without overshoot: the direction state ends where the step went
    let truth = Response {
        channel_hysteresis: 0.05,
        ..Response::base(0.95, 23.04, [0.9, 1.0])
    };
    // a step settles 5 % of its level short after a rise (12, row 1499) and over after a
    // fall (8, row 2249)
    let y = simulate_x(&truth, &d, &t);
    assert!(y[1499] < 0.9 * 12.0 * 0.97, "{}", y[1499]);
    assert!(y[2249] > 0.9 * 8.0 * 1.03, "{}", y[2249]);
    let p = x_axis_trial(&truth, &d, &t);
    let start = Response::base(0.6, 18.0, [1.0, 1.0]);
    let f = fit(
        &p,
        &d,
        &start,
        &[StepExtra::ChannelHysteresis],
        &[0],
        &HeldOut::nothing(n),
    );
    assert!(
        (f.channel_hysteresis - 0.05).abs() < 0.005
            && (f.channel_turn_share - 0.02).abs() < 0.004
            && (f.gain[0] - 0.9).abs() < 0.01,
        "{f:?}"
    );
}

/// A cap on one channel: only that channel's large set-points fall short; the fit finds
/// which channel and where the cap sits, and leaves the other channel alone.
#[test]
fn a_cap_on_one_channel_is_found_on_that_channel() {
    let dt = 0.002;
    let levels = [0.0, 8.0, -8.0, 16.0, 12.0, -12.0, 20.0, -20.0];
    let (mut sx, mut sy) = (Vec::new(), Vec::new());
    for k in 0..16 {
        sx.extend(std::iter::repeat_n(levels[k % 8], 750));
        sy.extend(std::iter::repeat_n(levels[(k + 3) % 8], 750));
    }
    let (mut d, t) = force_drive(sx.clone(), dt);
    let n = t.len();
    d.set = sx
        .iter()
        .zip(&sy)
        .map(|(&x, &y)| [x, y, 0.0, 0.0])
        .collect();
    let zero = vec![0.0; n];
    let truth = Response {
        cap_channel: Some(1),
        cap: 10.0,
        cap_span: 1.0,
        ..Response::base(0.42, 23.04, [1.0, 1.0])
    };
    let mut y = [vec![0.0; n], vec![0.0; n]];
    simulate(&truth, &d, &t, [&zero, &zero], n, &mut y);
    // the capped channel falls short on its largest steps only, the other follows
    let i_high = (0..n).find(|&i| sy[i] == 20.0).unwrap() + 700;
    assert!((y[1][i_high] - 11.0).abs() < 0.1, "{}", y[1][i_high]);
    let i_x = (0..n).find(|&i| sx[i] == 20.0).unwrap() + 700;
    assert!((y[0][i_x] - 20.0).abs() < 0.05, "{}", y[0][i_x]);
    let trial = pam_ident::Trial {
        t_s: t.clone(),
        alpha_rad: [zero.clone(), zero.clone()],
        force_n: y.clone(),
        force_ref_n: Some([sx.clone(), sy.clone()]),
        current_ma: None,
    };
    let p = trial
        .prepare(&RobotModel::thesis(), Default::default())
        .unwrap();
    let start = Response::base(0.6, 18.0, [1.0, 1.0]);
    let f = fit(
        &p,
        &d,
        &start,
        &[StepExtra::ChannelCap],
        &[0, 1],
        &HeldOut::nothing(n),
    );
    assert_eq!(f.cap_channel, Some(1), "{f:?}");
    assert!((f.cap - 10.0).abs() < 0.3, "cap {}", f.cap);
    assert!(
        (f.cap + f.cap_span - 11.0).abs() < 0.3,
        "max {}",
        f.cap + f.cap_span
    );
    let named = f.extra_params(StepExtra::ChannelCap, Units::Force, &[0, 1]);
    assert_eq!(named[0], ("axis".to_string(), 2.0));
}

/// Limits on the measured handle force, with a rig's gain well below 1: a saturation
/// (knee and maximum in measured newtons) and a slew (N/s up and down) are recovered from
/// a start at the base's gain, as the diagnosis starts them.
#[test]
fn fit_recovers_limits_of_the_measured_force() {
    let dt = 0.005;
    let mut set = Vec::new();
    for k in 0..16 {
        let level = [0.0, 8.0, -8.0, 16.0, 12.0, -12.0, 24.0, -24.0][k % 8];
        set.extend(std::iter::repeat_n(level, 300));
    }
    let (d, t) = force_drive(set, dt);
    let n = t.len();
    let base = Response::base(0.42, 23.04, [0.55, 1.0]);
    let saturated = Response {
        force_knee_n: 8.0,
        force_span_n: 1.5,
        ..base
    };
    let slewed = Response {
        force_rise_n_per_s: 30.0,
        force_fall_n_per_s: 18.0,
        ..base
    };
    for (extra, truth) in [
        (StepExtra::ForceSaturation, saturated),
        (StepExtra::ForceSlew, slewed),
    ] {
        let p = x_axis_trial(&truth, &d, &t);
        // the base fitted without the limit: its gain is the rig's
        let start = Response::base(0.5, 20.0, [0.5, 1.0]);
        let f = fit(&p, &d, &start, &[extra], &[0], &HeldOut::nothing(n));
        let checks = match extra {
            StepExtra::ForceSaturation => vec![
                ("knee", f.force_knee_n, 8.0),
                ("max", f.force_knee_n + f.force_span_n, 9.5),
            ],
            _ => vec![
                ("rise", f.force_rise_n_per_s, 30.0),
                ("fall", f.force_fall_n_per_s, 18.0),
            ],
        };
        for (name, got, want) in checks.into_iter().chain([("gain", f.gain[0], 0.55)]) {
            assert!(
                (got - want).abs() < 0.05 * want,
                "{extra:?} {name}: {got} vs {want}; {f:?}"
            );
        }
    }
}

/// A term that never turns over within the channel's levels is a curvature of the force in
/// the level's travel, not a hysteresis: the fit holds the turn-over within half the span.
#[test]
fn a_hysteresis_turns_over_within_half_the_channels_span() {
    // a state that turns over five spans: within the levels, a smooth function of the travel
    let truth = Response {
        channel_hysteresis: 0.5,
        channel_turn_share: 5.0,
        ..Response::base(0.95, 23.04, [0.9, 1.0])
    };
    let f = fit_eight_levels(&truth, StepExtra::ChannelHysteresis);
    assert!(
        f.channel_turn_share <= super::params::MAX_TURN_OVER_SHARE + 1e-12,
        "{f:?}"
    );
}

/// A compression of every level is a gain and a curvature, not a supply that runs out: the
/// fit holds a saturation's span within the levels, and one channel's cap at or above that
/// channel's lowest level.
#[test]
fn a_saturation_levels_off_within_the_levels() {
    // every level compressed alike, from zero: no level is reached without it
    let all = Response {
        knee: 0.0,
        knee_span: 30.0,
        ..Response::base(0.95, 23.04, [1.0, 1.0])
    };
    let one = Response {
        cap_channel: Some(0),
        cap: 0.0,
        cap_span: 30.0,
        ..Response::base(0.95, 23.04, [1.0, 1.0])
    };
    for (extra, truth) in [(StepExtra::Saturation, all), (StepExtra::ChannelCap, one)] {
        let f = fit_eight_levels(&truth, extra);
        // the levels run from 4 to 20 (at the start's gain, which scales force channels)
        let within = match extra {
            StepExtra::Saturation => f.knee_span <= 16.0 + 1e-9,
            _ => f.cap_channel == Some(0) && f.cap >= 4.0 - 1e-9 && f.cap_span <= 16.0 + 1e-9,
        };
        assert!(within, "{extra:?}: {f:?}");
    }
}
