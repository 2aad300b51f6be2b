//! Effects of the load cell and its wiring, shared by both trials: they add to the logged
//! force directly. Drift lives in the sensor frame, which turns with θ1 + θ2.

use std::f64::consts::PI;

use pam_model::RobotModel;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::case::Shape;
use crate::effect::{named, EffectModel};
use crate::signal::Forces;

/// `t_s` and the true angles on the fine grid.
pub fn build<'a>(
    shape: Shape,
    t_s: &'a [f64],
    alpha_rad: &'a [[f64; 2]],
    model: &'a RobotModel<f64>,
    rng: &mut ChaCha8Rng,
) -> Option<EffectModel<'a>> {
    let duration = t_s.last().copied().unwrap_or(1.0).max(1.0);
    match shape {
        Shape::OffsetLinear | Shape::OffsetExponential => {
            // λ = size of the drift over the trial (N); an offset of up to half that
            let dir_d = rng.random_range(0.0..2.0 * PI);
            let dir_o = rng.random_range(0.0..2.0 * PI);
            let offset_share = rng.random_range(0.0..0.5);
            let tau_s = duration * rng.random_range(0.2..1.0);
            let linear = shape == Shape::OffsetLinear;
            let unit: Forces = t_s
                .iter()
                .zip(alpha_rad)
                .map(|(&t, a)| {
                    let ramp = if linear {
                        t / duration
                    } else {
                        (1.0 - (-t / tau_s).exp()) / (1.0 - (-duration / tau_s).exp())
                    };
                    let s = [
                        offset_share * dir_o.cos() + ramp * dir_d.cos(),
                        offset_share * dir_o.sin() + ramp * dir_d.sin(),
                    ];
                    model.kinematics.sensor_to_user(*a, s)
                })
                .collect();
            Some(EffectModel::additive(unit, (1e-3, 500.0), move |c| {
                let mut p = named(&[
                    ("offset_x_n", c * offset_share * dir_o.cos()),
                    ("offset_z_n", c * offset_share * dir_o.sin()),
                ]);
                if linear {
                    p.extend(named(&[
                        ("drift_x_n_per_s", c * dir_d.cos() / duration),
                        ("drift_z_n_per_s", c * dir_d.sin() / duration),
                    ]));
                } else {
                    p.extend(named(&[
                        ("settled_drift_x_n", c * dir_d.cos()),
                        ("settled_drift_z_n", c * dir_d.sin()),
                        ("time_constant_s", tau_s),
                    ]));
                }
                p
            }))
        }
        Shape::MainsTone => {
            let f_hz = if rng.random::<f64>() < 0.5 {
                50.0
            } else {
                60.0
            };
            let phase = rng.random_range(0.0..2.0 * PI);
            let dir = rng.random_range(0.0..PI);
            let unit: Forces = t_s
                .iter()
                .map(|&t| {
                    let s = (2.0 * PI * f_hz * t + phase).sin();
                    [s * dir.cos(), s * dir.sin()]
                })
                .collect();
            Some(EffectModel::additive(unit, (1e-3, 100.0), move |c| {
                named(&[("amplitude_n", c), ("frequency_hz", f_hz)])
            }))
        }
        Shape::SlowWander => {
            // a few slow sines per axis with the linear trend removed, so no offset + drift
            // describes it; unit RMS
            let mut unit: Forces = vec![[0.0; 2]; t_s.len()];
            for ax in 0..2 {
                let comps: Vec<(f64, f64, f64)> = (0..rng.random_range(3..=5))
                    .map(|_| {
                        let period = duration / rng.random_range(1.5..8.0);
                        (
                            rng.random_range(0.3..1.0),
                            2.0 * PI / period,
                            rng.random_range(0.0..2.0 * PI),
                        )
                    })
                    .collect();
                let raw: Vec<f64> = t_s
                    .iter()
                    .map(|&t| comps.iter().map(|(a, w, p)| a * (w * t + p).sin()).sum())
                    .collect();
                let detrended = detrend(t_s, &raw);
                for (u, d) in unit.iter_mut().zip(detrended) {
                    u[ax] = d;
                }
            }
            let rms = (unit.iter().map(|u| u[0] * u[0] + u[1] * u[1]).sum::<f64>()
                / unit.len().max(1) as f64)
                .sqrt()
                .max(1e-12);
            unit.iter_mut().for_each(|u| *u = [u[0] / rms, u[1] / rms]);
            Some(EffectModel::additive(unit, (1e-3, 100.0), |c| {
                named(&[("wander_rms_n", c)])
            }))
        }
        _ => None,
    }
}

/// `y` minus its least-squares line in `t`.
fn detrend(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = t.len().max(1) as f64;
    let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let stt: f64 = t.iter().map(|x| (x - mt).powi(2)).sum();
    let sty: f64 = t.iter().zip(y).map(|(a, b)| (a - mt) * (b - my)).sum();
    let slope = if stt > 0.0 { sty / stt } else { 0.0 };
    t.iter()
        .zip(y)
        .map(|(a, b)| b - my - slope * (a - mt))
        .collect()
}
