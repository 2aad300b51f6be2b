//! What a soak run counted and measured.

use std::collections::BTreeMap;
use std::fmt;

use super::Kind;
use crate::plant::Plant;

/// What the handle did in the watch window after an injected fault: its largest distance
/// from where it was at the injection, its largest speed, and the largest force the arm put
/// on whatever held it (the twin's true load-cell force, whatever the fault did to the
/// reading).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Aftermath {
    pub excursion_mm: f64,
    pub speed_mm_s: f64,
    pub force_n: f64,
}

impl Aftermath {
    /// Takes in the twin's present state; `start_m` is the handle at the injection.
    pub(crate) fn add(&mut self, plant: &Plant, start_m: [f64; 2]) {
        let s = plant.twin.state();
        let d = [
            s.handle_user_m[0] - start_m[0],
            s.handle_user_m[1] - start_m[1],
        ];
        let v = s.handle_velocity_user_m_s;
        let f = plant.last.force_user_n;
        self.excursion_mm = self.excursion_mm.max(d[0].hypot(d[1]) * 1e3);
        self.speed_mm_s = self.speed_mm_s.max(v[0].hypot(v[1]) * 1e3);
        self.force_n = self.force_n.max(f[0].hypot(f[1]));
    }

    fn max(self, o: Aftermath) -> Aftermath {
        Aftermath {
            excursion_mm: self.excursion_mm.max(o.excursion_mm),
            speed_mm_s: self.speed_mm_s.max(o.speed_mm_s),
            force_n: self.force_n.max(o.force_n),
        }
    }
}

/// Detection of one kind of fault injected in one mode.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Coverage {
    pub injected: u64,
    /// A fault latched within the watch window.
    pub detected: u64,
    /// The worst of each figure over the detected ones.
    pub worst_detected: Aftermath,
    /// Every undetected one, in order.
    pub undetected: Vec<Aftermath>,
}

impl Coverage {
    pub(crate) fn add(&mut self, detected: bool, after: Aftermath) {
        self.injected += 1;
        if detected {
            self.detected += 1;
            self.worst_detected = self.worst_detected.max(after);
        } else {
            self.undetected.push(after);
        }
    }

    fn worst_undetected(&self) -> Option<Aftermath> {
        self.undetected.iter().copied().reduce(Aftermath::max)
    }
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
    /// Detection and what followed, by fault kind and the mode it was injected in.
    pub coverage: BTreeMap<(Kind, &'static str), Coverage>,
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

impl SoakReport {
    /// Detection coverage per kind and mode, the worst aftermath of the detected and the
    /// undetected, then every undetected one.
    fn fmt_coverage(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "| fault | mode | injected | latched | coverage | detected: worst excursion mm / speed mm/s / force N | undetected: worst excursion mm / speed mm/s / force N |"
        )?;
        writeln!(f, "|---|---|---|---|---|---|---|")?;
        let fig = |a: Aftermath| {
            format!(
                "{:.1} / {:.0} / {:.1}",
                a.excursion_mm, a.speed_mm_s, a.force_n
            )
        };
        for ((k, mode), c) in &self.coverage {
            writeln!(
                f,
                "| {} | {mode} | {} | {} | {:.0} % | {} | {} |",
                k.name(),
                c.injected,
                c.detected,
                100.0 * c.detected as f64 / c.injected.max(1) as f64,
                if c.detected > 0 {
                    fig(c.worst_detected)
                } else {
                    "—".into()
                },
                c.worst_undetected().map_or("—".into(), fig)
            )?;
        }
        writeln!(f, "undetected faults, each: excursion mm / force N")?;
        for ((k, mode), c) in &self.coverage {
            if c.undetected.is_empty() {
                continue;
            }
            let each: Vec<String> = c
                .undetected
                .iter()
                .map(|a| format!("{:.1}/{:.1}", a.excursion_mm, a.force_n))
                .collect();
            writeln!(f, "  {} in {mode}: {}", k.name(), each.join(", "))?;
        }
        Ok(())
    }
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
        self.fmt_coverage(f)?;
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
