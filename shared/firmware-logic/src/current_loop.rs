//! The 4–20 mA output law: loop current → PWM duty → timer compare value, with the clamp
//! to the loop's range.

pub const LOOP_MIN_MA: f32 = 4.0;
pub const LOOP_MAX_MA: f32 = 20.0;
/// The most the output stage may ever be driven to, whatever law or request: NAMUR NE43
/// reserves loop currents above 21 mA for signalling a failure, and 20.5 mA leaves room for
/// the stage's tolerance (reference 0.2 %, R_SET 0.1 %: 20.56 mA at worst).
pub const LOOP_CEILING_MA: f32 = 20.5;

/// Compare value (rounded) of a loop current on a stage that delivers `full_scale_ma` at
/// 100 % duty and 0 mA at 0 %, with `period_counts` counts per PWM period. A `const fn`, so
/// the safe state's compare values are constants in flash, not values read from RAM.
pub const fn nominal_counts(current_ma: f32, full_scale_ma: f32, period_counts: u16) -> u16 {
    let counts = current_ma / full_scale_ma * period_counts as f32 + 0.5;
    // `as` saturates: negative and NaN give 0 (0 mA, a vent as well)
    counts as u16
}

/// The largest compare value allowed on such a stage: [`LOOP_CEILING_MA`], rounded down,
/// and never beyond the period.
pub const fn ceiling_counts(full_scale_ma: f32, period_counts: u16) -> u16 {
    let counts = (LOOP_CEILING_MA / full_scale_ma * period_counts as f32) as u16;
    if counts < period_counts {
        counts
    } else {
        period_counts
    }
}

/// mA → duty law of one output stage: duty = `duty_per_ma` · I + `duty_offset` (fractions
/// of the PWM period).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelLaw {
    pub duty_per_ma: f32,
    pub duty_offset: f32,
}

impl ChannelLaw {
    /// The law of a stage that delivers `full_scale_ma` at 100 % duty and 0 mA at 0 %.
    pub fn proportional(full_scale_ma: f32) -> Self {
        Self {
            duty_per_ma: 1.0 / full_scale_ma,
            duty_offset: 0.0,
        }
    }

    pub fn duty(&self, current_ma: f32) -> f32 {
        self.duty_per_ma * current_ma + self.duty_offset
    }

    /// Usable: finite, increasing, and the whole 4–20 mA range inside 0–100 % duty.
    pub fn is_valid(&self) -> bool {
        self.duty_per_ma.is_finite()
            && self.duty_offset.is_finite()
            && self.duty_per_ma > 0.0
            && self.duty(LOOP_MIN_MA) >= 0.0
            && self.duty(LOOP_MAX_MA) <= 1.0
    }

    /// Timer compare value for a loop current already inside 4–20 mA; `full_duty_counts`
    /// is the compare value of 100 % duty (the timer period). Never beyond 0..=full.
    pub fn compare(&self, current_ma: f32, full_duty_counts: u16) -> u16 {
        let counts = self.duty(current_ma) * f32::from(full_duty_counts) + 0.5;
        // `as` saturates (negative → 0, NaN → 0 = 0 mA, also a vent); the min holds a law
        // asking for more than 100 % at the period
        (counts as u16).min(full_duty_counts)
    }
}

/// An XTR111 error flag must be seen this many consecutive periods before it is an open
/// loop: the flag may glitch while the output filter settles after a step. The firmware and
/// the emulator's board both use it.
pub const OUTPUT_ERROR_DEBOUNCE_PERIODS: u16 = 10;

