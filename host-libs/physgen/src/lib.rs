//! pam-physgen: a log generator built from the rig's physics, sharing no code and no
//! functional form with the twin, pam-synth or the model loop's catalog.
//!
//! The plant (`plant.rs`) is the two-link arm's rigid-body dynamics with its Coriolis terms
//! (`arm.rs`), four Tondu–Lopez muscles as gas volumes filled by second-order pressure
//! regulators behind dead times (`muscle.rs`), a hand or the blocks holding the handle as a
//! spring-damper, and friction and hysteresis in their literature forms (`friction.rs`:
//! LuGre, generalized Maxwell-slip, Bouc–Wen), integrated by RK4 at 1 kHz. The sensors
//! (`sensor.rs`) add a load cell's white, 1/f and autoregressive noise, a tare fixed in the
//! sensor frame and the encoders' rounding. pam-model supplies only the geometry, the
//! nominal parameters and the controller's side (the currents the rig would command).

#![allow(clippy::needless_range_loop)]

pub mod arm;
pub mod case;
pub mod error;
pub mod experiment;
pub mod friction;
pub mod muscle;
pub mod plant;
pub mod sensor;
pub mod truth;

pub use case::{CaseSpec, Effect, Experiment};
pub use error::PhysgenError;
pub use truth::Truth;

use std::collections::BTreeMap;

use pam_model::RobotModel;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use experiment::{Hold, OperatorPath};
use muscle::Regulator;
use plant::{Effects, Hand, Plant};
use sensor::LoadCellNoise;

/// The simulation step and the logged period.
pub const DT_S: f64 = 0.001;
/// The plant settles this long before the log starts.
const PRE_ROLL_S: f64 = 2.0;

const STREAM_BASE: u64 = 1;
const STREAM_EFFECT: u64 = 2;
const STREAM_NOISE: u64 = 3;

fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// A generated log and its truth.
#[derive(Clone, Debug)]
pub struct Generated {
    pub log_text: String,
    pub truth: Truth,
}

/// The nominal rig of one log, drawn from the base stream.
struct Rig {
    regulators: [Regulator; 4],
    hand: Hand,
    alpha0: [f64; 2],
    duration_s: f64,
    site: usize,
    /// Dynamic: the operator's path and the constant currents; step: the holds.
    path: Option<OperatorPath>,
    currents: [f64; 4],
    holds: Vec<Hold>,
    /// Step at a co-contraction set instead of drawn: the holds at the drawn one (the
    /// lowest that lets every level through), which set a supply limit's ceiling: the
    /// supply does not change with the co-contraction a trial asks for. `None`: `holds`.
    drawn_holds: Option<Vec<Hold>>,
    base: BTreeMap<String, f64>,
}

