//! Physics sanity of the plant's parts.

use pam_model::RobotParams;
use pam_physgen::arm::{rk4, Arm};
use pam_physgen::friction::{BoucWen, LuGre, MaxwellSlip};
use pam_physgen::muscle::{Muscle, Regulator};

#[test]
fn free_arm_conserves_its_kinetic_energy_with_the_coriolis_terms() {
    let arm = Arm::nominal(&RobotParams::thesis());
    let theta2_0 = -1.2;
    let mut y = [0.3, theta2_0, 1.5, -2.0];
    let e0 = arm.kinetic_energy_j(y[1], [y[2], y[3]]);
    let dt = 0.001;
    for _ in 0..5000 {
        y = rk4(&y, dt, |s| {
            let a = arm.acceleration(s[1], [s[2], s[3]], [0.0, 0.0]);
            [s[2], s[3], a[0], a[1]]
        });
    }
    let e1 = arm.kinetic_energy_j(y[1], [y[2], y[3]]);
    assert!(((e1 - e0) / e0).abs() < 1e-6, "energy {e0} → {e1}");
    // the elbow moved, so the inertia changed and the Coriolis terms did work between joints
    assert!((y[1] - theta2_0).abs() > 1.0);
    // without the Coriolis terms q̈ = M⁻¹·0: constant rates, and the energy is not kept
    let mut z = [0.3, theta2_0, 1.5, -2.0];
    for _ in 0..5000 {
        z = rk4(&z, dt, |s| [s[2], s[3], 0.0, 0.0]);
    }
    let e2 = arm.kinetic_energy_j(z[1], [z[2], z[3]]);
    assert!(((e2 - e0) / e0).abs() > 1e-3);
}

fn lugre() -> LuGre {
    LuGre {
        sigma0: 1e5,
        sigma1: 300.0,
        sigma2: 0.4,
        coulomb: 1.0,
        stiction: 1.5,
        stribeck_speed: 0.001,
    }
}

#[test]
fn lugre_sticks_and_slips_when_a_spring_drags_a_mass() {
    // Canudas de Wit et al. (1995), fig. 4: 1 kg, 2 N/m spring pulled at 0.1 m/s
    let l = lugre();
    let (m, k, vd) = (1.0, 2.0, 0.1);
    let (mut x, mut v, mut z) = (0.0f64, 0.0f64, 0.0f64);
    let dt = 1e-4;
    let mut spring_max = 0.0f64;
    let mut slips = 0;
    let mut slipping = false;
    for i in 0..400_000 {
        let t = i as f64 * dt;
        let spring = k * (vd * t - x);
        let f = l.force(z, v);
        v += dt * (spring - f) / m;
        x += dt * v;
        z = l.advance(z, v, dt);
        spring_max = spring_max.max(spring);
        if !slipping && v > 2.0 * vd {
            slipping = true;
            slips += 1;
        } else if slipping && v.abs() < 0.1 * vd {
            slipping = false;
        }
    }
    assert!(slips >= 3, "{slips} slips");
    // it breaks away at the stiction level, above the Coulomb level
    assert!(
        spring_max > 1.4 && spring_max < 1.7,
        "peak spring force {spring_max}"
    );
}

#[test]
fn lugre_steady_state_follows_the_stribeck_curve() {
    let l = lugre();
    // thirty of the bristles' time constants at that speed
    let steady = |v: f64| {
        let settle_s = 30.0 * l.g(v) / (l.sigma0 * v.abs());
        let z = l.advance(0.0, v, settle_s);
        l.force(z, v)
    };
    for v in [1e-5, 5e-4, 2e-3, 0.01, 1.0] {
        assert!((steady(v) - l.steady_force(v)).abs() < 1e-6 * (1.0 + l.steady_force(v)));
    }
    // falls from stiction to Coulomb with speed, then rises with the viscous part
    assert!(steady(1e-5) > 1.49);
    assert!(steady(2e-3) < steady(5e-4));
    assert!(steady(0.01) < 1.01);
    assert!(steady(1.0) > steady(0.01) + 0.35);
}

