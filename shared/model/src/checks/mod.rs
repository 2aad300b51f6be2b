//! Self-checks of the model: the thesis's reference values and property sweeps.
//!
//! They are plain `no_std` functions so that the same code runs under `cargo test` on the
//! host (in f32 and f64) and on the emulated Cortex-M4F (`qemu-tests/`, in f32 and
//! soft-float f64). Each returns the first deviation it finds with the numbers involved.
//! Sweeps use a fixed-seed generator so a failure reproduces.
//!
//! Reference values: README, "Reproduced values" (`cargo run -p pam-model --example
//! reference_values` prints them). Where the thesis's printed
//! number does not follow from its equations, the check uses what the equations give and
//! the comment keeps the printed number.

use crate::ellipse::Ellipse;
use crate::joint::Limited;
use crate::mat2::Mat2;
use crate::params::RobotParams;
use crate::real::Real;
use crate::robot::RobotModel;

/// What a failed check found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Failure {
    pub what: &'static str,
    pub got: f64,
    pub expected: f64,
    pub tolerance: f64,
    /// Sample number within a sweep, or the table row.
    pub index: u32,
}

pub type CheckResult = Result<(), Failure>;

/// `Ok` when `ok`, else a failure named `what` (for yes/no facts).
pub fn holds_that(what: &'static str, ok: bool) -> CheckResult {
    holds(what, 0, ok)
}

/// `Ok` when `got` is finite and within `tolerance` of `expected`.
pub fn near_f32(what: &'static str, got: f32, expected: f32, tolerance: f32) -> CheckResult {
    close(what, 0, got as f64, expected as f64, tolerance as f64)
}

#[derive(Clone, Copy)]
pub struct Check {
    pub name: &'static str,
    pub run: fn() -> CheckResult,
}

/// Lists non-generic check functions as `pub const CHECKS: &[Check]` (run on the target by
/// the QEMU suite) and as one host `#[test]` each. Used by the crates above the model
/// (pam-control, pam-device); the model's own checks are generic over f32/f64.
#[macro_export]
macro_rules! register_checks {
    ($($name:ident),* $(,)?) => {
        pub const CHECKS: &[$crate::checks::Check] =
            &[$($crate::checks::Check { name: stringify!($name), run: $name }),*];
        #[cfg(test)]
        mod on_host {
            $(#[test] fn $name() { if let Err(e) = super::$name() { panic!("{e:?}") } })*
        }
    };
}

fn close(what: &'static str, index: u32, got: f64, expected: f64, tolerance: f64) -> CheckResult {
    if (got - expected).abs() <= tolerance && got.is_finite() {
        Ok(())
    } else {
        Err(Failure {
            what,
            got,
            expected,
            tolerance,
            index,
        })
    }
}

fn holds(what: &'static str, index: u32, ok: bool) -> CheckResult {
    if ok {
        Ok(())
    } else {
        Err(Failure {
            what,
            got: 0.0,
            expected: 1.0,
            tolerance: 0.0,
            index,
        })
    }
}

/// Relative numerical tolerance of the scalar type (f32 runs get looser identity bounds).
fn num_tol<R: Real>() -> f64 {
    if core::mem::size_of::<R>() == 4 {
        1.0
    } else {
        1e-6
    }
}

/// The sweeps' seeded generator: ChaCha8 (`rand_chacha`, no_std), the project's one
/// generator (the twin and the model-loop tests use it too), so a sweep draws the same
/// points on the host and on the Cortex-M4F.
pub struct Rng(rand_chacha::ChaCha8Rng);
impl Rng {
    pub fn new(seed: u64) -> Self {
        use rand_chacha::rand_core::SeedableRng;
        Rng(rand_chacha::ChaCha8Rng::seed_from_u64(seed))
    }
    pub fn next_u64(&mut self) -> u64 {
        use rand_chacha::rand_core::RngCore;
        self.0.next_u64()
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }
}

fn model<R: Real>() -> RobotModel<R> {
    RobotModel::new(RobotParams::thesis())
}

const SWEEP: u32 = 400;

fn random_alpha<R: Real>(m: &RobotModel<R>, rng: &mut Rng) -> [R; 2] {
    let mut a = [R::ZERO; 2];
    for j in 0..2 {
        a[j] = R::from_f64(rng.uniform(
            m.joints[j].alpha_min_rad.to_f64(),
            m.joints[j].alpha_max_rad.to_f64(),
        ));
    }
    a
}

mod joint_model;
mod kinematics;
pub mod precision;
mod reference;
mod signals;
pub mod workload;

pub use joint_model::*;
pub use kinematics::*;
pub use reference::*;
pub use signals::*;

macro_rules! register_checks {
    ($($name:ident),* $(,)?) => {
        /// Every check, instantiated for f32 (the target's type).
        pub const CHECKS_F32: &[Check] = &[$(Check { name: stringify!($name), run: $name::<f32> }),*];
        /// Every check, instantiated for f64 (the host reference).
        pub const CHECKS_F64: &[Check] = &[$(Check { name: stringify!($name), run: $name::<f64> }),*];

        #[cfg(test)]
        mod f32_on_host {
            $(#[test] fn $name() { if let Err(e) = super::$name::<f32>() { panic!("{e:?}") } })*
        }
        #[cfg(test)]
        mod f64_on_host {
            $(#[test] fn $name() { if let Err(e) = super::$name::<f64>() { panic!("{e:?}") } })*
        }
    };
}

register_checks!(
    epsilon0_values,
    anti_slack_force_joint1,
    anti_slack_force_joint2,
    whole_range_torque_joint1,
    whole_range_torque_joint2,
    table_4_1_all_points,
    neutral_handle_position,
    inverse_then_direct_is_identity,
    direct_then_inverse_is_identity,
    unattainable_requests_are_clamped_and_flagged,
    invalid_inputs_give_safe_pressures,
    capability_vertices_match_table_3_2,
    forward_then_inverse_kinematics_is_identity,
    jacobian_matches_finite_differences,
    joint_torques_satisfy_virtual_work,
    ellipse_of_rotated_diagonal,
    cartesian_stiffness_round_trip,
    load_cell_rotation,
    signal_laws,
    gain_plane_correction,
    channel_map_round_trip,
    force_mode_reproduces_force,
    sin_cos_accuracy,
);
