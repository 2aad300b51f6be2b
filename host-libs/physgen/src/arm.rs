//! Joint-space rigid-body dynamics of the planar two-link arm: M(q) q̈ + C(q, q̇) q̇ = τ
//! (Spong, Hutchinson & Vidyasagar, *Robot Modeling and Control*, §7.4). The arm moves in a
//! horizontal plane on the table (thesis §2.1–2.2: a SCARA whose joint axes are vertical),
//! so gravity does no work and the potential term vanishes.
//!
//! q are the D-H angles θ1 (absolute) and θ2 (relative); the encoder angles α differ from
//! them by constants (eq. 2.3–2.4), so q̇ = α̇ and the dynamics are the same in α.

use pam_model::RobotParams;

/// Mass properties of the two links.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arm {
    pub l1_m: f64,
    pub m1_kg: f64,
    pub m2_kg: f64,
    /// Joint axis to each link's centre of mass.
    pub lc1_m: f64,
    pub lc2_m: f64,
    /// Inertia of each link about its centre of mass (vertical axis).
    pub i1_kg_m2: f64,
    pub i2_kg_m2: f64,
    /// Pulley, cable and shaft inertia reflected to each joint.
    pub rotor_kg_m2: [f64; 2],
}

impl Arm {
    /// The robot's nominal links (pam-model's segment estimates).
    pub fn nominal(params: &RobotParams<f64>) -> Self {
        let [s1, s2] = [params.joints[0].segment, params.joints[1].segment];
        Arm {
            l1_m: params.joints[0].segment_length_m,
            m1_kg: s1.mass_kg,
            m2_kg: s2.mass_kg,
            lc1_m: s1.com_distance_m,
            lc2_m: s2.com_distance_m,
            i1_kg_m2: s1.inertia_com_kg_m2,
            i2_kg_m2: s2.inertia_com_kg_m2,
            rotor_kg_m2: [0.002, 0.001],
        }
    }

    /// The inertia matrix at relative elbow angle `theta2_rad`.
    pub fn mass_matrix(&self, theta2_rad: f64) -> [[f64; 2]; 2] {
        let c2 = theta2_rad.cos();
        let a = self.m2_kg * self.l1_m * self.lc2_m;
        let m22 = self.i2_kg_m2 + self.m2_kg * self.lc2_m * self.lc2_m;
        let m11 = self.i1_kg_m2
            + self.m1_kg * self.lc1_m * self.lc1_m
            + m22
            + self.m2_kg * self.l1_m * self.l1_m
            + 2.0 * a * c2
            + self.rotor_kg_m2[0];
        let m12 = m22 + a * c2;
        [[m11, m12], [m12, m22 + self.rotor_kg_m2[1]]]
    }

    /// C(q, q̇) q̇: the Coriolis and centrifugal torques.
    pub fn coriolis(&self, theta2_rad: f64, qd: [f64; 2]) -> [f64; 2] {
        let h = self.m2_kg * self.l1_m * self.lc2_m * theta2_rad.sin();
        [
            -h * (2.0 * qd[0] * qd[1] + qd[1] * qd[1]),
            h * qd[0] * qd[0],
        ]
    }

    /// q̈ for the applied joint torques.
    pub fn acceleration(&self, theta2_rad: f64, qd: [f64; 2], tau_nm: [f64; 2]) -> [f64; 2] {
        let m = self.mass_matrix(theta2_rad);
        let c = self.coriolis(theta2_rad, qd);
        let r = [tau_nm[0] - c[0], tau_nm[1] - c[1]];
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        [
            (m[1][1] * r[0] - m[0][1] * r[1]) / det,
            (m[0][0] * r[1] - m[1][0] * r[0]) / det,
        ]
    }

    /// Kinetic energy ½ q̇ᵀ M q̇.
    pub fn kinetic_energy_j(&self, theta2_rad: f64, qd: [f64; 2]) -> f64 {
        let m = self.mass_matrix(theta2_rad);
        0.5 * (m[0][0] * qd[0] * qd[0] + 2.0 * m[0][1] * qd[0] * qd[1] + m[1][1] * qd[1] * qd[1])
    }
}

/// One classical fourth-order Runge–Kutta step of ẏ = f(y) on a fixed-size state.
pub fn rk4<const N: usize>(y: &[f64; N], dt: f64, f: impl Fn(&[f64; N]) -> [f64; N]) -> [f64; N] {
    let add = |a: &[f64; N], k: &[f64; N], h: f64| {
        let mut o = *a;
        for i in 0..N {
            o[i] += h * k[i];
        }
        o
    };
    let k1 = f(y);
    let k2 = f(&add(y, &k1, 0.5 * dt));
    let k3 = f(&add(y, &k2, 0.5 * dt));
    let k4 = f(&add(y, &k3, dt));
    let mut o = *y;
    for i in 0..N {
        o[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    o
}
