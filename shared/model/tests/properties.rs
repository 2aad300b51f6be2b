//! Property tests in f64 with shrinking (proptest), beside the fixed-seed sweeps of
//! `checks` that also run on the target.
use pam_model::ellipse::Ellipse;
use pam_model::{Limited, Mat2, RobotModel};
use proptest::prelude::*;

fn model() -> RobotModel<f64> {
    RobotModel::thesis()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn inverse_of_direct_is_identity_inside_quadrilateral(
        j in 0usize..2, a in -1.0f64..1.0, u in 0.001f64..0.999, v in 0.001f64..0.999
    ) {
        let m = model();
        let alpha = a * m.joints[j].alpha_max_rad;
        let cap = m.capability(j, alpha);
        let (t_lo, t_hi) = cap.torque_limits_nm();
        let t = t_lo + (t_hi - t_lo) * u;
        let (k_lo, k_hi) = cap.stiffness_range(t).unwrap();
        let k = k_lo + (k_hi - k_lo) * v;
        let sol = m.joints[j].inverse(&m.params.muscle, alpha, t, k);
        prop_assert!(sol.limited.is_none());
        let pose = m.pose(j, alpha);
        prop_assert!((pose.torque_nm(sol.pressure_bar) - t).abs() < 1e-9);
        prop_assert!((pose.stiffness_nm_per_rad(sol.pressure_bar) - k).abs() < 1e-9);
        prop_assert!(sol.pressure_bar.iter().all(|p| (0.0..=5.0).contains(p)));
    }

    #[test]
    fn any_request_yields_pressures_within_limits(
        j in 0usize..2, a in -2.0f64..2.0, t in -500.0f64..500.0, k in -500.0f64..500.0
    ) {
        let m = model();
        let sol = m.joints[j].inverse(&m.params.muscle, a, t, k);
        prop_assert!(sol.pressure_bar.iter().all(|p| p.is_finite() && (0.0..=5.0).contains(p)));
        let cap = m.capability(j, a.clamp(m.joints[j].alpha_min_rad, m.joints[j].alpha_max_rad));
        let attainable = a.abs() <= m.joints[j].alpha_max_rad && cap.contains(t, k);
        // never silent: either the request was met or a flag says why not
        prop_assert!(attainable || !sol.limited.is_none());
        if sol.limited.is_none() {
            prop_assert!((sol.torque_nm - t).abs() < 1e-6 && (sol.stiffness_nm_per_rad - k).abs() < 1e-6);
        }
    }

    #[test]
    fn torque_clamp_keeps_the_sign_and_hits_the_limit(j in 0usize..2, a in -1.0f64..1.0, over in 1.01f64..10.0, up in any::<bool>()) {
        let m = model();
        let alpha = a * m.joints[j].alpha_max_rad;
        let cap = m.capability(j, alpha);
        let (t_lo, t_hi) = cap.torque_limits_nm();
        let t = if up { t_hi * over } else { t_lo * over };
        let sol = m.joints[j].inverse(&m.params.muscle, alpha, t, cap.k_min.stiffness_nm_per_rad);
        prop_assert!(sol.limited.contains(Limited::TORQUE));
        let limit = if up { t_hi } else { t_lo };
        prop_assert!((sol.torque_nm - limit).abs() < 1e-6);
    }

    #[test]
    fn fk_ik_round_trip(a1 in -1.0f64..1.0, a2 in -1.0f64..1.0) {
        let m = model();
        let alpha = [a1 * m.joints[0].alpha_max_rad, a2 * m.joints[1].alpha_max_rad];
        let back = m.kinematics.inverse_user(m.kinematics.forward_user(alpha)).unwrap();
        prop_assert!((back[0] - alpha[0]).abs() < 1e-9 && (back[1] - alpha[1]).abs() < 1e-9);
    }

    #[test]
    fn ellipse_orientation_of_rotated_diagonal(big in 1.0f64..1000.0, ratio in 0.01f64..0.95, phi in -1.55f64..1.55) {
        let small = big * ratio;
        let r = Mat2::rotation(phi);
        let m = Mat2::diag(big, small).congruence(&r.transpose());
        let e = Ellipse::of(&m);
        prop_assert!((e.lambda_max - big).abs() < 1e-9 * big);
        prop_assert!((e.lambda_min - small).abs() < 1e-9 * big);
        prop_assert!((e.orientation_rad - phi).abs() < 1e-7);
    }
}

#[test]
fn params_round_trip_through_serde_keep_every_value() {
    // the host loads user calibrations through serde; a lossy field would be a silent change
    let p = pam_model::RobotParams::<f64>::thesis();
    let f32_copy: pam_model::RobotParams<f32> = p.cast();
    let back: pam_model::RobotParams<f64> = f32_copy.cast();
    assert!((back.joints[0].pulley_radius_m - 0.070).abs() < 1e-7);
    assert_eq!(back.joints[0].channel_of_muscle, [1, 0]);
    assert!(p.validate().is_ok());
    let mut bad = p;
    bad.joints[1].channel_of_muscle = [1, 3]; // channel 1 already belongs to joint 1
    assert!(bad.validate().is_err());
}
