//! Every number that describes the robot, in one place, with the thesis values as
//! defaults. A user loads their own calibration by replacing fields (the host side
//! reads and writes this struct as TOML through the `serde` feature).
//!
//! Sources (thesis chapter/table numbers): geometry Table 2.1, ε0 eq. 2.8, muscle
//! polynomial Table 3.1 / eq. 3.1, anti-slack pressure §2.3, I/P law eq. 2.2, load-cell
//! law eq. 2.1, I/P dynamics Table 5.2, gain plane eq. 5.2.

use crate::real::Real;

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Coefficients of the experimental muscle model F(ε, P) = A(ε)·P + B(ε) (eq. 3.1),
/// highest power first. P is in pascal inside the polynomial, as fitted in the thesis.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct MuscleCoeffs<R> {
    /// a, b, c, d, e of A(ε) = aε⁴ + bε³ + cε² + dε + e, in N/Pa.
    pub pressure_n_per_pa: [R; 5],
    /// f, g, h, i, j, k of B(ε) = fε⁵ + gε⁴ + hε³ + iε² + jε + k, in N.
    pub passive_n: [R; 6],
}

/// Mass properties of one arm segment, used for the inertia matrix (eq. 4.14–4.17) and
/// by the digital twin. The thesis gives no masses; the defaults are estimates (see
/// [`RobotParams::thesis`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct SegmentMass<R> {
    pub mass_kg: R,
    /// Distance from the joint axis to the segment's centre of mass.
    pub com_distance_m: R,
    /// Rotational inertia about the centre of mass, vertical axis.
    pub inertia_com_kg_m2: R,
}

/// One joint: its segment, pulley, muscle pair and range.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct JointParams<R> {
    pub segment_length_m: R,
    pub pulley_radius_m: R,
    pub alpha_min_rad: R,
    pub alpha_max_rad: R,
    /// δl, the initial shortening of the pair at the neutral pose (Table 2.1).
    pub initial_shortening_m: R,
    /// l0, the unloaded muscle length.
    pub muscle_rest_length_m: R,
    /// Pressure that tensions both cables at the neutral pose (2.3 bar, §2.3); the force
    /// it gives at ε0 is the anti-slack force.
    pub pretension_pressure_bar: R,
    /// Output channel (0..=3) of the model's muscle 1 and muscle 2 of this joint.
    ///
    /// The model always numbers the pair the same way: muscle 1 lengthens when α grows
    /// (ε1 = ε0 − Rα/l0, eq. 2.9), muscle 2 shortens. On joint 1 the pulley is fixed and the
    /// segment turns around it, so the rig's labels are swapped (§2.3, last paragraph).
    /// That permutation lives here, and only here: the equations stay the thesis's, and the
    /// mapping to I/P channels is a calibration fact of the rig.
    pub channel_of_muscle: [u8; 2],
    pub segment: SegmentMass<R>,
}

impl<R: Real> JointParams<R> {
    /// ε0 = δl / (2 l0) (eq. 2.8).
    pub fn epsilon0(&self) -> R {
        self.initial_shortening_m / (R::from_f64(2.0) * self.muscle_rest_length_m)
    }
}

/// Intensity/pressure converter law P = gain·I + offset (eq. 2.2) and its ranges.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct IpConverter<R> {
    pub gain_bar_per_ma: R,
    pub offset_bar: R,
    pub current_min_ma: R,
    pub current_max_ma: R,
    /// The converter cannot regulate below this (0.1 bar, §2.1).
    pub output_min_bar: R,
    pub output_max_bar: R,
    /// Second-order dynamics from command to pressure (Table 5.2: the thesis identified
    /// them from force reference to force; used by the twin as the converter's default).
    pub natural_freq_rad_s: R,
    pub damping_ratio: R,
}

/// Bi-axial load cell, volts → newtons in the sensor frame (eq. 2.1), per-channel
/// gain and offset so the rig's calibration can replace the thesis's.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct LoadCell<R> {
    /// Sensor X (along the sensor) and Z (its radius) gains.
    pub gain_n_per_v: [R; 2],
    pub offset_v: [R; 2],
    /// Rated load, 20 kg per axis (§2.1).
    pub rated_force_n: R,
}

