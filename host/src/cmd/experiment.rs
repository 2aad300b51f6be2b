//! `pamctl experiment static|dynamic|step`: the thesis protocols run on the connected device,
//! each trial recorded into its own log-format-v1 file in `--out`.
//!
//! - static (§4.2): joint mode at a Table 4.1 point with K_low or K_high, zero torque; the
//!   operator holds the handle at the nine points of the 8 cm square (centre, corners, edge
//!   midpoints), announced one by one (move, then hold).
//! - dynamic (§4.2): the same set-up; the operator moves the handle smoothly over the square
//!   for the trial's duration (90 s).
//! - step (§5.2): at each of the nine poses, joint mode brings the arm there, the handle is
//!   blocked, then force mode steps the reference 0 → 27.3 → −27.3 → 0 N in 9.1 N steps along
//!   X, then along Y (24 steps; `--repeats N` runs that staircase N times in the pose's log).
//!   `--co-contraction high` runs it with the muscles co-contracted harder (`both`: a log at
//!   each): the pair of logs that tells a supply's ceiling from the converters' spread.
//!
//! The stiffnesses and poses are pam-model's thesis protocols (`pam_model::protocols`, the
//! same the twin runs), computed from the robot parameters the device reports, and the
//! files carry the same metadata keys as the twin's logs, so the identification tools read
//! both alike. On the emulator, `pamctl sim --handle operator` plays the operator (dynamic),
//! `--handle blocked` blocks the handle in force mode (step), `--handle held` holds it at the
//! joint target (static).

use crate::LinkArgs;
use anyhow::Context;
use clap::{Args, Subcommand, ValueEnum};
use pam_control::{Mode, State};
use pam_link::{fault_names, Client};
use pam_model::protocols::{
    static_points, step_levels, step_test_stiffness_at, trial_stiffness, StiffnessLevel,
};
use pam_model::thesis::{STEP_POSES_DEG, TABLE_4_1_POINTS_DEG};
use pam_model::{RobotModel, Vec2};
use pam_protocol::{Config, ConfigSection, ReplyData, RequestBody};
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

mod session;
use session::{close_trial, open_trial, Session};

