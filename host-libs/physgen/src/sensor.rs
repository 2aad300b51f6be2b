//! A rig's sensors: the load cell's noise (white, a 1/f part and an autoregressive part),
//! its tare offset fixed in the sensor's frame (so it turns with the handle, eq. 2.6–2.7),
//! and the encoders' rounding.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// A 2 000-line encoder read on all four edges (§2.1).
pub const ENCODER_COUNTS_PER_REV: f64 = 8000.0;

/// Rounds an angle to the encoder's counts.
pub fn quantise(alpha_rad: f64) -> f64 {
    let q = std::f64::consts::TAU / ENCODER_COUNTS_PER_REV;
    (alpha_rad / q).round() * q
}

/// What the load cell adds, per channel (sensor X and Z).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LoadCellNoise {
    pub white_n: f64,
    /// Standard deviation of the 1/f part (flicker between `pink_low_hz` and `pink_corner_hz`).
    pub pink_n: f64,
    pub pink_low_hz: f64,
    pub pink_corner_hz: f64,
    /// Standard deviation of the AR(2) part and its poles (radius, frequency).
    pub ar_n: f64,
    pub ar_radius: f64,
    pub ar_hz: f64,
    /// Tare offset in the sensor frame (X, Z), N.
    pub tare_n: [f64; 2],
}

impl LoadCellNoise {
    /// A draw of a rig's load cell: white 0.05–0.5 N, a 1/f part of 0.3–1.5 × the white
    /// with its corner at 1–6 Hz, an AR(2) part of 0.2–1 × the white, a tare of up to 1.5 N.
    pub fn draw(rng: &mut ChaCha8Rng) -> Self {
        let white_n = 0.05 * 10f64.powf(rng.random::<f64>());
        LoadCellNoise {
            white_n,
            pink_n: white_n * rng.random_range(0.3..1.5),
            pink_low_hz: 0.01,
            pink_corner_hz: rng.random_range(1.0..6.0),
            ar_n: white_n * rng.random_range(0.2..1.0),
            ar_radius: rng.random_range(0.85..0.98),
            ar_hz: rng.random_range(2.0..40.0),
            tare_n: [rng.random_range(-1.5..1.5), rng.random_range(-1.5..1.5)],
        }
    }

    /// `n` samples of one channel's noise at period `dt_s` (tare excluded).
    pub fn channel(&self, rng: &mut ChaCha8Rng, n: usize, dt_s: f64) -> Vec<f64> {
        let gauss = |r: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(r) };
        // 1/f: equal-variance AR(1) processes with corners one octave apart (Voss's
        // construction: a sum of octave-spaced relaxations has a 1/f spectrum between them)
        let mut corners = Vec::new();
        let mut f = self.pink_low_hz;
        while f <= self.pink_corner_hz {
            corners.push(f);
            f *= 2.0;
        }
        let poles: Vec<f64> = corners
            .iter()
            .map(|fc| (-std::f64::consts::TAU * fc * dt_s).exp())
            .collect();
        let mut pink = vec![0.0; poles.len()];
        for s in pink.iter_mut() {
            *s = gauss(rng);
        }
        let pink_scale = self.pink_n / (poles.len().max(1) as f64).sqrt();
        // AR(2): x_k = 2 r cos ω x_{k−1} − r² x_{k−2} + e, normalised to unit variance
        let (r, w) = (self.ar_radius, std::f64::consts::TAU * self.ar_hz * dt_s);
        let (a1, a2) = (2.0 * r * w.cos(), -r * r);
        let ar_var = (1.0 - a2) / ((1.0 + a2) * ((1.0 - a2).powi(2) - a1 * a1));
        let ar_scale = self.ar_n / ar_var.max(1e-12).sqrt();
        let (mut x1, mut x2) = (0.0, 0.0);
        let mut out = Vec::with_capacity(n);
        for k in 0..n + 200 {
            for (s, a) in pink.iter_mut().zip(&poles) {
                *s = a * *s + (1.0 - a * a).sqrt() * gauss(rng);
            }
            let x = a1 * x1 + a2 * x2 + gauss(rng);
            x2 = x1;
            x1 = x;
            if k >= 200 {
                let p: f64 = pink.iter().sum();
                out.push(self.white_n * gauss(rng) + pink_scale * p + ar_scale * x);
            }
        }
        out
    }
}

/// A load-cell amplifier's anti-alias filter: a critically damped second order of corner
/// `hz` (its group delay 1/(π hz) at low frequency), applied to the force samples.
pub fn amplifier_lag(force: &mut [[f64; 2]], hz: f64, dt_s: f64) {
    let w = std::f64::consts::TAU * hz;
    for ax in 0..2 {
        let (mut y, mut yd) = (force.first().map_or(0.0, |f| f[ax]), 0.0);
        for f in force.iter_mut() {
            let u = f[ax];
            // semi-implicit Euler on a sub-grid fine enough for the corner
            let subs = ((w * dt_s) * 10.0).ceil().max(1.0) as usize;
            let h = dt_s / subs as f64;
            for _ in 0..subs {
                yd += h * (w * w * (u - y) - 2.0 * w * yd);
                y += h * yd;
            }
            f[ax] = y;
        }
    }
}
