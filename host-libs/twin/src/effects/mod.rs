//! Catalog of switchable physical effects.
//!
//! Each effect is one file in this folder: a struct with named `f64` parameters, a stable
//! snake_case [`Effect::id`], and the hooks of the chain it acts on. Every hook has a no-op
//! default, so an effect overrides only the stages it changes. The stages, in the order the
//! twin calls them each integration step:
//!
//! 1. [`Effect::pressure_command`] — the pressure each converter is asked for (eq. 2.2 output).
//! 2. [`Effect::regulator_flow`] — the converter's flow into the muscle (bar/s).
//! 3. [`Effect::transmission`] — the joint angle the cables/muscles see (slip, backlash).
//! 4. [`Effect::muscle_pressure`] — the pressure that acts in the force law.
//! 5. [`Effect::muscle_force`] — each cable's force (before the cable-cannot-push clamp).
//! 6. [`Effect::joint_torque`] — the torques on the joints.
//! 7. [`Effect::handle_force`] — forces of the environment at the handle (user frame), on the
//!    arm side of the load cell (the load cell sees them through the hand that must overcome
//!    them) or on the handle side (they load the hand only; the load cell cannot see them
//!    while the hand imposes the motion).
//! 8. [`Effect::sensor`] — the raw readings (load-cell volts, encoder counts).
//!
//! To add an effect: copy a file (e.g. `velocity_squared.rs`), change the id, the
//! parameters and the hook, and add one line to [`REGISTRY`].
//!
//! A spec string selects and parameterises one: `carrier_ball_friction:coulomb_n=2.0,smoothing_m_s=0.01`.

use std::fmt;

pub use pam_effect_id::EffectId;
use pam_model::{RobotParams, Vec2};

mod asymmetric_ip_rates;
mod cable_slip;
mod carrier_ball_friction;
mod loadcell_drift;
mod mains_hum;
mod muscle_hysteresis;
mod nonlinear_stiffness;
mod pose_dependence;
mod pressure_saturation;
mod transport_delay;
mod velocity_squared;

pub use asymmetric_ip_rates::AsymmetricIpRates;
pub use cable_slip::CableSlip;
pub use carrier_ball_friction::CarrierBallFriction;
pub use loadcell_drift::LoadcellDrift;
pub use mains_hum::MainsHum;
pub use muscle_hysteresis::MuscleHysteresis;
pub use nonlinear_stiffness::NonlinearStiffness;
pub use pose_dependence::PoseDependence;
pub use pressure_saturation::PressureSaturation;
pub use transport_delay::TransportDelay;
pub use velocity_squared::VelocitySquared;

/// What an effect can see of the plant when a hook runs (the state at the start of the
/// integration step).
#[derive(Clone, Copy, Debug)]
pub struct Ctx<'a> {
    pub t_s: f64,
    /// Integration step.
    pub dt_s: f64,
    pub alpha_rad: Vec2<f64>,
    pub alpha_dot_rad_s: Vec2<f64>,
    pub handle_user_m: Vec2<f64>,
    pub handle_velocity_user_m_s: Vec2<f64>,
    /// The handle is blocked (force-step tests).
    pub blocked: bool,
    /// Joint torques of the muscles at the previous step (for effects that need the load).
    pub last_joint_torque_nm: Vec2<f64>,
    pub params: &'a RobotParams<f64>,
}

/// One muscle as the force stage sees it.
#[derive(Clone, Copy, Debug)]
pub struct MuscleView {
    /// I/P channel 0..=3.
    pub channel: usize,
    pub joint: usize,
    /// Contraction ratio ε and its rate.
    pub epsilon: f64,
    pub epsilon_rate_per_s: f64,
    pub pressure_bar: f64,
}

/// Environment forces at the handle point, user frame, split by which side of the load cell
/// they act on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HandleForces {
    pub arm_side_user_n: Vec2<f64>,
    pub handle_side_user_n: Vec2<f64>,
}

/// Raw sensor values before the ADC and the encoder counter.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RawSensors {
    /// Load-cell channel voltages (sensor X, Z).
    pub loadcell_v: [f64; 2],
    /// Angle the encoder disc sits at (rad, α convention), before quantization.
    pub encoder_alpha_rad: [f64; 2],
}

