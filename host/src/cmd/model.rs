//! `pamctl model …`: the robot model at a pose, in f64 (the same code the firmware runs
//! in f32).

use clap::{Args, Subcommand};
use pam_model::ellipse::Ellipse;
use pam_model::thesis::TABLE_4_1;
use pam_model::{Limited, Mat2, RobotModel};
use std::io::Write;

#[derive(Subcommand, Debug)]
pub enum ModelCommand {
    /// Torque and stiffness capability of both joints at a pose (Fig. 3.2–3.4), and the
    /// Cartesian stiffness and mass the handle presents there.
    Capability(PoseArgs),
    /// Inverse model: joint torque and stiffness → the four muscle pressures and I/P currents.
    Inverse(InverseArgs),
    /// Table 4.1 of the thesis recomputed from the model.
    Table41,
    /// Fit the base model (plus `--with` effects) to a log and show where it fails.
    Compare(crate::cmd::model_loop::LoopArgs),
    /// Test every catalog effect against a log; name the missing one, or "none", or the
    /// structure no effect explains. With a second log of the same dynamic trial at Table
    /// 4.1's other stiffness level, also decide friction or hysteresis.
    Diagnose(crate::cmd::model_loop::DiagnoseArgs),
    /// Fit the model with `--with` effects: their parameters, the error before and after.
    Fit(crate::cmd::model_loop::LoopArgs),
}

#[derive(Args, Debug)]
pub struct PoseArgs {
    /// Encoder angle of joint 1, degrees from the neutral pose (range ±22.5).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub alpha1_deg: f64,
    /// Encoder angle of joint 2, degrees from the neutral pose (range ±32.5).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub alpha2_deg: f64,
}

#[derive(Args, Debug)]
pub struct InverseArgs {
    #[command(flatten)]
    pub pose: PoseArgs,
    /// Joint torques τ1,τ2 in N·m.
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.0], allow_negative_numbers = true, value_name = "T1,T2")]
    pub torque_nm: Vec<f64>,
    /// Joint stiffnesses K1,K2 in N·m/rad.
    #[arg(long, value_delimiter = ',', default_values_t = [60.0, 27.0], allow_negative_numbers = true, value_name = "K1,K2")]
    pub stiffness_nm_per_rad: Vec<f64>,
}

impl PoseArgs {
    fn alpha_rad(&self, model: &RobotModel<f64>) -> anyhow::Result<[f64; 2]> {
        let deg = [self.alpha1_deg, self.alpha2_deg];
        let mut out = [0.0; 2];
        for j in 0..2 {
            let (lo, hi) = (
                model.joints[j].alpha_min_rad.to_degrees(),
                model.joints[j].alpha_max_rad.to_degrees(),
            );
            if !(deg[j].is_finite() && deg[j] >= lo - 1e-9 && deg[j] <= hi + 1e-9) {
                return Err(anyhow::anyhow!(
                    "--alpha{}-deg {} is outside joint {}'s range [{lo:.1}, {hi:.1}] degrees",
                    j + 1,
                    deg[j],
                    j + 1
                ));
            }
            out[j] = deg[j].to_radians();
        }
        Ok(out)
    }
}

pub fn run(cmd: ModelCommand, out: &mut impl Write) -> anyhow::Result<()> {
    let model = RobotModel::<f64>::thesis();
    match cmd {
        ModelCommand::Capability(pose) => capability(&model, &pose, out),
        ModelCommand::Inverse(args) => inverse(&model, &args, out),
        ModelCommand::Table41 => table41(out),
        ModelCommand::Compare(a) => return crate::cmd::model_loop::compare(&a, out),
        ModelCommand::Diagnose(a) => return crate::cmd::model_loop::diagnose(&a, out),
        ModelCommand::Fit(a) => return crate::cmd::model_loop::fit(&a, out),
    }
    .map_err(anyhow::Error::from)
    .and_then(|r| r)
}

fn fmt_mat(m: &Mat2<f64>) -> String {
    format!(
        "[[{:8.2}, {:8.2}], [{:8.2}, {:8.2}]]",
        m.0[0][0], m.0[0][1], m.0[1][0], m.0[1][1]
    )
}

fn fmt_ellipse(m: &Mat2<f64>) -> String {
    let e = Ellipse::of(m);
    format!(
        "area {:.4e}, aspect ratio {:.2}, orientation {:.1} deg",
        e.area,
        e.aspect_ratio,
        e.orientation_rad.to_degrees()
    )
}

