//! What the recording did to a log, before the loop compares models: uneven sampling (said
//! in a warning; a step trial is simulated at its logged times) and isolated spikes in the
//! measured force, which are bridged ([`pam_ident::spikes`] says what a spike is). The base is fitted once on the log as it is;
//! if its residual shows isolated spikes, the log's force is bridged at those rows and the
//! loop starts again on the cleaned log. The diagnosis says how many rows were bridged.

use serde::Serialize;

use super::{Loop, ModelFit, Settings, Warning};
use crate::effects::Experiment;
use pam_ident::spikes;
use pam_ident::trial::Trial;
use pam_model::RobotModel;
use pam_numerics::interp::linear_at;

/// Log rows from a change of the reference or the currents on that are never bridged: at
/// coarse sampling a delay or a rate limit shows as a residual burst of one or two rows at
/// each step, which would pass for a spike. Longer bursts are not isolated and stay anyway.
/// (Protecting the whole response, 0.6 s, left a quarter of the rows unguarded and the
/// spikes in them decided verdicts: measured on pam-synth's spike nuisance.)
const STEP_PROTECTED_ROWS: usize = 3;
/// Log rows on either side of a reversal of the handle's velocity that are never bridged in
/// a dynamic trial: friction's static peak (Stribeck) or a backlash's impact can last one
/// sample of a coarse log there, isolated and pointed like a spike (measured: pam-synth's
/// Stribeck friction at 20 ms). In a fast log the same peak spans many rows and is not
/// isolated, so the guard is counted in rows, not in time.
const REVERSAL_PROTECTED_ROWS: usize = 2;

/// The spikes a report lists by time.
const LISTED: usize = 5;

/// What was bridged.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SpikeReport {
    /// Log rows bridged (both axes counted once).
    pub rows: usize,
    /// The largest departure of a bridged row from the line of its neighbours, N.
    pub largest_n: f64,
    /// Times of the first few, s.
    pub first_t_s: Vec<f64>,
}

impl SpikeReport {
    pub fn warning(&self) -> Warning {
        Warning::Spikes(self.clone())
    }
}

/// What the diagnosis says about the log's sampling, if it was uneven.
pub fn sampling_warning(lp: &Loop) -> Option<Warning> {
    if lp.p.resampled() {
        return Some(Warning::Resampled);
    }
    let intervals = crate::response::uneven_intervals(&lp.p.t_s, lp.p.dt_s)?;
    let (lo, hi) = intervals
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), &h| {
            (lo.min(h), hi.max(h))
        });
    Some(Warning::UnevenSampling {
        shortest_s: lo,
        longest_s: hi,
        experiment: lp.experiment,
    })
}

/// The loop on `trial`, or on a copy with its spikes bridged when the base's residual has
/// any; the base fit of the loop returned, and what was bridged. `diagnose`, and
/// `pamctl model compare` and `fit`, start here, so their numbers agree.
pub fn loop_without_spikes<'a>(
    trial: &Trial,
    model: &'a RobotModel<f64>,
    experiment: Experiment,
    settings: Settings,
) -> Result<(Loop<'a>, ModelFit, Option<SpikeReport>), pam_ident::IdentError> {
    let lp = Loop::new(trial, model, experiment, settings)?;
    let base = lp.fit(&[]);
    let Some((cleaned, report)) = bridged(trial, &lp, &base) else {
        return Ok((lp, base, None));
    };
    let lp = Loop::new(&cleaned, model, experiment, settings)?;
    let base = lp.fit(&[]);
    Ok((lp, base, Some(report)))
}

/// The log rows that may not be bridged: in a step trial, the row before each change of the
/// reference or of a current and [`STEP_PROTECTED_ROWS`] from it; in a dynamic trial,
/// [`REVERSAL_PROTECTED_ROWS`] about each reversal of the velocity on either axis (the
/// loop's filtered velocity, interpolated to the log's rows).
fn protected_log_rows(trial: &Trial, lp: &Loop) -> Vec<bool> {
    let n = trial.len();
    let mut protected = vec![false; n];
    let mut protect = |from: usize, to: usize| {
        for p in &mut protected[from..to.min(n)] {
            *p = true;
        }
    };
    match lp.experiment {
        Experiment::Step => {
            let mut commands: Vec<&Vec<f64>> = Vec::new();
            if let Some(r) = &trial.force_ref_n {
                commands.extend(r.iter());
            }
            if let Some(c) = &trial.current_ma {
                commands.extend(c.iter());
            }
            for j in 1..n {
                if commands.iter().any(|c| c[j] != c[j - 1]) {
                    protect(j - 1, j + STEP_PROTECTED_ROWS);
                }
            }
        }
        Experiment::Dynamic => {
            // each axis's velocity at the log's rows, once
            let forward: Vec<Vec<bool>> =
                lp.p.v_m_s
                    .iter()
                    .map(|v| {
                        linear_at(&lp.p.t_s, v, &trial.t_s)
                            .into_iter()
                            .map(|x| x > 0.0)
                            .collect()
                    })
                    .collect();
            for j in 1..n {
                if forward.iter().any(|f| f[j] != f[j - 1]) {
                    protect(
                        j.saturating_sub(REVERSAL_PROTECTED_ROWS + 1),
                        j + REVERSAL_PROTECTED_ROWS,
                    );
                }
            }
        }
    }
    protected
}

/// The trial with the force bridged at its spikes, found at the log's own rows: the base's
/// prediction on the analysis grid is interpolated to every row of the log (it is smooth on
/// the grid's scale wherever it is not protected), so a spike between two grid rows of a
/// 1 kHz log, or one spread by an uneven log's resampling, is found where it is.
fn bridged(trial: &Trial, lp: &Loop, base: &ModelFit) -> Option<(Trial, SpikeReport)> {
    let protected = protected_log_rows(trial, lp);
    // the loop models −f in a dynamic trial and f in a step trial
    let sign = match lp.experiment {
        Experiment::Dynamic => -1.0,
        Experiment::Step => 1.0,
    };
    let mut cleaned = trial.clone();
    let mut largest: f64 = 0.0;
    let mut all: Vec<usize> = Vec::new();
    for &a in &base.axes {
        let measured: Vec<f64> = trial.force_n[a].iter().map(|f| sign * f).collect();
        let residual: Vec<f64> = measured
            .iter()
            .zip(linear_at(&lp.p.t_s, &base.predicted[a], &trial.t_s))
            .map(|(m, p)| m - p)
            .collect();
        let rows = spikes::spikes(&measured, &residual, &|j| protected[j]);
        if rows.is_empty() {
            continue;
        }
        let before = cleaned.force_n[a].clone();
        spikes::bridge(&mut cleaned.force_n[a], &rows);
        for &j in &rows {
            largest = largest.max((before[j] - cleaned.force_n[a][j]).abs());
        }
        all.extend(rows);
    }
    if all.is_empty() {
        return None;
    }
    all.sort_unstable();
    all.dedup();
    let report = SpikeReport {
        rows: all.len(),
        largest_n: largest,
        first_t_s: all.iter().take(LISTED).map(|&j| trial.t_s[j]).collect(),
    };
    Some((cleaned, report))
}
