//! Largest differences between the f32 model and the f64 reference over a grid of poses
//! and requests. Run on the target, the f64 side is soft-float and bit-identical to the
//! host's f64.

use super::{workload, Rng};
use crate::robot::RobotModel;

#[derive(Clone, Copy, Debug, Default)]
pub struct Quantity {
    pub name: &'static str,
    pub unit: &'static str,
    pub max_abs: f64,
    pub max_rel: f64,
    pub samples: u32,
}

impl Quantity {
    fn new(name: &'static str, unit: &'static str) -> Self {
        Quantity {
            name,
            unit,
            ..Default::default()
        }
    }
    fn add(&mut self, single: f32, double: f64) {
        let d = (single as f64 - double).abs();
        let rel = d / double.abs().max(1e-12);
        if d > self.max_abs || !d.is_finite() {
            self.max_abs = d;
        }
        if rel > self.max_rel {
            self.max_rel = rel;
        }
        self.samples += 1;
    }
}

pub const N: usize = 8;

pub fn compare() -> [Quantity; N] {
    let m32 = RobotModel::<f32>::thesis();
    let m64 = RobotModel::<f64>::thesis();
    let mut q = [
        Quantity::new("muscle force", "N"),
        Quantity::new("joint torque (direct)", "N m"),
        Quantity::new("joint stiffness (direct)", "N m/rad"),
        Quantity::new("capability tau_max/K_min/K_max", "-"),
        Quantity::new("inverse model pressures", "bar"),
        Quantity::new("handle position (FK)", "m"),
        Quantity::new("Jacobian entries", "m/rad"),
        Quantity::new("load cell rotation", "N"),
    ];
    let mut rng = Rng::new(0x9e37_79b9);
    for _ in 0..200 {
        let a = [rng.uniform(-0.39, 0.39), rng.uniform(-0.56, 0.56)];
        let p = [
            [rng.uniform(0.0, 5.0), rng.uniform(0.0, 5.0)],
            [rng.uniform(0.0, 5.0), rng.uniform(0.0, 5.0)],
        ];
        let a32 = [a[0] as f32, a[1] as f32];
        let p32 = p.map(|r| r.map(|x| x as f32));
        for j in 0..2 {
            let (s, d) = (m32.pose(j, a32[j]), m64.pose(j, a[j]));
            for k in 0..2 {
                q[0].add(s.forces_n(p32[j])[k], d.forces_n(p[j])[k]);
            }
            q[1].add(s.torque_nm(p32[j]), d.torque_nm(p[j]));
            q[2].add(s.stiffness_nm_per_rad(p32[j]), d.stiffness_nm_per_rad(p[j]));
            let (c32, c64) = (s.capability(&m32.joints[j]), d.capability(&m64.joints[j]));
            q[3].add(c32.tau_max.torque_nm, c64.tau_max.torque_nm);
            q[3].add(
                c32.k_min.stiffness_nm_per_rad,
                c64.k_min.stiffness_nm_per_rad,
            );
            q[3].add(
                c32.k_max.stiffness_nm_per_rad,
                c64.k_max.stiffness_nm_per_rad,
            );
        }
        let x32 = m32.kinematics.forward_user(a32);
        let x64 = m64.kinematics.forward_user(a);
        q[5].add(x32[0], x64[0]);
        q[5].add(x32[1], x64[1]);
        let (j32, j64) = (m32.kinematics.jacobian(a32), m64.kinematics.jacobian(a));
        for r in 0..2 {
            for c in 0..2 {
                q[6].add(j32.0[r][c], j64.0[r][c]);
            }
        }
        let f = [rng.uniform(-40.0, 40.0), rng.uniform(-40.0, 40.0)];
        let r32 = m32
            .kinematics
            .sensor_to_user(a32, [f[0] as f32, f[1] as f32]);
        let r64 = m64.kinematics.sensor_to_user(a, f);
        q[7].add(r32[0], r64[0]);
        q[7].add(r32[1], r64[1]);
    }
    let w32 = workload::inputs::<f32>();
    let w64 = workload::inputs::<f64>();
    for (a, b) in w32.iter().zip(w64.iter()) {
        let s = m32.evaluate(a.alpha_rad, a.torque_nm, a.stiffness_nm_per_rad);
        let d = m64.evaluate(b.alpha_rad, b.torque_nm, b.stiffness_nm_per_rad);
        for j in 0..2 {
            for k in 0..2 {
                q[4].add(s[j].solution.pressure_bar[k], d[j].solution.pressure_bar[k]);
            }
        }
    }
    q
}
