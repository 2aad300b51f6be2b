//! Digital twin of the PAM rehabilitation robot.
//!
//! A physics simulator of the whole chain of the thesis — loop currents → I/P converters
//! (second order, Table 5.2) → compressible muscles (volume of a DMSP-20, polytropic air) →
//! polynomial muscle forces with slack cables (eq. 3.1) → joint torques (eq. 3.2) → rigid-body
//! dynamics of the two segments with their configuration-dependent inertia and Coriolis terms
//! (eq. 4.14–4.17) → the handle and what holds it → encoders and load cell — with a catalog
//! of switchable physical effects ([`effects`]) and scripted thesis experiments
//! ([`experiments`]) that write the project's log format v1.
//!
//! Host only, f64, deterministic for a given seed. All robot physics is `pam_model`'s
//! (kinematics, muscle law, I/P and load-cell laws, inertia/Coriolis); this crate adds the
//! dynamics, the air, the surroundings and the sensors.

// Per-joint and per-channel loops index several parallel arrays at once (as in pam-model).
#![allow(clippy::needless_range_loop)]

pub mod config;
pub mod effects;
pub mod experiments;
pub mod faults;
pub mod harness;
pub mod impedance_trial;
pub mod plant;
pub mod pneumatics;
pub mod rig;
pub mod rng;
pub mod simulate;
pub mod step_metrics;
pub mod tune;

pub use effects::{Effect, EffectSet};
pub use plant::{
    HandSpring, HandleCondition, Measurement, MechanicsConfig, SensorConfig, TrueState, Twin,
    TwinConfig,
};
pub use pneumatics::{ConverterRates, PneumaticConfig};
