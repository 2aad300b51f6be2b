//! The home judged against the pressures' equilibrium.
//!
//! `Home` takes the present encoder counts as the zero of the joint angles. What the device
//! knows when it is asked: the counts (incremental, from an arbitrary value at power-up),
//! the commanded pressures (the vent: `Home` is refused while armed) and the load cell. A
//! vented arm has no equilibrium (its slack cables pull nothing: the vented twin drifts to
//! its range ends), so no pose can be refused at that moment; a re-home is bounded by the
//! zero in use ([`crate::supervisor::Controller`]'s caller checks it). A first home is
//! judged where the muscles make the pose known: at the first rest after it, armed, with
//! the cables taut.
//!
//! At rest (the joint still within [`STILL_BAND_RAD`] and every commanded pressure steady
//! within [`PRESSURE_BAND_BAR`] for [`HOME_SETTLE_S`]), with a free handle (the load cell's
//! torque at the joint below [`HOME_FREE_TORQUE_NM`]) and both of the joint's cables taut
//! in the model ([`HOME_TAUT_FORCE_N`]), the arm rests where the muscles' torque vanishes.
//! The model's equilibrium, where `τ(α, P) = Jᵀ F` (Newton's method from the measured
//! angle), against the measured angle says how far the two lie apart. A home wrong by θ
//! puts the measured angle θ from where the arm rests, so this distance is ≈ θ; on a right
//! home it is the model's error in angle: across the joint, pressures and open-loop force
//! modes, from two starting poses, the identified rig's twin rests up to 0.17 rad from the
//! model's equilibrium (joint 2 at 40 N·m/rad), 0.22 rad with muscle hysteresis, a
//! pose-dependent force gain and carrier friction, the thesis's twin within 0.011 rad
//! (host-libs/twin/tests/home_check.rs, `--nocapture`). Beyond [`HOME_OFFSET_MAX_RAD`]
//! (≈ 14°) the home is refused: the controller latches `STATIC_IMBALANCE` (a joint at
//! rest that its muscles' torque does not balance; the outputs vent) and the device
//! forgets the home, so `Arm` answers `NotHomed` until the arm is homed again at the
//! neutral pose. A zero off by 0.25–0.35 rad may pass at a rest where the model's error
//! adds to it the other way; the static-balance check still judges every later rest.
//!
//! Each joint is judged once; a joint within [`STOP_BAND_RAD`] of a range end (a stop holds
//! a torque no sensor sees), with slack cables or a held handle waits for a rest that can
//! be judged. The static-balance check ([`crate::plausibility`]) keeps watching after.

use pam_model::{Real, RobotModel, Vec2};

use crate::plausibility::{PRESSURE_BAND_BAR, STILL_BAND_RAD, STOP_BAND_RAD};

/// How long the joint must rest, with steady commanded pressures, before the home is
/// judged, s: the converters settle in 0.41 s (Table 5.2), a swing of the lightly damped arm
/// (≈ 2 Hz) has died down well within it.
pub const HOME_SETTLE_S: f32 = 1.5;
/// Largest distance of the measured angle from the model's equilibrium a right home shows,
/// rad (≈ 14°: the model's error on the twins is up to 0.22 rad, see the module comment).
pub const HOME_OFFSET_MAX_RAD: f32 = 0.25;
/// "A free handle": the load cell's torque at the joint below this, N·m (≈ 4 N at joint 1's
/// 0.7 m lever, the load cell's drift between tares plus a light touch).
pub const HOME_FREE_TORQUE_NM: f32 = 3.0;
/// "Taut": both of the joint's muscles pull at least this in the model at the measured
/// angle, N (below, a cable may be slack, and where the model's equilibrium lies is beyond
/// what it knows of the rig).
pub const HOME_TAUT_FORCE_N: f32 = 20.0;
/// The model's joint stiffness below which the equilibrium is too flat to judge, N·m/rad.
pub const HOME_MIN_STIFFNESS_NM_PER_RAD: f32 = 20.0;
/// Newton steps toward the model's equilibrium (a smooth, monotone torque: a few suffice).
const HOME_NEWTON_STEPS: usize = 6;

/// The verdict of one period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HomeVerdict {
    /// No home to judge, or not yet at a rest that can judge it.
    Waiting,
    /// Both joints rest within [`HOME_OFFSET_MAX_RAD`] of the model's equilibrium.
    Confirmed,
    /// A joint rests farther: the home is wrong.
    Refused,
}

/// The judgement of the last home. One per controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomeCheck {
    pending: bool,
    refused: bool,
    started: bool,
    anchor_alpha_rad: Vec2<f32>,
    anchor_pressure_bar: [f32; 4],
    rest_periods: [u32; 2],
    confirmed: [bool; 2],
}

impl Default for HomeCheck {
    fn default() -> Self {
        Self::new()
    }
}

impl HomeCheck {
    /// Nothing to judge (not homed).
    pub const fn new() -> Self {
        HomeCheck {
            pending: false,
            refused: false,
            started: false,
            anchor_alpha_rad: [0.0; 2],
            anchor_pressure_bar: [0.0; 4],
            rest_periods: [0; 2],
            confirmed: [false; 2],
        }
    }