/// Gain plane G(α1, α2) = p1·α1 + p2·α2 + p3 per Cartesian axis (eq. 5.2), α in rad.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct GainPlane<R> {
    /// [p1 per rad, p2 per rad, p3] for the X force, then for the Y force.
    pub coeffs: [[R; 3]; 2],
    /// Below this gain the correction 1/G is not trusted: G is clamped up to it.
    pub min_gain: R,
}

#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct PressureLimits<R> {
    pub min_bar: R,
    pub max_bar: R,
}

/// The whole robot. `RobotParams::thesis()` (also `Default`) holds the thesis values.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct RobotParams<R> {
    pub joints: [JointParams<R>; 2],
    pub muscle: MuscleCoeffs<R>,
    pub pressure: PressureLimits<R>,
    pub ip: IpConverter<R>,
    pub load_cell: LoadCell<R>,
    pub gain_plane: GainPlane<R>,
}

impl<R: Real> Default for RobotParams<R> {
    fn default() -> Self {
        Self::thesis()
    }
}

impl<R: Real> RobotParams<R> {
    /// The values printed in the thesis.
    ///
    /// Segment masses are not in the thesis. The defaults are estimates for the hardware
    /// it describes: segment 1 is a 0.70 m aluminium extrusion carrying the four muscles and
    /// the joint-2 pulley (2.5 kg, centre of mass at 0.35 m); segment 2 is a 0.45 m
    /// extrusion with the load cell, handle and carrier ball at its tip (1.2 kg, centre of
    /// mass at 0.30 m). With them the Cartesian mass at point 1 is of the order the thesis
    /// identified (M_xx ≈ 0.9–1.9 kg, §4.3–4.4).
    pub fn thesis() -> Self {
        let f = R::from_f64;
        let deg = |d: f64| f(d.to_radians());
        let muscle = MuscleCoeffs {
            pressure_n_per_pa: [f(-1.235), f(0.8748), f(-0.1696), f(0.003), f(0.0025)],
            passive_n: [
                f(-6394597.5996),
                f(4353194.3094),
                f(-1296730.9029),
                f(188507.2445),
                f(-12713.2922),
                f(-58.1436),
            ],
        };
        let segment = |mass_kg: f64, length_m: f64, com_m: f64| SegmentMass {
            mass_kg: f(mass_kg),
            com_distance_m: f(com_m),
            // slender rod about its centre
            inertia_com_kg_m2: f(mass_kg * length_m * length_m / 12.0),
        };
        let joint1 = JointParams {
            segment_length_m: f(0.700),
            pulley_radius_m: f(0.070),
            alpha_min_rad: deg(-22.5),
            alpha_max_rad: deg(22.5),
            initial_shortening_m: f(0.055),
            muscle_rest_length_m: f(0.400),
            pretension_pressure_bar: f(2.3),
            channel_of_muscle: [1, 0],
            segment: segment(2.5, 0.700, 0.35),
        };
        let joint2 = JointParams {
            segment_length_m: f(0.450),
            pulley_radius_m: f(0.045),
            alpha_min_rad: deg(-32.5),
            alpha_max_rad: deg(32.5),
            initial_shortening_m: f(0.051),
            muscle_rest_length_m: f(0.400),
            pretension_pressure_bar: f(2.3),
            channel_of_muscle: [2, 3],
            segment: segment(1.2, 0.450, 0.30),
        };
        RobotParams {
            joints: [joint1, joint2],
            muscle,
            pressure: PressureLimits {
                min_bar: f(0.0),
                max_bar: f(5.0),
            },
            ip: IpConverter {
                // eq. 2.2 is P[bar] = 326.67·I[A] − 1.63, i.e. 0.32667 bar/mA.
                gain_bar_per_ma: f(0.32667),
                offset_bar: f(-1.63),
                current_min_ma: f(4.0),
                current_max_ma: f(20.0),
                output_min_bar: f(0.1),
                output_max_bar: f(5.0),
                natural_freq_rad_s: f(23.04),
                damping_ratio: f(0.42),
            },
            load_cell: LoadCell {
                gain_n_per_v: [f(1.0 / 0.09), f(1.0 / 0.06)],
                offset_v: [f(0.0), f(0.0)],
                rated_force_n: f(20.0 * 9.81),
            },
            gain_plane: GainPlane {
                // The thesis shows the fitted planes only as figures (Fig. 5.7); the default
                // is the flat plane at the averaged gain of Table 5.2.
                coeffs: [[f(0.0), f(0.0), f(0.57)], [f(0.0), f(0.0), f(0.57)]],
                min_gain: f(0.2),
            },
        }
    }

