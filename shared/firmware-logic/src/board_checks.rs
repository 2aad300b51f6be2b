//! The board checks the firmware reports in every status (`Status.board_checks`): the bits
//! of what is wrong with the board now. The device refuses to arm, and refuses to clear its
//! faults, while any is set; this module is where the straps, the ADC's dual mode and the
//! VDDA measurement become those bits, so that the path from a strap pin to "never arms"
//! is tested on the host and not only on a board.

use pam_protocol::{BOARD_CHECK_ADC_DUAL, BOARD_CHECK_OUTPUT_STAGE, BOARD_CHECK_VDDA};

use crate::board_revision::BoardRevision;
use crate::vdda;

/// The checks failing now: an output stage that is not safe in reset, the ADCs' dual mode
/// not set, or a VDDA measured out of range (no measurement yet is not a failure: the
/// nominal value scales the readings until one exists).
pub fn board_checks(revision: BoardRevision, dual_mode_ok: bool, vdda_v: Option<f32>) -> u8 {
    let mut checks = 0;
    if !revision.outputs_safe_in_reset() {
        checks |= BOARD_CHECK_OUTPUT_STAGE;
    }
    if !dual_mode_ok {
        checks |= BOARD_CHECK_ADC_DUAL;
    }
    if vdda_v.is_some_and(|v| !vdda::in_range(v)) {
        checks |= BOARD_CHECK_VDDA;
    }
    checks
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_board_without_straps_reports_its_output_stage() {
        // both straps open read high through the pull-ups: the first output stage
        let unstrapped = BoardRevision::from_straps(true, true);
        assert_eq!(
            board_checks(unstrapped, true, Some(3.3)),
            BOARD_CHECK_OUTPUT_STAGE
        );
        // a pattern no board uses is not taken for the safe one
        for (s0, s1) in [(true, false), (false, false)] {
            let checks = board_checks(BoardRevision::from_straps(s0, s1), true, None);
            assert_eq!(checks, BOARD_CHECK_OUTPUT_STAGE, "straps {s0} {s1}");
        }
    }

    #[test]
    fn the_revised_board_with_a_good_supply_passes() {
        let revised = BoardRevision::from_straps(false, true);
        assert_eq!(board_checks(revised, true, Some(3.3)), 0);
        assert_eq!(board_checks(revised, true, None), 0, "no VDDA measured yet");
    }

    #[test]
    fn each_failing_check_sets_its_own_bit() {
        let revised = BoardRevision::from_straps(false, true);
        assert_eq!(
            board_checks(revised, false, Some(3.3)),
            BOARD_CHECK_ADC_DUAL
        );
        assert_eq!(board_checks(revised, true, Some(3.0)), BOARD_CHECK_VDDA);
        assert_eq!(board_checks(revised, true, Some(3.6)), BOARD_CHECK_VDDA);
        let all = board_checks(BoardRevision::Rev1, false, Some(2.9));
        assert_eq!(
            all,
            BOARD_CHECK_OUTPUT_STAGE | BOARD_CHECK_ADC_DUAL | BOARD_CHECK_VDDA
        );
    }
}