/// One named parameter, for `describe()` and the CLI.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamInfo {
    pub name: &'static str,
    pub value: f64,
    pub unit: &'static str,
    pub doc: &'static str,
}

/// A physical effect. Hooks mutate the value of their stage in place.
pub trait Effect: Send {
    /// Stable id (shared with the model tools).
    fn id(&self) -> EffectId;
    /// One paragraph: the physics, and where the defaults come from.
    fn summary(&self) -> &'static str;
    /// The parameters with their present values.
    fn params(&self) -> Vec<ParamInfo>;
    /// Sets one parameter by name.
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), EffectError>;
    /// Whether the model catalog describes this effect (its id has a family). `false` marks
    /// a disturbance the model tools should report as unexplained.
    fn in_model_catalog(&self) -> bool {
        self.id().family().is_some()
    }
    fn boxed_clone(&self) -> Box<dyn Effect>;
    /// Back to the initial state; `seed` is this effect's own stream.
    fn reset(&mut self, _seed: u64) {}

    fn pressure_command(&mut self, _ctx: &Ctx, _p_set_bar: &mut [f64; 4]) {}
    fn regulator_flow(&mut self, _ctx: &Ctx, _flow_bar_s: &mut [f64; 4]) {}
    fn transmission(&mut self, _ctx: &Ctx, _alpha_muscle_rad: &mut Vec2<f64>) {}
    fn muscle_pressure(&mut self, _ctx: &Ctx, _p_bar: &mut [f64; 4]) {}
    fn muscle_force(&mut self, _ctx: &Ctx, _muscle: &MuscleView, _force_n: &mut f64) {}
    fn joint_torque(&mut self, _ctx: &Ctx, _torque_nm: &mut Vec2<f64>) {}
    fn handle_force(&mut self, _ctx: &Ctx, _forces: &mut HandleForces) {}
    fn sensor(&mut self, _ctx: &Ctx, _raw: &mut RawSensors) {}
}

impl Clone for Box<dyn Effect> {
    fn clone(&self) -> Self {
        self.boxed_clone()
    }
}

/// Human-readable description of one effect: id, summary, parameters.
pub fn describe(effect: &dyn Effect) -> String {
    let mut s = format!(
        "{}{}\n  {}\n",
        effect.id(),
        if effect.in_model_catalog() {
            ""
        } else {
            "  [NOT in the model catalog]"
        },
        effect.summary()
    );
    for p in effect.params() {
        s.push_str(&format!(
            "  {} = {} {}  — {}\n",
            p.name, p.value, p.unit, p.doc
        ));
    }
    s
}

#[derive(Clone, Debug, PartialEq)]
pub struct EffectError {
    pub message: String,
}

impl fmt::Display for EffectError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for EffectError {}

impl EffectError {
    pub fn unknown_param(id: &str, name: &str, known: &[ParamInfo]) -> Self {
        let names: Vec<&str> = known.iter().map(|p| p.name).collect();
        EffectError {
            message: format!(
                "effect `{id}` has no parameter `{name}` (known: {})",
                names.join(", ")
            ),
        }
    }
}

/// Every effect, with its default parameters, in catalog order.
pub const REGISTRY: &[fn() -> Box<dyn Effect>] = &[
    || Box::new(CarrierBallFriction::default()),
    || Box::new(VelocitySquared::default()),
    || Box::new(NonlinearStiffness::default()),
    || Box::new(MuscleHysteresis::default()),
    || Box::new(AsymmetricIpRates::default()),
    || Box::new(PressureSaturation::default()),
    || Box::new(PoseDependence::default()),
    || Box::new(CableSlip::default()),
    || Box::new(TransportDelay::default()),
    || Box::new(LoadcellDrift::default()),
    || Box::new(MainsHum::default()),
];

/// All effects with default parameters.
pub fn catalog() -> Vec<Box<dyn Effect>> {
    REGISTRY.iter().map(|make| make()).collect()
}

/// The stable ids, in catalog order.
pub fn ids() -> Vec<&'static str> {
    catalog().iter().map(|e| e.id().name()).collect()
}

