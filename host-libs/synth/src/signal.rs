//! Signal helpers shared by both trial types: noise, scaling an effect to its relative
//! size, decimation, the exact zero-order-hold second order and a first-order lag.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Forces of both axes, one entry per sample.
pub type Forces = Vec<[f64; 2]>;

/// The samples at these fine-grid indices (clamped to the grid).
pub fn pick<T: Copy>(fine: &[T], rows: &[usize]) -> Vec<T> {
    rows.iter().map(|&i| fine[i.min(fine.len() - 1)]).collect()
}

/// Load-cell noise: white (σ = `white_n`) plus an AR(1) part (σ = `coloured_n`, time
/// constant `tau_s`), independent per axis. Each white draw is multiplied by
/// `white_scale()` (1 for Gaussian noise; a heavy-tailed nuisance draws its own).
pub fn load_cell_noise(
    rng: &mut ChaCha8Rng,
    n: usize,
    dt_s: f64,
    white_n: f64,
    coloured_n: f64,
    tau_s: f64,
    mut white_scale: impl FnMut() -> f64,
) -> Forces {
    let rho = (-dt_s / tau_s).exp();
    let drive = coloured_n * (1.0 - rho * rho).sqrt();
    let mut ar = [0.0; 2];
    for a in &mut ar {
        let z: f64 = StandardNormal.sample(rng);
        *a = coloured_n * z;
    }
    (0..n)
        .map(|_| {
            let mut out = [0.0; 2];
            for ax in 0..2 {
                let w: f64 = StandardNormal.sample(rng);
                let c: f64 = StandardNormal.sample(rng);
                ar[ax] = rho * ar[ax] + drive * c;
                out[ax] = white_n * w * white_scale() + ar[ax];
            }
            out
        })
        .collect()
}

/// RMS of the contribution over the std of the logged force, both axes pooled.
pub fn relative_size(contribution: &[[f64; 2]], logged: &[[f64; 2]]) -> f64 {
    let n = logged.len().max(1) as f64;
    let mut num = 0.0;
    let mut den = 0.0;
    for ax in 0..2 {
        let mean = logged.iter().map(|f| f[ax]).sum::<f64>() / n;
        den += logged.iter().map(|f| (f[ax] - mean).powi(2)).sum::<f64>();
        num += contribution.iter().map(|c| c[ax] * c[ax]).sum::<f64>();
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        0.0
    }
}

/// Finds the strength λ in `[lo, hi]` (log scale) whose relative size is `target`,
/// assuming the size grows with λ; clamps to the range ends when it cannot be reached.
pub fn solve_strength(lo: f64, hi: f64, target: f64, mut size_of: impl FnMut(f64) -> f64) -> f64 {
    let (mut a, mut b) = (lo.ln(), hi.ln());
    if size_of(hi) <= target {
        return hi;
    }
    if size_of(lo) >= target {
        return lo;
    }
    for _ in 0..40 {
        let m = 0.5 * (a + b);
        if size_of(m.exp()) < target {
            a = m;
        } else {
            b = m;
        }
        if b - a < 1e-4 {
            break;
        }
    }
    (0.5 * (a + b)).exp()
}

/// Uniform in [lo, hi] on a log scale.
pub fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.random::<f64>() * (hi.ln() - lo.ln())).exp()
}

/// Uniform in [1 − r, 1 + r].
pub fn perturb(rng: &mut ChaCha8Rng, r: f64) -> f64 {
    1.0 + r * (2.0 * rng.random::<f64>() - 1.0)
}

/// The second order G ωn²/(s² + 2ζωn s + ωn²) discretised exactly for an input held over
/// each sub-step `h_s` (matrix exponential of the augmented 3×3 system by a Taylor series,
/// which converges in a few terms since ωn h ≪ 1).
#[derive(Clone, Copy, Debug)]
pub struct SecondOrder {
    phi: [[f64; 2]; 2],
    gamma: [f64; 2],
    gain: f64,
}

impl SecondOrder {
    pub fn new(gain: f64, zeta: f64, omega_n_rad_s: f64, h_s: f64) -> Self {
        let w2 = omega_n_rad_s * omega_n_rad_s;
        // state (y, ẏ), input u: ẏ' = −ωn² y − 2ζωn ẏ + ωn² u
        let m = [
            [0.0, 1.0, 0.0],
            [-w2, -2.0 * zeta * omega_n_rad_s, w2],
            [0.0, 0.0, 0.0],
        ];
        let mut e = [[0.0; 3]; 3];
        let mut term = [[0.0; 3]; 3];
        for i in 0..3 {
            e[i][i] = 1.0;
            term[i][i] = 1.0;
        }
        for k in 1..30 {
            let mut next = [[0.0; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    next[i][j] = (0..3).map(|l| term[i][l] * m[l][j]).sum::<f64>() * h_s / k as f64;
                }
            }
            term = next;
            for i in 0..3 {
                for j in 0..3 {
                    e[i][j] += term[i][j];
                }
            }
        }
        SecondOrder {
            phi: [[e[0][0], e[0][1]], [e[1][0], e[1][1]]],
            gamma: [e[0][2], e[1][2]],
            gain,
        }
    }

    /// Runs the filter over `u` (one value per sub-step), starting at rest at `u[0]`.
    pub fn run(&self, u: &[f64]) -> Vec<f64> {
        let mut s = [u.first().copied().unwrap_or(0.0), 0.0];
        u.iter()
            .map(|&x| {
                let y = s[0];
                s = [
                    self.phi[0][0] * s[0] + self.phi[0][1] * s[1] + self.gamma[0] * x,
                    self.phi[1][0] * s[0] + self.phi[1][1] * s[1] + self.gamma[1] * x,
                ];
                self.gain * y
            })
            .collect()
    }
}

/// First-order lag 1/(τs + 1), exact for an input held over each sub-step.
pub fn first_order_lag(u: &[f64], tau_s: f64, h_s: f64) -> Vec<f64> {
    let a = (-h_s / tau_s.max(1e-9)).exp();
    let mut y = u.first().copied().unwrap_or(0.0);
    u.iter()
        .map(|&x| {
            let out = y;
            y = a * y + (1.0 - a) * x;
            out
        })
        .collect()
}

/// Linear interpolation of `x` (spacing `h_s`, first sample at 0) at time `t_s`, held at
/// the ends.
pub fn interp(x: &[f64], h_s: f64, t_s: f64) -> f64 {
    let p = (t_s / h_s).max(0.0);
    let i = p.floor() as usize;
    if i + 1 >= x.len() {
        return x[x.len() - 1];
    }
    let w = p - i as f64;
    x[i] * (1.0 - w) + x[i + 1] * w
}

/// A play (backlash) operator of half-width `half`: the output follows the input only
/// once the input has crossed the gap.
pub fn play(input: &[f64], half: f64) -> Vec<f64> {
    let mut y = input.first().copied().unwrap_or(0.0);
    input
        .iter()
        .map(|&x| {
            if x - y > half {
                y = x - half;
            } else if y - x > half {
                y = x + half;
            }
            y
        })
        .collect()
}
