//! Time-domain identification (§4.3): the mass-spring-damper model of eq. 4.29–4.30 for
//! dynamic trials and the pure spring of eq. 4.27–4.28 for static trials, fitted on the
//! first 80 % and scored on the last 20 %.

use crate::trial::Prepared;
use pam_model::ellipse::Ellipse;
use pam_model::Mat2;
use pam_numerics::lsq::{self, Column};
use pam_numerics::stats::{rms, std_dev};
use serde::Serialize;

/// The sign convention of the log: fx_n is the force the robot exerts on the hand, so the
/// hand's force on the robot, −f, is what M ẍ + B ẋ + K Δx balances.
pub fn target(p: &Prepared) -> [Vec<f64>; 2] {
    [
        p.force_n[0].iter().map(|f| -f).collect(),
        p.force_n[1].iter().map(|f| -f).collect(),
    ]
}

/// Eq. 4.30: three symmetric 2×2 matrices, nine parameters.
pub fn msd_columns(p: &Prepared) -> Vec<Column> {
    let mut cols = Vec::with_capacity(9);
    for (sym, s) in [("m", &p.a_m_s2), ("b", &p.v_m_s), ("k", &p.dx_m)] {
        cols.push(Column::on(format!("{sym}_xx"), 0, s[0].clone()));
        cols.push(Column::both(
            format!("{sym}_xy"),
            s[1].clone(),
            s[0].clone(),
        ));
        cols.push(Column::on(format!("{sym}_yy"), 1, s[1].clone()));
    }
    cols
}

/// Indices of b_xx, b_yy, k_xx, k_yy in [`msd_columns`]: the diagonals kept positive.
pub const MSD_POSITIVE: [usize; 4] = [3, 5, 6, 8];

/// Eq. 4.28: the static spring, three parameters.
pub fn spring_columns(p: &Prepared) -> Vec<Column> {
    vec![
        Column::on("k_xx", 0, p.dx_m[0].clone()),
        Column::both("k_xy", p.dx_m[1].clone(), p.dx_m[0].clone()),
        Column::on("k_yy", 1, p.dx_m[1].clone()),
    ]
}

pub const SPRING_POSITIVE: [usize; 2] = [0, 2];

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct AxisScore {
    pub mse: f64,
    pub r2: f64,
    pub nrmse: f64,
}

/// Scores on a row range, per axis.
pub fn score(measured: &[f64], predicted: &[f64]) -> AxisScore {
    let res: Vec<f64> = measured.iter().zip(predicted).map(|(m, p)| m - p).collect();
    let mse = rms(&res).powi(2);
    let sd = std_dev(measured);
    let var = sd * sd;
    AxisScore {
        mse,
        r2: if var > 0.0 { 1.0 - mse / var } else { f64::NAN },
        nrmse: if sd > 0.0 { mse.sqrt() / sd } else { f64::NAN },
    }
}

/// Table 4.2's split, made automatic: the held-out part is cut into windows, each window
/// classed by the dominant angular frequency of its motion (rms ẍ / rms ẋ); windows above
/// the median are "high frequency".
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FrequencySplit {
    pub window_s: f64,
    pub boundary_rad_s: f64,
    pub mse_low: [f64; 2],
    pub mse_high: [f64; 2],
    pub mse_all: [f64; 2],
}

