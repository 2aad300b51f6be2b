//! Sensor and actuator failures of the rig, for fault-injection tests: what a broken encoder,
//! load cell or I/P converter does to the signals the controller sees or the air the
//! muscles get. They act on the twin's inputs (loop currents) and outputs (the raw sensor
//! readings of a [`Measurement`]), never on its physics, and are switched on at run time
//! by whoever drives the twin (the emulator's `--inject`), unlike the [`crate::effects`],
//! which are part of the plant from the start.
//!
//! Only the raw fields of a [`Measurement`] (`encoder_counts`, `loadcell_v`) are faulted:
//! they are what the device reads; the converted fields keep the healthy values.

use crate::plant::Measurement;
use thiserror::Error;

/// One failure of a sensor or an actuator. Joints and channels are numbered from 0 here;
/// the text form ([`PlantFault::parse`]) numbers joints 1–2 and channels 1–4 like the
/// rest of the command line (α1, α2; channels 1–4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PlantFault {
    /// The encoder disc no longer turns with the joint (a loose coupling): the count holds.
    EncoderStuck { joint: usize },
    /// The encoder cable is pulled: the board's pull-ups hold A and B high, so the timer
    /// sees no edge and the count holds (at the counter, the same as a stuck encoder).
    EncoderUnplugged { joint: usize },
    /// A miscount: the count jumps by `counts` at once (noise on A/B, a missed edge pair).
    EncoderJump { joint: usize, counts: i64 },
    /// The channel's amplifier clips at its positive full scale.
    LoadcellSaturated { channel: usize },
    /// Both amplifier outputs freeze at their last value (a failed amplifier or a
    /// disconnected bridge with a hold stage): the ADC reads the same code every period.
    LoadcellFrozen,
    /// The converter's valve stops following its loop current and holds the pressure it
    /// was set to (a jammed pilot valve, a converter without power).
    ConverterStuck { channel: usize },
    /// The current loop to the converter is open (a cut wire): no current flows, the
    /// converter vents, and the XTR111 reports the open loop on its error flag.
    ConverterOpen { channel: usize },
}

#[derive(Debug, Error, PartialEq)]
pub enum FaultParseError {
    #[error("unknown plant fault {0:?} (known: {KNOWN})")]
    Unknown(String),
    #[error("{kind}: parameter {param:?} missing or not {expected}")]
    Parameter {
        kind: String,
        param: &'static str,
        expected: &'static str,
    },
}

const KNOWN: &str = "encoder_stuck:joint=1|2, encoder_unplugged:joint=1|2, \
    encoder_jump:joint=1|2,counts=N, loadcell_saturated:channel=x|z, loadcell_frozen, \
    converter_stuck:channel=1..4, converter_open:channel=1..4";

impl PlantFault {
    /// `kind` or `kind:param=value,...`, e.g. `encoder_jump:joint=1,counts=400`.
    pub fn parse(text: &str) -> Result<PlantFault, FaultParseError> {
        let (kind, params) = text.split_once(':').unwrap_or((text, ""));
        let get = |name: &str| {
            params
                .split(',')
                .filter_map(|kv| kv.split_once('='))
                .find(|(k, _)| k.trim() == name)
                .map(|(_, v)| v.trim())
        };
        let bad = |param: &'static str, expected: &'static str| FaultParseError::Parameter {
            kind: kind.to_string(),
            param,
            expected,
        };
        let index = |param: &'static str, n: usize, expected: &'static str| {
            get(param)
                .and_then(|v| v.parse::<usize>().ok())
                .filter(|i| (1..=n).contains(i))
                .map(|i| i - 1)
                .ok_or_else(|| bad(param, expected))
        };
        let joint = || index("joint", 2, "1 or 2");
        let channel = || index("channel", 4, "1 to 4");
        Ok(match kind {
            "encoder_stuck" => PlantFault::EncoderStuck { joint: joint()? },
            "encoder_unplugged" => PlantFault::EncoderUnplugged { joint: joint()? },
            "encoder_jump" => PlantFault::EncoderJump {
                joint: joint()?,
                counts: get("counts")
                    .and_then(|v| v.parse().ok())
                    .ok_or_else(|| bad("counts", "an integer"))?,
            },
            "loadcell_saturated" => PlantFault::LoadcellSaturated {
                channel: match get("channel") {
                    Some("x") | Some("X") => 0,
                    Some("z") | Some("Z") => 1,
                    _ => return Err(bad("channel", "x or z")),
                },
            },
            "loadcell_frozen" => PlantFault::LoadcellFrozen,
            "converter_stuck" => PlantFault::ConverterStuck {
                channel: channel()?,
            },
            "converter_open" => PlantFault::ConverterOpen {
                channel: channel()?,
            },
            other => return Err(FaultParseError::Unknown(other.to_string())),
        })
    }
}

/// The failures switched on so far, with what each froze when it started.
#[derive(Clone, Debug, Default)]
pub struct FaultState {
    frozen_counts: [Option<i64>; 2],
    count_offset: [i64; 2],
    saturated: [bool; 2],
    frozen_volts: Option<[f64; 2]>,
    stuck_current_ma: [Option<f64>; 4],
    open: [bool; 4],
}

/// Loop current through an open loop: none.
const OPEN_LOOP_MA: f64 = 0.0;

impl FaultState {
    pub fn new() -> Self {
        Self::default()
    }

