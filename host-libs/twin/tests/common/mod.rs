//! Analysis helpers for the tests: the thesis's post-processing (§4.2: differentiation and
//! zero-phase low-pass), the linear mass-spring-damper least-squares fit of eq. 4.30 and the
//! graphical second-order step analysis of §5.3. Deliberately small: the identification
//! crate proper is written elsewhere.
#![allow(dead_code, clippy::needless_range_loop)]

use pam_log::{col, Log};
use pam_model::{Mat2, RobotModel};

/// Second-order Butterworth low-pass run forward then backward (zero phase).
pub fn filtfilt(x: &[f64], cutoff_hz: f64, dt: f64) -> Vec<f64> {
    let k = (std::f64::consts::PI * cutoff_hz * dt).tan();
    let q = std::f64::consts::FRAC_1_SQRT_2;
    let norm = 1.0 / (1.0 + k / q + k * k);
    let b0 = k * k * norm;
    let (b1, b2) = (2.0 * b0, b0);
    let a1 = 2.0 * (k * k - 1.0) * norm;
    let a2 = (1.0 - k / q + k * k) * norm;
    let pass = |input: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; input.len()];
        let (mut x1, mut x2) = (input[0], input[0]);
        let (mut y1, mut y2) = (input[0], input[0]);
        for (i, &x0) in input.iter().enumerate() {
            let y0 = b0 * x0 + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
            out[i] = y0;
            x2 = x1;
            x1 = x0;
            y2 = y1;
            y1 = y0;
        }
        out
    };
    let fwd = pass(x);
    let mut rev: Vec<f64> = fwd.into_iter().rev().collect();
    rev = pass(&rev);
    rev.reverse();
    rev
}

/// Central difference (one-sided at the ends).
pub fn derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (x[b] - x[a]) / ((b - a) as f64 * dt)
        })
        .collect()
}

/// Solves the least-squares problem min |A p − y| through the normal equations.
pub fn least_squares(rows: &[Vec<f64>], y: &[f64]) -> Vec<f64> {
    let n = rows[0].len();
    let mut ata = vec![vec![0.0; n + 1]; n];
    for (r, &yi) in rows.iter().zip(y) {
        for i in 0..n {
            for j in 0..n {
                ata[i][j] += r[i] * r[j];
            }
            ata[i][n] += r[i] * yi;
        }
    }
    // Gauss–Jordan with partial pivoting
    for c in 0..n {
        let p = (c..n)
            .max_by(|&a, &b| ata[a][c].abs().total_cmp(&ata[b][c].abs()))
            .unwrap();
        ata.swap(c, p);
        let d = ata[c][c];
        assert!(d.abs() > 1e-300, "singular normal equations");
        for j in c..=n {
            ata[c][j] /= d;
        }
        for i in 0..n {
            if i != c {
                let f = ata[i][c];
                for j in c..=n {
                    ata[i][j] -= f * ata[c][j];
                }
            }
        }
    }
    (0..n).map(|i| ata[i][n]).collect()
}

#[derive(Debug, Clone, Copy)]
pub struct MsdFit {
    pub m: Mat2<f64>,
    pub b: Mat2<f64>,
    pub k: Mat2<f64>,
    /// Coefficient of determination per axis.
    pub r2: [f64; 2],
}

/// Handle position (user frame) from the log's angles.
pub fn handle_positions(log: &Log, model: &RobotModel<f64>) -> (Vec<f64>, Vec<f64>) {
    let a1 = log.column(col::ALPHA1_RAD).unwrap();
    let a2 = log.column(col::ALPHA2_RAD).unwrap();
    a1.iter()
        .zip(a2)
        .map(|(&p, &q)| model.kinematics.forward_user([p, q]))
        .map(|x| (x[0], x[1]))
        .unzip()
}

