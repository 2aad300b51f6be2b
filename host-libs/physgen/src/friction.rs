//! Friction and hysteresis in their literature forms. Each state is advanced after the
//! rigid-body step (operator splitting) by an update that is stable at any step: the
//! bristle and element states relax exponentially or are clipped, so a stiff presliding
//! stiffness does not force a tiny step.

/// LuGre (Canudas de Wit, Olsson, Åström & Lischinsky, IEEE T-AC 40(3), 1995):
/// ż = v − σ0 |v| z / g(v), g(v) = Fc + (Fs − Fc) e^{−(v/vs)²}, F = σ0 z + σ1 ż + σ2 v.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LuGre {
    pub sigma0: f64,
    pub sigma1: f64,
    pub sigma2: f64,
    pub coulomb: f64,
    pub stiction: f64,
    pub stribeck_speed: f64,
}

impl LuGre {
    /// The Stribeck curve g(v) (force units).
    pub fn g(&self, v: f64) -> f64 {
        self.coulomb + (self.stiction - self.coulomb) * (-(v / self.stribeck_speed).powi(2)).exp()
    }

    /// ż at state z and velocity v.
    pub fn z_rate(&self, z: f64, v: f64) -> f64 {
        v - self.sigma0 * v.abs() * z / self.g(v)
    }

    /// The friction force at state z and velocity v.
    pub fn force(&self, z: f64, v: f64) -> f64 {
        self.sigma0 * z + self.sigma1 * self.z_rate(z, v) + self.sigma2 * v
    }

    /// The state after `dt` at constant v: exact (ż is linear in z for fixed v).
    pub fn advance(&self, z: f64, v: f64, dt: f64) -> f64 {
        let rate = self.sigma0 * v.abs() / self.g(v);
        if rate < 1e-12 {
            return z + v * dt;
        }
        let z_ss = v / rate;
        z_ss + (z - z_ss) * (-rate * dt).exp()
    }

    /// The steady-state force at constant velocity: g(v) sgn v + σ2 v.
    pub fn steady_force(&self, v: f64) -> f64 {
        self.g(v) * v.signum() + self.sigma2 * v
    }
}

/// Generalized Maxwell-slip (Lampaert, Al-Bender & Swevers, IEEE T-AC 48(10), 2003): N
/// elasto-slide elements in parallel, each sticking (its spring follows the motion) until
/// its force reaches its share of the Stribeck curve, then sliding at that force; plus
/// viscous friction.
#[derive(Clone, Debug, PartialEq)]
pub struct MaxwellSlip {
    /// Stiffness of each element (force per unit displacement).
    pub k: Vec<f64>,
    /// Each element's share of the breakaway force (force units).
    pub w: Vec<f64>,
    /// Ratio Coulomb / breakaway, and the Stribeck speed.
    pub coulomb_ratio: f64,
    pub stribeck_speed: f64,
    pub viscous: f64,
}

impl MaxwellSlip {
    fn s(&self, v: f64) -> f64 {
        self.coulomb_ratio + (1.0 - self.coulomb_ratio) * (-(v / self.stribeck_speed).powi(2)).exp()
    }

    /// The force of the element states `z` (element deflections) at velocity v.
    pub fn force(&self, z: &[f64], v: f64) -> f64 {
        self.k.iter().zip(z).map(|(k, z)| k * z).sum::<f64>() + self.viscous * v
    }

    /// Advances the element deflections by a displacement `dx` at velocity v.
    pub fn advance(&self, z: &mut [f64], dx: f64, v: f64) {
        let s = self.s(v);
        for i in 0..z.len() {
            let limit = self.w[i] * s / self.k[i];
            z[i] = (z[i] + dx).clamp(-limit, limit);
        }
    }
}

/// Bouc–Wen (Wen, ASCE J. Eng. Mech. 102(2), 1976), normalised so |z| ≤ 1:
/// ż = (ẋ − β |ẋ| |z|^{n−1} z − γ ẋ |z|^n) / x_ref with β + γ = 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoucWen {
    pub beta: f64,
    pub gamma: f64,
    pub n: f64,
    /// The displacement over which z saturates.
    pub x_ref: f64,
}

impl BoucWen {
    pub fn z_rate(&self, z: f64, xd: f64) -> f64 {
        let az = z.abs();
        (xd - self.beta * xd.abs() * az.powf(self.n - 1.0) * z - self.gamma * xd * az.powf(self.n))
            / self.x_ref
    }

    /// The state after a step `dt` at rate `xd`: sub-stepped so the update stays inside
    /// [−1, 1] whatever the step.
    pub fn advance(&self, z: f64, xd: f64, dt: f64) -> f64 {
        let subs = ((xd.abs() * dt / self.x_ref) * 8.0).ceil().clamp(1.0, 64.0) as usize;
        let h = dt / subs as f64;
        let mut z = z;
        for _ in 0..subs {
            z = (z + h * self.z_rate(z, xd)).clamp(-1.0, 1.0);
        }
        z
    }
}