    /// Switches `fault` on. `last` is the latest healthy reading and `currents_ma` the
    /// loop currents of the present period: a frozen sensor or a stuck converter holds them.
    pub fn inject(&mut self, fault: PlantFault, last: &Measurement, currents_ma: [f64; 4]) {
        match fault {
            PlantFault::EncoderStuck { joint } | PlantFault::EncoderUnplugged { joint } => {
                let shown = last.encoder_counts[joint] + self.count_offset[joint];
                self.frozen_counts[joint].get_or_insert(shown);
            }
            PlantFault::EncoderJump { joint, counts } => {
                self.count_offset[joint] += counts;
                if let Some(c) = self.frozen_counts[joint].as_mut() {
                    *c += counts;
                }
            }
            PlantFault::LoadcellSaturated { channel } => self.saturated[channel] = true,
            PlantFault::LoadcellFrozen => {
                self.frozen_volts.get_or_insert(last.loadcell_v);
            }
            PlantFault::ConverterStuck { channel } => {
                self.stuck_current_ma[channel].get_or_insert(currents_ma[channel]);
            }
            PlantFault::ConverterOpen { channel } => self.open[channel] = true,
        }
    }

    /// Every failure mended (the rig repaired: the soak test's next episode starts healthy).
    pub fn repair(&mut self) {
        *self = Self::default();
    }

    /// The currents that reach the converters when the device drives `commanded_ma`. A
    /// stuck converter is modelled by holding its input, which holds its set point.
    pub fn currents_ma(&self, commanded_ma: [f64; 4]) -> [f64; 4] {
        let mut out = commanded_ma;
        for c in 0..4 {
            if let Some(i) = self.stuck_current_ma[c] {
                out[c] = i;
            }
            if self.open[c] {
                out[c] = OPEN_LOOP_MA;
            }
        }
        out
    }

    /// The XTR111 error flags: true where the loop is open.
    pub fn open_loop(&self) -> [bool; 4] {
        self.open
    }

    /// What the device reads instead of the healthy `m`.
    pub fn measurement(&self, m: Measurement, amplifier_full_scale_v: f64) -> Measurement {
        let mut out = m;
        for j in 0..2 {
            out.encoder_counts[j] =
                self.frozen_counts[j].unwrap_or(m.encoder_counts[j] + self.count_offset[j]);
        }
        if let Some(v) = self.frozen_volts {
            out.loadcell_v = v;
        }
        for ch in 0..2 {
            if self.saturated[ch] {
                out.loadcell_v[ch] = amplifier_full_scale_v;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(counts: [i64; 2], volts: [f64; 2]) -> Measurement {
        Measurement {
            t_s: 0.0,
            encoder_counts: counts,
            loadcell_v: volts,
            alpha_rad: [0.0; 2],
            force_sensor_n: [0.0; 2],
            force_user_n: [0.0; 2],
            pressure_bar: [0.0; 4],
        }
    }

    #[test]
    fn parses_every_kind_and_refuses_bad_parameters() {
        assert_eq!(
            PlantFault::parse("encoder_jump:joint=2,counts=-400"),
            Ok(PlantFault::EncoderJump {
                joint: 1,
                counts: -400
            })
        );
        assert_eq!(
            PlantFault::parse("loadcell_saturated:channel=z"),
            Ok(PlantFault::LoadcellSaturated { channel: 1 })
        );
        assert_eq!(
            PlantFault::parse("converter_open:channel=4"),
            Ok(PlantFault::ConverterOpen { channel: 3 })
        );
        assert_eq!(
            PlantFault::parse("loadcell_frozen"),
            Ok(PlantFault::LoadcellFrozen)
        );
        assert!(PlantFault::parse("encoder_stuck:joint=3").is_err());
        assert!(PlantFault::parse("converter_stuck").is_err());
        assert!(matches!(
            PlantFault::parse("gremlins"),
            Err(FaultParseError::Unknown(_))
        ));
    }

    #[test]
    fn a_stuck_encoder_holds_its_count_and_a_jump_offsets_it() {
        let mut f = FaultState::new();
        f.inject(
            PlantFault::EncoderJump {
                joint: 0,
                counts: 300,
            },
            &reading([10, 20], [0.0; 2]),
            [4.0; 4],
        );
        let m = f.measurement(reading([15, 25], [0.1, 0.2]), 10.0);
        assert_eq!(m.encoder_counts, [315, 25]);
        f.inject(
            PlantFault::EncoderStuck { joint: 1 },
            &reading([15, 25], [0.0; 2]),
            [4.0; 4],
        );
        let m = f.measurement(reading([99, 999], [0.1, 0.2]), 10.0);
        assert_eq!(m.encoder_counts, [399, 25]);
    }

    #[test]
    fn load_cell_faults_freeze_or_clip_the_volts() {
        let mut f = FaultState::new();
        f.inject(
            PlantFault::LoadcellFrozen,
            &reading([0; 2], [0.5, -0.25]),
            [4.0; 4],
        );
        assert_eq!(
            f.measurement(reading([0; 2], [3.0, 3.0]), 10.0).loadcell_v,
            [0.5, -0.25]
        );
        f.inject(
            PlantFault::LoadcellSaturated { channel: 0 },
            &reading([0; 2], [0.0; 2]),
            [4.0; 4],
        );
        assert_eq!(
            f.measurement(reading([0; 2], [3.0, 3.0]), 10.0).loadcell_v,
            [10.0, -0.25]
        );
    }

    #[test]
    fn converter_faults_hold_or_cut_the_current_and_flag_the_open_loop() {
        let mut f = FaultState::new();
        let last = reading([0; 2], [0.0; 2]);
        f.inject(
            PlantFault::ConverterStuck { channel: 1 },
            &last,
            [5.0, 12.0, 6.0, 7.0],
        );
        f.inject(PlantFault::ConverterOpen { channel: 3 }, &last, [4.0; 4]);
        assert_eq!(f.currents_ma([4.0; 4]), [4.0, 12.0, 4.0, 0.0]);
        assert_eq!(f.open_loop(), [false, false, false, true]);
    }
}
