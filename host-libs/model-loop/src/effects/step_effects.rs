//! Effects of the pressure chain seen in step trials (and the load cell's drift, seen in both).

use super::DynCtx;
use super::DynTerm;
use super::Experiment;
use super::Family;
use super::ModelEffect;
use super::Shape;
use super::ShapeParam;
use crate::response::StepExtra;
use pam_numerics::lsq::Column;

/// The longest dynamic delay tried, s.
pub const MAX_DYNAMIC_DELAY_S: f64 = 0.15;

/// Pure delay: the force follows the motion late (dynamic trials) / the reference late
/// (step trials).
pub struct TransportDelay;
impl ModelEffect for TransportDelay {
    fn id(&self) -> &'static str {
        "transport_delay"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Delay)
    }
    fn shape_name(&self) -> &'static str {
        "dead_time"
    }
    fn summary(&self) -> &'static str {
        "pure delay between command/motion and force (tubes, converter pilot stage; Table 5.1)"
    }
    fn signature(&self) -> &'static str {
        "lagged cross-correlation of the residual with the inputs peaks at a non-zero lag"
    }
    /// Steps: a dead time of the set-points. Dynamic trials: the force samples lag the
    /// encoder samples (a sensor-sync delay, what a slow loop with filtering produces); the
    /// base model's pneumatic term describes a lag of a different shape (a high-pass of
    /// the displacement), so the fold test tells the two apart.
    fn applies(&self, _e: Experiment) -> bool {
        true
    }
    fn shapes(&self, ctx: &DynCtx) -> Vec<Shape> {
        let step = delay_grid_step_s(ctx.p.dt_s);
        (1..)
            .map(|k| k as f64 * step)
            .take_while(|d| *d <= MAX_DYNAMIC_DELAY_S + 1e-9)
            .map(|d| Shape(vec![(ShapeParam::DelayS, d)]))
            .collect()
    }
    /// Between a coarse grid's neighbours (a 5 ms log's whole samples), every millisecond:
    /// the load cell's filter is continuous in its group delay, and a dead time between two
    /// samples would otherwise lose to it on resolution alone.
    fn finer_shapes(&self, ctx: &DynCtx, best: &Shape) -> Vec<Shape> {
        let step = delay_grid_step_s(ctx.p.dt_s);
        let Some(d) = best.get(ShapeParam::DelayS) else {
            return Vec::new();
        };
        if step <= 0.002 + 1e-9 {
            return Vec::new();
        }
        let fine = step / (step / 0.001).round();
        (1..)
            .map(|k| k as f64 * fine)
            .take_while(|&x| x < step - 1e-9)
            .flat_map(|x| [d - x, d + x])
            .filter(|&x| x > 0.0 && x <= MAX_DYNAMIC_DELAY_S + 1e-9)
            .map(|x| Shape(vec![(ShapeParam::DelayS, x)]))
            .collect()
    }
    fn dynamic_term(&self, _ctx: &DynCtx, shape: &Shape) -> DynTerm {
        DynTerm {
            columns: vec![],
            base_delay_s: shape.get(ShapeParam::DelayS).unwrap_or(0.0),
            ..Default::default()
        }
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::Delay]
    }
}

/// The dynamic delay grid's step: up to 150 ms, whole samples every 2 ms, or every sample
/// when sampling is slower; from 10 ms sampling on (the thesis's 50 ms, a rig's 40 ms),
/// fifths of a sample as well — a 30 ms lag sampled every 50 ms is neither 0 nor 50 ms, and
/// the regressors are smooth enough to interpolate (`Loop::delay_split`).
fn delay_grid_step_s(dt_s: f64) -> f64 {
    if dt_s >= 0.01 - 1e-9 {
        dt_s / 5.0
    } else {
        (0.002 / dt_s).round().max(1.0) * dt_s
    }
}

/// Load-cell offset and linear drift, in the sensor frame (it turns with θ1 + θ2).
pub struct LoadcellDrift;
impl ModelEffect for LoadcellDrift {
    fn id(&self) -> &'static str {
        "loadcell_drift"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Drift)
    }
    fn shape_name(&self) -> &'static str {
        "offset_and_linear_drift"
    }
    fn summary(&self) -> &'static str {
        "offset and linear drift of the load-cell channels (sensor frame)"
    }
    fn signature(&self) -> &'static str {
        "residual has an offset and drifts with time"
    }
    fn applies(&self, _e: Experiment) -> bool {
        true
    }
    fn dynamic_term(&self, ctx: &DynCtx, _s: &Shape) -> DynTerm {
        let t0 = ctx.p.t_s[0];
        DynTerm {
            columns: sensor_frame_columns(
                ctx,
                [
                    ("offset_x_n", "drift_x_n_per_s"),
                    ("offset_z_n", "drift_z_n_per_s"),
                ],
                |t| t - t0,
            ),
            carries_constant: true,
            ..Default::default()
        }
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::Drift]
    }
}

/// Flow-limited converters: the force slews at a limited rate, different up and down.
pub struct AsymmetricIpRates;
impl ModelEffect for AsymmetricIpRates {
    fn id(&self) -> &'static str {
        "asymmetric_ip_rates"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::RateLimits)
    }
    fn shape_name(&self) -> &'static str {
        "converter_fill_times"
    }
    fn summary(&self) -> &'static str {
        "flow-limited I/P converters: the force rises and falls at limited, different rates (Table 5.1)"
    }
    fn signature(&self) -> &'static str {
        "large steps are slower than small ones, and rising differs from falling (ramp-shaped residual after large steps)"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::SlewRate]
    }
}