/// Fits −f = M ẍ + B ẋ + K (x − x0) (eq. 4.29–4.30, symmetric matrices, x0 given) on the
/// whole log, velocities and accelerations as in §4.2 (derivative, then zero-phase 8 Hz
/// low-pass).
pub fn fit_msd(log: &Log, model: &RobotModel<f64>, x0: [f64; 2]) -> MsdFit {
    let dt = log.sample_period_s().unwrap();
    let (x, y) = handle_positions(log, model);
    let lp = |s: &[f64]| filtfilt(s, 8.0, dt);
    let (xf, yf) = (lp(&x), lp(&y));
    let (vx, vy) = (lp(&derivative(&xf, dt)), lp(&derivative(&yf, dt)));
    let (ax, ay) = (lp(&derivative(&vx, dt)), lp(&derivative(&vy, dt)));
    let fx = lp(log.column(col::FX_N).unwrap());
    let fy = lp(log.column(col::FY_N).unwrap());
    let mut rows = Vec::new();
    let mut rhs = Vec::new();
    // skip the filter's edge transients
    let edge = (1.0 / dt) as usize;
    for i in edge..x.len() - edge {
        let (dx, dy) = (xf[i] - x0[0], yf[i] - x0[1]);
        rows.push(vec![ax[i], ay[i], 0.0, vx[i], vy[i], 0.0, dx, dy, 0.0]);
        rhs.push(-fx[i]);
        rows.push(vec![0.0, ax[i], ay[i], 0.0, vx[i], vy[i], 0.0, dx, dy]);
        rhs.push(-fy[i]);
    }
    let p = least_squares(&rows, &rhs);
    let mut ss_res = [0.0; 2];
    let mut ss_tot = [0.0; 2];
    let mut mean = [0.0; 2];
    for (i, &r) in rhs.iter().enumerate() {
        mean[i % 2] += r / (rhs.len() / 2) as f64;
    }
    for (i, (row, &r)) in rows.iter().zip(&rhs).enumerate() {
        let pred: f64 = row.iter().zip(&p).map(|(a, b)| a * b).sum();
        ss_res[i % 2] += (r - pred).powi(2);
        ss_tot[i % 2] += (r - mean[i % 2]).powi(2);
    }
    MsdFit {
        m: Mat2::symmetric(p[0], p[1], p[2]),
        b: Mat2::symmetric(p[3], p[4], p[5]),
        k: Mat2::symmetric(p[6], p[7], p[8]),
        r2: [1.0 - ss_res[0] / ss_tot[0], 1.0 - ss_res[1] / ss_tot[1]],
    }
}

/// One step of a force-step log, analysed graphically as in §5.3.
#[derive(Debug, Clone, Copy)]
pub struct StepFigures {
    pub axis: usize,
    pub from_n: f64,
    pub to_n: f64,
    pub gain: f64,
    /// `None` when the response does not overshoot (ζ ≥ 1).
    pub zeta: Option<f64>,
    pub omega_n_rad_s: Option<f64>,
}

/// Splits a force-step log at the reference changes and analyses each step.
pub fn analyse_steps(log: &Log) -> Vec<StepFigures> {
    let dt = log.sample_period_s().unwrap();
    let refs = [
        log.column(col::FX_REF_N).unwrap(),
        log.column(col::FY_REF_N).unwrap(),
    ];
    let meas = [
        filtfilt(log.column(col::FX_N).unwrap(), 15.0, dt),
        filtfilt(log.column(col::FY_N).unwrap(), 15.0, dt),
    ];
    let n = refs[0].len();
    let mut starts = vec![0usize];
    for i in 1..n {
        if refs[0][i] != refs[0][i - 1] || refs[1][i] != refs[1][i - 1] {
            starts.push(i);
        }
    }
    starts.push(n);
    let mut out = Vec::new();
    for w in 1..starts.len() - 1 {
        let (s, e) = (starts[w], starts[w + 1]);
        let prev = starts[w - 1];
        let axis = if refs[0][s] != refs[0][s - 1] { 0 } else { 1 };
        let u0 = refs[axis][s - 1];
        let u1 = refs[axis][s];
        let y = &meas[axis];
        let tail = |a: usize, b: usize| {
            let k = ((0.3 / dt) as usize).min(b - a);
            y[b - k..b].iter().sum::<f64>() / k as f64
        };
        let y0 = tail(prev, s);
        let yss = tail(s, e);
        let dy = yss - y0;
        let gain = dy / (u1 - u0);
        let dir = dy.signum();
        let (mut peak_i, mut peak) = (s, f64::NEG_INFINITY);
        for i in s..e {
            let v = dir * (y[i] - yss);
            if v > peak {
                peak = v;
                peak_i = i;
            }
        }
        let mp = peak / dy.abs();
        let (zeta, wn) = if mp > 0.005 && peak_i > s {
            let l = mp.ln();
            let z = -l / (std::f64::consts::PI.powi(2) + l * l).sqrt();
            let tp = (peak_i - s) as f64 * dt;
            (
                Some(z),
                Some(std::f64::consts::PI / (tp * (1.0 - z * z).sqrt())),
            )
        } else {
            (None, None)
        };
        out.push(StepFigures {
            axis,
            from_n: u0,
            to_n: u1,
            gain,
            zeta,
            omega_n_rad_s: wn,
        });
    }
    out
}