fn draw_rig(
    spec: &CaseSpec,
    model: &RobotModel<f64>,
    duration: Option<f64>,
    stiffness_level: Option<f64>,
) -> Rig {
    let mut r = rng(spec.seed, STREAM_BASE);
    let ip = &model.params.ip;
    let spread = |r: &mut ChaCha8Rng, x: f64, s: f64| x * (1.0 + r.random_range(-s..s));
    let regulators = [0; 4].map(|_| Regulator {
        gain_bar_per_ma: spread(&mut r, ip.gain_bar_per_ma, 0.03),
        offset_bar: ip.offset_bar + r.random_range(-0.05..0.05),
        // the chain from current to muscle pressure answers close to Table 5.2's second
        // order (ωn 23 rad/s, ζ 0.42, identified end to end): the servo a little faster
        // and better damped, a short dead time and a short fill make up the rest
        omega_n_rad_s: spread(&mut r, 1.15 * ip.natural_freq_rad_s, 0.15),
        zeta: spread(&mut r, 0.5, 0.15),
        dead_steps: r.random_range(1..5),
        fill_s: r.random_range(0.003..0.008),
        cap_bar: 5.0,
        max_rise_bar_s: f64::INFINITY,
        max_fall_bar_s: f64::INFINITY,
    });
    let mut base = BTreeMap::new();
    for (c, g) in regulators.iter().enumerate() {
        let c = c + 1;
        base.insert(format!("reg{c}_gain_bar_per_ma"), g.gain_bar_per_ma);
        base.insert(format!("reg{c}_offset_bar"), g.offset_bar);
        base.insert(format!("reg{c}_omega_n_rad_s"), g.omega_n_rad_s);
        base.insert(format!("reg{c}_zeta"), g.zeta);
        base.insert(format!("reg{c}_dead_time_s"), g.dead_steps as f64 * DT_S);
        base.insert(format!("reg{c}_fill_s"), g.fill_s);
    }
    match spec.experiment {
        Experiment::Dynamic => {
            let site = r.random_range(1..=5);
            let alpha0 = experiment::point_rad(site);
            let drawn = r.random::<f64>();
            let level = stiffness_level.map_or(drawn, |l| l.clamp(0.0, 1.0));
            let (currents, kj) = experiment::dynamic_currents(model, alpha0, level);
            let hand = Hand {
                k_n_per_m: r.random_range(800.0..2500.0),
                b_n_s_per_m: r.random_range(15.0..40.0),
            };
            let mut path = OperatorPath::draw(&mut r);
            let duration_s = duration.unwrap_or_else(|| r.random_range(60.0..90.0f64).round());
            fit_in_reach(model, alpha0, &mut path, duration_s);
            base.insert("hand_k_n_per_m".into(), hand.k_n_per_m);
            base.insert("hand_b_n_s_per_m".into(), hand.b_n_s_per_m);
            base.insert("joint_stiffness_nm_per_rad_1".into(), kj[0]);
            base.insert("joint_stiffness_nm_per_rad_2".into(), kj[1]);
            // where between the point's K_low (0) and K_high (1): the other level's trial
            // (`generate_at_stiffness`) is the experiment that separates friction from
            // the muscles' hysteresis
            base.insert("stiffness_level".into(), level);
            Rig {
                regulators,
                hand,
                alpha0,
                duration_s,
                site,
                path: Some(path),
                currents,
                holds: Vec::new(),
                drawn_holds: None,
                base,
            }
        }
        Experiment::Step => {
            let site = r.random_range(1..=9);
            let alpha0 = experiment::step_pose_rad(site);
            let duration_s = duration.unwrap_or_else(|| r.random_range(60.0..120.0f64).round());
            let drawn_holds = stiffness_level.map(|_| {
                experiment::step_schedule(model, alpha0, duration_s, &mut r.clone(), None).0
            });
            let (holds, step_n, k) =
                experiment::step_schedule(model, alpha0, duration_s, &mut r, stiffness_level);
            if let Some(l) = stiffness_level {
                // 0 = the lowest co-contraction that lets every level through (the drawn
                // trial's), 1 = the highest
                base.insert("step_stiffness_level".into(), l.clamp(0.0, 1.0));
            }
            base.insert("step_n".into(), step_n);
            base.insert("joint_stiffness_nm_per_rad_1".into(), k[0]);
            base.insert("joint_stiffness_nm_per_rad_2".into(), k[1]);
            Rig {
                regulators,
                hand: Hand {
                    k_n_per_m: 3e4,
                    b_n_s_per_m: 300.0,
                },
                alpha0,
                duration_s,
                site,
                path: None,
                currents: holds[0].currents_ma,
                drawn_holds,
                holds,
                base,
            }
        }
    }
}

/// Shrinks the operator's path until it stays 2° inside both joints' ranges.
fn fit_in_reach(
    model: &RobotModel<f64>,
    alpha0: [f64; 2],
    path: &mut OperatorPath,
    duration_s: f64,
) {
    let x0 = model.kinematics.forward_user(alpha0);
    let margin = 2f64.to_radians();
    for _ in 0..15 {
        let ok = (0..(duration_s * 50.0) as usize).all(|k| {
            let (dx, _) = path.eval(k as f64 * 0.02);
            match model
                .kinematics
                .inverse_user([x0[0] + dx[0], x0[1] + dx[1]])
            {
                Some(a) => (0..2).all(|j| {
                    let p = &model.params.joints[j];
                    a[j] > p.alpha_min_rad + margin && a[j] < p.alpha_max_rad - margin
                }),
                None => false,
            }
        });
        if ok {
            return;
        }
        path.scale(0.8);
    }
}

