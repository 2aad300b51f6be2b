//! What a soak run counted and measured.

use std::collections::BTreeMap;
use std::fmt;

use pam_twin::TrueState;

use super::Kind;

/// What the handle did after one injected fault, within the soak's watch of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Consequence {
    pub kind: Kind,
    /// The mode the fault was injected in.
    pub mode: &'static str,
    /// A fault latched within the watch window.
    pub detected: bool,
    /// Largest distance of the handle from where it was at the injection (mm).
    pub excursion_mm: f64,
    /// Largest handle speed (mm/s).
    pub speed_mm_s: f64,
    /// Largest force on what holds the handle (the block in the force modes; N).
    pub force_n: f64,
}

impl Default for Consequence {
    fn default() -> Self {
        Consequence {
            kind: Kind::LinkLoss,
            mode: "",
            detected: false,
            excursion_mm: 0.0,
            speed_mm_s: 0.0,
            force_n: 0.0,
        }
    }
}

impl Consequence {
    /// One period of the twin after the injection; `start_m` is the handle at it.
    pub(crate) fn observe(&mut self, start_m: [f64; 2], s: &TrueState) {
        let d = [
            s.handle_user_m[0] - start_m[0],
            s.handle_user_m[1] - start_m[1],
        ];
        self.excursion_mm = self.excursion_mm.max(d[0].hypot(d[1]) * 1e3);
        let v = s.handle_velocity_user_m_s;
        self.speed_mm_s = self.speed_mm_s.max(v[0].hypot(v[1]) * 1e3);
        let f = s.force_on_holder_user_n;
        self.force_n = self.force_n.max(f[0].hypot(f[1]));
    }
}

/// Injections and detections of one fault kind in one mode, and the worst that followed
/// the undetected ones.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Coverage {
    pub injected: u64,
    pub detected: u64,
    pub worst_undetected_excursion_mm: f64,
    pub worst_undetected_speed_mm_s: f64,
    pub worst_undetected_force_n: f64,
    /// Largest excursion after a detected one (mm): the motion while the muscles vent.
    pub worst_detected_excursion_mm: f64,
}

