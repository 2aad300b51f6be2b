//! Air in the muscles: the volume of a Festo DMSP-20 as it contracts, and the pressure
//! regulation of the I/P converter into that changing volume.
//!
//! # Why this is in the base chain
//! The thesis's muscle law F = A(ε)P + B(ε) is isobaric: it was fitted with the pressure held
//! by a regulator while the load changed slowly (§3.1). On the rig the air in a muscle is a
//! compressible mass fed through a converter whose flow is limited (Table 5.1; §5.1 names the
//! converter's internal structure and its 1.2 mm exhaust as the limit). When the handle moves,
//! the stretched muscle's volume shrinks and its pressure rises before the converter can bleed
//! the excess; the shortened one loses pressure. Both changes add to the restoring force, so
//! the dynamic stiffness and damping exceed the isobaric model's.
//!
//! # Model
//! Per channel, gauge pressure p (bar) and the converter's delivered flow q, expressed as the
//! pressure rate it would cause in the reference volume (bar/s):
//!
//! ```text
//! q̇ = ωn² (p_set − p) − 2 ζ ωn q          converter regulating the muscle pressure (Table 5.2)
//! ṗ = q · V_ref / V − n (p + p_atm) · V̇ / V   mass balance of a polytropic gas in volume V(ε)
//! ```
//!
//! At a blocked handle V̇ = 0 and V = V_ref near the neutral pose, so the step response from
//! command to pressure is exactly the second order of Table 5.2 (ωn = 23.04 rad/s, ζ = 0.42);
//! the moving handle adds the compressibility term.
//!
//! # Volume of a braided muscle
//! V(ε) = V0 (1 − ε)(1 − cos²θ0 (1 − ε)²) / sin²θ0 (cylinder of constant braid length,
//! Chou & Hannaford). V0 = π d²/4 · l0 with the DMSP-20's 20 mm inner diameter and l0 =
//! 0.400 m (Table 2.1). θ0 follows from the datasheet's maximum contraction (25 %): an ideal
//! braid stops contracting at 54.7°, so cos θ0 = cos 54.7° / (1 − 0.25), θ0 ≈ 39.6°. The
//! thesis rejects the braid model for *forces* (§3.1); only its geometry is used here.

/// Parameters of the air path. Sources in the field docs; every value is an estimate where
/// the thesis gives none.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PneumaticConfig {
    /// Polytropic index of the air in the muscle: 1 isothermal, 1.4 adiabatic. Cycles of
    /// 0.1–2 Hz in a 0.1–0.2 l rubber bladder exchange some heat: 1.2 (estimate).
    pub polytropic_index: f64,
    pub atmosphere_bar: f64,
    /// DMSP-20: 20 mm nominal inner diameter (Festo datasheet).
    pub muscle_inner_diameter_m: f64,
    /// DMSP: 25 % maximum contraction (Festo datasheet); fixes the braid angle.
    pub max_contraction: f64,
    /// Fittings and tube between converter and muscle (Table 5.1 finds tube length
    /// negligible for timing; its volume still dilutes the compressibility). 4 mm tube,
    /// ~0.5 m, plus fittings: 8 cm³ (estimate).
    pub dead_volume_m3: f64,
    /// The muscle pressure can never exceed the supply (nor go below atmosphere).
    pub supply_bar: f64,
}

impl Default for PneumaticConfig {
    fn default() -> Self {
        PneumaticConfig {
            polytropic_index: 1.2,
            atmosphere_bar: 1.013,
            muscle_inner_diameter_m: 0.020,
            max_contraction: 0.25,
            dead_volume_m3: 8.0e-6,
            supply_bar: 6.0,
        }
    }
}

/// Volume of one muscle (plus dead volume) as a function of its contraction ratio.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MuscleVolume {
    v0_m3: f64,
    cos2_theta0: f64,
    sin2_theta0: f64,
    dead_m3: f64,
}

impl MuscleVolume {
    pub fn new(cfg: &PneumaticConfig, rest_length_m: f64) -> Self {
        let d = cfg.muscle_inner_diameter_m;
        let v0 = std::f64::consts::PI * d * d / 4.0 * rest_length_m;
        // ideal braid locks at cos²θ = 1/3
        let cos_lock = (1.0f64 / 3.0).sqrt();
        let cos_theta0 = (cos_lock / (1.0 - cfg.max_contraction)).min(0.999);
        let cos2 = cos_theta0 * cos_theta0;
        MuscleVolume {
            v0_m3: v0,
            cos2_theta0: cos2,
            sin2_theta0: 1.0 - cos2,
            dead_m3: cfg.dead_volume_m3,
        }
    }

    /// (V, dV/dε) at contraction ratio ε.
    #[inline]
    pub fn at(&self, epsilon: f64) -> (f64, f64) {
        let s = 1.0 - epsilon;
        let k = self.v0_m3 / self.sin2_theta0;
        let v = k * s * (1.0 - self.cos2_theta0 * s * s) + self.dead_m3;
        let dv = k * (3.0 * self.cos2_theta0 * s * s - 1.0);
        (v, dv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn volume_grows_with_contraction_until_the_braid_locks() {
        let cfg = PneumaticConfig {
            dead_volume_m3: 0.0,
            ..PneumaticConfig::default()
        };
        let vol = MuscleVolume::new(&cfg, 0.4);
        let v0 = std::f64::consts::PI * 0.01 * 0.01 * 0.4;
        let (v_rest, _) = vol.at(0.0);
        assert!(
            (v_rest - v0).abs() < 1e-12,
            "rest volume is the 20 mm cylinder"
        );
        // numbers quoted in the docs at ε0 = 6.875 % (joint 1)
        let (v, dv) = vol.at(0.06875);
        assert!(
            (v / v0 - 1.11).abs() < 0.01 && (dv / v0 - 1.33).abs() < 0.02,
            "{} {}",
            v / v0,
            dv / v0
        );
        // the derivative is the slope, and it vanishes at the 25 % lock
        let h = 1e-6;
        let num = (vol.at(0.1 + h).0 - vol.at(0.1 - h).0) / (2.0 * h);
        assert!((num - vol.at(0.1).1).abs() < 1e-9 * v0.max(1.0));
        assert!(vol.at(0.25).1.abs() < 1e-3 * v0, "{}", vol.at(0.25).1);
    }
}
