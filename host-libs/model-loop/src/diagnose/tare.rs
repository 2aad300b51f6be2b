//! The load cell's tare in its own frame. The cell turns with the handle (by α₁ + α₂): a
//! tare error is a constant force in the cell's frame and, in the user's, a force that
//! turns with the pose. Its constant part is the base's offset per axis; its turning part
//! is a force proportional to the handle's rotation that no stiffness form holds (it is
//! not symmetric), which a drift in the sensor frame or a pose dependence would otherwise
//! take up. It is a sensor's nuisance, not an effect: part of the base alone when the data
//! asks for it (a drift's offset in the sensor frame is the tare itself, and a pose
//! dependence turns with the pose much as it does: in one fit with either it would be
//! collinear).

use super::base::BaseVariant;
use pam_ident::msd;
use pam_ident::trial::Prepared;
use pam_model::RobotModel;
use pam_numerics::lsq;
use pam_numerics::lsq::Column;
use pam_numerics::stats::rms;

/// The largest tare offset in the load cell's frame a log may carry, N per axis: the
/// device's bound on the force at a tare.
const TARE_MAX_N: f64 = 5.0;

/// The tare taken out of a dynamic trial's force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorTare {
    /// The tare in the load cell's frame (X, Z), N.
    pub sensor_n: [f64; 2],
    /// RMS of its turning part over the trial, per handle axis, N.
    pub turning_rms_n: [f64; 2],
    /// The share of the base's training residual it removes.
    pub gain: f64,
}

/// The turning part of a unit tare along each of the cell's axes, per handle axis and row:
/// the tare as the user's frame sees it, less its mean over the trial (the base's offsets
/// hold the mean).
fn turning_parts(p: &Prepared, model: &RobotModel<f64>) -> [[Vec<f64>; 2]; 2] {
    let n = p.len();
    let mut parts = [[vec![0.0; n], vec![0.0; n]], [vec![0.0; n], vec![0.0; n]]];
    for i in 0..n {
        let alpha = [p.alpha_rad[0][i], p.alpha_rad[1][i]];
        for (j, part) in parts.iter_mut().enumerate() {
            let mut e = [0.0; 2];
            e[j] = 1.0;
            let u = model.kinematics.sensor_to_user(alpha, e);
            part[0][i] = u[0];
            part[1][i] = u[1];
        }
    }
    for part in parts.iter_mut() {
        for axis in part.iter_mut() {
            let m = axis.iter().sum::<f64>() / n.max(1) as f64;
            axis.iter_mut().for_each(|v| *v -= m);
        }
    }
    parts
}

/// Adds the tare's turning part to the dynamic base's variants (before their offsets; the
/// fits with effects leave it out, see [`super::Loop::assemble`])
/// when it pays by the information criterion, counted on the residual's `n_eff`
/// independent samples, on top of the variant the base alone prefers. `None` (and the
/// variants unchanged) when it does not: a log without a turning tare keeps its base.
pub(super) fn add_tare(
    p: &Prepared,
    model: &RobotModel<f64>,
    variants: &mut [BaseVariant],
    n_eff: f64,
) -> Option<SensorTare> {
    let rows = 0..p.split();
    if rows.len() < 20 {
        return None;
    }
    let y = msd::target(p);
    let target = [y[0].as_slice(), y[1].as_slice()];
    let yty: f64 = (0..2)
        .map(|a| y[a][rows.clone()].iter().map(|v| v * v).sum::<f64>())
        .sum();
    let n = n_eff.max(10.0);
    let criterion = |rss: f64, k: usize| n * rss.max(1e-300).ln() + k as f64 * n.ln();
    // the variant (with offsets) the base alone prefers
    let (best, rss0) = variants
        .iter()
        .enumerate()
        .filter(|(_, v)| v.offset)
        .map(|(i, v)| {
            let th = lsq::solve(&v.normal, &v.positive());
            let k = v.cols.len() + usize::from(v.pneumatic.0 > 0.0);
            (i, lsq::rss(&v.normal, yty, &th), k)
        })
        .min_by(|a, b| criterion(a.1, a.2).total_cmp(&criterion(b.1, b.2)))
        .map(|(i, rss, _)| (i, rss))?;
    let parts = turning_parts(p, model);
    // in −f, as the offsets
    let neg = |v: &Vec<f64>| v.iter().map(|x| -x).collect::<Vec<f64>>();
    let tare_cols: Vec<Column> = ["tare_n_sensor_x", "tare_n_sensor_z"]
        .iter()
        .enumerate()
        .map(|(j, name)| Column::both(*name, neg(&parts[j][0]), neg(&parts[j][1])))
        .collect();
    let with = |v: &BaseVariant| {
        let mut cols = v.cols.clone();
        let at = cols.len() - 2;
        cols.splice(at..at, tare_cols.iter().cloned());
        cols
    };
    let cols = with(&variants[best]);
    let ne = lsq::normal_equations(&cols, &target, rows.clone());
    let th = lsq::solve(&ne, &variants[best].positive());
    let rss1 = lsq::rss(&ne, yty, &th);
    if !(rss1.is_finite() && n * (rss1 / rss0.max(1e-300)).max(1e-300).ln() + 2.0 * n.ln() < 0.0) {
        return None;
    }
    let at = variants[best].cols.len() - 2;
    let sensor_n = [th[at], th[at + 1]];
    // a tare left in the cell's frame is what the handle carried when it was tared, and the
    // device refuses a tare above 5 N on either axis (`pam_device::calibration::
    // TARE_MAX_FORCE_N`): a larger fit is the columns standing in for something else
    if !sensor_n.iter().all(|f| f.abs() <= TARE_MAX_N) {
        return None;
    }
    let turning_rms_n = [0, 1].map(|a| {
        let turning: Vec<f64> = (0..p.len())
            .map(|i| sensor_n[0] * parts[0][a][i] + sensor_n[1] * parts[1][a][i])
            .collect();
        rms(&turning)
    });
    for v in variants.iter_mut().filter(|v| v.offset) {
        v.cols = with(v);
        v.normal = lsq::normal_equations(&v.cols, &target, rows.clone());
        v.tare = true;
    }
    Some(SensorTare {
        sensor_n,
        turning_rms_n,
        gain: 1.0 - rss1 / rss0.max(1e-300),
    })
}
