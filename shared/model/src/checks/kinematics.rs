//! Properties of the kinematics and the Cartesian quantities: FK ∘ IK, the Jacobian,
//! virtual work, stiffness ellipses, the Cartesian stiffness round trip.

use super::*;

/// FK ∘ IK is the identity in the workspace (user frame).
pub fn forward_then_inverse_kinematics_is_identity<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0005);
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        let p = m.kinematics.forward_user(alpha);
        let Some(back) = m.kinematics.inverse_user(p) else {
            return holds("IK reaches an FK point", i, false);
        };
        let tol = 2e-4 * num_tol::<R>() + 1e-10;
        close(
            "alpha1 after FK+IK [rad]",
            i,
            back[0].to_f64(),
            alpha[0].to_f64(),
            tol,
        )?;
        close(
            "alpha2 after FK+IK [rad]",
            i,
            back[1].to_f64(),
            alpha[1].to_f64(),
            tol,
        )?;
        let again = m.kinematics.forward_user(back);
        close(
            "x after IK+FK [m]",
            i,
            again[0].to_f64(),
            p[0].to_f64(),
            1e-4 * num_tol::<R>() + 1e-10,
        )?;
        close(
            "y after IK+FK [m]",
            i,
            again[1].to_f64(),
            p[1].to_f64(),
            1e-4 * num_tol::<R>() + 1e-10,
        )?;
    }
    Ok(())
}

/// The Jacobian matches central finite differences of the forward kinematics.
pub fn jacobian_matches_finite_differences<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0006);
    // f32 needs a larger step: the round-off of x ≈ 0.8 m is ~6e-8 m
    let h = if num_tol::<R>() > 0.5 { 1e-3 } else { 1e-6 };
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        let jac = m.kinematics.jacobian(alpha);
        for col in 0..2 {
            let mut ap = alpha;
            let mut am = alpha;
            ap[col] += R::from_f64(h);
            am[col] -= R::from_f64(h);
            let fp = m.kinematics.forward_world(ap);
            let fm = m.kinematics.forward_world(am);
            for row in 0..2 {
                let fd = (fp[row] - fm[row]).to_f64() / (2.0 * h);
                close(
                    "Jacobian vs finite difference [m/rad]",
                    i,
                    jac.0[row][col].to_f64(),
                    fd,
                    2e-4 * num_tol::<R>() + 1e-8,
                )?;
            }
        }
    }
    Ok(())
}

/// τ = Jᵀ F agrees with virtual work: F·δx = τ·δα for a small joint motion.
pub fn joint_torques_satisfy_virtual_work<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0007);
    let h = if num_tol::<R>() > 0.5 { 1e-3 } else { 1e-6 };
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        let f = [
            R::from_f64(rng.uniform(-30.0, 30.0)),
            R::from_f64(rng.uniform(-30.0, 30.0)),
        ];
        let tau = m.kinematics.joint_torques(alpha, f);
        let d = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)];
        let a1 = [
            alpha[0] + R::from_f64(d[0] * h),
            alpha[1] + R::from_f64(d[1] * h),
        ];
        let a0 = [
            alpha[0] - R::from_f64(d[0] * h),
            alpha[1] - R::from_f64(d[1] * h),
        ];
        let (x1, x0) = (
            m.kinematics.forward_world(a1),
            m.kinematics.forward_world(a0),
        );
        let work_cart = (f[0] * (x1[0] - x0[0]) + f[1] * (x1[1] - x0[1])).to_f64();
        let work_joint = tau[0].to_f64() * 2.0 * d[0] * h + tau[1].to_f64() * 2.0 * d[1] * h;
        close(
            "virtual work F.dx vs tau.dalpha [J]",
            i,
            work_cart,
            work_joint,
            60.0 * h * (1e-3 * num_tol::<R>() + 1e-8),
        )?;
    }
    Ok(())
}

/// The ellipse of R(φ)·diag(a, b)·R(φ)ᵀ returns φ (mod π) and the eigenvalues a, b.
pub fn ellipse_of_rotated_diagonal<R: Real>() -> CheckResult {
    let mut rng = Rng::new(0x5eed_0008);
    for i in 0..SWEEP {
        let big = rng.uniform(50.0, 600.0);
        let small = big * rng.uniform(0.05, 0.9);
        let phi = rng.uniform(-1.5, 1.5);
        let r = Mat2::<R>::rotation(R::from_f64(phi));
        let m = Mat2::diag(R::from_f64(big), R::from_f64(small)).congruence(&r.transpose());
        let e = Ellipse::of(&m);
        let tol = 1e-4 * num_tol::<R>() + 1e-9;
        close(
            "ellipse lambda_max",
            i,
            e.lambda_max.to_f64(),
            big,
            big * tol,
        )?;
        close(
            "ellipse lambda_min",
            i,
            e.lambda_min.to_f64(),
            small,
            big * tol,
        )?;
        close(
            "ellipse area",
            i,
            e.area.to_f64(),
            core::f64::consts::PI * big * small,
            core::f64::consts::PI * big * small * 10.0 * tol,
        )?;
        close(
            "ellipse aspect ratio",
            i,
            e.aspect_ratio.to_f64(),
            big / small,
            big / small * 100.0 * tol,
        )?;
        let mut d = e.orientation_rad.to_f64() - phi;
        while d > core::f64::consts::FRAC_PI_2 {
            d -= core::f64::consts::PI;
        }
        while d < -core::f64::consts::FRAC_PI_2 {
            d += core::f64::consts::PI;
        }
        close(
            "ellipse orientation (mod pi) [rad]",
            i,
            d,
            0.0,
            10.0 * tol / (1.0 - small / big),
        )?;
    }
    Ok(())
}

/// Joint → Cartesian → joint round trip (eq. 4.13 and its inverse), and the Cartesian
/// stiffness at point 1 has the thesis's structure (positive diagonal, coupled).
pub fn cartesian_stiffness_round_trip<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0009);
    for i in 0..SWEEP / 2 {
        let alpha = random_alpha(&m, &mut rng);
        let kj = [
            R::from_f64(rng.uniform(50.0, 150.0)),
            R::from_f64(rng.uniform(20.0, 70.0)),
        ];
        let Some(kc) = m.cartesian_stiffness(alpha, kj) else {
            return holds("Jacobian invertible in the workspace", i, false);
        };
        let back = crate::cartesian::cartesian_to_joint(&m.kinematics.jacobian(alpha), &kc);
        let tol = 1e-3 * num_tol::<R>() + 1e-9;
        close(
            "K_j11 after round trip",
            i,
            back.0[0][0].to_f64(),
            kj[0].to_f64(),
            kj[0].to_f64() * tol,
        )?;
        close(
            "K_j22 after round trip",
            i,
            back.0[1][1].to_f64(),
            kj[1].to_f64(),
            kj[1].to_f64() * tol,
        )?;
        close(
            "K_j12 after round trip",
            i,
            back.0[0][1].to_f64(),
            0.0,
            kj[0].to_f64() * tol,
        )?;
        holds(
            "Cartesian stiffness symmetric",
            i,
            (kc.0[0][1] - kc.0[1][0]).abs().to_f64() <= kc.0[0][0].abs().to_f64() * tol,
        )?;
    }
    Ok(())
}
