//! What the encoders' resolution puts in the force residual. An encoder reports its angle in
//! whole counts. While the handle moves, the rounding error changes from row to row and
//! looks like noise. While the handle rests (a reach-and-hold task, a pause), the error is
//! frozen for the whole rest. The model then predicts the force of the rounded angle, so
//! the residual takes a new level at every rest: a "wander" as large as the stiffness times
//! a fraction of a count. Such a wander is not structure the model misses, and the data
//! cannot tell it from one that is. [`encoder_floor`] gives the size the wander test finds
//! in that rounding alone, per axis, from the log's own lattice of angles, the runs of rows
//! that hold a count, and the fitted model's sensitivity to the angles.

use nalgebra::{DMatrix, DVector};

use super::Loop;
use super::ModelFit;
use crate::effects::Experiment;

/// Least number of moves of an encoder (rows whose angle changed) to judge its lattice.
const MIN_MOVES: usize = 50;
/// A move must be a whole number of counts to within this share of a count...
const LATTICE_TOLERANCE: f64 = 0.05;
/// ...in this share of the moves (an interpolated angle is not on a lattice).
const LATTICE_SHARE: f64 = 0.98;

/// The count of an encoder whose angles lie on a lattice, rad: the largest step whose
/// whole multiples are (nearly) all the log's moves. `None` when the angle does not move
/// often enough to tell, or is not quantised (an interpolating encoder, a simulation's
/// exact angle).
pub fn encoder_step_rad(alpha_rad: &[f64]) -> Option<f64> {
    let moves: Vec<f64> = alpha_rad
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 1e-12)
        .collect();
    if moves.len() < MIN_MOVES {
        return None;
    }
    let smallest = moves.iter().cloned().fold(f64::INFINITY, f64::min);
    // the smallest move may be two or more counts when the angle never moves by one
    (1..=4).map(|k| smallest / k as f64).find(|&q| {
        let on = moves
            .iter()
            .filter(|&&d| {
                let r = d / q;
                (r - r.round()).abs() <= LATTICE_TOLERANCE
            })
            .count();
        on as f64 >= LATTICE_SHARE * moves.len() as f64
    })
}

/// Draws of the rounding behind [`EncoderFloor::bound_n`]: its largest is about the
/// 99.5 % quantile of the wander the rounding alone gives.
pub(super) const DRAWS: usize = 200;
/// The draws' seed: the same log gets the same floor.
const DRAW_SEED: u64 = 0x5eed_0fc0_u64;

/// Each row's run of a held count: a new index wherever the angle changes.
pub fn held_runs(alpha_rad: &[f64]) -> (Vec<usize>, usize) {
    let mut run = 0;
    let index = alpha_rad
        .iter()
        .enumerate()
        .map(|(i, a)| {
            if i > 0 && *a != alpha_rad[i - 1] {
                run += 1;
            }
            run
        })
        .collect();
    (index, if alpha_rad.is_empty() { 0 } else { run + 1 })
}

/// The encoders' rounding, seen in the level of the force residual.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderFloor {
    /// Each joint's count, rad (0 where it was not found).
    pub step_rad: [f64; 2],
    /// The count's force per handle axis (rows) and joint (columns): the fitted model's
    /// sensitivity to the angle times the count, N.
    pub count_force_n: [[f64; 2]; 2],
    /// The wander amplitude the wander test finds in the rounding alone, RMS over the
    /// draws, per handle axis, N.
    pub expected_n: [f64; 2],
    /// The largest of the draws, N.
    pub bound_n: [f64; 2],
}

