//! Impedance mode, rendered against identified: for a commanded K and B, the K, B
//! and M that the dynamic identification (`pamctl ident dynamic`) finds on the twin's
//! impedance trial, next to what it finds on a *pure* spring-damper driven by the same
//! motion (the log's force replaced by −K Δx − B ẋ computed from the logged encoder angles,
//! plus the load cell's noise): the identification's own bias, with no robot in it.
//!
//! ```sh
//! cargo run --release -p pam-eval --example impedance_bias -- K B [M] [POINT] [SECONDS]
//! ```

use pam_ident::msd;
use pam_ident::trial::Trial;
use pam_ident::FilterSettings;
use pam_model::RobotModel;
use pam_twin::experiments::ExperimentConfig;
use pam_twin::impedance_trial::{impedance_trial, VirtualImpedance};
use pam_twin::TwinConfig;

fn diag(f: &msd::TimeFit) -> [[f64; 2]; 3] {
    let d = |n: &str| {
        let m = f.matrices.iter().find(|m| m.name == n).expect("matrix");
        [m.matrix[0][0], m.matrix[1][1]]
    };
    [d("K"), d("B"), d("M")]
}

fn main() {
    let mut args = std::env::args().skip(1);
    let mut num = |default: f64| {
        args.next()
            .map(|v| v.parse::<f64>().expect("a number"))
            .unwrap_or(default)
    };
    let (k, b, m) = (num(300.0), num(5.0), num(0.0));
    let point = num(1.0) as usize;
    let seconds = num(30.0);
    let model = RobotModel::<f64>::thesis();
    let cfg = ExperimentConfig::new(TwinConfig::thesis());
    let imp = VirtualImpedance {
        stiffness_n_per_m: [k; 2],
        damping_n_s_per_m: [b; 2],
        mass_kg: [m; 2],
    };
    let log = match impedance_trial(&cfg, point, imp, seconds) {
        Ok(log) => log,
        Err(e) => {
            println!("K {k} N/m, B {b} N·s/m, M {m} kg: {}", e.message);
            if let Some(l) = e.partial_log {
                let _ = l.write_path("/tmp/i14/partial.csv");
            }
            return;
        }
    };
    let trial = Trial::from_log(&log).expect("trial");
    let fit = |t: &Trial| {
        let p = t
            .prepare(&model, FilterSettings::default())
            .expect("prepared");
        let f = msd::fit_dynamic(&p, model.cartesian_mass(p.alpha0_rad));
        (diag(&f), [f.test[0].r2, f.test[1].r2])
    };
    let (twin, r2) = fit(&trial);
    // the same motion through a pure spring-damper-mass
    let mut pure = trial.clone();
    let n = trial.t_s.len();
    let x: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            model
                .kinematics
                .forward_user([trial.alpha_rad[0][i], trial.alpha_rad[1][i]])
        })
        .collect();
    let start = ((0.1 / cfg.period_s).round() as usize).max(1);
    let x0 = [0, 1].map(|a| x[..start].iter().map(|p| p[a]).sum::<f64>() / start as f64);
    let dt = cfg.period_s;
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut noise = || {
        // sum of 12 uniforms − 6: a cheap normal, σ = 1
        (0..12)
            .map(|_| {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                (rng >> 11) as f64 / (1u64 << 53) as f64
            })
            .sum::<f64>()
            - 6.0
    };
    for i in 0..n {
        let (im, ip) = (i.saturating_sub(1), (i + 1).min(n - 1));
        for a in 0..2 {
            let v = (x[ip][a] - x[im][a]) / ((ip - im).max(1) as f64 * dt);
            let acc = (x[ip][a] - 2.0 * x[i][a] + x[im][a]) / (dt * dt);
            let acc = if ip - im == 2 { acc } else { 0.0 };
            pure.force_n[a][i] = -k * (x[i][a] - x0[a]) - b * v - m * acc + 0.15 * noise();
        }
    }
    let (ideal, r2i) = fit(&pure);
    let desired = ideal_force(&model, &trial, x0, [k, b, m], dt);
    for (a, (want, got)) in desired.iter().zip(&trial.force_n).enumerate() {
        let (lag, gain, resid) = lag_of(want, got, (4.0 / dt) as usize);
        println!("axis {a}: rendered {lag} ms late, gain {gain:.3}, RMS residual {resid:.3} N");
    }
    println!("commanded K {k} N/m, B {b} N·s/m, M {m} kg, point {point}, {seconds} s");
    println!("| | K_xx, K_yy | B_xx, B_yy | M_xx, M_yy | R² X, Y |");
    println!("|---|---|---|---|---|");
    for (name, d, r) in [("twin", twin, r2), ("pure", ideal, r2i)] {
        println!(
            "| {name} | {:.1}, {:.1} | {:.2}, {:.2} | {:.3}, {:.3} | {:.3}, {:.3} |",
            d[0][0], d[0][1], d[1][0], d[1][1], d[2][0], d[2][1], r[0], r[1]
        );
    }
}

/// The force the impedance asks for, without the loop's lead: K (x₀ − x) − B ẋ − M ẍ with the
/// controller's own motion observer (lag-free velocity and acceleration) on the logged angles.
fn ideal_force(
    model: &RobotModel<f64>,
    trial: &Trial,
    x0: [f64; 2],
    [k, b, m]: [f64; 3],
    dt: f64,
) -> [Vec<f64>; 2] {
    let m32 = RobotModel::<f32>::new(model.params.cast());
    let home = m32.kinematics.home_world_m;
    let mut motion = pam_control::Impedance::new();
    let mut f = [Vec::new(), Vec::new()];
    for (a1, a2) in trial.alpha_rad[0].iter().zip(&trial.alpha_rad[1]) {
        let w = m32.kinematics.forward_world([*a1 as f32, *a2 as f32]);
        let x = [(w[0] - home[0]) as f64, (w[1] - home[1]) as f64];
        motion.track([x[0] as f32, x[1] as f32], dt as f32);
        let (v, acc) = (motion.observed_velocity_m_s(), motion.acceleration_m_s2());
        for (a, fa) in f.iter_mut().enumerate() {
            fa.push(k * (x0[a] - x[a]) - b * v[a] as f64 - m * acc[a] as f64);
        }
    }
    f
}

/// The delay (ms, 0–79) and gain with which `got` follows `want` best (least squares), from
/// sample `start`, and the RMS residual there.
fn lag_of(want: &[f64], got: &[f64], start: usize) -> (usize, f64, f64) {
    let end = want.len().saturating_sub(80);
    let mut best = (f64::INFINITY, 0, 0.0);
    for tau in 0..80 {
        let pairs = || want[start..end].iter().zip(&got[start + tau..end + tau]);
        let sxy: f64 = pairs().map(|(w, g)| w * g).sum();
        let sxx: f64 = pairs().map(|(w, _)| w * w).sum();
        let gain = sxy / sxx;
        let r: f64 = pairs().map(|(w, g)| (g - gain * w).powi(2)).sum();
        if r < best.0 {
            best = (r, tau, gain);
        }
    }
    (best.1, best.2, (best.0 / (end - start) as f64).sqrt())
}
