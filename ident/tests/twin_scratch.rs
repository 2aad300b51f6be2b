use pam_ident::lsq::{self, Column};
use pam_ident::msd;
use pam_ident::{FilterSettings, Trial};
use pam_model::RobotModel;
use pam_twin::experiments::{dynamic_trial, ExperimentConfig, StiffnessLevel};
use pam_twin::TwinConfig;

fn lpf(x: &[f64], dt: f64, tau: f64) -> Vec<f64> {
    let a = dt / (tau + dt);
    let mut y = vec![0.0; x.len()];
    let mut s = x[0];
    for i in 0..x.len() { s += a * (x[i] - s); y[i] = s; }
    y
}

#[test]
#[ignore]
fn scratch() {
    let mut tw = TwinConfig::thesis();
    tw.seed = 1;
    let mut cfg = ExperimentConfig::new(tw);
    cfg.period_s = 0.01;
    let level = if std::env::var("HIGH").is_ok() { StiffnessLevel::High } else { StiffnessLevel::Low };
    let log = dynamic_trial(&cfg, 1, level, 60.0).unwrap();
    let tr = Trial::from_log(&log).unwrap();
    let model = RobotModel::<f64>::thesis();
    let p = tr.prepare(&model, FilterSettings::default()).unwrap();
    let y = msd::target(&p);
    let base = msd::msd_columns(&p);
    let (th, pred) = msd::fit_columns(&p, &base, &msd::MSD_POSITIVE, &y);
    let (t, _) = msd::scores(&p, &y, &pred);
    println!("base {:.3} {:.3} theta {:?}", t[0].nrmse, t[1].nrmse, th.iter().map(|v| format!("{v:.1}")).collect::<Vec<_>>());
    for tau in [0.01, 0.02, 0.04, 0.08, 0.16, 0.32] {
        let mut cols = base.clone();
        for (nm, s) in [("kf", &p.dx_m), ("bf", &p.v_m_s)] {
            let f = [lpf(&s[0], p.dt_s, tau), lpf(&s[1], p.dt_s, tau)];
            cols.push(Column::on(format!("{nm}xx"), 0, f[0].clone()));
            cols.push(Column::both(format!("{nm}xy"), f[1].clone(), f[0].clone()));
            cols.push(Column::on(format!("{nm}yy"), 1, f[1].clone()));
        }
        let (th, pred) = msd::fit_columns(&p, &cols, &msd::MSD_POSITIVE, &y);
        let (t, _) = msd::scores(&p, &y, &pred);
        println!("tau {tau}: {:.3} {:.3} theta {:?}", t[0].nrmse, t[1].nrmse, th.iter().map(|v| format!("{v:.1}")).collect::<Vec<_>>());
    }
    let ip = &model.params.ip;
    println!("ip wn {} zeta {}", ip.natural_freq_rad_s, ip.damping_ratio);
    for (wn, z) in [(ip.natural_freq_rad_s, ip.damping_ratio), (15.0, 0.42), (30.0, 0.42), (23.0, 0.7)] {
        let mut cols = base.clone();
        let sp = pam_ident::step::StepParams::base(1.0, z, wn);
        let lp2 = |x: &[f64]| { let mut o = vec![0.0; x.len()]; pam_ident::step::simulate(&sp, &p.t_s, x, [&p.alpha_rad[0], &p.alpha_rad[1]], x[0], &mut o); o };
        let f = [lp2(&p.dx_m[0]), lp2(&p.dx_m[1])];
        let h: [Vec<f64>; 2] = [ (0..p.len()).map(|i| p.dx_m[0][i] - f[0][i]).collect(), (0..p.len()).map(|i| p.dx_m[1][i] - f[1][i]).collect() ];
        cols.push(Column::on("hxx", 0, h[0].clone()));
        cols.push(Column::both("hxy", h[1].clone(), h[0].clone()));
        cols.push(Column::on("hyy", 1, h[1].clone()));
        let (th, pred) = msd::fit_columns(&p, &cols, &msd::MSD_POSITIVE, &y);
        let (t, _) = msd::scores(&p, &y, &pred);
        println!("hp2 wn {wn} z {z}: {:.3} {:.3} theta {:?}", t[0].nrmse, t[1].nrmse, th.iter().map(|v| format!("{v:.1}")).collect::<Vec<_>>());
    }
    for tau in [0.02, 0.04, 0.06] {
        let mut cols = base.clone();
        for (nm, s) in [("kf", &p.dx_m)] {
            let f = [lpf(&s[0], p.dt_s, tau), lpf(&s[1], p.dt_s, tau)];
            cols.push(Column::on(format!("{nm}xx"), 0, f[0].clone()));
            cols.push(Column::both(format!("{nm}xy"), f[1].clone(), f[0].clone()));
            cols.push(Column::on(format!("{nm}yy"), 1, f[1].clone()));
        }
        let (th, pred) = msd::fit_columns(&p, &cols, &msd::MSD_POSITIVE, &y);
        let (t, _) = msd::scores(&p, &y, &pred);
        println!("kf only tau {tau}: {:.3} {:.3} theta {:?}", t[0].nrmse, t[1].nrmse, th.iter().map(|v| format!("{v:.1}")).collect::<Vec<_>>());
    }
    // residual vs speed bins
    let r: Vec<f64> = (0..p.len()).map(|i| y[0][i] - pred[0][i]).collect();
    let _ = r;
}
