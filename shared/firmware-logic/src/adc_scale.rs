//! ADC counts → volts at the input of an analogue front end V_adc = mid + gain · V_in.

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdcFrontEnd {
    /// ADC reference (full scale), V.
    pub vref_v: f32,
    /// Largest code (4095 for 12 bits).
    pub full_scale_counts: u16,
    /// V_adc per V_in.
    pub gain: f32,
    /// V_adc at V_in = 0.
    pub mid_v: f32,
    /// Codes this close to either end mean the front end or the source is saturated.
    pub rail_margin_counts: u16,
}

impl AdcFrontEnd {
    /// The volts at the front end's input for a code (codes beyond full scale are masked
    /// by the caller; here they are simply scaled).
    pub fn input_volts(&self, counts: u16) -> f32 {
        let adc_v = f32::from(counts) * (self.vref_v / f32::from(self.full_scale_counts));
        (adc_v - self.mid_v) / self.gain
    }

    /// The same with the ADC's full scale at `vdda_v` rather than `vref_v`. The front end's
    /// mid-point is a divider from VDDA (ratiometric), its gain is not: the whole reading
    /// scales with VDDA (`crate::vdda`).
    pub fn input_volts_at(&self, counts: u16, vdda_v: f32) -> f32 {
        self.input_volts(counts) * (vdda_v / self.vref_v)
    }

    pub fn saturated(&self, counts: u16) -> bool {
        counts <= self.rail_margin_counts
            || counts
                >= self
                    .full_scale_counts
                    .saturating_sub(self.rail_margin_counts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The load-cell front end of docs/output-stage.md (100 k / 30.1 k / 43.2 k into a
    /// buffer, 3.3 V reference, 12 bits).
    const LOAD_CELL: AdcFrontEnd = AdcFrontEnd {
        vref_v: 3.3,
        full_scale_counts: 4095,
        gain: 0.1507,
        mid_v: 1.652,
        rail_margin_counts: 8,
    };

    fn counts_for(v_in: f32) -> u16 {
        ((LOAD_CELL.mid_v + LOAD_CELL.gain * v_in) / LOAD_CELL.vref_v * 4095.0).round() as u16
    }

    #[test]
    fn the_amplifier_range_maps_back_within_one_code() {
        let one_code_v = 3.3 / 4095.0 / 0.1507;
        for v in [-10.0f32, -5.0, -0.01, 0.0, 0.01, 2.5, 10.0] {
            let back = LOAD_CELL.input_volts(counts_for(v));
            assert!(
                (back - v).abs() <= one_code_v / 2.0 + 1e-5,
                "{v} V → {back} V"
            );
        }
        // one code is 5.3 mV at the amplifier
        assert!((one_code_v - 0.00535).abs() < 0.00005);
    }

    #[test]
    fn the_full_amplifier_range_is_inside_the_rails() {
        assert!(!LOAD_CELL.saturated(counts_for(-10.0)));
        assert!(!LOAD_CELL.saturated(counts_for(10.0)));
        assert!(!LOAD_CELL.saturated(counts_for(0.0)));
    }

    /// The front end of docs/output-stage.md at another VDDA: the divider's node is
    /// (V_amp/R1 + VDDA/R2) / (1/R1 + 1/R2 + 1/R3) and the ADC's full scale is VDDA.
    fn counts_at(v_in: f32, vdda: f32) -> u16 {
        let (r1, r2, r3) = (100e3f32, 30.1e3, 43.2e3);
        let node = (v_in / r1 + vdda / r2) / (1.0 / r1 + 1.0 / r2 + 1.0 / r3);
        (node / vdda * 4095.0).round() as u16
    }

    #[test]
    fn a_measured_vdda_removes_the_supplys_scale_error() {
        let one_code_v = 3.3 / 4095.0 / 0.1507;
        for vdda in [3.15f32, 3.3, 3.45] {
            for v in [-9.0f32, -1.0, 0.5, 8.0] {
                let c = counts_at(v, vdda);
                let corrected = LOAD_CELL.input_volts_at(c, vdda);
                // the divider's own rounding (1.652 V, 0.1507) is worth a few mV
                assert!(
                    (corrected - v).abs() < one_code_v + 0.01,
                    "{vdda} V, {v} V → {corrected}"
                );
            }
        }
        // without it, at 3.15 V the 8 V reads as ≈ 8.4 V (the full scale shrank with VDDA)
        let c = counts_at(8.0, 3.15);
        assert!((LOAD_CELL.input_volts(c) - 8.0 * 3.3 / 3.15).abs() < 0.02);
    }

    #[test]
    fn codes_at_the_rails_are_saturated() {
        for c in [0u16, 1, 8, 4087, 4090, 4095] {
            assert!(LOAD_CELL.saturated(c), "{c}");
        }
        for c in [9u16, 2048, 4086] {
            assert!(!LOAD_CELL.saturated(c), "{c}");
        }
        // beyond the amplifier's ±10 V the front end drives the ADC to its rails
        assert!(LOAD_CELL.input_volts(0) < -10.0);
        assert!(LOAD_CELL.input_volts(4095) > 10.0);
    }
}