/// The encoders' rounding through the model `fit` of a dynamic trial. The sensitivity: the
/// fit's prediction regressed on the joints' displacements (with the handle's velocity,
/// acceleration and a constant, so that the motion's other terms do not leak into it). The
/// rounding: an error uniform over ± half a count, drawn once for each run of rows that
/// holds a count (independent from run to run), through the sensitivity, and put through
/// the wander test as the residual would be, [`DRAWS`] times. `None` for a step trial (the
/// angle does not move), when neither encoder shows a lattice, or when the regression is
/// singular.
pub fn encoder_floor(lp: &Loop, fit: &ModelFit) -> Option<EncoderFloor> {
    use rand::{Rng, SeedableRng};
    if lp.experiment != Experiment::Dynamic {
        return None;
    }
    let p = &lp.p;
    // the encoders' counts are in the angles as logged: a resampled trial keeps them aside,
    // and the rounding drawn at the logged rows is interpolated to the trial's as its
    // angles were
    let (rows_t_s, rows_alpha) = match &p.logged_angles {
        Some(l) => (Some(&l.t_s), &l.alpha_rad),
        None => (None, &p.alpha_rad),
    };
    let step_rad = [0, 1].map(|j| encoder_step_rad(&rows_alpha[j]).unwrap_or(0.0));
    if step_rad.iter().all(|q| *q == 0.0) {
        return None;
    }
    let n = p.len();
    let cols: [&dyn Fn(usize) -> f64; 7] = [
        &|i| p.alpha_smooth_rad[0][i] - p.alpha0_rad[0],
        &|i| p.alpha_smooth_rad[1][i] - p.alpha0_rad[1],
        &|i| p.v_m_s[0][i],
        &|i| p.v_m_s[1][i],
        &|i| p.a_m_s2[0][i],
        &|i| p.a_m_s2[1][i],
        &|_| 1.0,
    ];
    // scaled to unit norm, so the solver's tolerance means the same for every column
    let mut xs = DMatrix::from_fn(n, cols.len(), |i, c| cols[c](i));
    let norms: Vec<f64> = (0..cols.len())
        .map(|c| {
            let norm = xs.column(c).norm().max(1e-300);
            xs.column_mut(c).scale_mut(1.0 / norm);
            norm
        })
        .collect();
    let svd = xs.svd(true, true);
    let mut count_force_n = [[0.0; 2]; 2];
    for (a, row) in count_force_n.iter_mut().enumerate() {
        let y = DVector::from_column_slice(&fit.predicted[a]);
        let theta = svd.solve(&y, 1e-10).ok()?;
        *row = [0, 1].map(|j| theta[j] / norms[j] * step_rad[j]);
    }
    if !count_force_n.iter().flatten().all(|f| f.is_finite()) {
        return None;
    }
    let runs = [0, 1].map(|j| held_runs(&rows_alpha[j]));
    let rows = rows_alpha[0].len();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(DRAW_SEED);
    let mut sum_sq = [0.0; 2];
    let mut bound_n = [0.0f64; 2];
    let mut r = vec![0.0; rows];
    for _ in 0..DRAWS {
        // one error per held run of each joint, in counts
        let errors = [0, 1].map(|j| {
            (0..runs[j].1)
                .map(|_| rng.random_range(-0.5..0.5))
                .collect::<Vec<f64>>()
        });
        for (a, row) in count_force_n.iter().enumerate() {
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = row[0] * errors[0][runs[0].0[i]] + row[1] * errors[1][runs[1].0[i]];
            }
            let on_trial = rows_t_s.map(|t| pam_numerics::interp::linear_at(t, &r, &p.t_s));
            let amp = pam_numerics::stats::wander_test(on_trial.as_deref().unwrap_or(&r))
                .map_or(0.0, |w| w.amplitude_n);
            sum_sq[a] += amp * amp;
            bound_n[a] = bound_n[a].max(amp);
        }
    }
    Some(EncoderFloor {
        step_rad,
        count_force_n,
        expected_n: sum_sq.map(|s| (s / DRAWS as f64).sqrt()),
        bound_n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lattice_of_a_quantised_angle_is_found_and_an_exact_one_has_none() {
        let q = 2.0 * std::f64::consts::PI / 8000.0;
        let exact: Vec<f64> = (0..2000)
            .map(|i| 0.3 + 0.02 * (i as f64 * 0.01).sin())
            .collect();
        let counted: Vec<f64> = exact.iter().map(|a| (a / q).round() * q).collect();
        let found = encoder_step_rad(&counted).expect("a lattice");
        assert!((found / q - 1.0).abs() < 1e-9, "{found} against {q}");
        assert_eq!(encoder_step_rad(&exact), None);
        // written with six decimals, as a rig's CSV might: still found
        let rounded: Vec<f64> = counted.iter().map(|a| (a * 1e6).round() / 1e6).collect();
        let found = encoder_step_rad(&rounded).expect("a lattice at six decimals");
        assert!((found / q - 1.0).abs() < 1e-3);
        // a fast angle that never moves by a single count: the count, not twice it
        let fast: Vec<f64> = (0..400).map(|i| ((5 * i) / 2) as f64 * q).collect();
        let found = encoder_step_rad(&fast).expect("a lattice");
        assert!((found / q - 1.0).abs() < 1e-9, "{found}");
        // a resting angle has too few moves to judge
        assert_eq!(encoder_step_rad(&vec![0.1; 500]), None);
    }

    #[test]
    fn runs_change_where_the_angle_does() {
        let (index, runs) = held_runs(&[0.1, 0.1, 0.2, 0.2, 0.2, 0.1]);
        assert_eq!(index, vec![0, 0, 1, 1, 1, 2]);
        assert_eq!(runs, 3);
        assert_eq!(held_runs(&[]), (vec![], 0));
    }
}
