//! The must-shows against the thesis, plus passivity and the experiments' logs.
//! Figures are printed (`--nocapture`) side by side with the thesis's.

mod common;

use common::*;
use pam_log::col;
use pam_model::{Mat2, RobotModel};
use pam_twin::experiments::*;
use pam_twin::{HandleCondition, Twin, TwinConfig};

/// The stiffness the twin's physics should show at point 1: the model's trial stiffness
/// times the rig's muscle force ratio plus the rig's parallel stiffness (`pam_twin::rig`),
/// mapped to the handle.
fn expected_k(cfg: &ExperimentConfig, model: &RobotModel<f64>, level: StiffnessLevel) -> Mat2<f64> {
    let k_muscles = trial_stiffness(model, [0.0; 2], level);
    let ratio = cfg.twin.mechanics.muscle_force_ratio;
    let k_parallel = cfg.twin.mechanics.parallel_stiffness_nm_per_rad;
    model
        .cartesian_stiffness(
            [0.0; 2],
            [0, 1].map(|j| ratio * k_muscles[j] + k_parallel[j]),
        )
        .unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn print_mat(name: &str, m: &Mat2<f64>) -> String {
    format!(
        "{name} [[{:.3}, {:.3}], [{:.3}, {:.3}]]",
        m.0[0][0], m.0[0][1], m.0[1][0], m.0[1][1]
    )
}

/// §4.3: the simulated 90 s dynamic trial at point 1 (K_low), fitted with a linear
/// mass-spring-damper (eq. 4.30), gives positive masses and the stiffness and mass of the
/// physics it simulates.
///
/// Thesis (point 1, minimum stiffness): K_C = [[253.7, 107.1], [107.1, 364.0]],
/// B_C = [[26.6, 9.4], [9.4, 0.9]], M_C = [[0.93, −0.053], [−0.053, −0.027]];
/// static trial K_C = [[145.9, 73.5], [73.5, 387.0]]. The model's K_C at K_min is
/// [[85.8, 55.2], [55.2, 221.3]]: the thesis measured more than its model predicts (Fig. 4.3),
/// statically too. The twin's rig has a parallel stiffness calibrated on the static and the
/// high-stiffness trials (`pam_twin::rig`); this trial is held out of that calibration, and
/// it is asked for within a factor 1.5 of the print.
#[test]
fn dynamic_trial_point1_fits_linear_msd_with_positive_masses() {
    let cfg = ExperimentConfig::new(TwinConfig::identified_rig());
    let model = RobotModel::new(cfg.twin.params);
    let log = dynamic_trial(&cfg, 1, StiffnessLevel::Low, 90.0).unwrap();
    assert_eq!(log.len(), 90_000);
    let fit = fit_msd(&log, &model, [0.0, 0.0]);
    let k_model = expected_k(&cfg, &model, StiffnessLevel::Low);
    let m_model = model.cartesian_mass([0.0; 2]).unwrap();
    println!(
        "{}   (thesis temporal fit [[253.7, 107.1], [107.1, 364.0]]; model {:?})",
        print_mat("K_fit", &fit.k),
        k_model.0
    );
    println!(
        "{}   (thesis [[26.6, 9.4], [9.4, 0.9]])",
        print_mat("B_fit", &fit.b)
    );
    println!(
        "{}   (thesis [[0.93, -0.053], [-0.053, -0.027]]; model {:?})",
        print_mat("M_fit", &fit.m),
        m_model.0
    );
    println!(
        "R² = {:.3}, {:.3}   (thesis Table 4.3/4.5: 0.28–0.98)",
        fit.r2[0], fit.r2[1]
    );
    assert!(
        fit.m.0[0][0] > 0.0 && fit.m.0[1][1] > 0.0 && fit.m.det() > 0.0,
        "masses must be positive: {:?}",
        fit.m
    );
    for (i, j) in [(0, 0), (0, 1), (1, 1)] {
        assert!(
            rel(fit.k.0[i][j], k_model.0[i][j]) < 0.10,
            "K[{i}][{j}] {} vs model {}",
            fit.k.0[i][j],
            k_model.0[i][j]
        );
    }
    assert!(
        rel(fit.m.0[0][0], m_model.0[0][0]) < 0.25 && rel(fit.m.0[1][1], m_model.0[1][1]) < 0.25,
        "{:?}",
        fit.m
    );
    assert!(
        fit.b.0[0][0] > 0.0 && fit.b.0[1][1] > 0.0,
        "the air and bearings dissipate: {:?}",
        fit.b
    );
    assert!(fit.r2[0] > 0.9 && fit.r2[1] > 0.9, "{:?}", fit.r2);
    let printed = pam_twin::rig::KC_DYNAMIC_LOW_POINT1_N_PER_M;
    for (i, j) in [(0, 0), (0, 1), (1, 1)] {
        let ratio = fit.k.0[i][j] / printed[i][j];
        println!("K[{i}][{j}]: twin / thesis = {ratio:.2}");
        assert!(
            (1.0 / 1.5..=1.5).contains(&ratio),
            "K[{i}][{j}] {} is not within a factor 1.5 of the thesis's {}",
            fit.k.0[i][j],
            printed[i][j]
        );
    }
}

/// The default twin (no parallel stiffness) is the thesis's model: the fitted stiffness
/// is the model's K_C (and so a factor 1.6–3 under the thesis's measurement).
#[test]
fn thesis_model_alone_gives_the_model_stiffness() {
    let cfg = ExperimentConfig::thesis();
    let model = RobotModel::new(cfg.twin.params);
    let fit = fit_msd(
        &dynamic_trial(&cfg, 1, StiffnessLevel::Low, 45.0).unwrap(),
        &model,
        [0.0; 2],
    );
    let k_model = expected_k(&cfg, &model, StiffnessLevel::Low);
    println!(
        "{}   (model {:?})",
        print_mat("K_fit, thesis model alone", &fit.k),
        k_model.0
    );
    for (i, j) in [(0, 0), (0, 1), (1, 1)] {
        assert!(
            rel(fit.k.0[i][j], k_model.0[i][j]) < 0.10,
            "K[{i}][{j}] {:?}",
            fit.k
        );
    }
    assert!(fit.k.0[0][0] < 0.5 * pam_twin::rig::KC_DYNAMIC_LOW_POINT1_N_PER_M[0][0]);
}

/// The high-stiffness trial is stiffer than the low one, by the model's ratio.
#[test]
fn dynamic_trial_point1_high_stiffness_is_stiffer() {
    let cfg = ExperimentConfig::new(TwinConfig::identified_rig());
    let model = RobotModel::new(cfg.twin.params);
    let low = fit_msd(
        &dynamic_trial(&cfg, 1, StiffnessLevel::Low, 45.0).unwrap(),
        &model,
        [0.0; 2],
    );
    let high = fit_msd(
        &dynamic_trial(&cfg, 1, StiffnessLevel::High, 45.0).unwrap(),
        &model,
        [0.0; 2],
    );
    let k_high = expected_k(&cfg, &model, StiffnessLevel::High);
    println!(
        "{}   (thesis max [[304.1, 166.7], [166.7, 491.5]]; model {:?})",
        print_mat("K_fit high", &high.k),
        k_high.0
    );
    assert!(high.k.0[0][0] > 1.2 * low.k.0[0][0] && high.k.0[1][1] > 1.2 * low.k.0[1][1]);
    assert!(rel(high.k.0[0][0], k_high.0[0][0]) < 0.1 && rel(high.k.0[1][1], k_high.0[1][1]) < 0.1);
}

/// §4.2 at the thesis's own sampling period (50 ms loop and log).
#[test]
fn dynamic_trial_at_the_thesis_50ms_period() {
    let mut cfg = ExperimentConfig::thesis();
    cfg.period_s = 0.05;
    let model = RobotModel::new(cfg.twin.params);
    let log = dynamic_trial(&cfg, 1, StiffnessLevel::Low, 90.0).unwrap();
    assert_eq!(log.len(), 1800, "the thesis's ~1800 points per trial");
    let period = log.sample_period_s().unwrap();
    assert!((period - 0.05).abs() < 1e-9, "{period}");
    let fit = fit_msd(&log, &model, [0.0; 2]);
    let k_model = expected_k(&cfg, &model, StiffnessLevel::Low);
    println!(
        "50 ms: {} {} {}",
        print_mat("K", &fit.k),
        print_mat("B", &fit.b),
        print_mat("M", &fit.m)
    );
    assert!(
        rel(fit.k.0[0][0], k_model.0[0][0]) < 0.25 && rel(fit.k.0[1][1], k_model.0[1][1]) < 0.25,
        "{:?}",
        fit.k
    );
}

/// §4.3 static trial: the pure-spring fit (eq. 4.28) on the hold phases gives the model's
/// K_C (the thesis measured [[145.9, 73.5], [73.5, 387.0]] at point 1, minimum stiffness).
#[test]
fn static_trial_point1_gives_the_spring_of_the_model() {
    let cfg = ExperimentConfig::new(TwinConfig::identified_rig());
    let model = RobotModel::new(cfg.twin.params);
    let log = static_trial(&cfg, 1, StiffnessLevel::Low).unwrap();
    let (x, y) = handle_positions(&log, &model);
    let fx = log.column(col::FX_N).unwrap();
    let fy = log.column(col::FY_N).unwrap();
    let xr = log.column("hand_x_ref_m").unwrap();
    let yr = log.column("hand_y_ref_m").unwrap();
    let mut rows = Vec::new();
    let mut rhs = Vec::new();
    // hold samples: the target has not moved for 1 s
    let hold = (1.0 / 0.001) as usize;
    for i in hold..log.len() {
        if xr[i] == xr[i - hold] && yr[i] == yr[i - hold] {
            rows.push(vec![x[i], y[i], 0.0]);
            rhs.push(-fx[i]);
            rows.push(vec![0.0, x[i], y[i]]);
            rhs.push(-fy[i]);
        }
    }
    assert!(rows.len() > 2 * 8 * 4000, "{} hold samples", rows.len() / 2);
    let p = least_squares(&rows, &rhs);
    let k = Mat2::symmetric(p[0], p[1], p[2]);
    let k_model = expected_k(&cfg, &model, StiffnessLevel::Low);
    println!(
        "{}   (thesis static [[145.9, 73.5], [73.5, 387.0]]; model {:?})",
        print_mat("K_static", &k),
        k_model.0
    );
    for (i, j) in [(0, 0), (0, 1), (1, 1)] {
        assert!(
            rel(k.0[i][j], k_model.0[i][j]) < 0.10,
            "K[{i}][{j}] {} vs {}",
            k.0[i][j],
            k_model.0[i][j]
        );
    }
}

/// §5.2–5.3: the blocked force-step test at the nine poses. Each step looks second order
/// (overshoot then settling); ζ, ωn and the settling time 4/(ζ ωn) sit in the thesis's ranges
/// (Table 5.2: ζ = 0.42, ωn = 23.04 rad/s; §5.3: t_s = 0.28–0.42 s along X, 0.31–0.38 s along
/// Y — Fig. 5.4–5.5 are images, their ranges are not in the text), and the gain changes with
/// the pose.
#[test]
fn force_steps_are_second_order_with_pose_dependent_gain() {
    let cfg = ExperimentConfig::thesis();
    let mut pose_gain = Vec::new();
    let mut edge_gain = Vec::new();
    let mut all = Vec::new();
    for pose in STEP_POSES_DEG {
        let log = force_step_test(&cfg, pose).unwrap();
        assert!(log.column(col::FX_REF_N).is_some() && log.column(col::FY_REF_N).is_some());
        let steps = analyse_steps(&log);
        // 12 reference changes per axis (0 → 27.3 → −27.3 → 0 in 9.1 N steps)
        assert_eq!(steps.len(), 24, "{}", steps.len());
        let gains: Vec<f64> = steps.iter().map(|s| s.gain).collect();
        let mean = gains.iter().sum::<f64>() / gains.len() as f64;
        // the steps that reach ±27.3 N: where the converters' 0.1 bar floor, the 4.9 bar top
        // of the 4–20 mA loop and slack cables cut in, differently at each pose
        let edge = steps
            .iter()
            .filter(|s| s.to_n.abs() > 27.0 || s.from_n.abs() > 27.0)
            .map(|s| s.gain)
            .fold(f64::INFINITY, f64::min);
        edge_gain.push(edge);
        println!(
            "pose {:>5?}: gain mean {:.3} (min {:.3}), ζ median {:.3}, ωn median {:.2} rad/s",
            pose,
            mean,
            gains.iter().cloned().fold(f64::INFINITY, f64::min),
            median(steps.iter().filter_map(|s| s.zeta).collect()),
            median(steps.iter().filter_map(|s| s.omega_n_rad_s).collect())
        );
        pose_gain.push(mean);
        all.extend(steps);
    }
    let zetas: Vec<f64> = all.iter().filter_map(|s| s.zeta).collect();
    let wns: Vec<f64> = all.iter().filter_map(|s| s.omega_n_rad_s).collect();
    assert!(
        zetas.len() as f64 > 0.9 * all.len() as f64,
        "most steps overshoot (second order, ζ < 1)"
    );
    let (z, w) = (median(zetas), median(wns));
    let ts = 4.0 / (z * w);
    println!("all poses: ζ {z:.3} (thesis 0.42), ωn {w:.2} rad/s (thesis 23.04), t_s {ts:.3} s (thesis 0.28–0.42 s)");
    assert!(
        (0.3..=0.6).contains(&z) && (15.0..=35.0).contains(&w),
        "ζ {z}, ωn {w}"
    );
    assert!((0.28 * 0.9..=0.42 * 1.1).contains(&ts), "settling {ts} s");
    let span = |v: &[f64]| {
        v.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - v.iter().cloned().fold(f64::INFINITY, f64::min)
    };
    println!(
        "gain per pose: mean over all steps spans {:.3}, lowest gain (a ±27.3 N step) spans {:.3} ({:.3}–{:.3}) (thesis Fig. 5.4a/5.5a: varies over the poses, mean 0.57)",
        span(&pose_gain),
        span(&edge_gain),
        edge_gain.iter().cloned().fold(f64::INFINITY, f64::min),
        edge_gain.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
    );
    assert!(
        span(&edge_gain) > 0.2,
        "gain should change with the pose: {edge_gain:?}"
    );
    assert!(
        pose_gain.iter().all(|&g| g > 0.5 && g < 1.1),
        "{pose_gain:?}"
    );
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// A hand moves the handle along a closed path that starts and ends at rest. With the
/// pressure dynamics frozen (isobaric muscles, no bearing friction) the arm is conservative:
/// the net work of the hand is ~0 (checks the integrator and the inertia/Coriolis terms).
/// With the base chain's compressible air the robot is passive: the hand does positive work.
#[test]
fn the_arm_is_conservative_without_air_dynamics_and_passive_with_them() {
    let work = |isobaric: bool| {
        let mut cfg = TwinConfig::thesis();
        cfg.initial_pressure_bar = Some([2.3; 4]);
        if isobaric {
            cfg.pneumatics.polytropic_index = 0.0;
            cfg.mechanics.joint_damping_nm_s_per_rad = [0.0; 2];
        }
        let ip = cfg.params.ip;
        let i = (2.3 - ip.offset_bar) / ip.gain_bar_per_ma;
        let mut twin = Twin::new(cfg);
        // semi-implicit Euler's energy error is first order in the step: 0.1 ms keeps it < 1 %
        let dt = 0.0001;
        let (t_move, t_end) = (6.0, 9.0);
        let (mut w, mut e_peak) = (0.0, 0.0f64);
        let n = (t_end / dt) as usize;
        for k in 0..n {
            let t = k as f64 * dt;
            // raised-cosine window times a 1.3 Hz figure-eight, 4 cm
            let pi = std::f64::consts::PI;
            let (win, dwin) = if t < t_move {
                (
                    (pi * t / t_move).sin().powi(2),
                    pi / t_move * (2.0 * pi * t / t_move).sin(),
                )
            } else {
                (0.0, 0.0)
            };
            let om = std::f64::consts::TAU * 1.3;
            let p = [
                0.04 * win * (om * t).sin(),
                0.03 * win * (2.0 * om * t).sin(),
            ];
            let v = [
                0.04 * (dwin * (om * t).sin() + win * om * (om * t).cos()),
                0.03 * (dwin * (2.0 * om * t).sin() + win * 2.0 * om * (2.0 * om * t).cos()),
            ];
            let x_before = twin.state().handle_user_m;
            twin.step(dt, [i; 4], &HandleCondition::moved(p, v));
            let s = twin.state();
            let f = s.force_on_holder_user_n;
            let dx = [
                s.handle_user_m[0] - x_before[0],
                s.handle_user_m[1] - x_before[1],
            ];
            // the hand's force on the robot is −f
            w += -(f[0] * dx[0] + f[1] * dx[1]);
            e_peak = e_peak.max(w.abs());
        }
        let s = twin.state();
        assert!(
            s.handle_velocity_user_m_s.iter().all(|v| v.abs() < 1e-3),
            "ends at rest: {:?}",
            s.handle_velocity_user_m_s
        );
        (w, e_peak)
    };
    let (w_cons, peak) = work(true);
    let (w_air, _) = work(false);
    println!("hand work: isobaric {w_cons:.5} J (peak |W| {peak:.4} J), compressible {w_air:.5} J");
    assert!(peak > 0.05, "the path must load the arm");
    assert!(
        w_cons.abs() < 0.01 * peak,
        "conservative arm: net work {w_cons} J of {peak} J"
    );
    assert!(
        w_air > 0.0 && w_air > 10.0 * w_cons.abs(),
        "passive robot absorbs energy: {w_air} J"
    );
}

/// Logs carry the v1 columns, round-trip through the v1 reader, and metadata say what ran.
#[test]
fn experiment_logs_are_log_format_v1() {
    let mut cfg = ExperimentConfig::thesis();
    cfg.twin.effects = pam_twin::EffectSet::parse_list(&["mains_hum:amplitude_n=0.3"]).unwrap();
    cfg.twin.seed = 3;
    let log = dynamic_trial(&cfg, 2, StiffnessLevel::High, 5.0).unwrap();
    for c in col::REQUIRED
        .iter()
        .chain(col::PRESSURES_BAR.iter())
        .chain([col::SEQ, col::STATE].iter())
    {
        assert!(log.column(c).is_some(), "missing {c}");
    }
    assert!(
        log.column(col::FX_REF_N).is_none(),
        "no force target in a dynamic trial"
    );
    assert_eq!(log.meta("experiment"), Some("dynamic"));
    assert_eq!(log.meta("point"), Some("2"));
    assert_eq!(log.meta("seed"), Some("3"));
    assert!(log
        .meta("effects")
        .unwrap()
        .starts_with("mains_hum:amplitude_n=0.3"));
    let back = pam_log::read_str(&log.to_csv_string(), None).unwrap();
    assert_eq!(back.len(), log.len());
    assert_eq!(back.column(col::FX_N), log.column(col::FX_N));
    // every sample armed, sequence without gaps
    assert!(log.column(col::STATE).unwrap().iter().all(|&s| s == 1.0));
    let seq = log.column(col::SEQ).unwrap();
    assert!(seq.windows(2).all(|w| w[1] == w[0] + 1.0));
    // the same seed gives the same log
    let again = dynamic_trial(&cfg, 2, StiffnessLevel::High, 5.0).unwrap();
    assert_eq!(again, log);
}

#[test]
fn experiments_refuse_bad_requests_clearly() {
    let cfg = ExperimentConfig::thesis();
    assert!(dynamic_trial(&cfg, 6, StiffnessLevel::Low, 1.0)
        .unwrap_err()
        .message
        .contains("point 6"));
    assert!(dynamic_trial(&cfg, 1, StiffnessLevel::Low, -1.0)
        .unwrap_err()
        .message
        .contains("duration"));
    assert!(force_step_test(&cfg, [40.0, 0.0])
        .unwrap_err()
        .message
        .contains("outside joint 1"));
    let mut bad = ExperimentConfig::thesis();
    bad.period_s = 0.0;
    assert!(static_trial(&bad, 1, StiffnessLevel::Low)
        .unwrap_err()
        .message
        .contains("period"));
}

/// The operator path: the requested peak amplitude, starts and ends at the centre at rest,
/// velocity is the derivative of position, and it differs between seeds.
#[test]
fn operator_path_has_the_requested_shape() {
    let path = OperatorPath::new([0.01, -0.02], 0.04, (0.1, 2.0), 90.0, 9);
    let (mut peak, mut worst_dv) = ([0.0f64; 2], 0.0f64);
    let h = 1e-4;
    for i in 0..90_000 {
        let t = i as f64 * 0.001;
        let (p, v) = path.at(t);
        let (p2, _) = path.at(t + h);
        for a in 0..2 {
            peak[a] = peak[a].max((p[a] - [0.01, -0.02][a]).abs());
            worst_dv = worst_dv.max(((p2[a] - p[a]) / h - v[a]).abs());
        }
    }
    assert!(peak.iter().all(|&x| (x - 0.04).abs() < 0.002), "{peak:?}");
    assert!(worst_dv < 1e-3, "{worst_dv}");
    assert_eq!(path.at(0.0), ([0.01, -0.02], [0.0, 0.0]));
    let (end, v_end) = path.at(90.0);
    assert!((end[0] - 0.01).abs() < 1e-12 && v_end == [0.0; 2]);
    assert_ne!(
        OperatorPath::new([0.0; 2], 0.04, (0.1, 2.0), 90.0, 10).at(30.0),
        OperatorPath::new([0.0; 2], 0.04, (0.1, 2.0), 90.0, 9).at(30.0)
    );
}