    /// A new home: judge it at the first rest that can.
    pub fn expect(&mut self) {
        *self = Self::new();
        self.pending = true;
    }

    /// Whether a home waits for its judgement.
    pub fn pending(&self) -> bool {
        self.pending
    }

    /// Whether the last home was refused.
    pub fn refused(&self) -> bool {
        self.refused
    }

    /// Start the rest window again (disarmed, tensioning, idle, a non-finite sample).
    pub fn restart(&mut self) {
        self.started = false;
    }

    /// One armed period with the muscles tensioned and finite sensors: the measured angle,
    /// the commanded channel pressures, (τ_model(α, P), Jᵀ F) per joint (the step's; the
    /// judgement itself needs only the held torque).
    pub fn update(
        &mut self,
        model: &RobotModel<f32>,
        period_s: f32,
        alpha_rad: Vec2<f32>,
        pressure_bar: [f32; 4],
        (_, held_nm): (Vec2<f32>, Vec2<f32>),
    ) -> HomeVerdict {
        if !self.pending {
            return HomeVerdict::Waiting;
        }
        let steered = !self.started
            || (0..4)
                .any(|c| (pressure_bar[c] - self.anchor_pressure_bar[c]).abs() > PRESSURE_BAND_BAR);
        if steered {
            self.anchor_alpha_rad = alpha_rad;
            self.anchor_pressure_bar = pressure_bar;
            self.rest_periods = [0; 2];
            self.started = true;
            return HomeVerdict::Waiting;
        }
        let settle_periods = (HOME_SETTLE_S / period_s + 0.5) as u32;
        let joint_pressure_bar = model.joint_pressures_bar(pressure_bar);
        for j in 0..2 {
            if self.confirmed[j] {
                continue;
            }
            if (alpha_rad[j] - self.anchor_alpha_rad[j]).abs() > STILL_BAND_RAD {
                self.anchor_alpha_rad[j] = alpha_rad[j];
                self.rest_periods[j] = 0;
                continue;
            }
            self.rest_periods[j] = self.rest_periods[j].saturating_add(1);
            if self.rest_periods[j] < settle_periods {
                continue;
            }
            // a rest that cannot judge the home starts the window again
            self.rest_periods[j] = 0;
            match offset_from_equilibrium_rad(
                model,
                j,
                alpha_rad[j],
                joint_pressure_bar[j],
                held_nm[j],
            ) {
                Some(offset) if offset.abs() > HOME_OFFSET_MAX_RAD => {
                    self.pending = false;
                    self.refused = true;
                    return HomeVerdict::Refused;
                }
                Some(_) => self.confirmed[j] = true,
                None => {}
            }
        }
        if self.confirmed == [true; 2] {
            self.pending = false;
            return HomeVerdict::Confirmed;
        }
        HomeVerdict::Waiting
    }
}

/// How far joint `j`'s model equilibrium for its muscles' pressures and the torque the
/// handle holds lies from the measured angle, rad, or `None` where the rest cannot tell:
/// near a range end, slack cables, a flat equilibrium, a held handle. The equilibrium is
/// found by Newton's method from the measured angle (the joint stiffens away from the
/// neutral pose, so one step's `(τ − Jᵀ F) / K` alone falls short of a large offset).
pub fn offset_from_equilibrium_rad(
    model: &RobotModel<f32>,
    j: usize,
    alpha_rad: f32,
    pressure_bar: [f32; 2],
    held_nm: f32,
) -> Option<f32> {
    let jp = &model.params.joints[j];
    let in_range = alpha_rad >= jp.alpha_min_rad + STOP_BAND_RAD
        && alpha_rad <= jp.alpha_max_rad - STOP_BAND_RAD;
    if !in_range || !(held_nm.abs() <= HOME_FREE_TORQUE_NM) {
        return None;
    }
    let pose = model.pose(j, alpha_rad);
    let taut = pose
        .forces_n(pressure_bar)
        .iter()
        .all(|&f| f >= HOME_TAUT_FORCE_N);
    // NaN compares false: an undefined model never judges
    if !(taut && pose.stiffness_nm_per_rad(pressure_bar) >= HOME_MIN_STIFFNESS_NM_PER_RAD) {
        return None;
    }
    // τ falls with α (a restoring spring): each step moves to where the tangent meets Jᵀ F;
    // far outside the range the model says nothing more, so the search stays within it
    let (lo, hi) = (2.0 * jp.alpha_min_rad, 2.0 * jp.alpha_max_rad);
    let mut a = alpha_rad;
    for _ in 0..HOME_NEWTON_STEPS {
        let pose = model.pose(j, a);
        let k = pose.stiffness_nm_per_rad(pressure_bar);
        if !(k >= HOME_MIN_STIFFNESS_NM_PER_RAD) {
            break;
        }
        a = (a + (pose.torque_nm(pressure_bar) - held_nm) / k).clamp_to(lo, hi);
    }
    let offset = a - alpha_rad;
    offset.is_finite().then_some(offset)
}
