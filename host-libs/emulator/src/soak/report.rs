//! What a soak run counted and measured.

use std::collections::BTreeMap;
use std::fmt;

use super::Kind;

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
    /// Every violation of the soak's checks (at most 100 kept); empty on a pass.
    pub problems: Vec<String>,
}

impl SoakReport {
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
