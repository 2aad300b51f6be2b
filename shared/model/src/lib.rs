//! Robot model of the two-DoF pneumatic-muscle rehabilitation robot described in the
//! master thesis "Open-loop identification of a 2 degrees of freedom rehabilitation robot
//! actuated with pneumatic artificial muscles" (UCLouvain).
//!
//! `no_std`, no heap, fixed-size, generic over the scalar ([`Real`]): `f32` on the
//! Cortex-M4F, `f64` on the host. Equation numbers in the docs refer to the thesis.
//!
//! - [`params::RobotParams`]: every number of the robot, thesis values by default.
//! - [`muscle`]: F(ε, P) = A(ε)P + B(ε) and dF/dε.
//! - [`joint`]: direct and inverse joint models, capability quadrilateral.
//! - [`kinematics`]: α ↔ θ, forward/inverse kinematics, Jacobian, load-cell rotation.
//! - [`cartesian`], [`ellipse`]: joint ↔ Cartesian matrices and their ellipses.
//! - [`io`], [`gain_plane`]: I/P law, load-cell law, feed-forward correction.
//! - [`robot::RobotModel`]: all of it with the derived constants computed once.
//! - [`taut`]: the inverse model with cables that cannot push (the closed loops).
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
// `!(x >= lo)` is deliberate throughout: it is true for NaN, so a NaN never passes a limit.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Per-joint loops index several parallel two-element arrays at once.
#![allow(clippy::needless_range_loop)]

pub mod cartesian;
pub mod ellipse;
pub mod gain_plane;
pub mod io;
pub mod joint;
pub mod kinematics;
pub mod mat2;
pub mod muscle;
pub mod params;
pub mod protocols;
pub mod real;
pub mod robot;
pub mod taut;
pub mod thesis;

#[cfg(any(test, feature = "checks"))]
pub mod checks;

pub use joint::{Capability, InverseSolution, Limited};
pub use mat2::{Mat2, Vec2};
pub use params::RobotParams;
pub use real::Real;
pub use robot::RobotModel;