/// The effect's plant changes and parameters (the effect stream only).
fn apply_effect(
    spec: &CaseSpec,
    rig: &mut Rig,
    effects: &mut Effects,
    lag_hz: &mut Option<f64>,
) -> BTreeMap<String, f64> {
    let mut r = rng(spec.seed, STREAM_EFFECT);
    let s = spec.severity;
    let mut p = BTreeMap::new();
    match spec.effect {
        Effect::Control => {}
        Effect::HandleLugre => {
            let l = case::handle_lugre(s, &mut r);
            p.insert("coulomb_n".into(), l.coulomb);
            p.insert("stiction_n".into(), l.stiction);
            p.insert("stribeck_m_s".into(), l.stribeck_speed);
            p.insert("sigma0_n_per_m".into(), l.sigma0);
            p.insert("viscous_n_s_per_m".into(), l.sigma2);
            effects.handle_lugre = Some(l);
        }
        Effect::JointLugre => {
            let l = case::joint_lugre(s, &mut r);
            for j in 0..2 {
                p.insert(format!("coulomb_nm_joint{}", j + 1), l[j].coulomb);
                p.insert(format!("stiction_nm_joint{}", j + 1), l[j].stiction);
                p.insert(format!("sigma0_nm_per_rad_joint{}", j + 1), l[j].sigma0);
            }
            p.insert("stribeck_rad_s".into(), l[0].stribeck_speed);
            effects.joint_lugre = Some(l);
        }
        Effect::JointMaxwellSlip => {
            let g = case::joint_gms(s, &mut r);
            for j in 0..2 {
                p.insert(format!("breakaway_nm_joint{}", j + 1), g[j].w.iter().sum());
            }
            p.insert("first_breakaway_rad".into(), g[0].w[0] / g[0].k[0]);
            p.insert("coulomb_ratio".into(), g[0].coulomb_ratio);
            effects.joint_gms = Some(g);
        }
        Effect::MuscleBoucWen => {
            let (bw, n_per_bar) = case::muscle_bouc_wen(s, &mut r);
            let on_pressure = spec.experiment == Experiment::Step;
            let bw = if on_pressure {
                // at one length the loop follows the pressure: it saturates over 0.05–0.3 bar
                friction::BoucWen {
                    x_ref: bw.x_ref * 30.0,
                    ..bw
                }
            } else {
                bw
            };
            p.insert("force_n_per_bar".into(), n_per_bar);
            p.insert("beta".into(), bw.beta);
            p.insert("n".into(), bw.n);
            p.insert(
                if on_pressure {
                    "saturation_bar"
                } else {
                    "saturation_contraction"
                }
                .into(),
                bw.x_ref,
            );
            effects.muscle_bouc_wen = Some((bw, n_per_bar));
            effects.bouc_wen_on_pressure = on_pressure;
        }
        Effect::AmplifierLag => {
            let hz = case::log_between(10.0, 2.5, s);
            p.insert("corner_hz".into(), hz);
            p.insert("group_delay_s".into(), 1.0 / (std::f64::consts::PI * hz));
            *lag_hz = Some(hz);
        }
        Effect::SupplyLimit => {
            let sp: Vec<f64> = rig
                .drawn_holds
                .as_ref()
                .unwrap_or(&rig.holds)
                .iter()
                .flat_map(|h| (0..4).map(|c| rig.regulators[c].setpoint_bar(h.currents_ma[c])))
                .collect();
            let hi = sp.iter().cloned().fold(0.0, f64::max);
            let mut sorted = sp.clone();
            sorted.sort_by(f64::total_cmp);
            let med = sorted[sorted.len() / 2];
            let cap = hi - (0.2 + 0.5 * s) * (hi - med);
            p.insert("cap_bar".into(), cap);
            for g in rig.regulators.iter_mut() {
                g.cap_bar = cap;
            }
        }
        Effect::ChokedFlow => {
            let rise = case::log_between(6.0, 1.0, s);
            let fall = rise * case::log_between(0.3, 3.0, r.random::<f64>());
            p.insert("rise_bar_per_s".into(), rise);
            p.insert("fall_bar_per_s".into(), fall);
            for g in rig.regulators.iter_mut() {
                g.max_rise_bar_s = rise;
                g.max_fall_bar_s = fall;
            }
        }
        Effect::LongTube => {
            let d = case::log_between(0.02, 0.15, s);
            p.insert("delay_s".into(), d);
            for g in rig.regulators.iter_mut() {
                g.dead_steps += (d / DT_S).round() as usize;
            }
        }
    }
    p
}

