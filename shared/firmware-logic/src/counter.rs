//! Extension of a wrapping 16-bit hardware counter (a timer in encoder mode) to a signed
//! 64-bit count, so that no count is lost when the hardware wraps.

/// Between two samples the counter may move by at most ±32767 counts (half its range):
/// the difference of the two 16-bit values is then unambiguous.
pub const MAX_COUNTS_PER_SAMPLE: i64 = i16::MAX as i64;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WrapExtender {
    last_raw: u16,
    count: i64,
}

impl WrapExtender {
    /// The first sample is the origin (count 0).
    pub const fn new(first_raw: u16) -> Self {
        Self {
            last_raw: first_raw,
            count: 0,
        }
    }

    /// Adds the signed distance from the last sample (two's-complement difference of the
    /// 16-bit values: the shorter way round) and returns the extended count.
    pub fn update(&mut self, raw: u16) -> i64 {
        let delta = raw.wrapping_sub(self.last_raw) as i16;
        self.last_raw = raw;
        self.count = self.count.wrapping_add(i64::from(delta));
        self.count
    }

    pub const fn count(&self) -> i64 {
        self.count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hardware counter that wraps at 2^16, driven by a true position.
    fn raw_of(position: i64) -> u16 {
        position.rem_euclid(1 << 16) as u16
    }

    #[test]
    fn first_sample_is_the_origin_wherever_the_counter_starts() {
        let mut e = WrapExtender::new(40_000);
        assert_eq!(e.count(), 0);
        assert_eq!(e.update(40_000), 0);
        assert_eq!(e.update(40_005), 5);
    }

    #[test]
    fn forward_across_the_top_of_the_counter() {
        let mut e = WrapExtender::new(65_530);
        assert_eq!(e.update(65_535), 5);
        assert_eq!(e.update(4), 10);
    }

    #[test]
    fn backward_across_zero() {
        let mut e = WrapExtender::new(3);
        assert_eq!(e.update(0), -3);
        assert_eq!(e.update(65_533), -6);
    }

    #[test]
    fn many_wraps_both_ways_lose_no_count() {
        let start: i64 = 12_345;
        let mut e = WrapExtender::new(raw_of(start));
        let mut position = start;
        // 2 000 samples of +3 001 counts: ~92 wraps forward
        for _ in 0..2_000 {
            position += 3_001;
            assert_eq!(e.update(raw_of(position)), position - start);
        }
        // then back past the origin: ~137 wraps backward
        for _ in 0..3_000 {
            position -= 3_001;
            assert_eq!(e.update(raw_of(position)), position - start);
        }
        assert!(e.count() < -(1 << 16) * 10);
    }

    #[test]
    fn the_largest_step_per_sample_is_half_the_counter() {
        let mut e = WrapExtender::new(0);
        assert_eq!(
            e.update(raw_of(MAX_COUNTS_PER_SAMPLE)),
            MAX_COUNTS_PER_SAMPLE
        );
        let mut e = WrapExtender::new(0);
        assert_eq!(
            e.update(raw_of(-MAX_COUNTS_PER_SAMPLE)),
            -MAX_COUNTS_PER_SAMPLE
        );
        // one more and the step is read the other way round (the documented limit)
        let mut e = WrapExtender::new(0);
        assert_eq!(
            e.update(raw_of(MAX_COUNTS_PER_SAMPLE + 1)),
            -(MAX_COUNTS_PER_SAMPLE + 1)
        );
    }
}
