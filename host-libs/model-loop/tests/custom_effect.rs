//! Adding an effect that is not in the catalog (docs/model-loop.md shows this file's
//! effect): a mains tone on the load cell. Without it the loop says "unexplained" and names
//! the 50 Hz line; with it in the catalog the loop names it and fits its amplitude.
mod common;

use common::*;
use pam_model_loop::diagnose::Verdict;
use pam_model_loop::diagnose::{diagnose_with, Settings};
use pam_model_loop::effects::{self, DynCtx, DynTerm, Experiment, ModelEffect, Shape, ShapeParam};

/// The custom effect's own shape parameter.
const FREQUENCY: ShapeParam = ShapeParam::Custom("frequency_hz");
use pam_model::RobotModel;
use pam_numerics::lsq::Column;

/// A tone of unknown amplitude and phase at a frequency from a small grid.
struct MainsTone;

impl ModelEffect for MainsTone {
    fn id(&self) -> &'static str {
        "mains_tone"
    }
    fn summary(&self) -> &'static str {
        "mains pickup on the load-cell wiring: a sine on both channels"
    }
    fn signature(&self) -> &'static str {
        "a narrow line in the residual spectrum at the mains frequency"
    }
    fn applies(&self, _e: Experiment) -> bool {
        true
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        [50.0, 60.0]
            .iter()
            .map(|&f| Shape(vec![(FREQUENCY, f)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let w = 2.0 * std::f64::consts::PI * shape.get(FREQUENCY).unwrap_or(0.0);
        let sin: Vec<f64> = ctx.p.t_s.iter().map(|t| (w * t).sin()).collect();
        let cos: Vec<f64> = ctx.p.t_s.iter().map(|t| (w * t).cos()).collect();
        // a tone of its own amplitude and phase on each axis (in −f)
        DynTerm {
            columns: vec![
                Column::on("sin_x_n", 0, sin.clone()),
                Column::on("cos_x_n", 0, cos.clone()),
                Column::on("sin_y_n", 1, sin),
                Column::on("cos_y_n", 1, cos),
            ],
            ..Default::default()
        }
    }
    fn report_params(
        &self,
        _ctx: &DynCtx,
        fitted: &[(String, f64)],
        shape: &Shape,
    ) -> Vec<(String, f64)> {
        let mut v = fitted.to_vec();
        v.push(("amplitude_x_n".into(), fitted[0].1.hypot(fitted[1].1)));
        v.push(("amplitude_y_n".into(), fitted[2].1.hypot(fitted[3].1)));
        v.push(("frequency_hz".into(), shape.get(FREQUENCY).unwrap_or(0.0)));
        v
    }
}

#[test]
fn a_custom_effect_turns_unexplained_into_explained() {
    let model = RobotModel::<f64>::thesis();
    let trial = dynamic(&DynConfig {
        dt_s: 0.001,
        duration_s: 30.0,
        noise_n: 0.5,
        hidden: Hidden::Hum {
            amplitude_n: 1.0,
            freq_hz: 50.0,
        },
        seed: 9,
        ..Default::default()
    });
    let standard = effects::catalog();
    let (d, _) = diagnose_with(
        &trial,
        &model,
        Experiment::Dynamic,
        Settings::default(),
        &standard,
    )
    .unwrap();
    assert_eq!(d.verdict, Verdict::Unexplained);
    assert!(d
        .unexplained
        .iter()
        .any(|u| (u.frequency_hz.unwrap() - 50.0).abs() < 0.2));

    let mut extended = effects::catalog();
    extended.push(&MainsTone);
    let (d, _) = diagnose_with(
        &trial,
        &model,
        Experiment::Dynamic,
        Settings::default(),
        &extended,
    )
    .unwrap();
    assert_eq!(d.verdict, Verdict::Effect);
    let top = &d.effects[0];
    assert_eq!(top.id, "mains_tone");
    // the simulator puts 1 N on both load-cell channels (sensor frame); in the user frame
    // that is R(θ1 + θ2)·[1, 1], θ1 + θ2 = atan(L2/L1) at the neutral pose
    let th = (0.45f64).atan2(0.7);
    let truth = [(th.cos() - th.sin()).abs(), th.sin() + th.cos()];
    assert!(
        (top.params["amplitude_x_n"] - truth[0]).abs() < 0.1,
        "{:?} vs {truth:?}",
        top.params
    );
    assert!(
        (top.params["amplitude_y_n"] - truth[1]).abs() < 0.1,
        "{:?} vs {truth:?}",
        top.params
    );
    assert_eq!(top.params["frequency_hz"], 50.0);
    assert!(d.unexplained.is_empty(), "{:?}", d.unexplained);
}
