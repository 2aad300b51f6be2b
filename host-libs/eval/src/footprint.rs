//! How much of a log a hidden effect is: the force the robot exerts, with the effect and
//! without it, from the same seed.
//!
//! A generator's truth names the effect it switched on, not what the effect did. A
//! saturation whose knee the protocol's set-points never reach leaves the log as it was,
//! and no decision can name it. The footprint tells such logs from the misses a decision
//! should answer for: the strict score counts them as they are, and the tables say how many
//! of its misses carry an effect under the model loop's own materiality line
//! (`Settings::min_effect_size`).

use crate::strict::{judge, FinalModel, Strict};
use pam_log::Log;

/// The force columns compared, as the log format names them.
const FORCE_COLUMNS: [&str; 2] = ["fx_n", "fy_n"];

/// The effect's footprint: the RMS difference between the force with the effect and the
/// same log's force without it, over the RMS spread of the force with it, both axes pooled
/// (pam-physgen's and pam-synth's `relative_size`, which they draw without the noise).
/// `None` when either log lacks a force column, the two differ in length, or the force
/// does not vary.
///
/// Both logs must come from the same seed with the noise drawn apart from the effect, else
/// the noise's difference is counted too.
pub fn footprint(with: &Log, without: &Log) -> Option<f64> {
    let (mut diff, mut spread, mut n) = (0.0, 0.0, 0usize);
    for name in FORCE_COLUMNS {
        let (a, b) = (with.column(name)?, without.column(name)?);
        if a.len() != b.len() || a.is_empty() {
            return None;
        }
        let mean = a.iter().sum::<f64>() / a.len() as f64;
        spread += a.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
        diff += a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
        n += a.len();
    }
    let n = n as f64;
    let sd = (spread / n).sqrt();
    (sd > 0.0).then(|| (diff / n).sqrt() / sd)
}

/// The effect logs of one generator by footprint: how many carry an effect under a line
/// (the model loop's materiality, `Settings::min_effect_size`), and how many of the logs
/// not strictly right are those.
#[derive(Clone, Copy, Debug, Default)]
pub struct Footprints {
    line: f64,
    /// Effect logs whose footprint was drawn.
    pub measured: usize,
    /// Of them, under the line.
    pub under: usize,
    /// Of those, strictly right (the loop named an effect the log hardly holds).
    pub under_right: usize,
    /// Effect logs with a footprint, not strictly right.
    pub missed: usize,
    /// Of them, under the line.
    pub missed_under: usize,
}

impl Footprints {
    pub fn new(line: f64) -> Self {
        Footprints {
            line,
            ..Default::default()
        }
    }

    /// Counts one log (a control, `footprint` `None`, is not counted).
    pub fn add(&mut self, truth_family: &str, says: &FinalModel, footprint: Option<f64>) {
        let Some(f) = footprint else {
            return;
        };
        let under = f < self.line;
        let right = judge(truth_family, says) == Strict::Right;
        self.measured += 1;
        self.under += usize::from(under);
        self.under_right += usize::from(under && right);
        self.missed += usize::from(!right);
        self.missed_under += usize::from(!right && under);
    }

    /// The table's header and rule, the line in per cent.
    pub fn header(&self) -> String {
        format!(
            "| generator | effect logs with a footprint | under {:.1} % of the signal | of them strictly right | effect logs not strictly right | of them under the line |\n|---|---|---|---|---|---|",
            100.0 * self.line
        )
    }

    /// The table's row after the generator's name.
    pub fn row(&self) -> String {
        format!(
            "{} | {} | {} | {} | {}",
            self.measured, self.under, self.under_right, self.missed, self.missed_under
        )
    }
}

#[cfg(test)]
mod tests {
    use super::{footprint, Footprints};
    use crate::strict::FinalModel;
    use pam_log::Log;

    fn log(fx: &[f64], fy: &[f64]) -> Log {
        let mut l = Log::new(&["t_s", "fx_n", "fy_n"]);
        for (i, (x, y)) in fx.iter().zip(fy).enumerate() {
            l.push_row(&[i as f64, *x, *y]);
        }
        l
    }

    #[test]
    fn the_same_log_has_no_footprint() {
        let a = log(&[1.0, -1.0, 2.0, 0.0], &[0.0, 1.0, 0.0, -1.0]);
        assert_eq!(footprint(&a, &a), Some(0.0));
    }

    #[test]
    fn an_offset_is_its_share_of_the_signal_both_axes_pooled() {
        // fx: ±1 moved by 0.5 everywhere, fy: ±1 unmoved; pooled: RMS difference
        // sqrt(0.125), spread 1
        let with = log(&[1.5, -0.5, 1.5, -0.5], &[1.0, -1.0, 1.0, -1.0]);
        let without = log(&[1.0, -1.0, 1.0, -1.0], &[1.0, -1.0, 1.0, -1.0]);
        let f = footprint(&with, &without).unwrap();
        assert!((f - 0.125f64.sqrt()).abs() < 1e-12, "{f}");
    }

    #[test]
    fn logs_of_different_lengths_are_not_compared() {
        let a = log(&[1.0, -1.0, 2.0], &[0.0, 1.0, 0.0]);
        let b = log(&[1.0, -1.0], &[0.0, 1.0]);
        assert_eq!(footprint(&a, &b), None);
    }

    #[test]
    fn a_miss_under_the_line_is_counted_apart() {
        let none = FinalModel {
            verdict: "none".into(),
            ..Default::default()
        };
        let mut c = Footprints::new(0.005);
        c.add("saturation", &none, Some(0.0));
        c.add("saturation", &none, Some(0.03));
        c.add("none", &none, None);
        assert_eq!(
            (c.measured, c.under, c.under_right, c.missed, c.missed_under),
            (2, 1, 0, 2, 1)
        );
        assert_eq!(c.row(), "2 | 1 | 0 | 2 | 1");
        assert!(c.header().contains("under 0.5 % of the signal"));
    }
}
