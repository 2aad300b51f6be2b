//! The experimental muscle model F(ε, P) = A(ε)·P + B(ε) (eq. 3.1, 3.4) and its
//! ε-derivative dF/dε = C(ε)·P + D(ε) (eq. B.5).

use crate::params::MuscleCoeffs;
use crate::real::{horner, Real};

const PA_PER_BAR: f64 = 1.0e5;

/// A, B, C, D of one muscle evaluated at one contraction ratio, with pressure in bar
/// (A and C are scaled to N/bar so the control path never handles 1e5-sized numbers).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MuscleTerms<R> {
    pub a_n_per_bar: R,
    pub b_n: R,
    pub c_n_per_bar: R,
    pub d_n: R,
}

impl<R: Real> MuscleTerms<R> {
    /// Muscle force in N. Negative values are what the polynomial says; a cable cannot
    /// push, and the digital twin applies that, not this model.
    #[inline]
    pub fn force_n(&self, pressure_bar: R) -> R {
        self.a_n_per_bar * pressure_bar + self.b_n
    }
    /// ∂F/∂ε in N (per unit contraction ratio).
    #[inline]
    pub fn dforce_depsilon_n(&self, pressure_bar: R) -> R {
        self.c_n_per_bar * pressure_bar + self.d_n
    }
    /// The pressure at which this muscle produces `force_n`.
    #[inline]
    pub fn pressure_for_force_bar(&self, force_n: R) -> R {
        (force_n - self.b_n) / self.a_n_per_bar
    }
}

impl<R: Real> MuscleCoeffs<R> {
    /// Evaluates A, B and their derivatives at `epsilon` (contraction ratio, 1 = 100 %).
    #[inline]
    pub fn terms(&self, epsilon: R) -> MuscleTerms<R> {
        let pa_per_bar = R::from_f64(PA_PER_BAR);
        let p = &self.pressure_n_per_pa;
        let q = &self.passive_n;
        // derivative coefficients, highest power first
        let dp = [
            R::from_f64(4.0) * p[0],
            R::from_f64(3.0) * p[1],
            R::from_f64(2.0) * p[2],
            p[3],
        ];
        let dq = [
            R::from_f64(5.0) * q[0],
            R::from_f64(4.0) * q[1],
            R::from_f64(3.0) * q[2],
            R::from_f64(2.0) * q[3],
            q[4],
        ];
        MuscleTerms {
            a_n_per_bar: horner(p, epsilon) * pa_per_bar,
            b_n: horner(q, epsilon),
            c_n_per_bar: horner(&dp, epsilon) * pa_per_bar,
            d_n: horner(&dq, epsilon),
        }
    }

    /// F(ε, P) in N with P in bar.
    pub fn force_n(&self, epsilon: R, pressure_bar: R) -> R {
        self.terms(epsilon).force_n(pressure_bar)
    }
}
