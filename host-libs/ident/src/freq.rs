//! Frequency-domain identification (§4.4): single-sided amplitude spectra of force and
//! velocity, and the impedance fit of eq. 4.35 extended to two coupled axes,
//! |Fx| = Z1|Vx| + Z3|Vy|, |Fy| = Z3|Vx| + Z2|Vy|, Z_i = √((b_i ω)² + (k_i − m_i ω²)²)/ω,
//! started from the time-domain result and limited to a band (22 rad/s in the thesis).

use crate::msd::{self, matrix_report, sym, AxisScore, MatrixReport};
use crate::trial::Prepared;
use pam_numerics::lm::{self, LmSummary};
use pam_numerics::spectrum::amplitude_spectrum;
use serde::Serialize;
use std::f64::consts::PI;

#[derive(Clone, Debug, Serialize)]
pub struct FreqFit {
    pub band_rad_s: f64,
    pub bins: usize,
    pub matrices: Vec<MatrixReport>,
    /// R² of the spectral magnitudes in the band (Table 4.4), per axis.
    pub r2_spectrum: [f64; 2],
    /// The time-domain scores of these parameters on the held-out 20 % (Fig. 4.13–4.14).
    pub test: [AxisScore; 2],
    pub start: Vec<MatrixReport>,
    /// How the Levenberg–Marquardt fit ended (a fit that ran out of iterations is still
    /// reported, with this saying so).
    pub lm: LmSummary,
    #[serde(skip)]
    pub omega: Vec<f64>,
    #[serde(skip)]
    pub force_amp: [Vec<f64>; 2],
    #[serde(skip)]
    pub model_amp: [Vec<f64>; 2],
}

fn impedance(m: f64, b: f64, k: f64, w: f64) -> f64 {
    ((b * w).powi(2) + (k - m * w * w).powi(2)).sqrt() / w
}

fn model_amp(th: &[f64], w: f64, vx: f64, vy: f64) -> [f64; 2] {
    // th = m1 m3 m2 b1 b3 b2 k1 k3 k2 (eq. 4.30 order)
    let z1 = impedance(th[0], th[3], th[6], w);
    let z3 = impedance(th[1], th[4], th[7], w);
    let z2 = impedance(th[2], th[5], th[8], w);
    [z1 * vx + z3 * vy, z3 * vx + z2 * vy]
}

/// `start` = the nine time-domain parameters.
pub fn fit(p: &Prepared, start: &[f64], band_rad_s: f64) -> Result<FreqFit, crate::IdentError> {
    let s = p.split();
    let f = msd::target(p);
    let fx = amplitude_spectrum(&f[0][..s], p.dt_s);
    let fy = amplitude_spectrum(&f[1][..s], p.dt_s);
    let vx = amplitude_spectrum(&p.v_m_s[0][..s], p.dt_s);
    let vy = amplitude_spectrum(&p.v_m_s[1][..s], p.dt_s);
    let idx: Vec<usize> = (1..fx.freq_hz.len())
        .filter(|&k| 2.0 * PI * fx.freq_hz[k] <= band_rad_s)
        .collect();
    if idx.len() < 10 {
        return Err(crate::IdentError::TooFewBins {
            bins: idx.len(),
            band_rad_s,
        });
    }
    let omega: Vec<f64> = idx.iter().map(|&k| 2.0 * PI * fx.freq_hz[k]).collect();
    let n = idx.len();
    let resid = |th: &[f64], r: &mut [f64]| {
        for (j, &k) in idx.iter().enumerate() {
            let a = model_amp(th, omega[j], vx.amplitude[k], vy.amplitude[k]);
            r[j] = a[0] - fx.amplitude[k];
            r[n + j] = a[1] - fy.amplitude[k];
        }
    };
    let lower = [(3, 0.0), (5, 0.0), (6, 0.0), (8, 0.0)];
    let report = lm::minimize(start, &lower, 2 * n, 200, resid);
    if !report.is_finite() {
        return Err(crate::IdentError::FitNotFinite {
            fit: "frequency",
            termination: report.termination,
        });
    }
    let theta = &report.theta;
    let mut model = [Vec::with_capacity(n), Vec::with_capacity(n)];
    let mut meas = [Vec::with_capacity(n), Vec::with_capacity(n)];
    for (j, &k) in idx.iter().enumerate() {
        let a = model_amp(theta, omega[j], vx.amplitude[k], vy.amplitude[k]);
        model[0].push(a[0]);
        model[1].push(a[1]);
        meas[0].push(fx.amplitude[k]);
        meas[1].push(fy.amplitude[k]);
    }
    let r2 = [
        msd::score(&meas[0], &model[0]).r2,
        msd::score(&meas[1], &model[1]).r2,
    ];
    let cols = msd::msd_columns(p);
    let pred = pam_numerics::lsq::predict(&cols, theta, p.len());
    let (test, _) = msd::scores(p, &f, &pred);
    Ok(FreqFit {
        band_rad_s,
        bins: n,
        matrices: vec![
            matrix_report("M", sym(&theta[0..3])),
            matrix_report("B", sym(&theta[3..6])),
            matrix_report("K", sym(&theta[6..9])),
        ],
        r2_spectrum: r2,
        test,
        start: vec![
            matrix_report("M", sym(&start[0..3])),
            matrix_report("B", sym(&start[3..6])),
            matrix_report("K", sym(&start[6..9])),
        ],
        lm: report.summary(),
        omega,
        force_amp: meas,
        model_amp: model,
    })
}
