//! The exact step of a second-order system over one interval: the transition matrix
//! e^{Ah} of e'' + 2ζωn e' + ωn² e = 0, A = [[0, 1], [−ωn², −2ζωn]], with e the distance
//! to a set-point held over the interval (zero-order hold). The step identification of
//! §5.3, the model loop's step model and the twin's loop prediction all step their plant
//! with it.

use nalgebra::Matrix2;

/// e^{Ah} for one (ωn, ζ, h): [`SecondOrderStep::step`] advances (e, e') by h.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SecondOrderStep {
    m: [[f64; 2]; 2],
}

impl SecondOrderStep {
    /// The transition over `h_s` from A's eigenvalues μ ± q, μ = −ζωn:
    /// e^{Ah} = e^{μh} (c·I + s·(A − μI)) with (c, s) = (cosh qh, sinh qh / q) when
    /// overdamped, (cos qh, sin qh / q) when underdamped and (1, h) in the critically
    /// damped limit (q² within 1e-12 ωn² of zero).
    pub fn new(omega_n_rad_s: f64, zeta: f64, h_s: f64) -> Self {
        let wn2 = omega_n_rad_s * omega_n_rad_s;
        let mu = -zeta * omega_n_rad_s;
        let disc = mu * mu - wn2;
        let (c, s) = if disc > 1e-12 * wn2.max(1e-30) {
            let q = disc.sqrt();
            ((q * h_s).cosh(), (q * h_s).sinh() / q)
        } else if disc < -1e-12 * wn2.max(1e-30) {
            let q = (-disc).sqrt();
            ((q * h_s).cos(), (q * h_s).sin() / q)
        } else {
            (1.0, h_s)
        };
        let g = (mu * h_s).exp();
        // A − μI = [[−μ, 1], [−ωn², −2ζωn − μ]]
        SecondOrderStep {
            m: [
                [g * (c - s * mu), g * s],
                [
                    -g * s * wn2,
                    g * (c + s * (-2.0 * zeta * omega_n_rad_s - mu)),
                ],
            ],
        }
    }

    /// (e, e') one interval later.
    #[inline]
    pub fn step(&self, e: f64, e_dot: f64) -> (f64, f64) {
        (
            self.m[0][0] * e + self.m[0][1] * e_dot,
            self.m[1][0] * e + self.m[1][1] * e_dot,
        )
    }

    /// The transition matrix e^{Ah}.
    pub fn matrix(&self) -> Matrix2<f64> {
        Matrix2::new(self.m[0][0], self.m[0][1], self.m[1][0], self.m[1][1])
    }
}

#[cfg(test)]
mod tests {
    use super::SecondOrderStep;
    use nalgebra::Matrix2;

    fn system(wn: f64, zeta: f64) -> Matrix2<f64> {
        Matrix2::new(0.0, 1.0, -wn * wn, -2.0 * zeta * wn)
    }

    /// Under-, critically and overdamped, short and long intervals, against nalgebra's
    /// matrix exponential (Padé with scaling and squaring: an independent algorithm).
    #[test]
    fn matches_nalgebras_matrix_exponential() {
        for (wn, zeta) in [
            (25.0, 0.05),
            (25.0, 0.3),
            (40.0, 0.7),
            (40.0, 1.0),
            (40.0, 1.0 + 1e-7),
            (40.0, 1.0 - 1e-7),
            (15.0, 2.5),
            (220.0, 4.4),
            (0.5, 0.02),
        ] {
            for h in [1e-4, 0.005, 0.05, 0.3] {
                let ours = SecondOrderStep::new(wn, zeta, h).matrix();
                let reference = (system(wn, zeta) * h).exp();
                let scale = reference.abs().max().max(1e-300);
                let err = (ours - reference).abs().max() / scale;
                assert!(err < 1e-9, "ωn {wn} ζ {zeta} h {h}: {ours} vs {reference}");
            }
        }
    }

    /// One step against a fine explicit integration of the ODE.
    #[test]
    fn matches_a_fine_integration() {
        for (wn, zeta) in [(25.0, 0.3), (40.0, 1.0), (15.0, 2.5), (220.0, 4.4)] {
            let h = 0.005;
            let (e0, v0) = (1.0, -3.0);
            let (mut e, mut v) = (e0, v0);
            let n = 200_000;
            let dt = h / n as f64;
            for _ in 0..n {
                let a = -wn * wn * e - 2.0 * zeta * wn * v;
                v += dt * a;
                e += dt * v;
            }
            let (pe, pv) = SecondOrderStep::new(wn, zeta, h).step(e0, v0);
            assert!((pe - e).abs() < 1e-4, "{wn} {zeta}: e {pe} vs {e}");
            assert!(
                (pv - v).abs() < 1e-2 * (1.0 + v.abs()),
                "{wn} {zeta}: v {pv} vs {v}"
            );
        }
    }

    /// Stepping twice by h is stepping once by 2h (the semigroup property of e^{Ah}).
    #[test]
    fn two_half_steps_are_one_step() {
        for (wn, zeta) in [(30.0, 0.2), (30.0, 1.0), (30.0, 3.0)] {
            let half = SecondOrderStep::new(wn, zeta, 0.01);
            let whole = SecondOrderStep::new(wn, zeta, 0.02);
            let (e, v) = half.step(0.7, 2.0);
            let (e, v) = half.step(e, v);
            let (we, wv) = whole.step(0.7, 2.0);
            assert!((e - we).abs() < 1e-12 && (v - wv).abs() < 1e-10);
        }
    }
}
