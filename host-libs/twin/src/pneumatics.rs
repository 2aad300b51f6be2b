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
//!
//! # Flow limits per channel
//! [`ConverterRates`] limits each converter's flow on its own channel (an effect, off in the
//! base chain): filling and exhausting at different rates, and each converter its own, so
//! that the vent after a fault takes the seconds Table 5.1 measured, not the second order's
//! tenths.

use crate::effects::{Ctx, Effect, EffectError, EffectId, ParamInfo};

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

/// Flow limits of the four I/P converters, each its own: channel i's pressure rises at most
/// `span_bar / fill_s[i]` and falls at most `span_bar / exhaust_s[i]` (bar/s, in the
/// reference volume).
///
/// Table 5.1 measured one converter on one muscle: full inflation 2.412 s, full deflation
/// 1.608 s (0 ↔ 5 bar); §5.1 names the converter's internal structure (filling) and its
/// 1.2 mm exhaust (venting) as the limits. The thesis gives no spread between converters.
/// [`ConverterRates::spread`] spans the exhaust times from the measured 1.608 s to 2.412 s
/// (a converter whose exhaust is as slow as the measured filling) and fills each channel
/// 2.412 / 1.608 = 1.5 times slower than it exhausts: after a fault every muscle must vent,
/// and the slowest exhaust is the one that lets the arm move longest.
#[derive(Clone, Debug, PartialEq)]
pub struct ConverterRates {
    /// Time to fill each channel over the span (s).
    pub fill_s: [f64; 4],
    /// Time to exhaust each channel over the span (s).
    pub exhaust_s: [f64; 4],
    /// Pressure span of those times (bar).
    pub span_bar: f64,
}

/// Table 5.1: full inflation through the converter, 0 → 5 bar (s).
pub const TABLE_5_1_FILL_S: f64 = 2.412;
/// Table 5.1: full deflation through the converter, 5 → 0 bar (s).
pub const TABLE_5_1_EXHAUST_S: f64 = 1.608;
/// Table 5.1's pressure span (bar).
pub const TABLE_5_1_SPAN_BAR: f64 = 5.0;

impl ConverterRates {
    /// Every channel as the converter of Table 5.1.
    pub fn table_5_1() -> Self {
        ConverterRates {
            fill_s: [TABLE_5_1_FILL_S; 4],
            exhaust_s: [TABLE_5_1_EXHAUST_S; 4],
            span_bar: TABLE_5_1_SPAN_BAR,
        }
    }

    /// Exhaust times 1.608, 1.876, 2.144, 2.412 s on channels 1–4, each filling 1.5 times
    /// slower than it exhausts.
    pub fn spread() -> Self {
        let exhaust_s: [f64; 4] = std::array::from_fn(|i| {
            TABLE_5_1_EXHAUST_S + (TABLE_5_1_FILL_S - TABLE_5_1_EXHAUST_S) * i as f64 / 3.0
        });
        ConverterRates {
            fill_s: exhaust_s.map(|e| e * TABLE_5_1_FILL_S / TABLE_5_1_EXHAUST_S),
            exhaust_s,
            span_bar: TABLE_5_1_SPAN_BAR,
        }
    }

    /// Clamps each converter's flow (bar/s) to its channel's limits.
    pub fn limit(&self, flow_bar_s: &mut [f64; 4]) {
        for (i, q) in flow_bar_s.iter_mut().enumerate() {
            let up = self.span_bar / self.fill_s[i].max(1e-6);
            let down = self.span_bar / self.exhaust_s[i].max(1e-6);
            *q = q.clamp(-down, up);
        }
    }
}

const FILL_NAMES: [&str; 4] = ["fill_1_s", "fill_2_s", "fill_3_s", "fill_4_s"];
const EXHAUST_NAMES: [&str; 4] = ["exhaust_1_s", "exhaust_2_s", "exhaust_3_s", "exhaust_4_s"];

