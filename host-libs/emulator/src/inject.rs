//! Fault injection into the emulator, and the emulated board around the device.
//!
//! Faults are injected on the emulator's side only: into the twin's sensors and actuators
//! (`pam_twin::faults`) or into the emulated board (loop timing, the emergency-stop input).
//! The device protocol has no way to ask for one: a patient-facing firmware must never
//! accept "pretend a fault". They come from `pamctl sim --inject KIND@T` (a schedule in
//! emulated time) or, with `--stdin-control`, from lines `inject KIND` on the emulator's
//! standard input (what the hil-tests use); each is reported on standard output as
//! `injected KIND at time_us=N`, the device time of the first period it acts in.
//!
//! [`Board`] does, around `Device::step`, what the firmware's control task does
//! (firmware/src/control.rs), with the same shared logic: the XTR111 error flags debounced
//! into `OUTPUT_OPEN_LOOP`, the loop timing through `pam_firmware_logic::cycle_stats` into
//! `LOOP_OVERRUN`, and the emergency-stop input (EXTI: 4 mA at once, `ESTOP` latched).

use pam_control::Faults;
use pam_device::Device;
use pam_firmware_logic::current_loop::OUTPUT_ERROR_DEBOUNCE_PERIODS;
use pam_firmware_logic::cycle_stats::CycleStats;
use pam_firmware_logic::debounce::Debounce;
use pam_twin::faults::{FaultState, PlantFault};
use pam_twin::Measurement;

use crate::EmulatorError;

/// How long one injected overrun period takes, in periods.
const OVERRUN_STALL_PERIODS: u32 = 2;
/// The safe loop current the EXTI handler writes.
const SAFE_MA: f32 = 4.0;

/// One fault to inject.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Injection {
    /// A sensor or actuator of the rig fails.
    Plant(PlantFault),
    /// The control step takes `OVERRUN_STALL_PERIODS` periods, `periods` times in a row.
    Overrun { periods: u32 },
    /// The emergency-stop button is pressed (and stays pressed).
    EStop,
    /// The emergency-stop button is released.
    EStopRelease,
    /// Whatever held the handle (`--handle blocked|held|held-relaxed|operator`) lets go of it: the patient
    /// opens the hand, the block gives way. The handle is free from then on.
    HandleRelease,
}

impl Injection {
    /// `estop`, `estop_release`, `handle_release`, `overrun[:periods=N]` or a plant fault
    /// (`pam_twin::faults::PlantFault::parse`).
    pub fn parse(text: &str) -> Result<Injection, EmulatorError> {
        let bad = |reason: &str| EmulatorError::Injection {
            text: text.trim().to_string(),
            reason: reason.to_string(),
        };
        let text = text.trim();
        let (kind, params) = text.split_once(':').unwrap_or((text, ""));
        Ok(match kind {
            "estop" => Injection::EStop,
            "estop_release" => Injection::EStopRelease,
            "handle_release" => Injection::HandleRelease,
            "overrun" => {
                let periods = match params.strip_prefix("periods=") {
                    None if params.is_empty() => 5,
                    Some(n) => n
                        .parse::<u32>()
                        .ok()
                        .filter(|&n| n > 0)
                        .ok_or_else(|| bad("periods must be a positive integer"))?,
                    None => return Err(bad("overrun takes periods=N")),
                };
                Injection::Overrun { periods }
            }
            _ => Injection::Plant(PlantFault::parse(text).map_err(|source| {
                EmulatorError::PlantFault {
                    text: text.to_string(),
                    source,
                }
            })?),
        })
    }
}

/// An injection at a time of the emulated clock: `KIND@SECONDS`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scheduled {
    pub at_s: f64,
    pub injection: Injection,
}

impl Scheduled {
    pub fn parse(text: &str) -> Result<Scheduled, EmulatorError> {
        let bad = |reason: String| EmulatorError::Injection {
            text: text.to_string(),
            reason,
        };
        let (kind, at) = text
            .rsplit_once('@')
            .ok_or_else(|| bad("no time: give KIND@SECONDS".into()))?;
        let at_s: f64 = at
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite() && *t >= 0.0)
            .ok_or_else(|| bad(format!("{at} is not a time in seconds")))?;
        Ok(Scheduled {
            at_s,
            injection: Injection::parse(kind)?,
        })
    }
}

/// The emulated board: the twin's failures and the firmware's own fault sources.
pub struct Board {
    plant: FaultState,
    estop: bool,
    stall_periods_left: u32,
    meter: CycleStats,
    open_loop: [Debounce; 4],
}

impl Board {
    pub fn new(period_us: u32) -> Board {
        Board {
            plant: FaultState::new(),
            estop: false,
            stall_periods_left: 0,
            meter: CycleStats::new(period_us),
            open_loop: [Debounce::new(OUTPUT_ERROR_DEBOUNCE_PERIODS); 4],
        }
    }