/// The noise-free trace of one run.
struct Trace {
    alpha: Vec<[f64; 2]>,
    force: Vec<[f64; 2]>,
    currents: Vec<[f64; 4]>,
    refs: Vec<[f64; 2]>,
}

fn run(
    model: &RobotModel<f64>,
    rig: &Rig,
    effects: Effects,
    lag_hz: Option<f64>,
    n: usize,
) -> Result<Trace, PhysgenError> {
    let mut plant = Plant::new(&model.params, rig.regulators, rig.hand, effects, DT_S);
    plant.reset(rig.alpha0, rig.currents);
    let x0 = model.kinematics.forward_user(rig.alpha0);
    let target = |t: f64| match &rig.path {
        Some(p) if t >= 0.0 => {
            let (dx, v) = p.eval(t);
            ([x0[0] + dx[0], x0[1] + dx[1]], v)
        }
        _ => (x0, [0.0; 2]),
    };
    let pre = (PRE_ROLL_S / DT_S) as usize;
    let mut hold = 0usize;
    let mut tr = Trace {
        alpha: Vec::with_capacity(n),
        force: Vec::with_capacity(n),
        currents: Vec::with_capacity(n),
        refs: Vec::with_capacity(n),
    };
    for k in 0..pre + n {
        let t = (k as f64 - pre as f64) * DT_S;
        let (currents, refs) = if rig.holds.is_empty() {
            (rig.currents, [0.0; 2])
        } else {
            while hold + 1 < rig.holds.len() && rig.holds[hold + 1].start_s <= t + 1e-9 {
                hold += 1;
            }
            (rig.holds[hold].currents_ma, rig.holds[hold].ref_n)
        };
        let s = plant.step(currents, target(t));
        if !plant.finite() {
            return Err(PhysgenError::Diverged {
                t_s: t,
                what: "state not finite",
            });
        }
        if k >= pre {
            tr.alpha.push(s.alpha_rad);
            tr.force.push(s.force_n);
            tr.currents.push(currents);
            tr.refs.push(refs);
        }
    }
    if let Some(hz) = lag_hz {
        sensor::amplifier_lag(&mut tr.force, hz, DT_S);
    }
    Ok(tr)
}

/// Generates the log and its truth (`duration_s` overrides the drawn duration).
pub fn generate(spec: &CaseSpec, duration_s: Option<f64>) -> Result<Generated, PhysgenError> {
    generate_with_level(spec, duration_s, None)
}

/// [`generate`] with the trial's stiffness level set instead of drawn: the same rig,
/// operator (or step schedule) and effect at another stiffness. A dynamic trial's level
/// runs from the point's K_low (0) to its K_high (1); a step trial's from the lowest
/// co-contraction that lets every level through unclamped (0, the one [`generate`] uses)
/// to the highest that does with every commanded pressure under
/// `pam_model::protocols::STEP_HIGH_PRESSURE_SHARE` of the range (1). Everything else is
/// drawn from the seed as in [`generate`].
pub fn generate_at_stiffness(
    spec: &CaseSpec,
    duration_s: Option<f64>,
    level: f64,
) -> Result<Generated, PhysgenError> {
    generate_with_level(spec, duration_s, Some(level))
}

