//! The protocol's own wire types (the ICD pattern): every payload that carries a domain
//! value (a mode, a state, safety limits, robot parameters, load-cell calibration) does so
//! through a struct or enum declared here, never through pam-model's or pam-control's
//! types. Reordering or renaming a field in the model or the controller therefore cannot
//! change the bytes on the link; changing a type here does, and is caught by the
//! golden-bytes tests and the [`crate::SCHEMA_FINGERPRINT`].
//!
//! - [`schema`]: the compile-time fingerprint ([`Schema`], `wire_struct!`, `wire_enum!`).
//! - [`control`]: [`Mode`], [`State`], [`SafetyConfig`] (pam-control).
//! - [`model`]: [`RobotParams`] and its parts, [`LoadCell`] (pam-model).
//!
//! Conversions to and from the domain types are `From` impls beside each type. Every one
//! is total: each wire value has a domain value and back (the enums' tags are checked by
//! postcard when a frame is decoded, which the device answers with `Malformed`), so no
//! conversion can fail and none returns an error.

pub mod control;
pub mod model;
pub mod schema;

pub use control::{Mode, SafetyConfig, State};
pub use model::{
    GainPlane, IpConverter, JointParams, LoadCell, MuscleCoeffs, PressureLimits, RobotParams,
    SegmentMass,
};
pub use schema::Schema;
