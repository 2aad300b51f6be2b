//! The dynamic trial (thesis §4.3): an operator moves the handle about one of Table 4.1's
//! points (`motion.rs`: sines, a dense band, reach-and-hold or circles); the robot answers
//! −f = M ẍ + B ẋ + K (x − x0) with the thesis's identified Cartesian matrices (perturbed);
//! the currents hold the pressures the open-loop inverse model gives for that point and a
//! stiffness level.

use pam_model::RobotModel;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::case::CaseSpec;
use crate::error::SynthError;
use crate::motion::{Path, Sines, STREAM_MOTION};
use crate::robot::{self, is_pd, mul, M2};
use crate::signal::{perturb, Forces};

/// Internal simulation step: every sampling period is a whole number of these.
pub const FINE_S: f64 = 0.001;
/// The handle rests this long before the operator starts (the loop's equilibrium is the
/// mean of the first 0.1 s).
const REST_S: f64 = 0.6;
/// The operator's motion fades in over this long (quintic ramp: smooth to the second
/// derivative, so ẍ has no jump).
const RAMP_S: f64 = 2.5;

/// The noise-free dynamic trial on the fine grid.
pub struct DynBase {
    pub t_s: Vec<f64>,
    /// True joint angles (before the encoders' quantisation) and their rates.
    pub alpha_rad: Vec<[f64; 2]>,
    pub alpha_dot_rad_s: Vec<[f64; 2]>,
    /// Handle displacement from the equilibrium and its velocity (user frame).
    pub dx_m: Vec<[f64; 2]>,
    pub v_m_s: Vec<[f64; 2]>,
    pub alpha0_rad: [f64; 2],
    /// Force the robot exerts on the hand, without any effect.
    pub force_n: Forces,
    pub k_n_per_m: M2,
    pub b_n_s_per_m: M2,
    pub m_kg: M2,
    /// Joint stiffness the currents were computed for.
    pub joint_stiffness_nm_per_rad: [f64; 2],
    pub currents_ma: [f64; 4],
}

/// The quintic fade-in and its two derivatives.
fn ramp(t: f64) -> [f64; 3] {
    let u = (t - REST_S) / RAMP_S;
    if u <= 0.0 {
        return [0.0; 3];
    }
    if u >= 1.0 {
        return [1.0, 0.0, 0.0];
    }
    let tt = RAMP_S;
    [
        10.0 * u.powi(3) - 15.0 * u.powi(4) + 6.0 * u.powi(5),
        (30.0 * u * u - 60.0 * u.powi(3) + 30.0 * u.powi(4)) / tt,
        (60.0 * u - 180.0 * u * u + 120.0 * u.powi(3)) / (tt * tt),
    ]
}

/// A matrix with every entry scaled by 1 ± `r` (symmetric), redrawn until positive definite.
fn perturb_pd(rng: &mut ChaCha8Rng, m: &M2, r: f64) -> M2 {
    loop {
        let off = m[0][1] * perturb(rng, r);
        let p = [
            [m[0][0] * perturb(rng, r), off],
            [off, m[1][1] * perturb(rng, r)],
        ];
        if is_pd(&p) {
            return p;
        }
    }
}