/// Builds one effect from `id` or `id:name=value,name=value`.
pub fn parse(spec: &str) -> Result<Box<dyn Effect>, EffectError> {
    let spec = spec.trim();
    let (id, rest) = match spec.split_once(':') {
        Some((id, rest)) => (id.trim(), rest.trim()),
        None => (spec, ""),
    };
    let mut effect = catalog()
        .into_iter()
        .find(|e| e.id().name() == id)
        .ok_or_else(|| EffectError {
            message: format!("unknown effect `{id}` (known: {})", ids().join(", ")),
        })?;
    if !rest.is_empty() {
        for pair in rest.split(',') {
            let (name, value) = pair.split_once('=').ok_or_else(|| EffectError {
                message: format!("effect `{id}`: `{pair}` is not name=value"),
            })?;
            let value: f64 = value
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| EffectError {
                    message: format!(
                        "effect `{id}`: parameter `{}` = `{}` is not a finite number",
                        name.trim(),
                        value.trim()
                    ),
                })?;
            effect.set_param(name.trim(), value)?;
        }
    }
    Ok(effect)
}

/// The spec string that rebuilds this effect with its present parameters.
pub fn spec_of(effect: &dyn Effect) -> String {
    let params: Vec<String> = effect
        .params()
        .iter()
        .map(|p| format!("{}={}", p.name, p.value))
        .collect();
    if params.is_empty() {
        effect.id().to_string()
    } else {
        format!("{}:{}", effect.id(), params.join(","))
    }
}

/// The effects switched on in one twin (empty by default: the base chain only).
#[derive(Clone, Default)]
pub struct EffectSet {
    effects: Vec<Box<dyn Effect>>,
}

impl fmt::Debug for EffectSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list()
            .entries(self.effects.iter().map(|e| spec_of(e.as_ref())))
            .finish()
    }
}

impl EffectSet {
    pub fn none() -> Self {
        Self::default()
    }

    /// Parses a list of specs; an id given twice is an error.
    pub fn parse_list<S: AsRef<str>>(specs: &[S]) -> Result<Self, EffectError> {
        let mut set = EffectSet::none();
        for s in specs {
            set.push(parse(s.as_ref())?)?;
        }
        Ok(set)
    }

    pub fn push(&mut self, effect: Box<dyn Effect>) -> Result<(), EffectError> {
        if self.effects.iter().any(|e| e.id() == effect.id()) {
            return Err(EffectError {
                message: format!("effect `{}` given twice", effect.id()),
            });
        }
        self.effects.push(effect);
        Ok(())
    }

    pub fn with(mut self, effect: Box<dyn Effect>) -> Result<Self, EffectError> {
        self.push(effect)?;
        Ok(self)
    }

    pub fn is_empty(&self) -> bool {
        self.effects.is_empty()
    }

    pub fn iter(&self) -> impl Iterator<Item = &dyn Effect> {
        self.effects.iter().map(|e| e.as_ref())
    }

    /// Specs of the active effects, e.g. for log metadata.
    pub fn specs(&self) -> Vec<String> {
        self.effects.iter().map(|e| spec_of(e.as_ref())).collect()
    }

    pub(crate) fn all_mut(&mut self) -> &mut [Box<dyn Effect>] {
        &mut self.effects
    }

    pub(crate) fn reset(&mut self, seed: u64) {
        for e in &mut self.effects {
            let s = crate::rng::Rng::derive(seed, e.id().name()).next_u64();
            e.reset(s);
        }
    }
}

/// Implements `params`/`set_param` for an effect from a list of `field, unit, doc` triples.
macro_rules! effect_params {
    ($($field:ident, $unit:expr, $doc:expr;)*) => {
        fn params(&self) -> Vec<$crate::effects::ParamInfo> {
            vec![$($crate::effects::ParamInfo { name: stringify!($field), value: self.$field, unit: $unit, doc: $doc },)*]
        }
        fn set_param(&mut self, name: &str, value: f64) -> Result<(), $crate::effects::EffectError> {
            match name {
                $(stringify!($field) => { self.$field = value; Ok(()) })*
                _ => Err($crate::effects::EffectError::unknown_param(self.id().name(), name, &self.params())),
            }
        }
        fn boxed_clone(&self) -> Box<dyn $crate::effects::Effect> {
            Box::new(self.clone())
        }
    };
}
pub(crate) use effect_params;

/// Smooth sign: v / sqrt(v² + w²) — Coulomb friction without the chatter of sign().
#[inline]
pub(crate) fn smooth_sign(v: f64, width: f64) -> f64 {
    v / (v * v + width * width).sqrt()
}
