//! The signal chain and the force mode: load-cell rotation, the I/P and load-cell laws, the
//! gain plane, the channel map, force reproduction, and sin/cos accuracy of the scalar type.

use super::*;

/// The load-cell frame is the end-effector frame rotated by θ1 + θ2: a round trip is the
/// identity and, at the neutral pose, the rotation is α0 = atan(L2/L1).
pub fn load_cell_rotation<R: Real>() -> CheckResult {
    let m = model::<R>();
    let k = &m.kinematics;
    let u = k.sensor_to_user([R::ZERO; 2], [R::ONE, R::ZERO]);
    let alpha0 = libm::atan(0.45f64 / 0.70);
    close(
        "sensor X at neutral, user x",
        0,
        u[0].to_f64(),
        libm::cos(alpha0),
        1e-6,
    )?;
    close(
        "sensor X at neutral, user y",
        0,
        u[1].to_f64(),
        libm::sin(alpha0),
        1e-6,
    )?;
    let mut rng = Rng::new(0x5eed_000a);
    for i in 0..SWEEP / 4 {
        let alpha = random_alpha(&m, &mut rng);
        let f = [
            R::from_f64(rng.uniform(-50.0, 50.0)),
            R::from_f64(rng.uniform(-50.0, 50.0)),
        ];
        let back = k.sensor_to_user(alpha, k.user_to_sensor(alpha, f));
        close(
            "force after user->sensor->user [N]",
            i,
            back[0].to_f64(),
            f[0].to_f64(),
            1e-4 * num_tol::<R>() + 1e-9,
        )?;
        close(
            "force after user->sensor->user [N]",
            i,
            back[1].to_f64(),
            f[1].to_f64(),
            1e-4 * num_tol::<R>() + 1e-9,
        )?;
    }
    Ok(())
}

/// I/P law (eq. 2.2) both ways, saturation at the 4–20 mA ends, and load-cell law (eq. 2.1).
pub fn signal_laws<R: Real>() -> CheckResult {
    let p = RobotParams::<R>::thesis();
    let c = p.ip.current_for(R::from_f64(2.3));
    close(
        "current for 2.3 bar [mA]",
        0,
        c.current_ma.to_f64(),
        (2.3 + 1.63) / 0.32667,
        1e-4,
    )?;
    holds("2.3 bar not saturated", 0, !c.saturated)?;
    close(
        "pressure back from current [bar]",
        0,
        c.pressure_bar.to_f64(),
        2.3,
        1e-4,
    )?;
    let hi = p.ip.current_for(R::from_f64(5.0));
    holds("5 bar saturates the 20 mA end", 1, hi.saturated)?;
    close(
        "current at the top [mA]",
        1,
        hi.current_ma.to_f64(),
        20.0,
        0.0,
    )?;
    close(
        "highest commandable pressure [bar]",
        1,
        hi.pressure_bar.to_f64(),
        0.32667 * 20.0 - 1.63,
        1e-4,
    )?;
    let nan = p.ip.current_for(R::from_f64(f64::NAN));
    close(
        "NaN pressure gives the minimum current [mA]",
        2,
        nan.current_ma.to_f64(),
        4.0,
        0.0,
    )?;
    let f = p.load_cell.forces_n([R::from_f64(0.9), R::from_f64(-0.6)]);
    close("load cell X [N]", 3, f[0].to_f64(), 10.0, 1e-4)?;
    close("load cell Z [N]", 3, f[1].to_f64(), -10.0, 1e-4)
}