    /// The same parameters in another scalar type (e.g. the f64 host copy of the f32
    /// firmware parameters).
    pub fn cast<S: Real>(&self) -> RobotParams<S> {
        let c = |x: R| S::from_f64(x.to_f64());
        let seg = |s: &SegmentMass<R>| SegmentMass {
            mass_kg: c(s.mass_kg),
            com_distance_m: c(s.com_distance_m),
            inertia_com_kg_m2: c(s.inertia_com_kg_m2),
        };
        let joint = |j: &JointParams<R>| JointParams {
            segment_length_m: c(j.segment_length_m),
            pulley_radius_m: c(j.pulley_radius_m),
            alpha_min_rad: c(j.alpha_min_rad),
            alpha_max_rad: c(j.alpha_max_rad),
            initial_shortening_m: c(j.initial_shortening_m),
            muscle_rest_length_m: c(j.muscle_rest_length_m),
            pretension_pressure_bar: c(j.pretension_pressure_bar),
            channel_of_muscle: j.channel_of_muscle,
            segment: seg(&j.segment),
        };
        RobotParams {
            joints: [joint(&self.joints[0]), joint(&self.joints[1])],
            muscle: MuscleCoeffs {
                pressure_n_per_pa: self.muscle.pressure_n_per_pa.map(c),
                passive_n: self.muscle.passive_n.map(c),
            },
            pressure: PressureLimits {
                min_bar: c(self.pressure.min_bar),
                max_bar: c(self.pressure.max_bar),
            },
            ip: IpConverter {
                gain_bar_per_ma: c(self.ip.gain_bar_per_ma),
                offset_bar: c(self.ip.offset_bar),
                current_min_ma: c(self.ip.current_min_ma),
                current_max_ma: c(self.ip.current_max_ma),
                output_min_bar: c(self.ip.output_min_bar),
                output_max_bar: c(self.ip.output_max_bar),
                natural_freq_rad_s: c(self.ip.natural_freq_rad_s),
                damping_ratio: c(self.ip.damping_ratio),
            },
            load_cell: LoadCell {
                gain_n_per_v: self.load_cell.gain_n_per_v.map(c),
                offset_v: self.load_cell.offset_v.map(c),
                rated_force_n: c(self.load_cell.rated_force_n),
            },
            gain_plane: GainPlane {
                coeffs: self.gain_plane.coeffs.map(|row| row.map(c)),
                min_gain: c(self.gain_plane.min_gain),
            },
        }
    }

    /// Checks a user-supplied parameter set for values the model cannot work with.
    pub fn validate(&self) -> Result<(), ParamError> {
        for j in &self.joints {
            let positive = [
                j.segment_length_m,
                j.pulley_radius_m,
                j.muscle_rest_length_m,
                j.initial_shortening_m,
                j.segment.mass_kg,
            ];
            if positive.iter().any(|v| !(v.is_finite() && *v > R::ZERO)) {
                return Err(ParamError::NonPositiveGeometry);
            }
            if !(j.alpha_min_rad < j.alpha_max_rad) {
                return Err(ParamError::EmptyRange);
            }
            if j.channel_of_muscle[0] > 3
                || j.channel_of_muscle[1] > 3
                || j.channel_of_muscle[0] == j.channel_of_muscle[1]
            {
                return Err(ParamError::BadChannelMap);
            }
        }
        let mut used = [false; 4];
        for j in &self.joints {
            for &c in &j.channel_of_muscle {
                if used[c as usize] {
                    return Err(ParamError::BadChannelMap);
                }
                used[c as usize] = true;
            }
        }
        if !(self.pressure.min_bar >= R::ZERO && self.pressure.min_bar < self.pressure.max_bar) {
            return Err(ParamError::BadPressureLimits);
        }
        if !(self.ip.gain_bar_per_ma > R::ZERO && self.ip.current_min_ma < self.ip.current_max_ma) {
            return Err(ParamError::BadIpLaw);
        }
        if !(self.gain_plane.min_gain > R::ZERO) {
            return Err(ParamError::BadGainPlane);
        }
        Ok(())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamError {
    NonPositiveGeometry,
    EmptyRange,
    BadChannelMap,
    BadPressureLimits,
    BadIpLaw,
    BadGainPlane,
}
