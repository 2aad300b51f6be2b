//! The control task: sensors in → `pam_control::Controller::step` → outputs out, once per
//! period, on the high-priority interrupt executor. It is the only feeder of the
//! watchdog, the only writer of the outputs, and it never waits on anything but its
//! ticker (the ADC wait is a bounded poll of ≈1.4 µs).
//!
//! Sharing: the controller lives in a critical-section mutex so that the link task (thread
//! mode) can apply host commands between two steps. The link's critical sections are one
//! command long; the step's is one step long (a few µs), which is what the DWT execution
//! time reports. Telemetry leaves through a channel with `try_send`: when the consumer lags,
//! samples are dropped and counted, the loop never blocks.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::channel::Channel;
use embassy_time::{Duration, Ticker};
use pam_control::{Controller, Faults, Sensors, StepOutput};

use crate::board;
use crate::convert::SensorConversion;
use crate::current_output::{CurrentLoopOutputs, CHANNELS, LOOP_MIN_MA};
use crate::encoder::QuadratureEncoder;
use crate::load_cell_adc::LoadCellAdc;
use crate::loop_timing::{CycleMeter, LoopTiming};
use crate::watchdog::LoopWatchdog;

/// The controller, shared with the link task. `None` only before `main` installs it.
pub static CONTROLLER: Mutex<CriticalSectionRawMutex, RefCell<Option<Controller>>> =
    Mutex::new(RefCell::new(None));

/// One control period, as the link sends it to the host.
#[derive(Clone, Copy, Debug)]
pub struct TelemetrySample {
    /// Increments every period, so the host can count dropped samples.
    pub seq: u32,
    pub encoder_counts: [i64; 2],
    pub load_cell_volts: [f32; 2],
    pub sensors: Sensors,
    pub output: StepOutput,
    /// What reached the current loops (after the driver's 4–20 mA clamp).
    pub applied_ma: [f32; CHANNELS],
    pub timing: LoopTiming,
}

pub const TELEMETRY_DEPTH: usize = 16;
/// Filled by the control task at the loop rate, drained by the link (or the log task).
pub static TELEMETRY: Channel<CriticalSectionRawMutex, TelemetrySample, TELEMETRY_DEPTH> =
    Channel::new();
/// Samples the control task could not queue because the consumer lagged.
pub static TELEMETRY_DROPPED: AtomicU32 = AtomicU32::new(0);

/// The peripherals the control loop owns.
pub struct ControlHardware {
    pub encoder1: QuadratureEncoder<'static, board::Encoder1Timer>,
    pub encoder2: QuadratureEncoder<'static, board::Encoder2Timer>,
    pub load_cell: LoadCellAdc,
    pub outputs: CurrentLoopOutputs,
    pub watchdog: LoopWatchdog,
    pub meter: CycleMeter,
}

/// The period the controller is configured for, in µs, kept inside the 1–10 ms the
/// firmware supports (the controller's own validation already refuses anything else).
fn period_us(controller_period_s: f32) -> u64 {
    let us = controller_period_s * 1.0e6 + 0.5;
    if us.is_nan() {
        1_000
    } else {
        (us as u64).clamp(1_000, 10_000)
    }
}

pub fn period_cycles(period_us: u64) -> u32 {
    (period_us * u64::from(board::SYSCLK_HZ / 1_000_000)) as u32
}

#[embassy_executor::task]
pub async fn control_task(mut hw: ControlHardware, conversion: SensorConversion) {
    let mut period = CONTROLLER.lock(|c| {
        c.borrow()
            .as_ref()
            .map_or(1_000, |ctrl| period_us(ctrl.safety().period_s))
    });
    hw.meter.set_period(period_cycles(period));
    let mut ticker = Ticker::every(Duration::from_micros(period));
    let mut seq: u32 = 0;

    loop {
        hw.meter.cycle_start();

        let encoder_counts = [hw.encoder1.read_counts(), hw.encoder2.read_counts()];
        let alpha_rad = conversion.alpha_rad(encoder_counts);
        let adc = hw.load_cell.read();
        let open_loop = hw.outputs.poll_open_loop();

        let stepped = CONTROLLER.lock(|cell| {
            let Ok(mut guard) = cell.try_borrow_mut() else {
                return None;
            };
            let ctrl = guard.as_mut()?;
            let (volts, force_sensor_n) = match adc {
                Ok(sample) => {
                    if sample.saturated {
                        ctrl.raise(Faults::LOADCELL_SATURATED);
                    }
                    let forces = SensorConversion::force_sensor_n(
                        &ctrl.model().params.load_cell,
                        sample.volts,
                    );
                    (sample.volts, forces)
                }
                // No reading this period: NaN makes the supervisor latch NON_FINITE.
                Err(_) => ([f32::NAN; 2], [f32::NAN; 2]),
            };
            if open_loop.iter().any(|&open| open) {
                ctrl.raise(Faults::OUTPUT_OPEN_LOOP);
            }
            let sensors = Sensors {
                alpha_rad,
                force_sensor_n,
            };
            let output = ctrl.step(&sensors);
            Some((sensors, volts, output, ctrl.safety().period_s))
        });

        let applied = match &stepped {
            Some((_, _, output, _)) => hw.outputs.write_ma(output.current_ma),
            // No controller (cannot happen once main has run): hold the safe state.
            None => hw.outputs.write_ma([LOOP_MIN_MA; CHANNELS]),
        };
        hw.watchdog.feed();
        let timing = hw.meter.cycle_end();

        if let Some((sensors, volts, output, period_s)) = stepped {
            let sample = TelemetrySample {
                seq,
                encoder_counts,
                load_cell_volts: volts,
                sensors,
                output,
                applied_ma: applied.current_ma,
                timing,
            };
            if TELEMETRY.try_send(sample).is_err() {
                TELEMETRY_DROPPED.fetch_add(1, Ordering::Relaxed);
            }
            let wanted = period_us(period_s);
            if wanted != period {
                period = wanted;
                hw.meter.set_period(period_cycles(period));
                ticker = Ticker::every(Duration::from_micros(period));
            }
        }
        seq = seq.wrapping_add(1);

        ticker.next().await;
    }
}