pub fn frequency_split(
    p: &Prepared,
    measured: &[Vec<f64>; 2],
    predicted: &[Vec<f64>; 2],
) -> FrequencySplit {
    let n = p.len();
    let w = ((2.0 / p.dt_s).round() as usize).max(10);
    let mut windows = Vec::new();
    let mut s = p.split();
    while s + w / 2 <= n {
        let e = (s + w).min(n);
        let v = rms(&p.v_m_s[0][s..e]).hypot(rms(&p.v_m_s[1][s..e]));
        let a = rms(&p.a_m_s2[0][s..e]).hypot(rms(&p.a_m_s2[1][s..e]));
        windows.push((s, e, if v > 0.0 { a / v } else { 0.0 }));
        s = e;
    }
    let mut omegas: Vec<f64> = windows.iter().map(|w| w.2).collect();
    omegas.sort_by(|a, b| a.total_cmp(b));
    let boundary = omegas.get(omegas.len() / 2).copied().unwrap_or(0.0);
    let mut acc = [[0.0f64; 2]; 2];
    let mut cnt = [0usize; 2];
    for &(s, e, om) in &windows {
        let class = usize::from(om >= boundary);
        for ax in 0..2 {
            for i in s..e {
                let r = measured[ax][i] - predicted[ax][i];
                acc[class][ax] += r * r;
            }
        }
        cnt[class] += e - s;
    }
    let all = |ax: usize| {
        let r: Vec<f64> = (p.split()..n)
            .map(|i| measured[ax][i] - predicted[ax][i])
            .collect();
        rms(&r).powi(2)
    };
    let div = |a: f64, c: usize| if c > 0 { a / c as f64 } else { f64::NAN };
    FrequencySplit {
        window_s: w as f64 * p.dt_s,
        boundary_rad_s: boundary,
        mse_low: [div(acc[0][0], cnt[0]), div(acc[0][1], cnt[0])],
        mse_high: [div(acc[1][0], cnt[1]), div(acc[1][1], cnt[1])],
        mse_all: [all(0), all(1)],
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct MatrixReport {
    pub name: String,
    pub matrix: [[f64; 2]; 2],
    pub eigenvalues: [f64; 2],
    pub area: f64,
    pub aspect_ratio: f64,
    pub orientation_deg: f64,
    /// An ellipse (§4.6) exists only for a positive definite matrix; otherwise area,
    /// aspect and orientation mean nothing.
    pub positive_definite: bool,
}

pub fn matrix_report(name: &str, m: Mat2<f64>) -> MatrixReport {
    let e = Ellipse::of(&m);
    MatrixReport {
        name: name.into(),
        matrix: m.0,
        eigenvalues: [e.lambda_min, e.lambda_max],
        area: e.area,
        aspect_ratio: e.aspect_ratio,
        orientation_deg: e.orientation_rad.to_degrees(),
        positive_definite: e.is_positive_definite(),
    }
}

/// Result of a time-domain fit (dynamic or static).
#[derive(Clone, Debug, Serialize)]
pub struct TimeFit {
    pub experiment: String,
    pub samples: usize,
    pub dt_s: f64,
    pub equilibrium_m: [f64; 2],
    pub matrices: Vec<MatrixReport>,
    /// Held-out (last 20 %) scores per axis.
    pub test: [AxisScore; 2],
    pub train: [AxisScore; 2],
    pub split: Option<FrequencySplit>,
    pub warnings: Vec<String>,
    #[serde(skip)]
    pub predicted: [Vec<f64>; 2],
    #[serde(skip)]
    pub theta: Vec<f64>,
}

pub fn sym(theta: &[f64]) -> Mat2<f64> {
    Mat2::symmetric(theta[0], theta[1], theta[2])
}

/// Fits columns on the first 80 %, predicts everywhere.
pub fn fit_columns(
    p: &Prepared,
    cols: &[Column],
    positive: &[usize],
    y: &[Vec<f64>; 2],
) -> (Vec<f64>, [Vec<f64>; 2]) {
    let ne = lsq::normal_equations(cols, &[&y[0], &y[1]], 0..p.split());
    let theta = lsq::solve(&ne, positive);
    let pred = lsq::predict(cols, &theta, p.len());
    (theta, pred)
}

/// (held-out, training) scores per axis, on the trial's [`Prepared::held_out`] rows and
/// the rest.
pub fn scores(
    p: &Prepared,
    y: &[Vec<f64>; 2],
    pred: &[Vec<f64>; 2],
) -> ([AxisScore; 2], [AxisScore; 2]) {
    let held: Vec<usize> = p.held_out.rows().collect();
    let train: Vec<usize> = p.held_out.train_rows().collect();
    let on = |a: usize, rows: &[usize]| {
        let pick = |v: &[f64]| rows.iter().map(|&i| v[i]).collect::<Vec<f64>>();
        score(&pick(&y[a]), &pick(&pred[a]))
    };
    ([on(0, &held), on(1, &held)], [on(0, &train), on(1, &train)])
}

/// What is implausible about a fitted mass matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MassWarning {
    /// A negative diagonal or a matrix that is not positive definite.
    NotPositiveDefinite {
        lambda_min_kg: f64,
        lambda_max_kg: f64,
    },
    /// The largest eigenvalue is more than 5× above or below the robot's Cartesian inertia.
    FarFromRobot { fitted_kg: f64, robot_kg: f64 },
}

impl std::fmt::Display for MassWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MassWarning::NotPositiveDefinite {
                lambda_min_kg,
                lambda_max_kg,
            } => write!(
                f,
                "fitted mass matrix is not positive definite (eigenvalues {lambda_min_kg:.3}, {lambda_max_kg:.3} kg): a modelling or timing problem, not physics"
            ),
            MassWarning::FarFromRobot {
                fitted_kg,
                robot_kg,
            } => write!(
                f,
                "largest fitted mass eigenvalue {fitted_kg:.2} kg is far from the robot's Cartesian inertia ({robot_kg:.2} kg) at the mean pose"
            ),
        }
    }
}