pub fn build(
    spec: &CaseSpec,
    model: &RobotModel<f64>,
    rng: &mut ChaCha8Rng,
) -> Result<DynBase, SynthError> {
    let alpha0 = robot::point_alpha_rad(spec.site);
    let x0 = model.kinematics.forward_user(alpha0);
    // stiffness level between Table 4.1's K_low and K_high, the same fraction on both joints
    let level = rng.random::<f64>();
    let mut kj = [0.0; 2];
    let mut k_ratio = 0.0;
    for j in 0..2 {
        let (lo, hi) = model.capability(j, alpha0[j]).trial_stiffness_levels();
        kj[j] = lo + level * (hi - lo);
        k_ratio += 0.5 * kj[j] / lo;
    }
    let sol = model.inverse(alpha0, [0.0, 0.0], kj);
    let currents_ma = robot::currents_ma(model, [sol[0].pressure_bar, sol[1].pressure_bar]);
    // the thesis's K is at minimum stiffness: a stiffer setting scales it
    let k = perturb_pd(rng, &scale(&robot::K_THESIS, k_ratio), 0.2);
    let b = perturb_pd(rng, &robot::B_THESIS, 0.2);
    let m = perturb_pd(rng, &robot::M_THESIS, 0.2);

    let first = [Sines::random(rng), Sines::random(rng)];
    let mut rng_motion = crate::rng(spec.seed, STREAM_MOTION);
    let path = Path::new(spec.motion, first, &mut rng_motion, spec.duration_s);
    let mut amp_m = [rng.random_range(0.01..0.05), rng.random_range(0.01..0.05)];
    let n = (spec.duration_s / FINE_S).round() as usize + 1;
    let t_s: Vec<f64> = (0..n).map(|i| i as f64 * FINE_S).collect();
    // normalise each axis to its peak on the grid
    let mut peak = [1e-12f64; 2];
    for &t in &t_s {
        let p = path.eval(t);
        for ax in 0..2 {
            peak[ax] = peak[ax].max(p[ax][0].abs());
        }
    }
    let limits = |j: usize| {
        let p = &model.params.joints[j];
        let margin = 1.0f64.to_radians();
        (p.alpha_min_rad + margin, p.alpha_max_rad - margin)
    };
    // shrink the motion until it stays inside the joint ranges
    for _attempt in 0..12 {
        let mut base = DynBase {
            t_s: Vec::with_capacity(n),
            alpha_rad: Vec::with_capacity(n),
            alpha_dot_rad_s: Vec::with_capacity(n),
            dx_m: Vec::with_capacity(n),
            v_m_s: Vec::with_capacity(n),
            alpha0_rad: alpha0,
            force_n: Vec::with_capacity(n),
            k_n_per_m: k,
            b_n_s_per_m: b,
            m_kg: m,
            joint_stiffness_nm_per_rad: kj,
            currents_ma,
        };
        let mut ok = true;
        for &t in &t_s {
            let w = ramp(t);
            let mut dx = [0.0; 2];
            let mut v = [0.0; 2];
            let mut a = [0.0; 2];
            let p = path.eval(t);
            for ax in 0..2 {
                let s = p[ax];
                let g = amp_m[ax] / peak[ax];
                dx[ax] = g * w[0] * s[0];
                v[ax] = g * (w[1] * s[0] + w[0] * s[1]);
                a[ax] = g * (w[2] * s[0] + 2.0 * w[1] * s[1] + w[0] * s[2]);
            }
            let Some(al) = model
                .kinematics
                .inverse_user([x0[0] + dx[0], x0[1] + dx[1]])
            else {
                ok = false;
                break;
            };
            if (0..2).any(|j| {
                let (lo, hi) = limits(j);
                !(al[j] >= lo && al[j] <= hi)
            }) {
                ok = false;
                break;
            }
            let jac = model.kinematics.jacobian(al);
            let ad = jac.inverse().map(|ji| ji.mul_vec(v)).unwrap_or([0.0; 2]);
            let (fm, fb, fk) = (mul(&m, a), mul(&b, v), mul(&k, dx));
            base.t_s.push(t);
            base.alpha_rad.push(al);
            base.alpha_dot_rad_s.push(ad);
            base.dx_m.push(dx);
            base.v_m_s.push(v);
            base.force_n
                .push([-(fm[0] + fb[0] + fk[0]), -(fm[1] + fb[1] + fk[1])]);
        }
        if ok {
            return Ok(base);
        }
        amp_m = amp_m.map(|a| a * 0.8);
    }
    Err(SynthError::OutOfReach { t_s: 0.0 })
}

fn scale(m: &M2, r: f64) -> M2 {
    [[m[0][0] * r, m[0][1] * r], [m[1][0] * r, m[1][1] * r]]
}

/// Parameters of the base for the truth file.
pub fn base_params(b: &DynBase) -> Vec<(String, f64)> {
    let m = |name: &str, x: &M2| {
        vec![
            (format!("{name}_xx"), x[0][0]),
            (format!("{name}_xy"), x[0][1]),
            (format!("{name}_yy"), x[1][1]),
        ]
    };
    let mut out = m("k_n_per_m", &b.k_n_per_m);
    out.extend(m("b_n_s_per_m", &b.b_n_s_per_m));
    out.extend(m("m_kg", &b.m_kg));
    out.push((
        "joint_stiffness_nm_per_rad_1".into(),
        b.joint_stiffness_nm_per_rad[0],
    ));
    out.push((
        "joint_stiffness_nm_per_rad_2".into(),
        b.joint_stiffness_nm_per_rad[1],
    ));
    out
}