fn generate_with_level(
    spec: &CaseSpec,
    duration_s: Option<f64>,
    level: Option<f64>,
) -> Result<Generated, PhysgenError> {
    let model = RobotModel::<f64>::thesis();
    let mut rig = draw_rig(spec, &model, duration_s, level);
    let mut effects = Effects::default();
    let mut lag_hz = None;
    let params = apply_effect(spec, &mut rig, &mut effects, &mut lag_hz);
    let n = (rig.duration_s / DT_S).round() as usize;
    let tr = run(&model, &rig, effects, lag_hz, n)?;
    let nominal = if spec.effect == Effect::Control {
        None
    } else {
        let mut plain = draw_rig(spec, &model, duration_s, level);
        plain.holds.clone_from(&rig.holds);
        Some(run(&model, &plain, Effects::default(), None, n)?)
    };
    // the sensors
    let mut rn = rng(spec.seed, STREAM_NOISE);
    let cell = LoadCellNoise::draw(&mut rn);
    let noise = [
        cell.channel(&mut rn, n, DT_S),
        cell.channel(&mut rn, n, DT_S),
    ];
    let force: Vec<[f64; 2]> = (0..n)
        .map(|k| {
            let sensor_part = [cell.tare_n[0] + noise[0][k], cell.tare_n[1] + noise[1][k]];
            let u = model.kinematics.sensor_to_user(tr.alpha[k], sensor_part);
            [tr.force[k][0] + u[0], tr.force[k][1] + u[1]]
        })
        .collect();
    let relative_size = nominal
        .as_ref()
        .map_or(0.0, |nom| relative(&tr.force, &nom.force, &force));
    let log_text = write_log(spec, &tr, &force)?;
    let coloured = (cell.pink_n.powi(2) + cell.ar_n.powi(2)).sqrt();
    let truth = Truth {
        experiment: spec.experiment.name().into(),
        family: spec.effect.family().into(),
        shape: spec.effect.shape().into(),
        seed: spec.seed,
        dt_s: DT_S,
        duration_s: rig.duration_s,
        samples: n,
        noise_n: cell.white_n,
        coloured_noise_n: coloured,
        site: rig.site,
        alpha_deg: rig.alpha0.map(f64::to_degrees),
        target_relative_size: 0.0,
        relative_size,
        params,
        base: rig.base.clone(),
        generator: "pam-physgen".into(),
        physical_effect: spec.effect.name().into(),
        location: spec.effect.location().into(),
        severity: spec.severity,
        load_cell: cell,
    };
    Ok(Generated { log_text, truth })
}

/// RMS(with − without) / std(logged), both axes pooled.
fn relative(with: &[[f64; 2]], without: &[[f64; 2]], logged: &[[f64; 2]]) -> f64 {
    let n = with.len().max(1) as f64;
    let rms = (with
        .iter()
        .zip(without)
        .map(|(a, b)| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2))
        .sum::<f64>()
        / (2.0 * n))
        .sqrt();
    let mut var = 0.0;
    for ax in 0..2 {
        let mean = logged.iter().map(|f| f[ax]).sum::<f64>() / n;
        var += logged.iter().map(|f| (f[ax] - mean).powi(2)).sum::<f64>() / n;
    }
    rms / (var / 2.0).sqrt().max(1e-12)
}

/// The log's columns.
pub fn columns(experiment: Experiment) -> Vec<&'static str> {
    let mut c = vec![
        "t_s",
        "alpha1_rad",
        "alpha2_rad",
        "fx_n",
        "fy_n",
        "i1_ma",
        "i2_ma",
        "i3_ma",
        "i4_ma",
    ];
    if experiment == Experiment::Step {
        c.extend(["fx_ref_n", "fy_ref_n"]);
    }
    c
}

fn write_log(spec: &CaseSpec, tr: &Trace, force: &[[f64; 2]]) -> Result<String, PhysgenError> {
    let period = format!("{DT_S}");
    let meta = [
        ("experiment", spec.experiment.name()),
        ("generator", "pam-physgen"),
        ("sample_period_s", period.as_str()),
    ];
    let mut w = pam_log::LogWriter::new(Vec::new(), &columns(spec.experiment), &meta)?;
    let mut row = Vec::with_capacity(11);
    for k in 0..force.len() {
        row.clear();
        row.push((k as f64 * DT_S * 1e6).round() / 1e6);
        row.extend(tr.alpha[k].map(sensor::quantise));
        row.extend(force[k]);
        row.extend(tr.currents[k]);
        if spec.experiment == Experiment::Step {
            row.extend(tr.refs[k]);
        }
        w.write_row(&row)?;
    }
    let bytes = w.finish()?;
    Ok(String::from_utf8(bytes).unwrap_or_default())
}

/// Writes `FILE` and `FILE.truth.json` beside it (`a.csv` → `a.truth.json`).
pub fn write_files(g: &Generated, path: &std::path::Path) -> Result<(), PhysgenError> {
    std::fs::write(path, &g.log_text)?;
    std::fs::write(path.with_extension("truth.json"), g.truth.to_json()?)?;
    Ok(())
}
