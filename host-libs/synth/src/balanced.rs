//! A balanced plan of cases: the draw every accuracy run of the model loop starts from.

use crate::case::{CaseSpec, Experiment, Family, Shape, MAX_SAMPLES, PERIODS_S, TONE_MAX_PERIOD_S};

/// A balanced plan of `n` cases from seed `seed0`: every fourth a control, the others
/// cycling over every (experiment, shape) of the effect families and `unexplained`.
pub fn plan(n: usize, seed0: u64, experiment: Option<Experiment>) -> Vec<CaseSpec> {
    let exps: Vec<Experiment> = match experiment {
        Some(e) => vec![e],
        None => Experiment::ALL.to_vec(),
    };
    // alternate the experiments so a short plan covers both
    let per_exp: Vec<Vec<(Experiment, Shape)>> = exps
        .iter()
        .map(|&e| {
            Shape::ALL
                .into_iter()
                .filter(|s| *s != Shape::Control && s.experiments().contains(&e))
                .map(|s| (e, s))
                .collect()
        })
        .collect();
    let longest = per_exp.iter().map(Vec::len).max().unwrap_or(0);
    let mut slots: Vec<(Experiment, Shape)> = Vec::new();
    for k in 0..longest {
        for list in &per_exp {
            slots.push(list[k % list.len()]);
        }
    }
    let mut out = Vec::with_capacity(n);
    let (mut k_effect, mut k_control) = (0usize, 0usize);
    for i in 0..n {
        let seed = seed0 + i as u64;
        let spec = if i % 4 == 3 {
            let e = exps[k_control % exps.len()];
            k_control += 1;
            CaseSpec::random(seed, Some(e), Some(Family::None))
        } else {
            let (e, s) = slots[k_effect % slots.len()];
            k_effect += 1;
            CaseSpec::random(seed, Some(e), Some(s.family())).and_then(|mut c| {
                if s.needs_fast_sampling() && c.dt_s > TONE_MAX_PERIOD_S {
                    c.dt_s = PERIODS_S[(seed % 3) as usize];
                    c.duration_s = c.duration_s.min(MAX_SAMPLES as f64 * c.dt_s).round();
                }
                c.with_shape(s)
            })
        };
        out.push(spec.expect("every planned case is valid"));
    }
    out
}