    /// Switches `injection` on; `last` and `currents_ma` are the present sensors and loop
    /// currents (what a frozen sensor or a stuck converter holds).
    pub fn inject(&mut self, injection: Injection, last: &Measurement, currents_ma: [f64; 4]) {
        match injection {
            Injection::Plant(f) => self.plant.inject(f, last, currents_ma),
            Injection::Overrun { periods } => self.stall_periods_left = periods,
            Injection::EStop => self.estop = true,
            Injection::EStopRelease => self.estop = false,
            // the plant's handle condition, not the board's (`EmulatedPlant::inject`)
            Injection::HandleRelease => {}
        }
    }

    /// What the device reads this period.
    pub fn sensors(&self, healthy: Measurement) -> Measurement {
        self.plant
            .measurement(healthy, pam_control::LOADCELL_AMPLIFIER_FULL_SCALE_V as f64)
    }

    /// Before the step, like the control task: hardware conditions become faults.
    pub fn before_step(&mut self, device: &mut Device) {
        if self.estop {
            device.raise(Faults::ESTOP);
        }
        let flags = self.plant.open_loop();
        let mut open = false;
        // every debouncer sees its flag each period (no short-circuit)
        for (debounce, flag) in self.open_loop.iter_mut().zip(flags) {
            open |= debounce.update(flag);
        }
        if open {
            device.raise(Faults::OUTPUT_OPEN_LOOP);
        }
    }

    /// Everything injected undone: the rig repaired, the button released, no stall left.
    pub(crate) fn repair(&mut self) {
        self.plant.repair();
        self.estop = false;
        self.stall_periods_left = 0;
        self.open_loop = [Debounce::new(OUTPUT_ERROR_DEBOUNCE_PERIODS); 4];
    }

    /// The injected stall of this period, if any (the caller sleeps it: a real overrun).
    pub fn stall_us(&mut self, period_us: u32) -> u32 {
        if self.stall_periods_left == 0 {
            return 0;
        }
        self.stall_periods_left -= 1;
        period_us * OVERRUN_STALL_PERIODS
    }

    /// After the step, like the control task: the board's execution time of this period
    /// (the device step's CPU time, [`StepClock`], and any injected stall; the host's
    /// scheduling and the twin's physics are not the board's) through the firmware's cycle
    /// statistics. Returns the currents to
    /// drive: the step's, or 4 mA after an overrun fault or while the E-stop is pressed.
    pub fn after_step(
        &mut self,
        device: &mut Device,
        period_start_us: u32,
        exec_us: u32,
        period_us: u32,
        current_ma: [f32; 4],
    ) -> [f32; 4] {
        let mut out = current_ma;
        self.meter.set_period_if_changed(period_us);
        self.meter
            .set_overrun_fault_periods(device.controller().safety().overrun_fault_periods);
        self.meter.start(period_start_us);
        let timing = self.meter.end(period_start_us.wrapping_add(exec_us));
        if timing.overrun_fault {
            device.raise(Faults::LOOP_OVERRUN);
            out = [SAFE_MA; 4];
        }
        if self.estop {
            out = [SAFE_MA; 4];
        }
        out
    }

    /// The currents that reach the converters.
    pub fn converter_currents(&self, driven_ma: [f64; 4]) -> [f64; 4] {
        self.plant.currents_ma(driven_ma)
    }
}

/// What the board's execution time of a step is measured with: the real-time thread's CPU
/// time (Linux), so that the host descheduling the emulator in the middle of a step is not
/// taken for the board overrunning; elsewhere the wall clock.
pub struct StepClock(Option<std::time::Duration>, std::time::Instant);

impl StepClock {
    pub fn start() -> StepClock {
        StepClock(thread_cpu_time(), std::time::Instant::now())
    }

    /// µs of the step so far.
    pub fn elapsed_us(&self) -> u32 {
        let spent = match (self.0, thread_cpu_time()) {
            (Some(a), Some(b)) => b.saturating_sub(a),
            _ => self.1.elapsed(),
        };
        spent.as_micros().min(u32::MAX as u128) as u32
    }
}

#[cfg(target_os = "linux")]
fn thread_cpu_time() -> Option<std::time::Duration> {
    use nix::time::{clock_gettime, ClockId};
    clock_gettime(ClockId::CLOCK_THREAD_CPUTIME_ID)
        .ok()
        .map(std::time::Duration::from)
}

#[cfg(not(target_os = "linux"))]
fn thread_cpu_time() -> Option<std::time::Duration> {
    None
}

/// `CycleStats::set_period` restarts the jitter reference: only on a change.
trait SetPeriodIfChanged {
    fn set_period_if_changed(&mut self, period: u32);
}