/// Gain plane: G = p1 α1 + p2 α2 + p3; the corrected command times G is the request; a
/// gain under the floor is raised and flagged.
pub fn gain_plane_correction<R: Real>() -> CheckResult {
    let mut p = RobotParams::<R>::thesis();
    p.gain_plane.coeffs = [
        [R::from_f64(0.3), R::from_f64(-0.2), R::from_f64(0.6)],
        [R::from_f64(-0.1), R::from_f64(0.25), R::from_f64(0.5)],
    ];
    let alpha = [R::from_f64(0.2), R::from_f64(-0.3)];
    let g = [
        p.gain_plane.gain(0, alpha).to_f64(),
        p.gain_plane.gain(1, alpha).to_f64(),
    ];
    close("G_x", 0, g[0], 0.3 * 0.2 + 0.2 * 0.3 + 0.6, 1e-6)?;
    close("G_y", 0, g[1], -0.1 * 0.2 - 0.25 * 0.3 + 0.5, 1e-6)?;
    let (cmd, limited) = p
        .gain_plane
        .correct([R::from_f64(9.1), R::from_f64(-18.2)], alpha);
    holds("not limited", 0, !limited)?;
    close("corrected X times G", 0, cmd[0].to_f64() * g[0], 9.1, 1e-5)?;
    close(
        "corrected Y times G",
        0,
        cmd[1].to_f64() * g[1],
        -18.2,
        1e-5,
    )?;
    p.gain_plane.coeffs[0] = [R::ZERO, R::ZERO, R::from_f64(0.01)];
    let (cmd, limited) = p.gain_plane.correct([R::from_f64(9.1), R::ZERO], alpha);
    holds("tiny gain flagged", 1, limited)?;
    close("tiny gain floored", 1, cmd[0].to_f64(), 9.1 / 0.2, 1e-4)
}

/// Joint 1's permuted numbering: the channel map is applied once and inverts exactly.
pub fn channel_map_round_trip<R: Real>() -> CheckResult {
    let m = model::<R>();
    let jp = [
        [R::from_f64(1.0), R::from_f64(2.0)],
        [R::from_f64(3.0), R::from_f64(4.0)],
    ];
    let ch = m.channel_pressures_bar(jp);
    // joint 1's model muscle 1 drives channel 1, muscle 2 channel 0 (§2.3)
    close("channel 0 = joint 1 muscle 2", 0, ch[0].to_f64(), 2.0, 0.0)?;
    close("channel 1 = joint 1 muscle 1", 1, ch[1].to_f64(), 1.0, 0.0)?;
    close("channel 2 = joint 2 muscle 1", 2, ch[2].to_f64(), 3.0, 0.0)?;
    close("channel 3 = joint 2 muscle 2", 3, ch[3].to_f64(), 4.0, 0.0)?;
    holds("channel map inverts", 4, m.joint_pressures_bar(ch) == jp)?;
    holds("thesis parameters validate", 5, m.params.validate().is_ok())
}

/// The Cartesian force mode reproduces the requested force at the handle: the joint
/// torques it commands are Jᵀ F and the model's torques from its pressures match them.
pub fn force_mode_reproduces_force<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_000b);
    for i in 0..SWEEP / 4 {
        let alpha = random_alpha(&m, &mut rng);
        let f = [
            R::from_f64(rng.uniform(-20.0, 20.0)),
            R::from_f64(rng.uniform(-20.0, 20.0)),
        ];
        let k = [R::from_f64(200.0), R::from_f64(80.0)]; // above K_min everywhere: clamps to the range
        let cmd = m.force_command(alpha, f, k, false);
        for j in 0..2 {
            let sol = &cmd.joints[j];
            if sol.limited.contains(Limited::TORQUE) {
                continue;
            }
            close(
                "torque delivered for force request [N m]",
                i,
                sol.torque_nm.to_f64(),
                cmd.joint_torque_nm[j].to_f64(),
                1e-3 * num_tol::<R>() + 1e-8,
            )?;
        }
    }
    Ok(())
}

/// The scalar's sin/cos against f64 libm over ±2π (for f32 this is the crate's own
/// sincos; under the `micromath` feature it is micromath's, which does not pass).
pub fn sin_cos_accuracy<R: Real>() -> CheckResult {
    let tol = 1e-7 * num_tol::<R>() + 1e-15;
    for i in 0..4001u32 {
        let x = -2.0 * core::f64::consts::PI + 4.0 * core::f64::consts::PI * i as f64 / 4000.0;
        let xr = R::from_f64(x);
        let exact_x = xr.to_f64(); // compare at the argument the type can hold
        let (s, c) = xr.sin_cos();
        close("sin", i, s.to_f64(), libm::sin(exact_x), tol)?;
        close("cos", i, c.to_f64(), libm::cos(exact_x), tol)?;
    }
    Ok(())
}
