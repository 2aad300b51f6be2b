//! Wire forms of pam-control's types carried by the link: the mode, the state and the
//! safety limits, with lossless conversions both ways.

use super::schema::{wire_enum, wire_struct};
use serde::{Deserialize, Serialize};

wire_enum! {
    /// Wire form of [`pam_control::Mode`]. Vectors are `[joint 1, joint 2]` or `[x, y]`.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub enum Mode {
        Idle,
        Pressures { pressure_bar: [f32; 4] },
        Joint {
            alpha_rad: [f32; 2],
            torque_nm: [f32; 2],
            stiffness_nm_per_rad: [f32; 2],
        },
        Force {
            force_n: [f32; 2],
            stiffness_nm_per_rad: [f32; 2],
            feed_forward: bool,
        },
        /// Appended: the variants before it keep their tags and bytes.
        ForceClosedLoop {
            force_n: [f32; 2],
            stiffness_nm_per_rad: [f32; 2],
            feed_forward: bool,
            gain_scale: f32,
        },
        /// Appended.
        Impedance {
            target_user_m: [f32; 2],
            stiffness_n_per_m: [f32; 2],
            damping_n_s_per_m: [f32; 2],
        },
    }
}

wire_enum! {
    /// Wire form of [`pam_control::State`].
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
    pub enum State {
        Disarmed,
        Armed,
        Faulted,
    }
}

wire_struct! {
    /// Wire form of [`pam_control::SafetyConfig`] (same fields, same units).
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct SafetyConfig {
        pub period_s: f32,
        pub command_timeout_s: f32,
        pub slew_bar_per_s: f32,
        pub timeout_ramp_bar_per_s: f32,
        pub max_joint_speed_rad_s: f32,
        pub angle_margin_rad: f32,
        pub loadcell_limit_n: f32,
        pub loadcell_stuck_samples: u32,
        pub max_request_torque_nm: f32,
        pub max_request_stiffness_nm_per_rad: f32,
        pub max_request_force_n: f32,
        /// Appended in protocol 5.
        pub overrun_fault_periods: u32,
    }
}

impl From<pam_control::Mode> for Mode {
    fn from(m: pam_control::Mode) -> Self {
        use pam_control::Mode as D;
        match m {
            D::Idle => Mode::Idle,
            D::Pressures { pressure_bar } => Mode::Pressures { pressure_bar },
            D::Joint {
                alpha_rad,
                torque_nm,
                stiffness_nm_per_rad,
            } => Mode::Joint {
                alpha_rad,
                torque_nm,
                stiffness_nm_per_rad,
            },
            D::Force {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
            } => Mode::Force {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
            },
            D::ForceClosedLoop {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
                gain_scale,
            } => Mode::ForceClosedLoop {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
                gain_scale,
            },
            D::Impedance {
                target_user_m,
                stiffness_n_per_m,
                damping_n_s_per_m,
                ..
            } => Mode::Impedance {
                target_user_m,
                stiffness_n_per_m,
                damping_n_s_per_m,
            },
        }
    }
}

impl From<Mode> for pam_control::Mode {
    fn from(m: Mode) -> Self {
        use pam_control::Mode as D;
        match m {
            Mode::Idle => D::Idle,
            Mode::Pressures { pressure_bar } => D::Pressures { pressure_bar },
            Mode::Joint {
                alpha_rad,
                torque_nm,
                stiffness_nm_per_rad,
            } => D::Joint {
                alpha_rad,
                torque_nm,
                stiffness_nm_per_rad,
            },
            Mode::Force {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
            } => D::Force {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
            },
            Mode::ForceClosedLoop {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
                gain_scale,
            } => D::ForceClosedLoop {
                force_n,
                stiffness_nm_per_rad,
                feed_forward,
                gain_scale,
            },
            Mode::Impedance {
                target_user_m,
                stiffness_n_per_m,
                damping_n_s_per_m,
            } => D::Impedance {
                target_user_m,
                stiffness_n_per_m,
                damping_n_s_per_m,
                // the virtual mass is not on the wire: measured on the twin it is not rendered
                // faithfully (docs/impedance.md, "Virtual mass")
                mass_kg: [0.0; 2],
            },
        }
    }
}

impl From<pam_control::State> for State {
    fn from(s: pam_control::State) -> Self {
        match s {
            pam_control::State::Disarmed => State::Disarmed,
            pam_control::State::Armed => State::Armed,
            pam_control::State::Faulted => State::Faulted,
        }
    }
}

impl From<State> for pam_control::State {
    fn from(s: State) -> Self {
        match s {
            State::Disarmed => pam_control::State::Disarmed,
            State::Armed => pam_control::State::Armed,
            State::Faulted => pam_control::State::Faulted,
        }
    }
}

impl PartialEq<pam_control::State> for State {
    fn eq(&self, other: &pam_control::State) -> bool {
        *self == State::from(*other)
    }
}

/// Converts every field between the two structs, by name, with `Into` (fields after
/// `map` are arrays, converted element by element). A field missing from the list or
/// from either struct does not compile.
macro_rules! same_fields {
    ($(#[$a:meta])* $from:ty => $to:ty { $($f:ident),* $(,)? $(; map $($m:ident),* $(,)?)? }) => {
        impl From<$from> for $to {
            $(#[$a])*
            fn from(v: $from) -> Self {
                Self {
                    $($f: v.$f.into(),)*
                    $($($m: v.$m.map(Into::into),)*)?
                }
            }
        }
    };
}
pub(crate) use same_fields;

same_fields!(pam_control::SafetyConfig => SafetyConfig {
    period_s, command_timeout_s, slew_bar_per_s, timeout_ramp_bar_per_s,
    max_joint_speed_rad_s, angle_margin_rad, loadcell_limit_n, loadcell_stuck_samples,
    max_request_torque_nm, max_request_stiffness_nm_per_rad, max_request_force_n,
    overrun_fault_periods,
});
same_fields!(SafetyConfig => pam_control::SafetyConfig {
    period_s, command_timeout_s, slew_bar_per_s, timeout_ramp_bar_per_s,
    max_joint_speed_rad_s, angle_margin_rad, loadcell_limit_n, loadcell_stuck_samples,
    max_request_torque_nm, max_request_stiffness_nm_per_rad, max_request_force_n,
    overrun_fault_periods,
});
