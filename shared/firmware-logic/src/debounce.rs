//! A condition that must hold for a number of consecutive samples before it counts (an
//! error flag that may glitch while an output settles).

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Debounce {
    consecutive: u16,
    threshold: u16,
}

impl Debounce {
    /// `threshold` samples in a row (at least 1).
    pub const fn new(threshold: u16) -> Self {
        Self {
            consecutive: 0,
            threshold: if threshold == 0 { 1 } else { threshold },
        }
    }

    /// One sample; returns whether the condition has now held for `threshold` samples.
    pub fn update(&mut self, active: bool) -> bool {
        self.consecutive = if active {
            self.consecutive.saturating_add(1)
        } else {
            0
        };
        self.consecutive >= self.threshold
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_glitch_shorter_than_the_threshold_is_ignored() {
        let mut d = Debounce::new(10);
        for _ in 0..9 {
            assert!(!d.update(true));
        }
        assert!(!d.update(false));
        for _ in 0..9 {
            assert!(!d.update(true));
        }
    }

    #[test]
    fn a_lasting_condition_is_reported_until_it_clears() {
        let mut d = Debounce::new(10);
        let reports: Vec<bool> = (0..12).map(|_| d.update(true)).collect();
        assert_eq!(reports.iter().position(|&r| r), Some(9));
        // held for longer than u16::MAX samples: still reported, no overflow
        for _ in 0..70_000 {
            assert!(d.update(true));
        }
        assert!(!d.update(false));
    }

    #[test]
    fn a_zero_threshold_means_one_sample() {
        let mut d = Debounce::new(0);
        assert!(d.update(true));
        assert!(!d.update(false));
    }
}