/// A requested loop current made safe to apply: inside 4–20 mA, NaN → 4 mA (vent).
/// Returns the current and whether the request had to be changed.
pub fn clamp_loop_ma(request_ma: f32) -> (f32, bool) {
    if request_ma.is_nan() {
        return (LOOP_MIN_MA, true);
    }
    let ma = request_ma.clamp(LOOP_MIN_MA, LOOP_MAX_MA);
    (ma, ma != request_ma)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stage of docs/output-stage.md: 10 × 3.000 V / 1.24 kΩ at 100 % duty, 20 kHz PWM
    /// from 170 MHz (8500 counts).
    const FULL_SCALE_MA: f32 = 10.0 * 3.000 / 1.24;
    const PERIOD: u16 = 8_500;

    #[test]
    fn nominal_law_puts_4_and_20_ma_where_the_circuit_needs_them() {
        let law = ChannelLaw::proportional(FULL_SCALE_MA);
        assert!(law.is_valid());
        // 4 mA ↔ d = 0.16533 → 1405.3 counts; 20 mA ↔ d = 0.82667 → 7026.7 counts
        assert_eq!(law.compare(4.0, PERIOD), 1405);
        assert_eq!(law.compare(20.0, PERIOD), 7027);
        // one count is 2.85 µA
        let ma_per_count = FULL_SCALE_MA / f32::from(PERIOD);
        assert!((ma_per_count - 0.002846).abs() < 1e-6);
    }

    #[test]
    fn compare_grows_with_current_and_stays_within_the_period() {
        let law = ChannelLaw::proportional(FULL_SCALE_MA);
        let mut last = 0;
        for i in 0..=1600 {
            let c = law.compare(4.0 + i as f32 * 0.01, PERIOD);
            assert!(c >= last && c <= PERIOD);
            last = c;
        }
        // a law that asks for more than 100 % or less than 0 % is held at the ends
        let hot = ChannelLaw {
            duty_per_ma: 0.1,
            duty_offset: 0.0,
        };
        assert_eq!(hot.compare(20.0, PERIOD), PERIOD);
        let cold = ChannelLaw {
            duty_per_ma: 0.01,
            duty_offset: -0.5,
        };
        assert_eq!(cold.compare(4.0, PERIOD), 0);
        let broken = ChannelLaw {
            duty_per_ma: f32::NAN,
            duty_offset: 0.0,
        };
        assert_eq!(broken.compare(12.0, PERIOD), 0);
    }

    #[test]
    fn the_safe_and_the_ceiling_compares_are_constants_of_the_stage() {
        const SAFE: u16 = nominal_counts(LOOP_MIN_MA, FULL_SCALE_MA, PERIOD);
        const CEILING: u16 = ceiling_counts(FULL_SCALE_MA, PERIOD);
        // the same 4 mA compare as the law's
        assert_eq!(
            SAFE,
            ChannelLaw::proportional(FULL_SCALE_MA).compare(4.0, PERIOD)
        );
        assert_eq!(SAFE, 1405);
        // NAMUR NE43: the full scale (24.19 mA at 100 % duty) is cut to ≤ 20.5 mA
        let ceiling_ma = f32::from(CEILING) * FULL_SCALE_MA / f32::from(PERIOD);
        assert!(ceiling_ma <= LOOP_CEILING_MA && ceiling_ma > LOOP_CEILING_MA - 0.003);
        assert!(ceiling_ma * 1.003 < 21.0);
        // 20 mA stays reachable
        assert!(CEILING > nominal_counts(LOOP_MAX_MA, FULL_SCALE_MA, PERIOD));
        // a stage whose full scale is below the ceiling is held at the period
        assert_eq!(ceiling_counts(10.0, PERIOD), PERIOD);
        assert_eq!(nominal_counts(f32::NAN, FULL_SCALE_MA, PERIOD), 0);
    }

    #[test]
    fn requests_are_clamped_to_the_loop_range() {
        assert_eq!(clamp_loop_ma(12.0), (12.0, false));
        assert_eq!(clamp_loop_ma(4.0), (4.0, false));
        assert_eq!(clamp_loop_ma(20.0), (20.0, false));
        assert_eq!(clamp_loop_ma(3.9), (4.0, true));
        assert_eq!(clamp_loop_ma(-1.0), (4.0, true));
        assert_eq!(clamp_loop_ma(20.1), (20.0, true));
        assert_eq!(clamp_loop_ma(f32::INFINITY), (20.0, true));
        assert_eq!(clamp_loop_ma(f32::NEG_INFINITY), (4.0, true));
        assert_eq!(clamp_loop_ma(f32::NAN), (4.0, true));
    }

    #[test]
    fn invalid_laws_are_recognised() {
        let ok = ChannelLaw::proportional(FULL_SCALE_MA);
        assert!(ok.is_valid());
        for bad in [
            ChannelLaw {
                duty_per_ma: f32::NAN,
                ..ok
            },
            ChannelLaw {
                duty_offset: f32::INFINITY,
                ..ok
            },
            ChannelLaw {
                duty_per_ma: 0.0,
                ..ok
            },
            ChannelLaw {
                duty_per_ma: -0.04,
                ..ok
            },
            // 20 mA beyond 100 % duty (a stage with a full scale below 20 mA)
            ChannelLaw::proportional(19.0),
            // 4 mA below 0 % duty
            ChannelLaw {
                duty_offset: -0.2,
                ..ok
            },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }
}
