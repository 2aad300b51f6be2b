//! The benchmark workload shared by criterion (host) and the QEMU instruction count:
//! poses spread over the workspace with requests inside, on and outside the limits.

use super::Rng;
use crate::real::Real;

pub const LEN: usize = 64;

#[derive(Clone, Copy, Debug)]
pub struct Input<R> {
    pub alpha_rad: [R; 2],
    pub torque_nm: [R; 2],
    pub stiffness_nm_per_rad: [R; 2],
}

pub fn inputs<R: Real>() -> [Input<R>; LEN] {
    let mut rng = Rng::new(0xbe_7c4);
    let mut out = [Input {
        alpha_rad: [R::ZERO; 2],
        torque_nm: [R::ZERO; 2],
        stiffness_nm_per_rad: [R::ZERO; 2],
    }; LEN];
    for w in out.iter_mut() {
        let f = |x: f64| R::from_f64(x);
        w.alpha_rad = [f(rng.uniform(-0.39, 0.39)), f(rng.uniform(-0.56, 0.56))];
        w.torque_nm = [f(rng.uniform(-40.0, 40.0)), f(rng.uniform(-28.0, 28.0))];
        w.stiffness_nm_per_rad = [f(rng.uniform(40.0, 160.0)), f(rng.uniform(15.0, 75.0))];
    }
    out
}
