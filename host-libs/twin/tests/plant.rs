//! The plant against pam-model's laws, the handle conditions, and bad input.

use pam_model::{RobotModel, RobotParams};
use pam_twin::{HandleCondition, SensorConfig, Twin, TwinConfig};

fn ma(p_bar: f64) -> f64 {
    let ip = RobotParams::<f64>::thesis().ip;
    (p_bar - ip.offset_bar) / ip.gain_bar_per_ma
}

fn ideal_twin(alpha: [f64; 2]) -> Twin {
    let mut cfg = TwinConfig::thesis();
    cfg.sensors = SensorConfig::ideal();
    cfg.initial_alpha_rad = alpha;
    cfg.initial_pressure_bar = Some([2.3; 4]);
    Twin::new(cfg)
}

/// Blocked at a pose with steady pressures, the load cell reads J⁻ᵀ τ with τ from the model's
/// direct model (eq. 3.2, 3.1) at those pressures, less the rig's parallel stiffness.
#[test]
fn blocked_force_is_the_statics_of_the_model() {
    let model = RobotModel::<f64>::thesis();
    let alpha = [0.15, -0.2];
    let channel_p = [2.1, 2.9, 2.6, 1.8];
    let mut twin = ideal_twin(alpha);
    let mut m = None;
    for _ in 0..3000 {
        m = Some(twin.step(0.001, channel_p.map(ma), &HandleCondition::Blocked));
    }
    let m = m.unwrap();
    let joint_p = model.joint_pressures_bar(m.pressure_bar);
    let k_parallel = twin.config().mechanics.parallel_stiffness_nm_per_rad;
    let tau_muscles = model.direct(alpha, joint_p).map(|(t, _)| t);
    let tau = [0, 1].map(|j| tau_muscles[j] - k_parallel[j] * alpha[j]);
    let f = model
        .kinematics
        .jacobian(alpha)
        .transpose()
        .inverse()
        .unwrap()
        .mul_vec(tau);
    for i in 0..2 {
        assert!(
            (m.force_user_n[i] - f[i]).abs() < 1e-6 * (1.0 + f[i].abs()),
            "{:?} vs {f:?}",
            m.force_user_n
        );
        assert!((m.pressure_bar[2 * i] - channel_p[2 * i]).abs() < 1e-6);
    }
    assert_eq!(twin.state().alpha_rad, alpha, "a blocked arm does not move");
}

/// A free arm with zero-torque pressures settles at the pose the model's pretension holds
/// (zero torque at the neutral pose) and stays.
#[test]
fn free_arm_rests_at_the_zero_torque_pose() {
    let model = RobotModel::<f64>::thesis();
    let sol = model.inverse([0.0; 2], [0.0; 2], [60.0, 27.0]);
    let p = model.channel_pressures_bar([sol[0].pressure_bar, sol[1].pressure_bar]);
    let mut twin = ideal_twin([0.05, -0.05]);
    // lightly damped (the air and the bearings only): give it 30 s
    for _ in 0..30_000 {
        twin.step(0.001, p.map(ma), &HandleCondition::Free);
    }
    let s = twin.state();
    assert!(
        s.alpha_rad.iter().all(|a| a.abs() < 2e-3),
        "{:?}",
        s.alpha_rad
    );
    assert!(
        s.alpha_dot_rad_s.iter().all(|w| w.abs() < 1e-3),
        "{:?}",
        s.alpha_dot_rad_s
    );
}

/// Joint 1 locked: a hand moving the handle turns only joint 2.
#[test]
fn joint1_locked_moves_joint_2_only() {
    let mut twin = ideal_twin([0.1, 0.0]);
    let x0 = twin.state().handle_user_m;
    let mut swing: f64 = 0.0;
    for k in 0..2000 {
        let t = k as f64 * 0.001;
        let target = [
            x0[0] + 0.02 * (3.0 * t).sin(),
            x0[1] + 0.02 * (3.0 * t).sin(),
        ];
        twin.step(
            0.001,
            [ma(2.3); 4],
            &HandleCondition::Joint1Locked(Some(pam_twin::HandSpring::at(target, [0.0; 2]))),
        );
        assert_eq!(twin.state().alpha_rad[0], 0.1);
        swing = swing.max(twin.state().alpha_rad[1].abs());
    }
    assert!(swing > 0.005, "joint 2 swung by {swing} rad");
}

/// The encoder quantizes to its counts; the load cell's ADC to its steps.
#[test]
fn sensors_quantize() {
    let mut cfg = TwinConfig::thesis();
    cfg.sensors.encoder_counts_per_rev = [4096, 4096];
    cfg.sensors.loadcell_noise_n = [0.0; 2];
    cfg.initial_alpha_rad = [0.1234, -0.2345];
    let mut twin = Twin::new(cfg);
    let m = twin.step(0.001, [ma(2.3); 4], &HandleCondition::Blocked);
    let per_rad = 4096.0 / std::f64::consts::TAU;
    assert_eq!(
        m.encoder_counts,
        [
            (0.1234 * per_rad).round() as i64,
            (-0.2345 * per_rad).round() as i64
        ]
    );
    assert!((m.alpha_rad[0] - 0.1234).abs() <= 0.5 / per_rad + 1e-12);
    let lsb = 20.0 / 65536.0;
    for v in m.loadcell_v {
        assert!(((v / lsb) - (v / lsb).round()).abs() < 1e-6, "{v}");
    }
}

/// Bad input never panics nor produces NaN: NaN currents are the minimum current, a zero or
/// negative step does nothing.
#[test]
fn bad_inputs_are_harmless() {
    let mut twin = ideal_twin([0.0; 2]);
    let t0 = twin.state().t_s;
    let m = twin.step(-1.0, [f64::NAN; 4], &HandleCondition::Free);
    assert_eq!(m.t_s, t0);
    for _ in 0..500 {
        let m = twin.step(
            0.001,
            [f64::NAN, f64::INFINITY, -5.0, 1e9],
            &HandleCondition::Free,
        );
        assert!(m
            .alpha_rad
            .iter()
            .chain(m.force_user_n.iter())
            .chain(m.pressure_bar.iter())
            .all(|x| x.is_finite()));
    }
    let p = twin.state().pressure_bar;
    assert!(
        p[0] < 0.2 && p[3] > 4.9,
        "NaN → floor, huge → top of range: {p:?}"
    );
}
