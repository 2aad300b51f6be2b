//! The interface board's revision, from two strap pins read at boot, and whether its output
//! stage is safe while the MCU is in reset (docs/output-stage.md). The first board has no
//! straps and its buffers drive whatever their floating inputs say during reset, flashing
//! and brown-out: up to 24 mA, full pressure. The revised board pulls the buffers' inputs
//! low and their enable off, and ties strap 0 to ground. Straps read with pull-ups, so an
//! open strap reads high; a board that does not identify itself is taken for the first one.

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoardRevision {
    /// No straps: the first output stage (buffers always enabled, inputs floating in reset).
    Rev1,
    /// Strap 0 low: the revised output stage (≤ 0 mA in reset, `OUT_EN#`).
    Rev2,
    /// A strap pattern no revision uses (strap 1 low): treated as unsafe.
    Unknown { straps: u8 },
}

impl BoardRevision {
    /// From the straps' levels (`true` = high, the pull-up's level when open).
    pub fn from_straps(strap0_high: bool, strap1_high: bool) -> Self {
        match (strap0_high, strap1_high) {
            (true, true) => Self::Rev1,
            (false, true) => Self::Rev2,
            (s0, s1) => Self::Unknown {
                straps: u8::from(s0) | (u8::from(s1) << 1),
            },
        }
    }

    /// The outputs carry no current while the MCU is in reset: the condition for arming.
    pub fn outputs_safe_in_reset(self) -> bool {
        self == Self::Rev2
    }

    /// The number reported in the log.
    pub fn number(self) -> u8 {
        match self {
            Self::Rev1 => 1,
            Self::Rev2 => 2,
            Self::Unknown { .. } => 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_revised_board_may_arm() {
        assert_eq!(BoardRevision::from_straps(true, true), BoardRevision::Rev1);
        assert_eq!(BoardRevision::from_straps(false, true), BoardRevision::Rev2);
        assert!(BoardRevision::from_straps(false, true).outputs_safe_in_reset());
        // unstrapped (the first board), and the patterns no board uses
        for (s0, s1) in [(true, true), (true, false), (false, false)] {
            assert!(!BoardRevision::from_straps(s0, s1).outputs_safe_in_reset());
        }
        assert_eq!(
            BoardRevision::from_straps(false, false),
            BoardRevision::Unknown { straps: 0 }
        );
        assert_eq!(BoardRevision::from_straps(true, true).number(), 1);
    }
}
