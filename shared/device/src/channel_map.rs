//! The I/P channel map as wired: which output stage drives each converter.
//!
//! The controller computes one loop current per I/P channel, in the model's channel order
//! (`JointParams::channel_of_muscle`). On the rig, the output stage that reaches a
//! channel's converter is a matter of cables; the commissioning measures it and stores it
//! in the calibration (`Calibration::output_of_channel`), and every period the currents
//! are routed through it. Each output stage keeps its own trim.

use pam_protocol::OutputCalibration;

/// `map` sends the four channels to four different output stages (0–3).
pub fn is_permutation(map: [u8; 4]) -> bool {
    let mut seen = 0u8;
    for stage in map {
        if stage > 3 {
            return false;
        }
        seen |= 1 << stage;
    }
    seen == 0b1111
}

/// The currents per output stage, mA: channel c's current `channel_ma[c]` through the trim
/// of its stage `map[c]`, or the vent current where `vent` says so for the channel. A map
/// that is not a permutation (refused at configuration) would leave a stage unset: that
/// stage gets the vent current.
pub fn route(
    map: [u8; 4],
    channel_ma: [f32; 4],
    trims: &[OutputCalibration; 4],
    trimmed: impl Fn(&OutputCalibration, f32) -> f32,
    vent_ma: f32,
) -> [f32; 4] {
    let mut stage_ma = [vent_ma; 4];
    for (c, &stage) in map.iter().enumerate() {
        if let Some(slot) = stage_ma.get_mut(stage as usize) {
            *slot = trimmed(&trims[stage as usize], channel_ma[c]);
        }
    }
    stage_ma
}

#[cfg(test)]
mod tests {
    use super::{is_permutation, route};
    use pam_protocol::OutputCalibration;

    #[test]
    fn only_a_permutation_of_the_four_stages_is_a_map() {
        assert!(is_permutation([0, 1, 2, 3]));
        assert!(is_permutation([2, 0, 3, 1]));
        assert!(!is_permutation([0, 0, 2, 3]));
        assert!(!is_permutation([0, 1, 2, 4]));
    }

    #[test]
    fn each_channel_reaches_its_stage_through_that_stage_trim() {
        let mut trims = [OutputCalibration::default(); 4];
        trims[3].offset_ma = 0.5;
        let out = route(
            [1, 0, 3, 2],
            [5.0, 6.0, 7.0, 8.0],
            &trims,
            |t, i| t.gain * i + t.offset_ma,
            4.0,
        );
        assert_eq!(out, [6.0, 5.0, 8.0, 7.5]);
    }
}