/// The figures of one kind of injected fault.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct KindFigures {
    pub injected: u64,
    /// A fault latched within the watch window.
    pub detected: u64,
    /// Another fault latched before the expected one (the arm's own motion, mostly).
    pub preempted: u64,
    pub worst_periods_to_fault: Option<u64>,
    pub worst_periods_to_safe: Option<u64>,
    /// The documented bound (`Kind::bound_periods`) at the worst case seen, if it has one.
    pub bound_periods: Option<u64>,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct SoakReport {
    pub emulated_s: f64,
    pub wall_s: f64,
    pub periods: u64,
    pub telemetry_frames: u64,
    pub lost_frames: u64,
    pub fault_events: u64,
    pub requests: u64,
    pub episodes: u64,
    pub arms: u64,
    pub clears: u64,
    /// Arms refused because a fault latched again between the clear and the arm.
    pub relatched_before_arm: u64,
    /// Mode segments run, by mode name.
    pub modes: BTreeMap<&'static str, u64>,
    pub injected: BTreeMap<Kind, KindFigures>,
    /// Faults nobody injected (random targets that take the arm out of range, an unstable
    /// closed loop…), by mode and fault bits: each must have vented like any other.
    pub spontaneous: BTreeMap<(&'static str, u16), u64>,
    pub bad_targets_refused: u64,
    pub noise_bursts: u64,
    pub overrun_count_changes: u64,
    /// Detection per fault kind and the mode it was injected in.
    pub coverage: BTreeMap<(Kind, &'static str), Coverage>,
    /// What followed every fault that no fault bit answered within its watch.
    pub undetected: Vec<Consequence>,
    /// Every violation of the soak's checks (at most 100 kept); empty on a pass.
    pub problems: Vec<String>,
}

impl SoakReport {
    /// Counts one injected fault and what followed it.
    pub(crate) fn record(&mut self, c: Consequence) {
        let cov = self.coverage.entry((c.kind, c.mode)).or_default();
        cov.injected += 1;
        if c.detected {
            cov.detected += 1;
            cov.worst_detected_excursion_mm = cov.worst_detected_excursion_mm.max(c.excursion_mm);
        } else {
            cov.worst_undetected_excursion_mm =
                cov.worst_undetected_excursion_mm.max(c.excursion_mm);
            cov.worst_undetected_speed_mm_s = cov.worst_undetected_speed_mm_s.max(c.speed_mm_s);
            cov.worst_undetected_force_n = cov.worst_undetected_force_n.max(c.force_n);
            self.undetected.push(c);
        }
    }

    /// The undetected faults, largest excursion first.
    pub fn undetected_by_excursion(&self) -> Vec<Consequence> {
        let mut v = self.undetected.clone();
        v.sort_by(|a, b| b.excursion_mm.total_cmp(&a.excursion_mm));
        v
    }

    pub fn faults_injected(&self) -> u64 {
        self.injected.values().map(|f| f.injected).sum()
    }

    /// The slowest time to the safe state over every kind with a documented bound.
    pub fn worst_periods_to_safe(&self) -> Option<(Kind, u64)> {
        self.injected
            .iter()
            .filter(|(_, f)| f.bound_periods.is_some())
            .filter_map(|(k, f)| f.worst_periods_to_safe.map(|p| (*k, p)))
            .max_by_key(|(_, p)| *p)
    }
}

fn opt(v: Option<u64>) -> String {
    v.map_or("—".to_string(), |v| v.to_string())
}

impl fmt::Display for SoakReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "soak: {:.1} s emulated ({:.2} h) in {:.1} s wall ({:.0}× real time)",
            self.emulated_s,
            self.emulated_s / 3600.0,
            self.wall_s,
            self.emulated_s / self.wall_s.max(1e-9)
        )?;
        writeln!(
            f,
            "periods {}, telemetry frames {}, lost frames {}, fault events {}, requests {}",
            self.periods, self.telemetry_frames, self.lost_frames, self.fault_events, self.requests
        )?;
        writeln!(
            f,
            "episodes {}, arms {}, clears {}, re-latched before arming {}, bad targets refused {}, noise bursts {}, overrun count changes {}",
            self.episodes,
            self.arms,
            self.clears,
            self.relatched_before_arm,
            self.bad_targets_refused,
            self.noise_bursts,
            self.overrun_count_changes
        )?;
        let modes: Vec<String> = self.modes.iter().map(|(m, n)| format!("{m} {n}")).collect();
        writeln!(f, "mode segments: {}", modes.join(", "))?;
        writeln!(
            f,
            "| fault | injected | latched | preempted | worst periods to fault | worst periods to safe state | documented bound |"
        )?;
        writeln!(f, "|---|---|---|---|---|---|---|")?;
        for (k, v) in &self.injected {
            writeln!(
                f,
                "| {} | {} | {} | {} | {} | {} | {} |",
                k.name(),
                v.injected,
                v.detected,
                v.preempted,
                opt(v.worst_periods_to_fault),
                opt(v.worst_periods_to_safe),
                opt(v.bound_periods)
            )?;
        }
        writeln!(f, "faults injected: {}", self.faults_injected())?;
        if let Some((k, p)) = self.worst_periods_to_safe() {
            writeln!(
                f,
                "worst time to the safe state: {p} periods ({})",
                k.name()
            )?;
        }
        write_coverage(f, self)?;
        let spontaneous: Vec<String> = self
            .spontaneous
            .iter()
            .map(|((mode, bits), n)| format!("{mode} {bits:#06x} × {n}"))
            .collect();
        writeln!(f, "faults not injected: {}", spontaneous.join(", "))?;
        writeln!(f, "problems: {}", self.problems.len())?;
        for p in &self.problems {
            writeln!(f, "  {p}")?;
        }
        Ok(())
    }
}