/// The delivered pressure saturates: large force commands fall short.
pub struct PressureSaturation;
impl ModelEffect for PressureSaturation {
    fn id(&self) -> &'static str {
        "pressure_saturation"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Saturation)
    }
    fn shape_name(&self) -> &'static str {
        "pressure_knee"
    }
    fn summary(&self) -> &'static str {
        "the delivered pressure saturates, so large force commands fall short"
    }
    fn signature(&self) -> &'static str {
        "the step gain drops for large commands (residual grows with |reference|)"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::Saturation]
    }
}

/// One muscle's converter cannot deliver more than a cap (a kinked supply line, a worn
/// converter, a regulator set low): only the steps that drive that muscle high fall short.
pub struct MusclePressureCap;
impl ModelEffect for MusclePressureCap {
    fn id(&self) -> &'static str {
        "muscle_pressure_cap"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Saturation)
    }
    fn shape_name(&self) -> &'static str {
        "one_muscle_cap"
    }
    fn summary(&self) -> &'static str {
        "one converter's pressure is capped: steps that need that muscle high fall short"
    }
    fn signature(&self) -> &'static str {
        "steps fall short only in the directions one muscle drives, and only when it is driven high"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::ChannelCap]
    }
}

/// The delivered force saturates in magnitude: each axis's force is compressed above a knee
/// toward a maximum (N), whatever the pressures behind it.
pub struct ForceSaturation;
impl ModelEffect for ForceSaturation {
    fn id(&self) -> &'static str {
        "force_saturation"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Saturation)
    }
    fn shape_name(&self) -> &'static str {
        "force_magnitude"
    }
    fn summary(&self) -> &'static str {
        "the handle force saturates in magnitude: the largest steps fall short"
    }
    fn signature(&self) -> &'static str {
        "only the largest steps fall short of the reference, by more the larger they are"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::ForceSaturation]
    }
}

/// A load-cell offset that settles exponentially (warm-up of the bridge and amplifier), in
/// the sensor frame: offset + A·(1 − e^{−t/τ}), τ a grid over the trial's length.
pub struct SettlingDrift;
impl ModelEffect for SettlingDrift {
    fn id(&self) -> &'static str {
        "settling_drift"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Drift)
    }
    fn shape_name(&self) -> &'static str {
        "exponential_settling"
    }
    fn summary(&self) -> &'static str {
        "load-cell offset settling exponentially (warm-up), sensor frame"
    }
    fn signature(&self) -> &'static str {
        "residual level moves early in the trial and levels off"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, ctx: &DynCtx) -> Vec<Shape> {
        let p = ctx.p;
        let span = p.t_s[p.len() - 1] - p.t_s[0];
        [0.1, 0.25, 0.5, 1.0]
            .iter()
            .map(|f| Shape(vec![(ShapeParam::TimeConstantS, f * span)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, s: &Shape) -> DynTerm {
        let tau = s.get(ShapeParam::TimeConstantS).unwrap_or(0.0).max(1e-3);
        let t0 = ctx.p.t_s[0];
        DynTerm {
            columns: sensor_frame_columns(
                ctx,
                [("offset_x_n", "settled_x_n"), ("offset_z_n", "settled_z_n")],
                |t| 1.0 - (-(t - t0) / tau).exp(),
            ),
            carries_constant: true,
            ..Default::default()
        }
    }
}

/// Per load-cell channel (sensor frame, turning with θ1 + θ2): a constant and `shape(t)`,
/// as columns of −f.
fn sensor_frame_columns(
    ctx: &DynCtx,
    names: [(&str, &str); 2],
    shape: impl Fn(f64) -> f64,
) -> Vec<Column> {
    let p = ctx.p;
    let k = &ctx.model.kinematics;
    let mut cols = Vec::new();
    for (axis, (name_o, name_s)) in names.into_iter().enumerate() {
        let mut e = [0.0; 2];
        e[axis] = 1.0;
        let (mut ox, mut oy, mut sx, mut sy) = (vec![], vec![], vec![], vec![]);
        for i in 0..p.len() {
            // the offset adds to the measured f; the column is its share of −f
            let u = k.sensor_to_user([p.alpha_rad[0][i], p.alpha_rad[1][i]], e);
            let g = shape(p.t_s[i]);
            ox.push(-u[0]);
            oy.push(-u[1]);
            sx.push(-u[0] * g);
            sy.push(-u[1] * g);
        }
        cols.push(Column::both(name_o, ox, oy));
        cols.push(Column::both(name_s, sx, sy));
    }
    cols
}

/// The set-points slew at limited rates (the command is ramped before the converters, e.g.
/// by a rate limiter in the controller), different up and down.
pub struct CommandSlew;
impl ModelEffect for CommandSlew {
    fn id(&self) -> &'static str {
        "command_slew"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::RateLimits)
    }
    fn shape_name(&self) -> &'static str {
        "command_slew"
    }
    fn summary(&self) -> &'static str {
        "the command ramps at limited rates before the converters (a slew limit on the set-points)"
    }
    fn signature(&self) -> &'static str {
        "large steps start later and ramp; the ramp's slope is the same for every step of a sign"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::CommandSlew]
    }
}

/// The handle force slews at limited rates (N/s), different up and down: a rate limiter on
/// the force reference, or the converters' flow seen at the handle, whichever drive the
/// model uses (a limit in bar/s on each converter maps to different force rates per axis).
pub struct ForceSlew;
impl ModelEffect for ForceSlew {
    fn id(&self) -> &'static str {
        "force_slew"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::RateLimits)
    }
    fn shape_name(&self) -> &'static str {
        "force_slew"
    }
    fn summary(&self) -> &'static str {
        "the handle force ramps at limited rates (N/s), different up and down"
    }
    fn signature(&self) -> &'static str {
        "large steps ramp; the ramp's slope in newtons per second is the same on both axes"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::ForceSlew]
    }
}