/// Plausibility of a fitted mass matrix against the robot's Cartesian inertia at the mean pose.
pub fn mass_checks(m: &Mat2<f64>, robot_mass: Option<Mat2<f64>>) -> Vec<MassWarning> {
    let mut w = Vec::new();
    let e = Ellipse::of(m);
    if m.0[0][0] < 0.0 || m.0[1][1] < 0.0 || !e.is_positive_definite() {
        w.push(MassWarning::NotPositiveDefinite {
            lambda_min_kg: e.lambda_min,
            lambda_max_kg: e.lambda_max,
        });
    }
    if let Some(r) = robot_mass {
        let er = Ellipse::of(&r);
        if e.lambda_max > 5.0 * er.lambda_max || e.lambda_max < 0.2 * er.lambda_max {
            w.push(MassWarning::FarFromRobot {
                fitted_kg: e.lambda_max,
                robot_kg: er.lambda_max,
            });
        }
    }
    w
}

/// [`mass_checks`] as messages.
pub fn mass_warnings(m: &Mat2<f64>, robot_mass: Option<Mat2<f64>>) -> Vec<String> {
    mass_checks(m, robot_mass)
        .iter()
        .map(ToString::to_string)
        .collect()
}

/// §4.3 dynamic trial: M, B, K.
pub fn fit_dynamic(p: &Prepared, robot_mass: Option<Mat2<f64>>) -> TimeFit {
    let y = target(p);
    let cols = msd_columns(p);
    let (theta, pred) = fit_columns(p, &cols, &MSD_POSITIVE, &y);
    let (test, train) = scores(p, &y, &pred);
    let m = sym(&theta[0..3]);
    let mut warnings = mass_warnings(&m, robot_mass);
    for (i, name) in [(3, "b_xx"), (5, "b_yy"), (6, "k_xx"), (8, "k_yy")] {
        if theta[i] == 0.0 {
            warnings.push(format!("{name} hit its positivity bound (0)"));
        }
    }
    TimeFit {
        experiment: "dynamic".into(),
        samples: p.len(),
        dt_s: p.dt_s,
        equilibrium_m: p.x0_m,
        matrices: vec![
            matrix_report("M", m),
            matrix_report("B", sym(&theta[3..6])),
            matrix_report("K", sym(&theta[6..9])),
        ],
        test,
        train,
        split: Some(frequency_split(p, &y, &pred)),
        warnings,
        predicted: pred,
        theta,
    }
}

/// §4.3 static trial: K only (eq. 4.27–4.28).
pub fn fit_static(p: &Prepared) -> TimeFit {
    let y = target(p);
    let cols = spring_columns(p);
    let (theta, pred) = fit_columns(p, &cols, &SPRING_POSITIVE, &y);
    let (test, train) = scores(p, &y, &pred);
    let spread = std_dev(&p.dx_m[0]).hypot(std_dev(&p.dx_m[1]));
    let mut warnings = Vec::new();
    if spread < 1e-4 {
        warnings.push(format!(
            "the handle hardly moved ({:.2e} m): the stiffness is not identifiable",
            spread
        ));
    }
    TimeFit {
        experiment: "static".into(),
        samples: p.len(),
        dt_s: p.dt_s,
        equilibrium_m: p.x0_m,
        matrices: vec![matrix_report("K", sym(&theta))],
        test,
        train,
        split: None,
        warnings,
        predicted: pred,
        theta,
    }
}

#[cfg(test)]
mod report_tests {
    use super::*;

    /// A fitted mass with a zero diagonal has no ellipse; a stiffness does.
    #[test]
    fn matrix_report_flags_matrices_without_an_ellipse() {
        let m = matrix_report("M", Mat2::new(1.2, 0.4, 0.4, 0.0));
        assert!(!m.positive_definite, "{m:?}");
        assert!(m.eigenvalues[0] < 0.0);
        let k = matrix_report("K", Mat2::new(254.0, 107.0, 107.0, 364.0));
        assert!(k.positive_definite, "{k:?}");
    }
}
