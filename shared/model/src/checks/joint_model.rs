//! Properties of the joint model over random poses: inverse and direct are each other's
//! inverse, unattainable requests are clamped and flagged, invalid inputs give safe
//! pressures, the capability quadrilateral matches Table 3.2.

use super::*;

/// Inverse ∘ direct is the identity inside the quadrilateral: any attainable (τ, K) comes
/// back unchanged and unflagged.
pub fn inverse_then_direct_is_identity<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0001);
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        for j in 0..2 {
            let cap = m.capability(j, alpha[j]);
            let (t_lo, t_hi) = cap.torque_limits_nm();
            // stay a hair inside so rounding cannot put the request on the wrong side
            let t = rng.uniform(t_lo.to_f64() * 0.999, t_hi.to_f64() * 0.999);
            let Some((k_lo, k_hi)) = cap.stiffness_range(R::from_f64(t)) else {
                return holds("stiffness range exists inside torque limits", i, false);
            };
            let span = (k_hi - k_lo).to_f64();
            let k = k_lo.to_f64() + span * rng.uniform(0.001, 0.999);
            let sol =
                m.joints[j].inverse(&m.params.muscle, alpha[j], R::from_f64(t), R::from_f64(k));
            holds("attainable request not flagged", i, sol.limited.is_none())?;
            let back = m.pose(j, alpha[j]);
            let tol = num_tol::<R>();
            close(
                "torque after inverse+direct [N m]",
                i,
                back.torque_nm(sol.pressure_bar).to_f64(),
                t,
                2e-3 * tol + 1e-9,
            )?;
            close(
                "stiffness after inverse+direct [N m/rad]",
                i,
                back.stiffness_nm_per_rad(sol.pressure_bar).to_f64(),
                k,
                2e-3 * tol + 1e-9,
            )?;
        }
    }
    Ok(())
}

/// Direct ∘ inverse is the identity on pressures: pressures inside the quadrilateral map
/// to (τ, K) and back to themselves.
pub fn direct_then_inverse_is_identity<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0002);
    let mut tested = 0u32;
    for i in 0..SWEEP * 2 {
        let alpha = random_alpha(&m, &mut rng);
        let j = (i & 1) as usize;
        let p = [
            R::from_f64(rng.uniform(0.0, 5.0)),
            R::from_f64(rng.uniform(0.0, 5.0)),
        ];
        let pose = m.pose(j, alpha[j]);
        let (t, k) = (pose.torque_nm(p), pose.stiffness_nm_per_rad(p));
        let cap = pose.capability(&m.joints[j]);
        if !cap.contains(t, k) {
            continue; // pressure box corners outside the thesis's quadrilateral
        }
        tested += 1;
        let sol = m.joints[j].inverse(&m.params.muscle, alpha[j], t, k);
        let tol = 1e-4 * num_tol::<R>() + 1e-9;
        close(
            "P1 after direct+inverse [bar]",
            i,
            sol.pressure_bar[0].to_f64(),
            p[0].to_f64(),
            tol * 50.0,
        )?;
        close(
            "P2 after direct+inverse [bar]",
            i,
            sol.pressure_bar[1].to_f64(),
            p[1].to_f64(),
            tol * 50.0,
        )?;
    }
    holds(
        "enough samples inside the quadrilateral",
        tested,
        tested > SWEEP / 4,
    )
}

