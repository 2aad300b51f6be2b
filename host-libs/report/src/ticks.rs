//! Round axis ticks (1-2-5 steps) and their labels.

/// A tick step of 1, 2 or 5 × 10ᵏ giving about `target` intervals over `lo..hi`.
pub fn nice_step(lo: f64, hi: f64, target: usize) -> f64 {
    let span = (hi - lo).abs();
    if !(span > 0.0) || !span.is_finite() {
        return 1.0;
    }
    let raw = span / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let m = if norm <= 1.0 {
        1.0
    } else if norm <= 2.0 {
        2.0
    } else if norm <= 5.0 {
        5.0
    } else {
        10.0
    };
    m * mag
}

/// An axis: the range widened to whole ticks, and the ticks.
#[derive(Clone, Debug, PartialEq)]
pub struct Ticks {
    pub lo: f64,
    pub hi: f64,
    pub step: f64,
    pub values: Vec<f64>,
}

impl Ticks {
    /// Ticks for data in `lo..hi` (a degenerate or empty range gets a unit range around
    /// it), about `target` intervals, the range extended to the ticks outside the data.
    pub fn new(lo: f64, hi: f64, target: usize) -> Self {
        let (mut lo, mut hi) = if lo.is_finite() && hi.is_finite() {
            (lo.min(hi), lo.max(hi))
        } else {
            (0.0, 1.0)
        };
        if hi - lo <= 1e-12 * lo.abs().max(hi.abs()).max(1e-300) {
            let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
            lo -= d;
            hi += d;
        }
        let step = nice_step(lo, hi, target);
        let k0 = (lo / step + 1e-9).floor();
        let k1 = (hi / step - 1e-9).ceil();
        let values: Vec<f64> = (0..=((k1 - k0) as i64).max(1))
            .map(|i| clean((k0 + i as f64) * step, step))
            .collect();
        Ticks {
            lo: values[0],
            hi: *values.last().unwrap(),
            step,
            values,
        }
    }

    /// Ticks that stay inside `lo..hi` (the range is kept as it is).
    pub fn inside(lo: f64, hi: f64, target: usize) -> Self {
        let step = nice_step(lo, hi, target);
        let k0 = (lo / step - 1e-9).ceil() as i64;
        let k1 = (hi / step + 1e-9).floor() as i64;
        Ticks {
            lo,
            hi,
            step,
            values: (k0..=k1).map(|k| clean(k as f64 * step, step)).collect(),
        }
    }

    pub fn label(&self, v: f64) -> String {
        label(v, self.step)
    }
}

/// Removes the rounding noise of k·step (0.30000000000000004 → 0.3, −0 → 0).
fn clean(v: f64, step: f64) -> f64 {
    let d = decimals(step) as i32;
    let p = 10f64.powi(d);
    let r = if d <= 15 { (v * p).round() / p } else { v };
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// Decimals needed to print multiples of `step` exactly.
pub fn decimals(step: f64) -> usize {
    if !(step > 0.0) || !step.is_finite() {
        return 0;
    }
    (-(step.log10() + 1e-9).floor()).max(0.0) as usize
}

/// A tick label: as many decimals as the step needs; exponent notation for very large or
/// very small values.
pub fn label(v: f64, step: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if a >= 1e5 || step < 1e-4 {
        let s = format!("{v:.1e}");
        return s.replace(".0e", "e");
    }
    format!("{v:.*}", decimals(step))
}

/// A value in a table or a legend: 3–4 significant digits.
pub fn num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if !v.is_finite() {
        format!("{v}")
    } else if v.abs() >= 1e4 || v.abs() < 1e-3 {
        format!("{v:.3e}")
    } else {
        let d = (3 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.d$}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn is_125(step: f64) -> bool {
        let m = step / 10f64.powf(step.log10().floor());
        [1.0, 2.0, 5.0].iter().any(|c| (m - c).abs() < 1e-9)
    }

    #[test]
    fn steps_are_one_two_five() {
        for (lo, hi) in [
            (0.0, 1.0),
            (-3.7, 12.2),
            (0.013, 0.0171),
            (-0.04, 0.04),
            (0.0, 90.0),
            (1e-6, 7e-6),
            (-1234.0, 98765.0),
        ] {
            let t = Ticks::new(lo, hi, 6);
            assert!(is_125(t.step), "{lo}..{hi}: step {}", t.step);
            assert!(t.lo <= lo && t.hi >= hi, "{lo}..{hi}: {t:?}");
            assert!((3..=13).contains(&t.values.len()), "{lo}..{hi}: {t:?}");
            for w in t.values.windows(2) {
                assert!(((w[1] - w[0]) - t.step).abs() < 1e-9 * t.step.max(1.0));
            }
        }
    }

    #[test]
    fn ticks_are_round_numbers() {
        let t = Ticks::new(0.0, 0.9, 5);
        assert_eq!(t.step, 0.2);
        assert_eq!(t.values, vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
        let labels: Vec<String> = t.values.iter().map(|v| t.label(*v)).collect();
        assert_eq!(labels, ["0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        let t = Ticks::new(-0.041, 0.038, 4);
        assert_eq!(t.step, 0.02);
        assert_eq!(t.values.first(), Some(&-0.06));
        assert_eq!(t.label(-0.04), "-0.04");
        let t = Ticks::new(0.0, 90.0, 6);
        assert_eq!(t.step, 20.0);
        assert_eq!(t.label(40.0), "40");
    }

    #[test]
    fn degenerate_ranges_still_have_ticks() {
        let t = Ticks::new(2.0, 2.0, 5);
        assert!(t.lo < 2.0 && t.hi > 2.0 && t.values.len() >= 2);
        let t = Ticks::new(0.0, 0.0, 5);
        assert!(t.lo < 0.0 && t.hi > 0.0);
        let t = Ticks::new(f64::NAN, f64::INFINITY, 5);
        assert_eq!((t.lo, t.hi), (0.0, 1.0));
    }

    #[test]
    fn inside_keeps_the_range() {
        let t = Ticks::inside(-0.037, 0.052, 6);
        assert_eq!((t.lo, t.hi), (-0.037, 0.052));
        assert!(t.values.iter().all(|v| (-0.037..=0.052).contains(v)));
        assert_eq!(t.values, vec![-0.02, 0.0, 0.02, 0.04]);
    }

    #[test]
    fn labels_and_numbers() {
        assert_eq!(label(0.0, 0.1), "0");
        assert_eq!(label(2e5, 1e5), "2e5");
        assert_eq!(label(-2.5, 0.5), "-2.5");
        assert_eq!(num(1.98765), "1.988");
        assert_eq!(num(0.0123456), "0.01235");
        assert_eq!(num(123.456), "123.5");
        assert_eq!(num(0.0001234), "1.234e-4");
    }
}
