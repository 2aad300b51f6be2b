//! VDDA from the internal reference: the STM32G474's VREFINT (≈ 1.21 V) converted by the
//! ADC against VDDA, and its factory calibration (`VREFINT_CAL`, the 12-bit code at
//! VDDA = 3.0 V, 30 °C, stored at 0x1FFF_75AA) give VDDA = 3.0 V · CAL / code
//! (RM0440 §21.4.34).
//!
//! Why it matters here: the load-cell front end (docs/output-stage.md) is ratiometric in its
//! offset (the 1.652 V mid-point is a divider from VDDA) but not in its gain, and the ADC's
//! full scale is VDDA. A reading is therefore proportional to VDDA: 3.2 V instead of 3.3 V
//! is a 3 % force error ([`crate::adc_scale::AdcFrontEnd::input_volts_at`]).

/// VDDA at which `VREFINT_CAL` was measured.
pub const VREFINT_CAL_VDDA_V: f32 = 3.0;
/// The design's VDDA (the NUCLEO's 3.3 V regulator), used until a measurement exists.
pub const VDDA_NOMINAL_V: f32 = 3.3;
/// Outside 3.3 V ± 5 % the supply is not what the board's regulator gives (±2 %): a fault
/// (`BOARD_CHECK_VDDA`), and the nominal value is used for the scaling meanwhile.
pub const VDDA_MIN_V: f32 = 3.135;
pub const VDDA_MAX_V: f32 = 3.465;
/// The datasheet's VREFINT is 1.182–1.232 V: at 3.0 V that is codes 1613–1682. A calibration
/// word outside a slightly wider window is not one (erased or misread): no measurement.
const CAL_MIN: u16 = 1_550;
const CAL_MAX: u16 = 1_750;

/// VDDA from the calibration word and a 12-bit VREFINT conversion; `None` when either
/// cannot be right (calibration outside its window, a code of 0).
pub fn vdda_v(vrefint_cal: u16, vrefint_counts: u16) -> Option<f32> {
    if !(CAL_MIN..=CAL_MAX).contains(&vrefint_cal) || vrefint_counts == 0 {
        return None;
    }
    Some(VREFINT_CAL_VDDA_V * f32::from(vrefint_cal) / f32::from(vrefint_counts))
}

/// The measured VDDA is one the scaling may use.
pub fn in_range(vdda_v: f32) -> bool {
    (VDDA_MIN_V..=VDDA_MAX_V).contains(&vdda_v)
}

/// What the scaling uses: the measurement when there is one in range, else nominal.
pub fn for_scaling(measured: Option<f32>) -> f32 {
    match measured {
        Some(v) if in_range(v) => v,
        _ => VDDA_NOMINAL_V,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The code VREFINT (`vref_v`) gives at `vdda`.
    fn code(vref_v: f32, vdda: f32) -> u16 {
        (vref_v / vdda * 4095.0).round() as u16
    }

    #[test]
    fn vdda_comes_back_from_the_calibration_within_a_code() {
        let cal = code(1.212, 3.0);
        for vdda in [3.0f32, 3.135, 3.3, 3.465, 3.6] {
            let v = vdda_v(cal, code(1.212, vdda)).unwrap();
            // one code at ≈ 1500 is 0.07 %
            assert!((v - vdda).abs() < 0.003, "{vdda} → {v}");
        }
    }

    #[test]
    fn a_sagging_supply_is_out_of_range_and_not_used() {
        let cal = code(1.212, 3.0);
        let sag = vdda_v(cal, code(1.212, 3.0)).unwrap();
        assert!(!in_range(sag));
        assert_eq!(for_scaling(Some(sag)), VDDA_NOMINAL_V);
        let ok = vdda_v(cal, code(1.212, 3.28)).unwrap();
        assert!(in_range(ok));
        assert_eq!(for_scaling(Some(ok)), ok);
        assert_eq!(for_scaling(None), VDDA_NOMINAL_V);
        assert!(!in_range(f32::NAN));
    }

    #[test]
    fn a_calibration_word_that_cannot_be_one_gives_no_measurement() {
        assert_eq!(vdda_v(0xFFFF, 1500), None);
        assert_eq!(vdda_v(0, 1500), None);
        assert_eq!(vdda_v(1650, 0), None);
    }
}