/// Detection per fault kind and mode, what followed the undetected faults, the worst ten.
fn write_coverage(f: &mut fmt::Formatter<'_>, r: &SoakReport) -> fmt::Result {
    writeln!(
        f,
        "| fault | mode | injected | latched | coverage | undetected: worst excursion (mm) | worst speed (mm/s) | worst force (N) | detected: worst excursion (mm) |"
    )?;
    writeln!(f, "|---|---|---|---|---|---|---|---|---|")?;
    for ((kind, mode), c) in &r.coverage {
        let undetected = c.injected > c.detected;
        let worst = |v: f64| {
            if undetected {
                format!("{v:.1}")
            } else {
                "—".into()
            }
        };
        writeln!(
            f,
            "| {} | {mode} | {} | {} | {:.0} % | {} | {} | {} | {} |",
            kind.name(),
            c.injected,
            c.detected,
            100.0 * c.detected as f64 / c.injected.max(1) as f64,
            worst(c.worst_undetected_excursion_mm),
            worst(c.worst_undetected_speed_mm_s),
            worst(c.worst_undetected_force_n),
            if c.detected > 0 {
                format!("{:.1}", c.worst_detected_excursion_mm)
            } else {
                "—".into()
            }
        )?;
    }
    let all = r.undetected_by_excursion();
    writeln!(
        f,
        "undetected faults: {}; the ten largest excursions:",
        all.len()
    )?;
    for c in all.iter().take(10) {
        writeln!(
            f,
            "  {} in {}: {:.1} mm, {:.0} mm/s, {:.1} N",
            c.kind.name(),
            c.mode,
            c.excursion_mm,
            c.speed_mm_s,
            c.force_n
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn consequence(kind: Kind, mode: &'static str, detected: bool, mm: f64) -> Consequence {
        Consequence {
            kind,
            mode,
            detected,
            excursion_mm: mm,
            speed_mm_s: 10.0 * mm,
            force_n: mm / 2.0,
        }
    }

    #[test]
    fn coverage_counts_per_kind_and_mode_and_keeps_what_followed_each_undetected_fault() {
        let mut r = SoakReport::default();
        r.record(consequence(Kind::EncoderStuck, "joint", false, 12.0));
        r.record(consequence(Kind::EncoderStuck, "joint", true, 30.0));
        r.record(consequence(Kind::EncoderStuck, "joint", false, 40.0));
        r.record(consequence(Kind::EncoderStuck, "pressures", true, 5.0));
        r.record(consequence(Kind::ConverterStuck, "joint", false, 7.0));
        let joint = r.coverage[&(Kind::EncoderStuck, "joint")];
        assert_eq!((joint.injected, joint.detected), (3, 1));
        assert_eq!(joint.worst_undetected_excursion_mm, 40.0);
        assert_eq!(joint.worst_undetected_speed_mm_s, 400.0);
        assert_eq!(joint.worst_undetected_force_n, 20.0);
        assert_eq!(joint.worst_detected_excursion_mm, 30.0);
        let pressures = r.coverage[&(Kind::EncoderStuck, "pressures")];
        assert_eq!((pressures.injected, pressures.detected), (1, 1));
        assert_eq!(pressures.worst_undetected_excursion_mm, 0.0);
        let worst: Vec<f64> = r
            .undetected_by_excursion()
            .iter()
            .map(|c| c.excursion_mm)
            .collect();
        assert_eq!(worst, [40.0, 12.0, 7.0]);
        let text = r.to_string();
        assert!(
            text.contains("| stuck encoder | joint | 3 | 1 | 33 % | 40.0 | 400.0 | 20.0 | 30.0 |"),
            "{text}"
        );
        assert!(text.contains("undetected faults: 3"), "{text}");
    }
}