fn capability(
    model: &RobotModel<f64>,
    pose: &PoseArgs,
    out: &mut impl Write,
) -> std::io::Result<anyhow::Result<()>> {
    let alpha = match pose.alpha_rad(model) {
        Ok(a) => a,
        Err(e) => return Ok(Err(e)),
    };
    let xy = model.kinematics.forward_user(alpha);
    writeln!(
        out,
        "pose: alpha = ({:.2}, {:.2}) deg, handle at ({:+.4}, {:+.4}) m in the user frame",
        pose.alpha1_deg, pose.alpha2_deg, xy[0], xy[1]
    )?;
    let mut k_min = [0.0; 2];
    for j in 0..2 {
        let p = model.pose(j, alpha[j]);
        let cap = p.capability(&model.joints[j]);
        k_min[j] = cap.k_min.stiffness_nm_per_rad;
        writeln!(
            out,
            "joint {}: eps1 {:.4}, eps2 {:.4}, anti-slack force {:.2} N",
            j + 1,
            p.epsilon[0],
            p.epsilon[1],
            model.joints[j].anti_slack_force_n
        )?;
        writeln!(
            out,
            "  torque range          [{:+.2}, {:+.2}] N m",
            cap.tau_min.torque_nm, cap.tau_max.torque_nm
        )?;
        writeln!(
            out,
            "  stiffness at tau = 0  K_min {:.2}, K_max {:.2} N m/rad",
            cap.k_min.stiffness_nm_per_rad, cap.k_max.stiffness_nm_per_rad
        )?;
        for v in cap.vertices() {
            writeln!(
                out,
                "  vertex tau {:+7.2} N m, K {:7.2} N m/rad at P1 {:.3} bar, P2 {:.3} bar",
                v.torque_nm, v.stiffness_nm_per_rad, v.pressure_bar[0], v.pressure_bar[1]
            )?;
        }
    }
    if let Some(kc) = model.cartesian_stiffness(alpha, k_min) {
        writeln!(
            out,
            "Cartesian stiffness at K_min  {} N/m  ({})",
            fmt_mat(&kc),
            fmt_ellipse(&kc)
        )?;
    }
    if let Some(mc) = model.cartesian_mass(alpha) {
        writeln!(
            out,
            "Cartesian mass                {} kg   ({})",
            fmt_mat(&mc),
            fmt_ellipse(&mc)
        )?;
    }
    Ok(Ok(()))
}

fn inverse(
    model: &RobotModel<f64>,
    args: &InverseArgs,
    out: &mut impl Write,
) -> std::io::Result<anyhow::Result<()>> {
    let alpha = match args.pose.alpha_rad(model) {
        Ok(a) => a,
        Err(e) => return Ok(Err(e)),
    };
    for (name, v) in [
        ("--torque-nm", &args.torque_nm),
        ("--stiffness-nm-per-rad", &args.stiffness_nm_per_rad),
    ] {
        if v.len() != 2 {
            return Ok(Err(anyhow::anyhow!(
                "{name} takes two comma-separated values (joint 1, joint 2), got {}",
                v.len()
            )));
        }
    }
    let tau = [args.torque_nm[0], args.torque_nm[1]];
    let k = [args.stiffness_nm_per_rad[0], args.stiffness_nm_per_rad[1]];
    let sol = model.inverse(alpha, tau, k);
    for j in 0..2 {
        let s = &sol[j];
        writeln!(
            out,
            "joint {}: requested tau {:+.2} N m, K {:.2} N m/rad -> P1 {:.3} bar, P2 {:.3} bar (tau {:+.2}, K {:.2})",
            j + 1, tau[j], k[j], s.pressure_bar[0], s.pressure_bar[1], s.torque_nm, s.stiffness_nm_per_rad
        )?;
        if !s.limited.is_none() {
            writeln!(out, "  CLAMPED: {}", describe(s.limited))?;
        }
    }
    let channels = model.channel_pressures_bar([sol[0].pressure_bar, sol[1].pressure_bar]);
    for (c, p) in channels.iter().enumerate() {
        let cmd = model.params.ip.current_for(*p);
        writeln!(
            out,
            "channel {c}: {:.3} bar -> {:.3} mA{}",
            p,
            cmd.current_ma,
            if cmd.saturated {
                format!(
                    " (saturated: the converter will give {:.3} bar)",
                    cmd.pressure_bar
                )
            } else {
                String::new()
            }
        )?;
    }
    Ok(Ok(()))
}

/// Human-readable list of what the inverse model changed.
pub fn describe(l: Limited) -> String {
    let mut parts = Vec::new();
    if l.contains(Limited::TORQUE) {
        parts.push("torque outside the joint's range at this pose");
    }
    if l.contains(Limited::STIFFNESS) {
        parts.push("stiffness outside the range attainable at this torque");
    }
    if l.contains(Limited::PRESSURE) {
        parts.push("pressure limits");
    }
    if l.contains(Limited::INVALID_INPUT) {
        parts.push("invalid input (safe pretension used)");
    }
    if l.contains(Limited::SINGULAR) {
        parts.push("singular model (safe pretension used)");
    }
    parts.join("; ")
}

fn table41(out: &mut impl Write) -> std::io::Result<anyhow::Result<()>> {
    writeln!(out, "point  alpha1  alpha2   K_low,1  K_high,1  K_low,2  K_high,2   [N m/rad; printed value in brackets]")?;
    let model = RobotModel::<f64>::thesis();
    for (i, (a1, a2, printed)) in TABLE_4_1.iter().enumerate() {
        let alpha = [a1.to_radians(), a2.to_radians()];
        let mut k = [0.0; 4];
        for j in 0..2 {
            (k[2 * j], k[2 * j + 1]) = model.capability(j, alpha[j]).trial_stiffness_levels();
        }
        write!(out, "{:>5}  {:>6.1}  {:>6.1}", i + 1, a1, a2)?;
        for n in 0..4 {
            write!(out, "  {:6.1} [{:5.1}]", k[n], printed[n])?;
        }
        writeln!(out)?;
    }
    Ok(Ok(()))
}