/// An unattainable request is clamped to the boundary and flagged, never passed through.
pub fn unattainable_requests_are_clamped_and_flagged<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0003);
    for i in 0..SWEEP {
        let alpha = random_alpha(&m, &mut rng);
        let j = (i & 1) as usize;
        let cap = m.capability(j, alpha[j]);
        let (t_lo, t_hi) = cap.torque_limits_nm();
        // torque beyond the limit on a random side
        let beyond = if rng.uniform(0.0, 1.0) < 0.5 {
            t_hi * R::from_f64(1.5)
        } else {
            t_lo * R::from_f64(1.5)
        };
        let sol = m.joints[j].inverse(
            &m.params.muscle,
            alpha[j],
            beyond,
            cap.k_min.stiffness_nm_per_rad,
        );
        holds(
            "torque clamp flagged",
            i,
            sol.limited.contains(Limited::TORQUE),
        )?;
        let target = if beyond > R::ZERO { t_hi } else { t_lo };
        close(
            "clamped torque on the boundary [N m]",
            i,
            sol.torque_nm.to_f64(),
            target.to_f64(),
            1e-3 * num_tol::<R>() + 1e-7,
        )?;
        // stiffness beyond K_max at zero torque
        let sol = m.joints[j].inverse(
            &m.params.muscle,
            alpha[j],
            R::ZERO,
            cap.k_max.stiffness_nm_per_rad + R::from_f64(50.0),
        );
        holds(
            "stiffness clamp flagged",
            i,
            sol.limited.contains(Limited::STIFFNESS) && !sol.limited.contains(Limited::TORQUE),
        )?;
        close(
            "clamped stiffness at K_max [N m/rad]",
            i,
            sol.stiffness_nm_per_rad.to_f64(),
            cap.k_max.stiffness_nm_per_rad.to_f64(),
            1e-3 * num_tol::<R>() + 1e-7,
        )?;
        for p in sol.pressure_bar {
            holds(
                "clamped pressures within limits",
                i,
                p.to_f64() >= 0.0 && p.to_f64() <= 5.0,
            )?;
        }
    }
    Ok(())
}

/// NaN/∞ and out-of-range angles give the safe pretension, flagged, and finite pressures.
pub fn invalid_inputs_give_safe_pressures<R: Real>() -> CheckResult {
    let m = model::<R>();
    let nan = R::from_f64(f64::NAN);
    let inf = R::from_f64(f64::INFINITY);
    let cases: [(R, R, R); 5] = [
        (nan, R::ZERO, R::from_f64(60.0)),
        (R::ZERO, nan, R::from_f64(60.0)),
        (R::ZERO, R::ZERO, inf),
        (R::from_f64(1.0), R::ZERO, R::from_f64(60.0)), // 57°: outside ±22.5°
        (R::ZERO, -inf, nan),
    ];
    for (i, (a, t, k)) in cases.iter().enumerate() {
        let sol = m.joints[0].inverse(&m.params.muscle, *a, *t, *k);
        holds("invalid input flagged", i as u32, !sol.limited.is_none())?;
        for p in sol.pressure_bar {
            holds(
                "safe pressure finite and in limits",
                i as u32,
                p.is_finite() && p >= R::ZERO && p <= R::from_f64(5.0),
            )?;
        }
    }
    Ok(())
}

/// The quadrilateral's stiffness range at τ = 0 is [K_min, K_max], and its vertices are
/// the limit conditions of Table 3.2.
pub fn capability_vertices_match_table_3_2<R: Real>() -> CheckResult {
    let m = model::<R>();
    let mut rng = Rng::new(0x5eed_0004);
    for i in 0..SWEEP / 4 {
        let alpha = random_alpha(&m, &mut rng);
        for j in 0..2 {
            let cap = m.capability(j, alpha[j]);
            let Some((lo, hi)) = cap.stiffness_range(R::ZERO) else {
                return holds("zero torque attainable", i, false);
            };
            let tol = 1e-3 * num_tol::<R>() + 1e-9;
            close(
                "K range low at tau=0",
                i,
                lo.to_f64(),
                cap.k_min.stiffness_nm_per_rad.to_f64(),
                tol,
            )?;
            close(
                "K range high at tau=0",
                i,
                hi.to_f64(),
                cap.k_max.stiffness_nm_per_rad.to_f64(),
                tol,
            )?;
            close("tau at K_min", i, cap.k_min.torque_nm.to_f64(), 0.0, tol)?;
            close("tau at K_max", i, cap.k_max.torque_nm.to_f64(), 0.0, tol)?;
            let pmax = cap.k_max.pressure_bar[0]
                .max(cap.k_max.pressure_bar[1])
                .to_f64();
            close("one muscle at 5 bar for K_max", i, pmax, 5.0, 1e-4)?;
            close(
                "tau_max at P=(0,5)",
                i,
                cap.tau_max.pressure_bar[1].to_f64(),
                5.0,
                0.0,
            )?;
            holds(
                "K_min < K_max",
                i,
                cap.k_min.stiffness_nm_per_rad < cap.k_max.stiffness_nm_per_rad,
            )?;
            holds(
                "tau_min < 0 < tau_max",
                i,
                cap.tau_min.torque_nm < R::ZERO && cap.tau_max.torque_nm > R::ZERO,
            )?;
        }
    }
    Ok(())
}
