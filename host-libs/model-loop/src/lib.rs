//! The model loop: compare the model with a measurement, find which physical effect is
//! missing, add it and watch the held-out error fall.
//!
//! - [`effects`]: the catalog of effects a model can add, by family and shape;
//! - [`response`]: the step model (the converters' response and the force path);
//! - [`diagnose`]: compare, diagnose and fit, the diagnosis and its settings;
//! - [`stiffness_pair`]: friction or hysteresis, from a trial at two stiffness levels.
//!
//! It starts from a prepared log (pam-ident) and uses pam-numerics for its fits and tests.

// `!(x > y)` is deliberate: it is true for NaN, so a NaN never passes a check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Two-axis and per-joint loops index several parallel arrays at once.
#![allow(clippy::needless_range_loop)]

pub mod diagnose;
pub mod effects;
pub mod response;
pub mod spread_pair;
pub mod stiffness_pair;
