//! Levenberg–Marquardt for small nonlinear least-squares problems (the impedance fit of
//! §4.4 and the second-order step-response fit of §5.3), with a forward-difference Jacobian
//! whose columns are evaluated on all cores (a step fit's residuals are a simulation of
//! the whole trial, each column one more).

use crate::lsq::symmetric_eigen;
use rayon::prelude::*;

/// Minimises Σ r(θ)² from `theta0`. `residuals` writes into its output slice; parameters
/// listed in `lower` are kept at or above the given bound. Returns θ and the final cost.
pub fn minimize(
    theta0: &[f64],
    lower: &[(usize, f64)],
    n_res: usize,
    max_iter: usize,
    residuals: impl Fn(&[f64], &mut [f64]) + Sync,
) -> (Vec<f64>, f64) {
    let p = theta0.len();
    let clamp = |t: &mut Vec<f64>| {
        for &(i, lo) in lower {
            if !(t[i] >= lo) {
                t[i] = lo;
            }
        }
    };
    let mut theta = theta0.to_vec();
    clamp(&mut theta);
    let mut r = vec![0.0; n_res];
    residuals(&theta, &mut r);
    let mut cost: f64 = r.iter().map(|v| v * v).sum();
    let mut lambda = 1e-3;
    let mut jac = vec![vec![0.0; n_res]; p];
    let mut rt = vec![0.0; n_res];
    for _ in 0..max_iter {
        jac.par_iter_mut().enumerate().for_each(|(j, col)| {
            let h = 1e-6 * theta[j].abs().max(1e-3);
            let mut t = theta.clone();
            t[j] += h;
            residuals(&t, col);
            for (c, r) in col.iter_mut().zip(&r) {
                *c = (*c - r) / h;
            }
        });
        let mut g = vec![vec![0.0; p]; p];
        let mut b = vec![0.0; p];
        for i in 0..p {
            b[i] = -jac[i].iter().zip(&r).map(|(a, c)| a * c).sum::<f64>();
            for j in i..p {
                let s: f64 = jac[i].iter().zip(&jac[j]).map(|(a, c)| a * c).sum();
                g[i][j] = s;
                g[j][i] = s;
            }
        }
        let mut improved = false;
        for _ in 0..12 {
            let mut a = g.clone();
            for i in 0..p {
                a[i][i] += lambda * g[i][i].max(1e-12);
            }
            let (vals, vecs) = symmetric_eigen(&a);
            let vmax = vals.iter().cloned().fold(0.0, f64::max);
            let mut step = vec![0.0; p];
            for e in 0..p {
                if vals[e] > vmax * 1e-14 {
                    let proj: f64 = (0..p).map(|k| vecs[k][e] * b[k]).sum::<f64>() / vals[e];
                    for k in 0..p {
                        step[k] += vecs[k][e] * proj;
                    }
                }
            }
            let mut t: Vec<f64> = theta.iter().zip(&step).map(|(a, s)| a + s).collect();
            clamp(&mut t);
            residuals(&t, &mut rt);
            let c: f64 = rt.iter().map(|v| v * v).sum();
            if c.is_finite() && c < cost {
                let rel = (cost - c) / cost.max(1e-300);
                theta = t;
                std::mem::swap(&mut r, &mut rt);
                cost = c;
                lambda = (lambda * 0.3).max(1e-12);
                improved = true;
                if rel < 1e-6 {
                    return (theta, cost);
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (theta, cost)
}

#[cfg(test)]
mod tests {
    #[test]
    fn fits_an_exponential() {
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.0 * (-0.7 * t).exp()).collect();
        let (th, cost) = super::minimize(&[1.0, 0.1], &[], t.len(), 100, |p, r| {
            for i in 0..t.len() {
                r[i] = p[0] * (-p[1] * t[i]).exp() - y[i];
            }
        });
        assert!(cost < 1e-12 && (th[0] - 2.0).abs() < 1e-5 && (th[1] - 0.7).abs() < 1e-5);
    }
}