#[derive(Args, Debug)]
pub struct ExperimentArgs {
    #[command(subcommand)]
    pub kind: ExperimentKind,
    /// Directory for the logs (created if missing).
    #[arg(long, global = true, default_value = "experiments", value_name = "DIR")]
    pub out: PathBuf,
    /// Seconds in joint mode before recording, for the arm to settle.
    #[arg(long, global = true, default_value_t = 3.0, value_name = "SECONDS")]
    pub settle_s: f64,
    /// Do not wait for Enter at the operator prompts (prompts are still printed).
    #[arg(long, global = true)]
    pub yes: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Level {
    Low,
    High,
    Both,
}

#[derive(Subcommand, Debug)]
pub enum ExperimentKind {
    /// §4.2 static trials: the handle held at the nine points of the 8 cm square.
    Static {
        /// Table 4.1 point (1–5); default: all five.
        #[arg(long)]
        point: Option<usize>,
        #[arg(long, value_enum, default_value_t = Level::Both)]
        stiffness: Level,
        /// Hold time at each of the nine points, s.
        #[arg(long, default_value_t = 5.0, value_name = "SECONDS")]
        hold_s: f64,
        /// Time to move between points, s.
        #[arg(long, default_value_t = 1.5, value_name = "SECONDS")]
        move_s: f64,
    },
    /// §4.2 dynamic trials: the operator moves the handle over the square.
    Dynamic {
        /// Table 4.1 point (1–5); default: all five.
        #[arg(long)]
        point: Option<usize>,
        #[arg(long, value_enum, default_value_t = Level::Both)]
        stiffness: Level,
        /// Recording time of each trial, s.
        #[arg(long, default_value_t = 90.0, value_name = "SECONDS")]
        duration_s: f64,
    },
    /// §5.2 force-step test with the handle blocked at the nine poses.
    Step {
        /// Pose index 0–8 into the nine poses (repeatable); default: all nine.
        #[arg(long = "pose")]
        poses: Vec<usize>,
        /// Hold time of each force level, s.
        #[arg(long, default_value_t = 1.5, value_name = "SECONDS")]
        hold_s: f64,
        /// Correct the force command with the gain plane (eq. 5.2).
        #[arg(long)]
        feed_forward: bool,
        /// Run each pose's staircase (24 steps, both axes) this many times in its log: where
        /// `pamctl model diagnose` finds too few steps to decide, it says about how many
        /// would.
        #[arg(long, default_value_t = 1, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
        repeats: u32,
        /// The muscles' co-contraction: `low` is §5.2's (the least joint stiffness that holds
        /// every step), `high` 80 % of the way to the most every step allows, `both` a log
        /// at each. Where `pamctl model diagnose` cannot tell a family from the converters'
        /// spread, give it the pose's two logs.
        #[arg(long, value_enum, default_value_t = Level::Low)]
        co_contraction: Level,
    },
}

fn device_model(client: &Client) -> anyhow::Result<RobotModel<f64>> {
    match client.request(RequestBody::GetConfig(ConfigSection::Robot))? {
        ReplyData::Config(Config::Robot(p)) => Ok(RobotModel::new(
            pam_model::RobotParams::<f32>::from(p).cast(),
        )),
        _ => Err(anyhow::anyhow!(
            "the device answered config get robot with the wrong kind of reply"
        )),
    }
}

fn levels(l: Level) -> Vec<StiffnessLevel> {
    match l {
        Level::Low => vec![StiffnessLevel::Low],
        Level::High => vec![StiffnessLevel::High],
        Level::Both => vec![StiffnessLevel::Low, StiffnessLevel::High],
    }
}

/// A trial at Table 4.1's point `p` (1-based): the joint angles, the joint stiffness of
/// the level, the handle's centre and the trial's label.
fn point_trial(
    model: &RobotModel<f64>,
    kind: &str,
    p: usize,
    level: StiffnessLevel,
) -> (Vec2<f64>, [f64; 2], Vec2<f64>, String) {
    let alpha = TABLE_4_1_POINTS_DEG[p - 1].map(f64::to_radians);
    let k = trial_stiffness(model, alpha, level);
    let centre = model.kinematics.forward_user(alpha);
    (
        alpha,
        k,
        centre,
        format!("{kind} point {p} K_{}", level.name()),
    )
}

fn points(point: Option<usize>) -> anyhow::Result<Vec<usize>> {
    match point {
        Some(p) if (1..=5).contains(&p) => Ok(vec![p]),
        Some(p) => Err(anyhow::anyhow!("--point {p}: the Table 4.1 points are 1–5")),
        None => Ok((1..=5).collect()),
    }
}

fn positive(name: &str, v: f64) -> anyhow::Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(anyhow::anyhow!(
            "{name} {v}: give a positive number of seconds"
        ))
    }
}

/// Arms the device if needed (it must be homed and free of faults).
fn arm(s: &mut Session) -> anyhow::Result<()> {
    match s.client.request(RequestBody::GetStatus)? {
        ReplyData::Status(st) if st.state == State::Armed => Ok(()),
        ReplyData::Status(st) if st.state == State::Faulted => Err(anyhow::anyhow!(
            "the device is faulted ({}): `pamctl disarm`, `pamctl fault clear`, then try again",
            fault_names(st.faults)
        )),
        _ => s.request(RequestBody::Arm),
    }
}

