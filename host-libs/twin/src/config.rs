//! What defines a twin and what holds its handle: the handle conditions, the sensors', the
//! mechanics' and the whole twin's configuration (split from `plant`, which re-exports them).

use pam_model::{RobotParams, Vec2};

use crate::effects::EffectSet;
use crate::pneumatics::PneumaticConfig;

/// What holds the handle during one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HandleCondition {
    /// Nothing touches the handle (only the effects' environment forces act).
    Free,
    /// Mechanically blocked where it is (force-step tests, §5.2): the arm does not move and
    /// the force on the blocks follows from statics, f = J⁻ᵀ τ.
    Blocked,
    /// A hand holds the handle through a stiff impedance toward a target: held still (zero
    /// target velocity) in static trials, moved along a path in dynamic trials. The
    /// interaction force comes out of the physics.
    Hand(HandSpring),
    /// Joint 1 locked at its present angle (chapter 3 validation set-up); joint 2 free, or
    /// driven by a hand.
    Joint1Locked(Option<HandSpring>),
}

/// A hand that imposes a motion: F_hand = K (x_target − x) + B (v_target − v), user frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HandSpring {
    pub target_user_m: Vec2<f64>,
    pub target_velocity_user_m_s: Vec2<f64>,
    pub stiffness_n_per_m: f64,
    pub damping_n_s_per_m: f64,
}

impl HandSpring {
    /// Default hand: 5000 N/m, 100 N·s/m — stiff against the robot's 100–600 N/m, so the
    /// path is followed within a few mm (a firm grip; human arm stiffness is 300–1000 N/m,
    /// the operator co-contracts to impose a path).
    pub const STIFFNESS_N_PER_M: f64 = 5000.0;
    pub const DAMPING_N_S_PER_M: f64 = 100.0;

    pub fn at(target_user_m: Vec2<f64>, target_velocity_user_m_s: Vec2<f64>) -> Self {
        HandSpring {
            target_user_m,
            target_velocity_user_m_s,
            stiffness_n_per_m: Self::STIFFNESS_N_PER_M,
            damping_n_s_per_m: Self::DAMPING_N_S_PER_M,
        }
    }
}

impl HandleCondition {
    /// Held still at a point of the user frame.
    pub fn held_at(point_user_m: Vec2<f64>) -> Self {
        HandleCondition::Hand(HandSpring::at(point_user_m, [0.0; 2]))
    }
    /// Moved by an operator: the path's position and velocity at this instant.
    pub fn moved(position_user_m: Vec2<f64>, velocity_user_m_s: Vec2<f64>) -> Self {
        HandleCondition::Hand(HandSpring::at(position_user_m, velocity_user_m_s))
    }
}

/// The rig's sensors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorConfig {
    /// Encoder counts per revolution (after quadrature), per joint. The thesis does not give
    /// the encoders' resolution; 10 000 (a 2500-line encoder) is an estimate.
    pub encoder_counts_per_rev: [u32; 2],
    /// Load-cell noise, standard deviation in N per sensor channel (estimate).
    pub loadcell_noise_n: [f64; 2],
    /// ADC resolution and input span (±span) of the load-cell channels (estimate).
    pub adc_bits: u32,
    pub adc_span_v: f64,
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig {
            encoder_counts_per_rev: [10_000; 2],
            loadcell_noise_n: [0.15, 0.15],
            adc_bits: 16,
            adc_span_v: 10.0,
        }
    }
}

impl SensorConfig {
    /// Perfect sensors (no quantization, no noise): for tests of the physics.
    pub fn ideal() -> Self {
        SensorConfig {
            encoder_counts_per_rev: [0; 2],
            loadcell_noise_n: [0.0; 2],
            adc_bits: 0,
            adc_span_v: 10.0,
        }
    }
}