impl Effect for ConverterRates {
    fn id(&self) -> EffectId {
        EffectId::ConverterRates
    }
    fn summary(&self) -> &'static str {
        "Per-channel flow limits of the I/P converters, filling slower than exhausting (Table 5.1), with a spread between channels."
    }
    fn params(&self) -> Vec<ParamInfo> {
        let fill = (0..4).map(|i| ParamInfo {
            name: FILL_NAMES[i],
            value: self.fill_s[i],
            unit: "s",
            doc: "time to fill the channel over the span",
        });
        let exhaust = (0..4).map(|i| ParamInfo {
            name: EXHAUST_NAMES[i],
            value: self.exhaust_s[i],
            unit: "s",
            doc: "time to exhaust the channel over the span",
        });
        let span = std::iter::once(ParamInfo {
            name: "span_bar",
            value: self.span_bar,
            unit: "bar",
            doc: "pressure span of those times",
        });
        fill.chain(exhaust).chain(span).collect()
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), EffectError> {
        if let Some(i) = FILL_NAMES.iter().position(|n| *n == name) {
            self.fill_s[i] = value;
        } else if let Some(i) = EXHAUST_NAMES.iter().position(|n| *n == name) {
            self.exhaust_s[i] = value;
        } else if name == "span_bar" {
            self.span_bar = value;
        } else {
            return Err(EffectError::unknown_param(
                self.id().name(),
                name,
                &self.params(),
            ));
        }
        Ok(())
    }
    fn boxed_clone(&self) -> Box<dyn Effect> {
        Box::new(self.clone())
    }
    fn regulator_flow(&mut self, _ctx: &Ctx, flow_bar_s: &mut [f64; 4]) {
        self.limit(flow_bar_s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::effects::EffectSet;
    use crate::plant::{HandleCondition, Twin, TwinConfig};

    /// Per channel, the time from the start until the pressure first crosses `level_bar`
    /// (downward when `falling`), with the handle blocked and all four currents held.
    fn crossing_times(
        rates: ConverterRates,
        start_bar: Option<[f64; 4]>,
        current_ma: f64,
        level_bar: f64,
        falling: bool,
    ) -> [f64; 4] {
        let mut cfg = TwinConfig::thesis();
        cfg.effects = EffectSet::none().with(Box::new(rates)).expect("one effect");
        cfg.initial_pressure_bar = start_bar;
        let mut twin = Twin::new(cfg);
        let mut at = [f64::NAN; 4];
        let dt = 0.001;
        for k in 1..=6000 {
            twin.step(dt, [current_ma; 4], &HandleCondition::Blocked);
            for (i, p) in twin.state().pressure_bar.iter().enumerate() {
                let crossed = if falling {
                    *p < level_bar
                } else {
                    *p > level_bar
                };
                if crossed && at[i].is_nan() {
                    at[i] = k as f64 * dt;
                }
            }
        }
        at
    }

    #[test]
    fn spread_exhausts_in_1_6_to_2_4_s_and_fills_one_and_a_half_times_slower() {
        let r = ConverterRates::spread();
        assert_eq!(r.exhaust_s[0], 1.608);
        assert!((r.exhaust_s[3] - 2.412).abs() < 1e-12);
        for i in 0..4 {
            assert!((r.fill_s[i] / r.exhaust_s[i] - 1.5).abs() < 1e-3);
        }
        assert!(r.exhaust_s.windows(2).all(|w| w[0] < w[1]));
        let t = ConverterRates::table_5_1();
        assert_eq!((t.fill_s[2], t.exhaust_s[2]), (2.412, 1.608));
    }

    #[test]
    fn a_vent_from_5_bar_takes_each_channel_its_exhaust_time() {
        let r = ConverterRates::spread();
        // 4 mA: the converter's floor; 5 bar down to 0.5 bar is 4.5 of the 5 bar span
        let t = crossing_times(r.clone(), Some([5.0; 4]), 4.0, 0.5, true);
        for i in 0..4 {
            let rate_limited = 4.5 / 5.0 * r.exhaust_s[i];
            assert!(
                t[i] >= rate_limited && t[i] < rate_limited + 0.25,
                "channel {}: {:.3} s, exhaust limit {:.3} s",
                i + 1,
                t[i],
                rate_limited
            );
        }
        assert!(t.windows(2).all(|w| w[0] < w[1]), "{t:?}");
    }

    #[test]
    fn a_fill_to_4_5_bar_takes_each_channel_its_fill_time_slower_than_its_exhaust() {
        let r = ConverterRates::spread();
        // 20 mA asks for the converter's 5 bar full scale; from the vented floor
        let t = crossing_times(r.clone(), None, 20.0, 4.5, false);
        for i in 0..4 {
            let rate_limited = 4.4 / 5.0 * r.fill_s[i];
            assert!(
                t[i] >= rate_limited && t[i] < rate_limited + 0.3,
                "channel {}: {:.3} s, fill limit {:.3} s",
                i + 1,
                t[i],
                rate_limited
            );
        }
        let v = crossing_times(r, Some([5.0; 4]), 4.0, 0.6, true);
        assert!((0..4).all(|i| t[i] > v[i]), "fill {t:?} exhaust {v:?}");
    }

    #[test]
    fn without_the_limits_the_vent_is_the_converter_second_order_only() {
        let fast = ConverterRates {
            fill_s: [1e-3; 4],
            exhaust_s: [1e-3; 4],
            span_bar: 5.0,
        };
        let t = crossing_times(fast, Some([5.0; 4]), 4.0, 0.5, true);
        assert!(t.iter().all(|&t| t < 0.3), "{t:?}");
    }

    #[test]
    fn parameters_set_by_name_and_unknown_names_refused() {
        let mut r = ConverterRates::spread();
        r.set_param("exhaust_3_s", 3.0).expect("known");
        r.set_param("fill_1_s", 4.0).expect("known");
        assert_eq!((r.exhaust_s[2], r.fill_s[0]), (3.0, 4.0));
        assert!(r.set_param("exhaust_5_s", 1.0).is_err());
    }

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