/// Runs the experiment; returns the files written.
pub fn experiment(
    client: &Client,
    args: &ExperimentArgs,
    stop: &AtomicBool,
    out: &mut dyn Write,
    progress: &mut dyn Write,
) -> anyhow::Result<Vec<PathBuf>> {
    positive("--settle-s", args.settle_s)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let model = device_model(client)?;
    if let ReplyData::Status(st) = client.request(RequestBody::GetStatus)? {
        if st.telemetry_divider != 1 {
            client.command(RequestBody::SetTelemetry { divider: 1 })?;
        }
    }
    client.start_telemetry();
    let mut s = Session {
        client,
        stop,
        progress,
        yes: args.yes,
        last_beat: Instant::now(),
        alpha_rad: None,
    };
    let mut files = Vec::new();
    let result = run_trials(&mut s, &model, args, out, &mut files);
    // whatever happened: back to safe outputs
    let _ = client.command(RequestBody::Disarm);
    result.map(|_| files)
}

fn run_trials(
    s: &mut Session,
    model: &RobotModel<f64>,
    args: &ExperimentArgs,
    out: &mut dyn Write,
    files: &mut Vec<PathBuf>,
) -> anyhow::Result<()> {
    match &args.kind {
        ExperimentKind::Static {
            point,
            stiffness,
            hold_s,
            move_s,
        } => {
            positive("--hold-s", *hold_s)?;
            positive("--move-s", *move_s)?;
            for p in points(*point)? {
                for level in levels(*stiffness) {
                    let (alpha, k, centre, label) = point_trial(model, "static", p, level);
                    s.prompt(&format!(
                        "{label}: hold the handle lightly; the arm goes to point {p}"
                    ))?;
                    arm(s)?;
                    s.move_to(
                        alpha,
                        k,
                        args.settle_s,
                        &format!("{label}: going to the point"),
                    )?;
                    let mut trial = open_trial(
                        s.client,
                        &args.out,
                        &format!("static_p{p}_{}.csv", level.name()),
                        false,
                        &meta_trial("static", p, level, k, centre),
                    )?;
                    for (i, target) in static_points(centre, 0.04).iter().enumerate() {
                        let d = [(target[0] - centre[0]) * 1e3, (target[1] - centre[1]) * 1e3];
                        let _ = writeln!(s.progress, ">>> point {}/9: move the handle to ({:+.0}, {:+.0}) mm from the centre, then hold it still", i + 1, d[0], d[1]);
                        s.run_for(
                            *move_s,
                            Some(&mut trial),
                            &format!("{label}: moving to {}/9", i + 1),
                        )?;
                        s.run_for(
                            *hold_s,
                            Some(&mut trial),
                            &format!("{label}: holding {}/9", i + 1),
                        )?;
                    }
                    files.push(close_trial(trial, out)?);
                    s.set_mode(Mode::Idle)?;
                }
            }
        }
        ExperimentKind::Dynamic {
            point,
            stiffness,
            duration_s,
        } => {
            positive("--duration-s", *duration_s)?;
            for p in points(*point)? {
                for level in levels(*stiffness) {
                    let (alpha, k, centre, label) = point_trial(model, "dynamic", p, level);
                    arm(s)?;
                    s.move_to(
                        alpha,
                        k,
                        args.settle_s,
                        &format!("{label}: going to the point"),
                    )?;
                    s.prompt(&format!(
                        "{label}: move the handle smoothly, slow and fast, over the 8 cm square around the arm's rest point for {duration_s:.0} s"
                    ))?;
                    let mut trial = open_trial(
                        s.client,
                        &args.out,
                        &format!("dynamic_p{p}_{}.csv", level.name()),
                        false,
                        &meta_trial("dynamic", p, level, k, centre),
                    )?;
                    s.run_for(
                        *duration_s,
                        Some(&mut trial),
                        &format!("{label}: recording"),
                    )?;
                    files.push(close_trial(trial, out)?);
                    let _ = writeln!(s.progress, ">>> {label}: done, let go of the handle");
                    s.set_mode(Mode::Idle)?;
                }
            }
        }
        ExperimentKind::Step {
            poses,
            hold_s,
            feed_forward,
            repeats,
            co_contraction,
        } => {
            positive("--hold-s", *hold_s)?;
            let poses: Vec<usize> = if poses.is_empty() {
                (0..9).collect()
            } else {
                poses.clone()
            };
            if let Some(bad) = poses.iter().find(|&&i| i > 8) {
                return Err(anyhow::anyhow!("--pose {bad}: the nine poses are 0–8"));
            }
            let trials = poses
                .into_iter()
                .flat_map(|i| levels(*co_contraction).into_iter().map(move |l| (i, l)));
            for (i, co) in trials {
                let pose_deg = STEP_POSES_DEG[i];
                let alpha = pose_deg.map(f64::to_radians);
                let k = step_test_stiffness_at(model, alpha, co);
                let stiffness = [k[0] as f32, k[1] as f32];
                let (label, file) = match co {
                    StiffnessLevel::Low => (
                        format!("step pose {i} ({:+}°, {:+}°)", pose_deg[0], pose_deg[1]),
                        format!("step_pose{i}.csv"),
                    ),
                    StiffnessLevel::High => (
                        format!(
                            "step pose {i} ({:+}°, {:+}°), high co-contraction",
                            pose_deg[0], pose_deg[1]
                        ),
                        format!("step_pose{i}_high.csv"),
                    ),
                };
                arm(s)?;
                s.move_to(
                    alpha,
                    k,
                    args.settle_s,
                    &format!("{label}: going to the pose"),
                )?;
                s.prompt(&format!("{label}: block the handle where it is"))?;
                s.set_mode(Mode::Force {
                    force_n: [0.0; 2],
                    stiffness_nm_per_rad: stiffness,
                    feed_forward: *feed_forward,
                })?;
                s.run_for(1.0, None, &format!("{label}: zero force"))?;
                let meta = vec![
                    ("experiment", "force_step".to_string()),
                    ("pose_deg", format!("{} {}", pose_deg[0], pose_deg[1])),
                    ("k_joint_nm_per_rad", format!("{:.3} {:.3}", k[0], k[1])),
                    ("feed_forward", feed_forward.to_string()),
                    ("repeats", repeats.to_string()),
                    ("co_contraction", co.name().to_string()),
                ];
                let mut trial = open_trial(s.client, &args.out, &file, true, &meta)?;
                for axis in (0..*repeats).flat_map(|_| 0..2) {
                    for level in step_levels() {
                        let mut f = [0.0f32; 2];
                        f[axis] = level as f32;
                        s.set_mode(Mode::Force {
                            force_n: f,
                            stiffness_nm_per_rad: stiffness,
                            feed_forward: *feed_forward,
                        })?;
                        s.run_for(
                            *hold_s,
                            Some(&mut trial),
                            &format!("{label}: F{} = {level:+.1} N", ["x", "y"][axis]),
                        )?;
                    }
                }
                files.push(close_trial(trial, out)?);
                s.set_mode(Mode::Idle)?;
                let _ = writeln!(s.progress, ">>> {label}: done, unblock the handle");
            }
        }
    }
    Ok(())
}

fn meta_trial(
    kind: &str,
    point: usize,
    level: StiffnessLevel,
    k: Vec2<f64>,
    centre: Vec2<f64>,
) -> Vec<(&'static str, String)> {
    vec![
        ("experiment", kind.to_string()),
        ("point", point.to_string()),
        ("stiffness", level.name().to_string()),
        ("k_joint_nm_per_rad", format!("{:.3} {:.3}", k[0], k[1])),
        ("x0_user_m", format!("{:.6} {:.6}", centre[0], centre[1])),
    ]
}

pub fn run(args: ExperimentArgs, link: &LinkArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let client = super::connect(link)?;
    let stop = super::interrupted();
    let files = experiment(&client, &args, &stop, out, &mut std::io::stderr())?;
    Ok(writeln!(
        out,
        "{} log(s) in {}",
        files.len(),
        args.out.display()
    )?)
}