#[test]
fn maxwell_slip_sticks_then_slides_at_its_breakaway() {
    let g = MaxwellSlip {
        k: vec![400.0, 150.0],
        w: vec![0.4, 0.3],
        coulomb_ratio: 0.7,
        stribeck_speed: 0.03,
        viscous: 0.0,
    };
    let mut z = vec![0.0; 2];
    // a small displacement: both elements stick, the force is linear
    g.advance(&mut z, 5e-4, 0.0);
    assert!((g.force(&z, 0.0) - (400.0 + 150.0) * 5e-4).abs() < 1e-12);
    // a large one: both slide, the force is their breakaway
    g.advance(&mut z, 0.1, 0.0);
    assert!((g.force(&z, 0.0) - 0.7).abs() < 1e-12);
    // sliding fast, the Stribeck curve lowers it to the Coulomb level
    g.advance(&mut z, 0.1, 1.0);
    assert!((g.force(&z, 1.0) - 0.7 * 0.7).abs() < 1e-9);
}

#[test]
fn bouc_wen_loop_area_grows_with_amplitude() {
    let bw = BoucWen {
        beta: 0.7,
        gamma: 0.3,
        n: 1.5,
        x_ref: 0.01,
    };
    let area = |amp: f64| {
        let (w, dt) = (std::f64::consts::TAU, 1e-4);
        let mut z = 0.0;
        let mut a = 0.0;
        // two periods to settle, the third measured
        for i in 0..30_000 {
            let t = i as f64 * dt;
            let xd = amp * w * (w * t).cos();
            let z1 = bw.advance(z, xd, dt);
            if i >= 20_000 {
                a += 0.5 * (z + z1) * xd * dt;
            }
            z = z1;
            assert!(z.abs() <= 1.0);
        }
        a
    };
    let (a1, a2, a3) = (area(0.005), area(0.02), area(0.08));
    assert!(a1 > 0.0 && a2 > 1.5 * a1 && a3 > 1.5 * a2, "{a1} {a2} {a3}");
}

fn regulator() -> Regulator {
    Regulator {
        gain_bar_per_ma: 0.32667,
        offset_bar: -1.63,
        omega_n_rad_s: 30.0,
        zeta: 0.5,
        dead_steps: 0,
        fill_s: 0.015,
        cap_bar: 5.0,
        max_rise_bar_s: f64::INFINITY,
        max_fall_bar_s: f64::INFINITY,
    }
}

#[test]
fn a_muscle_at_one_length_fills_with_the_stated_time_constant() {
    let r = regulator();
    let m = Muscle::festo_20(0.4);
    let dt = 1e-5;
    // the time constant is the volume over the tube's conductance: fill_s at the rest
    // volume, longer in proportion where the contracted muscle holds more gas
    let eps = 0.05;
    let tau = r.fill_s * m.volume_m3(eps).0 / m.rest_volume_m3();
    assert!(tau > r.fill_s);
    let mut p = [1.0];
    let steps = (tau / dt).round() as usize;
    for _ in 0..steps {
        p = rk4(&p, dt, |s| [r.fill_rate(&m, s[0], 3.0, eps, 0.0)]);
    }
    let expected = 1.0 + 2.0 * (1.0 - (-1.0f64).exp());
    assert!((p[0] - expected).abs() < 0.005, "{} vs {expected}", p[0]);
}

#[test]
fn the_servo_overshoots_as_its_damping_says_and_a_choked_valve_limits_the_rise() {
    let r = regulator();
    let dt = 1e-4;
    let mut y = [0.0, 0.0];
    let mut peak = 0.0f64;
    for _ in 0..10_000 {
        y = rk4(&y, dt, |s| {
            let (a, b) = r.servo_rate(s[0], s[1], 1.0);
            [a, b]
        });
        peak = peak.max(y[0]);
    }
    let z = r.zeta;
    let overshoot = (-z * std::f64::consts::PI / (1.0 - z * z).sqrt()).exp();
    assert!((peak - 1.0 - overshoot).abs() < 1e-3, "{peak}");
    let choked = Regulator {
        max_rise_bar_s: 2.0,
        ..r
    };
    let m = Muscle::festo_20(0.4);
    let rate = choked.fill_rate(&m, 1.0, 4.0, 0.0, 0.0);
    assert!((rate - 2.0).abs() < 1e-9, "{rate}");
}

#[test]
fn a_muscle_pushes_nothing_and_pulls_more_with_pressure() {
    let m = Muscle::festo_20(0.4);
    assert_eq!(m.force_n(0.5, 4.0), 0.0);
    assert!(m.force_n(0.07, 3.0) > m.force_n(0.07, 2.0));
    assert!(m.force_n(0.05, 3.0) > m.force_n(0.10, 3.0));
    // the volume grows as the muscle contracts (it shortens and widens)
    assert!(m.volume_m3(0.1).0 > m.volume_m3(0.0).0);
}
