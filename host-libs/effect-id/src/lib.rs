//! The names of the robot's physical effects and of their families.
//!
//! An [`EffectId`] names one effect of the digital twin (`pam-twin`, `pamctl simulate
//! --with ID`); a [`Family`] names what the model loop reports (`friction`, `hysteresis`,
//! …). Each family's effects are reported under the id of the twin's effect of that family
//! ([`Family::catalog_id`]), so a diagnosis's `id` can be checked against the effect the
//! twin switched on, and [`EffectId::family`] goes the other way.
//!
//! This crate depends on nothing of the project so that the twin, the model loop
//! (`pam-model-loop`) and the second log generator (`pam-synth`) can all use it without a
//! circle. Both types (de)serialize as their snake_case name, the words the JSON of
//! `pamctl model diagnose --json` and the generators' truth files carry.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// A name that is not one of the known ones; the message lists those.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} `{name}` (known: {known})")]
pub struct UnknownName {
    /// `effect` or `family`.
    pub what: &'static str,
    pub name: String,
    /// The valid names, comma-separated.
    pub known: String,
}

/// One switchable effect of the digital twin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectId {
    CarrierBallFriction,
    VelocitySquared,
    NonlinearStiffness,
    MuscleHysteresis,
    AsymmetricIpRates,
    PressureSaturation,
    PoseDependence,
    CableSlip,
    TransportDelay,
    LoadcellDrift,
    /// A mains tone on the load cell: no model family describes it, so the model loop
    /// should call it unexplained.
    MainsHum,
    /// Per-channel flow limits of the I/P converters: part of the identified rig's
    /// pneumatics rather than a switch of its own, a rate limit to the model loop.
    ConverterRates,
}

impl EffectId {
    /// Every effect: the twin's switchable ones in its catalog order, then the converter
    /// rates.
    pub const ALL: [EffectId; 12] = [
        EffectId::CarrierBallFriction,
        EffectId::VelocitySquared,
        EffectId::NonlinearStiffness,
        EffectId::MuscleHysteresis,
        EffectId::AsymmetricIpRates,
        EffectId::PressureSaturation,
        EffectId::PoseDependence,
        EffectId::CableSlip,
        EffectId::TransportDelay,
        EffectId::LoadcellDrift,
        EffectId::MainsHum,
        EffectId::ConverterRates,
    ];

    /// The snake_case name (`carrier_ball_friction`).
    pub fn name(self) -> &'static str {
        match self {
            EffectId::CarrierBallFriction => "carrier_ball_friction",
            EffectId::VelocitySquared => "velocity_squared",
            EffectId::NonlinearStiffness => "nonlinear_stiffness",
            EffectId::MuscleHysteresis => "muscle_hysteresis",
            EffectId::AsymmetricIpRates => "asymmetric_ip_rates",
            EffectId::PressureSaturation => "pressure_saturation",
            EffectId::PoseDependence => "pose_dependence",
            EffectId::CableSlip => "cable_slip",
            EffectId::TransportDelay => "transport_delay",
            EffectId::LoadcellDrift => "loadcell_drift",
            EffectId::MainsHum => "mains_hum",
            EffectId::ConverterRates => "converter_rates",
        }
    }

    /// The family the model loop reports this effect as; `None` for an effect outside the
    /// families (the mains tone).
    pub fn family(self) -> Option<Family> {
        match self {
            EffectId::MainsHum => None,
            EffectId::ConverterRates => Some(Family::RateLimits),
            id => Family::ALL.into_iter().find(|f| f.catalog_id() == id),
        }
    }
}

impl fmt::Display for EffectId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for EffectId {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        EffectId::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| UnknownName {
                what: "effect",
                name: s.to_string(),
                known: EffectId::ALL.map(EffectId::name).join(", "),
            })
    }
}

/// The physical family an effect belongs to: what the user learns ("friction",
/// "hysteresis", …). A family holds several shapes (the model loop's effects and their
/// shape grids); reports name the family first, then the best shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    Friction,
    Drag,
    Hysteresis,
    Backlash,
    StiffnessNonlinearity,
    PoseDependence,
    Drift,
    Delay,
    RateLimits,
    Saturation,
}

impl Family {
    pub const ALL: [Family; 10] = [
        Family::Friction,
        Family::Drag,
        Family::Hysteresis,
        Family::Backlash,
        Family::StiffnessNonlinearity,
        Family::PoseDependence,
        Family::Drift,
        Family::Delay,
        Family::RateLimits,
        Family::Saturation,
    ];

    /// The id the family's effects are reported under (`--json`'s `id`): the twin's effect
    /// of that family. The one table between ids and families.
    pub fn catalog_id(self) -> EffectId {
        match self {
            Family::Friction => EffectId::CarrierBallFriction,
            Family::Drag => EffectId::VelocitySquared,
            Family::Hysteresis => EffectId::MuscleHysteresis,
            Family::Backlash => EffectId::CableSlip,
            Family::StiffnessNonlinearity => EffectId::NonlinearStiffness,
            Family::PoseDependence => EffectId::PoseDependence,
            Family::Drift => EffectId::LoadcellDrift,
            Family::Delay => EffectId::TransportDelay,
            Family::RateLimits => EffectId::AsymmetricIpRates,
            Family::Saturation => EffectId::PressureSaturation,
        }
    }

    /// The snake_case name used in reports and `--json`.
    pub fn name(self) -> &'static str {
        match self {
            Family::Friction => "friction",
            Family::Drag => "drag",
            Family::Hysteresis => "hysteresis",
            Family::Backlash => "backlash",
            Family::StiffnessNonlinearity => "stiffness_nonlinearity",
            Family::PoseDependence => "pose_dependence",
            Family::Drift => "drift",
            Family::Delay => "delay",
            Family::RateLimits => "rate_limits",
            Family::Saturation => "saturation",
        }
    }
}

impl fmt::Display for Family {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Family {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Family::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| UnknownName {
                what: "family",
                name: s.to_string(),
                known: Family::ALL.map(Family::name).join(", "),
            })
    }
}
