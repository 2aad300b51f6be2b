//! Levenberg–Marquardt for small nonlinear least-squares problems (the impedance fit of
//! §4.4 and the second-order step-response fit of §5.3), with a forward-difference Jacobian
//! whose columns are evaluated on all cores (a step fit's residuals are a simulation of
//! the whole trial, each column one more).

use crate::lsq::symmetric_eigen;
use rayon::prelude::*;

/// Why [`minimize`] stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    /// An accepted step lowered the cost by less than a relative 1e-6.
    Converged,
    /// No step lowered the cost, however strongly damped: a minimum to within the damping's
    /// reach (or a cost surface too rough for the forward-difference Jacobian).
    Stalled,
    /// The iteration budget ran out while steps still lowered the cost.
    MaxIterations,
    /// The cost at the start is NaN or infinite: nothing was minimised.
    NonFiniteStart,
}

impl std::fmt::Display for Termination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Termination::Converged => "converged",
            Termination::Stalled => "stopped where no step lowered the cost",
            Termination::MaxIterations => "ran out of iterations",
            Termination::NonFiniteStart => "started from a cost that is not a finite number",
        })
    }
}

/// The result of [`minimize`]: the parameters, their cost and how the minimisation ended.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LmReport {
    pub theta: Vec<f64>,
    /// Σ r(θ)² at `theta`.
    pub cost: f64,
    /// Jacobian evaluations (outer iterations) run.
    pub iterations: usize,
    pub termination: Termination,
}

/// An [`LmReport`] without the parameters, for a report that shows them its own way.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LmSummary {
    pub cost: f64,
    pub iterations: usize,
    pub termination: Termination,
}

impl LmSummary {
    /// True when the minimisation ended at a minimum (converged or stalled) with a finite
    /// cost; false when the budget ran out or the cost was not finite.
    pub fn reached_a_minimum(&self) -> bool {
        matches!(
            self.termination,
            Termination::Converged | Termination::Stalled
        ) && self.cost.is_finite()
    }
}

impl LmReport {
    pub fn summary(&self) -> LmSummary {
        LmSummary {
            cost: self.cost,
            iterations: self.iterations,
            termination: self.termination,
        }
    }

    /// See [`LmSummary::reached_a_minimum`].
    pub fn reached_a_minimum(&self) -> bool {
        self.summary().reached_a_minimum()
    }

    /// True when `theta` and the cost are finite numbers (whatever the termination).
    pub fn is_finite(&self) -> bool {
        self.cost.is_finite() && self.theta.iter().all(|v| v.is_finite())
    }
}

/// Minimises Σ r(θ)² from `theta0`. `residuals` writes into its output slice; parameters
/// listed in `lower` are kept at or above the given bound. Runs at most `max_iter`
/// iterations; the report says why it stopped.
pub fn minimize(
    theta0: &[f64],
    lower: &[(usize, f64)],
    n_res: usize,
    max_iter: usize,
    residuals: impl Fn(&[f64], &mut [f64]) + Sync,
) -> LmReport {
    minimize_within(theta0, lower, &[], n_res, max_iter, residuals)
}

/// [`minimize`] with upper bounds as well: parameters listed in `upper` are kept at or
/// below the given bound (each step is projected onto the box).
pub fn minimize_within(
    theta0: &[f64],
    lower: &[(usize, f64)],
    upper: &[(usize, f64)],
    n_res: usize,
    max_iter: usize,
    residuals: impl Fn(&[f64], &mut [f64]) + Sync,
) -> LmReport {
    let p = theta0.len();
    let clamp = |t: &mut Vec<f64>| {
        for &(i, lo) in lower {
            if !(t[i] >= lo) {
                t[i] = lo;
            }
        }
        for &(i, hi) in upper {
            if t[i] > hi {
                t[i] = hi;
            }
        }
    };
    let mut theta = theta0.to_vec();
    clamp(&mut theta);
    let mut r = vec![0.0; n_res];
    residuals(&theta, &mut r);
    let mut cost: f64 = r.iter().map(|v| v * v).sum();
    if !cost.is_finite() {
        return LmReport {
            theta,
            cost,
            iterations: 0,
            termination: Termination::NonFiniteStart,
        };
    }
    let mut lambda = 1e-3;
    let mut jac = vec![vec![0.0; n_res]; p];
    let mut rt = vec![0.0; n_res];
    for iteration in 1..=max_iter {
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
                    return LmReport {
                        theta,
                        cost,
                        iterations: iteration,
                        termination: Termination::Converged,
                    };
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            return LmReport {
                theta,
                cost,
                iterations: iteration,
                termination: Termination::Stalled,
            };
        }
    }
    LmReport {
        theta,
        cost,
        iterations: max_iter,
        termination: Termination::MaxIterations,
    }
}

#[cfg(test)]
mod tests {
    use super::{minimize, minimize_within, Termination};

    fn exponential() -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.0 * (-0.7 * t).exp()).collect();
        (t, y)
    }

    #[test]
    fn fits_an_exponential_and_says_it_converged() {
        let (t, y) = exponential();
        let rep = minimize(&[1.0, 0.1], &[], t.len(), 100, |p, r| {
            for i in 0..t.len() {
                r[i] = p[0] * (-p[1] * t[i]).exp() - y[i];
            }
        });
        let th = &rep.theta;
        assert!(rep.cost < 1e-12 && (th[0] - 2.0).abs() < 1e-5 && (th[1] - 0.7).abs() < 1e-5);
        assert!(rep.reached_a_minimum(), "{rep:?}");
        assert!(rep.iterations >= 1 && rep.iterations < 100);
    }

    #[test]
    fn an_upper_bound_holds_the_parameter_at_it() {
        let (t, y) = exponential();
        // the rate's least-squares value is 0.7; held at or below 0.5
        let rep = minimize_within(&[1.0, 0.1], &[], &[(1, 0.5)], t.len(), 100, |p, r| {
            for i in 0..t.len() {
                r[i] = p[0] * (-p[1] * t[i]).exp() - y[i];
            }
        });
        assert!(rep.theta[1] <= 0.5 && rep.theta[1] > 0.49, "{rep:?}");
        assert!(rep.cost > 1e-3, "{rep:?}");
    }

    #[test]
    fn a_short_budget_is_reported() {
        let (t, y) = exponential();
        let rep = minimize(&[1.0, 0.1], &[], t.len(), 2, |p, r| {
            for i in 0..t.len() {
                r[i] = p[0] * (-p[1] * t[i]).exp() - y[i];
            }
        });
        assert_eq!(rep.termination, Termination::MaxIterations);
        assert_eq!(rep.iterations, 2);
        assert!(!rep.reached_a_minimum() && rep.is_finite());
    }

    #[test]
    fn a_non_finite_start_is_reported_not_minimised() {
        let rep = minimize(&[1.0], &[], 3, 50, |p, r| {
            r.fill(f64::NAN * p[0]);
        });
        assert_eq!(rep.termination, Termination::NonFiniteStart);
        assert_eq!(rep.iterations, 0);
        assert!(!rep.is_finite() && !rep.reached_a_minimum());
    }

    #[test]
    fn a_cost_that_cannot_fall_stalls() {
        // constant residuals: no step lowers the cost
        let rep = minimize(&[1.0, 2.0], &[], 4, 50, |_, r| r.fill(1.0));
        assert_eq!(rep.termination, Termination::Stalled);
        assert_eq!(rep.theta, vec![1.0, 2.0]);
        assert!(rep.reached_a_minimum());
    }
}