/// Mechanical details of the arm beyond the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MechanicsConfig {
    /// Viscous friction of each joint's bearings (small; estimate).
    pub joint_damping_nm_s_per_rad: [f64; 2],
    /// Hard stops this far beyond the joint range (the supervisor faults at 0.05 rad).
    pub hard_stop_margin_rad: f64,
    pub hard_stop_stiffness_nm_per_rad: f64,
    pub hard_stop_damping_nm_s_per_rad: f64,
    /// Stiffness in parallel with each muscle pair, an elastoplastic (stick-slip) element:
    /// a spring anchored where the arm was placed, whose anchor slips once its torque
    /// exceeds [`MechanicsConfig::parallel_breakaway_nm`]. Zero by default (the thesis's
    /// model); [`MechanicsConfig::identified_rig`] calibrates it from the thesis's identified
    /// stiffness ([`crate::rig`]).
    pub parallel_stiffness_nm_per_rad: [f64; 2],
    /// Torque at which the parallel element's anchor slips (infinite: a plain spring
    /// anchored at the initial pose).
    pub parallel_breakaway_nm: [f64; 2],
    /// The muscles' force on the rig over the force law of eq. 3.1 (the same ratio at every
    /// strain and pressure). 1 by default (the thesis's model);
    /// [`MechanicsConfig::identified_rig`] sets Table 5.2's step gain ([`crate::rig`]).
    pub muscle_force_ratio: f64,
}

impl MechanicsConfig {
    /// The rig as the thesis measured it: the muscles' force ratio of Table 5.2
    /// ([`crate::rig::MUSCLE_FORCE_RATIO`]) and the parallel stiffness that, with it, gives
    /// the stiffness identified at point 1 ([`crate::rig::parallel_stiffness_from_thesis`]).
    pub fn identified_rig() -> Self {
        let ratio = crate::rig::MUSCLE_FORCE_RATIO;
        let params = RobotParams::thesis();
        let k = crate::rig::parallel_stiffness_from_thesis(&params, ratio);
        MechanicsConfig {
            muscle_force_ratio: ratio,
            parallel_stiffness_nm_per_rad: k,
            parallel_breakaway_nm: crate::rig::parallel_breakaway_from_thesis(&params, k),
            ..Self::default()
        }
    }
}

impl Default for MechanicsConfig {
    fn default() -> Self {
        MechanicsConfig {
            parallel_stiffness_nm_per_rad: [0.0; 2],
            parallel_breakaway_nm: [f64::INFINITY; 2],
            muscle_force_ratio: 1.0,
            joint_damping_nm_s_per_rad: [0.05, 0.05],
            hard_stop_margin_rad: 0.06,
            hard_stop_stiffness_nm_per_rad: 3000.0,
            hard_stop_damping_nm_s_per_rad: 30.0,
        }
    }
}

/// Everything that defines a twin.
#[derive(Clone, Debug)]
pub struct TwinConfig {
    /// The plant's true parameters (the controller may believe others).
    pub params: RobotParams<f64>,
    pub effects: EffectSet,
    pub sensors: SensorConfig,
    pub pneumatics: PneumaticConfig,
    pub mechanics: MechanicsConfig,
    pub seed: u64,
    pub initial_alpha_rad: Vec2<f64>,
    /// Initial muscle pressures (channel order); `None`: vented (the converters' 0.1 bar floor).
    pub initial_pressure_bar: Option<[f64; 4]>,
    /// Longest integration step; `step(dt)` subdivides.
    pub max_substep_s: f64,
}

impl TwinConfig {
    pub fn new(params: RobotParams<f64>) -> Self {
        TwinConfig {
            params,
            effects: EffectSet::none(),
            sensors: SensorConfig::default(),
            pneumatics: PneumaticConfig::default(),
            mechanics: MechanicsConfig::default(),
            seed: 0,
            initial_alpha_rad: [0.0; 2],
            initial_pressure_bar: None,
            max_substep_s: 0.001,
        }
    }
    pub fn thesis() -> Self {
        Self::new(RobotParams::thesis())
    }
    /// [`TwinConfig::thesis`] with the rig's identified parallel stiffness
    /// ([`MechanicsConfig::identified_rig`]).
    pub fn identified_rig() -> Self {
        TwinConfig {
            mechanics: MechanicsConfig::identified_rig(),
            ..Self::thesis()
        }
    }
}