impl SetPeriodIfChanged for CycleStats {
    fn set_period_if_changed(&mut self, period: u32) {
        if self.timing().period_cycles != period {
            self.set_period(period);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pam_control::SafetyConfig;
    use pam_device::DeviceOptions;
    use pam_model::RobotParams;

    fn device() -> Device {
        Device::new(
            RobotParams::thesis(),
            SafetyConfig::default_1khz(),
            DeviceOptions {
                firmware_version: crate::emulator_version(),
                encoder_counter_bits: 16,
                boot_nonce: 0,
            },
        )
    }

    fn healthy() -> Measurement {
        Measurement {
            t_s: 0.0,
            encoder_counts: [0; 2],
            loadcell_v: [0.0; 2],
            alpha_rad: [0.0; 2],
            force_sensor_n: [0.0; 2],
            force_user_n: [0.0; 2],
            pressure_bar: [0.0; 4],
        }
    }

    #[test]
    fn the_estop_vents_at_once_and_latches_its_fault() {
        let (mut board, mut d) = (Board::new(1000), device());
        board.inject(Injection::EStop, &healthy(), [12.0; 4]);
        board.before_step(&mut d);
        assert!(d.controller().faults().contains(Faults::ESTOP));
        assert_eq!(
            board.after_step(&mut d, 0, 20, 1000, [12.0; 4]),
            [SAFE_MA; 4]
        );
        board.inject(Injection::EStopRelease, &healthy(), [4.0; 4]);
        assert_eq!(board.after_step(&mut d, 1000, 20, 1000, [5.0; 4]), [5.0; 4]);
    }

    #[test]
    fn an_open_loop_is_a_fault_after_the_firmwares_debounce() {
        let (mut board, mut d) = (Board::new(1000), device());
        board.inject(
            Injection::Plant(PlantFault::ConverterOpen { channel: 2 }),
            &healthy(),
            [4.0; 4],
        );
        for _ in 1..OUTPUT_ERROR_DEBOUNCE_PERIODS {
            board.before_step(&mut d);
            assert!(d.controller().faults().is_none());
        }
        board.before_step(&mut d);
        assert!(d.controller().faults().contains(Faults::OUTPUT_OPEN_LOOP));
        assert_eq!(board.converter_currents([12.0; 4])[2], 0.0);
    }

    #[test]
    fn three_overrun_periods_in_a_row_are_a_loop_overrun() {
        let (mut board, mut d) = (Board::new(1000), device());
        board.inject(Injection::Overrun { periods: 3 }, &healthy(), [4.0; 4]);
        for k in 0..3u32 {
            let stall = board.stall_us(1000);
            assert_eq!(stall, 2000);
            let out = board.after_step(&mut d, k * 1000, stall + 20, 1000, [9.0; 4]);
            let faulted = d.controller().faults().contains(Faults::LOOP_OVERRUN);
            assert_eq!(faulted, k == 2, "period {k}");
            assert_eq!(out, if k == 2 { [SAFE_MA; 4] } else { [9.0; 4] });
        }
        assert_eq!(board.stall_us(1000), 0);
    }

    #[test]
    fn the_count_of_missed_periods_is_the_devices_safety_configuration() {
        assert_eq!(
            SafetyConfig::default_1khz().overrun_fault_periods,
            pam_firmware_logic::cycle_stats::DEFAULT_OVERRUN_FAULT_PERIODS,
            "the firmware's boot value and the configuration's default agree"
        );
        let (mut board, mut d) = (Board::new(1000), device());
        let limits = SafetyConfig {
            overrun_fault_periods: 6,
            ..SafetyConfig::default_1khz()
        };
        let reply = d.handle(&pam_protocol::Request {
            id: 1,
            body: pam_protocol::RequestBody::SetConfig(pam_protocol::Config::Limits(limits.into())),
            session: pam_protocol::NO_SESSION,
        });
        assert_eq!(reply.result, Ok(pam_protocol::ReplyData::Done));
        board.inject(Injection::Overrun { periods: 6 }, &healthy(), [4.0; 4]);
        for k in 0..6u32 {
            let stall = board.stall_us(1000);
            board.after_step(&mut d, k * 1000 * 3, stall + 20, 1000, [9.0; 4]);
            let faulted = d.controller().faults().contains(Faults::LOOP_OVERRUN);
            assert_eq!(faulted, k == 5, "period {k}");
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn time_the_thread_does_not_run_is_not_board_time() {
        let clock = StepClock::start();
        std::thread::sleep(std::time::Duration::from_millis(30));
        assert!(clock.elapsed_us() < 5_000, "{} µs", clock.elapsed_us());
    }

    #[test]
    fn parses_board_and_plant_injections_with_their_time() {
        assert_eq!(Injection::parse("estop").unwrap(), Injection::EStop);
        assert_eq!(
            Injection::parse("overrun").unwrap(),
            Injection::Overrun { periods: 5 }
        );
        assert_eq!(
            Injection::parse("overrun:periods=2").unwrap(),
            Injection::Overrun { periods: 2 }
        );
        assert!(Injection::parse("overrun:periods=0").is_err());
        assert_eq!(
            Scheduled::parse("encoder_stuck:joint=1@2.5").unwrap(),
            Scheduled {
                at_s: 2.5,
                injection: Injection::Plant(PlantFault::EncoderStuck { joint: 0 })
            }
        );
        assert!(Scheduled::parse("estop").is_err());
        assert!(Scheduled::parse("estop@-1").is_err());
        assert!(Injection::parse("meteor").is_err());
    }
}
