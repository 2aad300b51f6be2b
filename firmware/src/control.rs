//! The control task: sensors in → `pam_device::Device::step` (front end, controller,
//! supervisor, output trim) → outputs out, once per period, on the high-priority interrupt
//! executor. It is the only feeder of the watchdog, the only writer of the outputs, and it
//! never waits on anything but its ticker (the ADC wait is a bounded poll of ≈1.4 µs).
//!
//! Sharing: the device lives behind a priority-ceiling lock (BASEPRI at the control loop's
//! priority, `pam_fault_paths::ceiling`) so that the link task (thread mode) can apply host
//! requests between two steps. The lock is held for one request or one step (what the DWT
//! execution time reports); the E-stop's interrupt and the time driver stay above it and
//! pre-empt both.
//! Telemetry and fault events leave through channels with `try_send`: when the link lags
//! (or no host is connected) samples are dropped and counted, the loop never blocks.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::{CriticalSectionRawMutex, RawMutex};
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::channel::Channel;
use embassy_time::{Duration, Instant, Ticker};
use pam_control::Faults;
use pam_device::{BoardHealth, Device, RawSensors, StepTiming};
use pam_firmware_logic::board_checks::board_checks;
use pam_firmware_logic::board_revision::BoardRevision;
use pam_protocol::{FaultEvent, Telemetry};

use crate::board;
use crate::current_output::{CurrentLoopOutputs, CHANNELS, LOOP_MIN_MA};
use crate::encoder::QuadratureEncoder;
use crate::estop::{self, EStop};
use crate::load_cell_adc::LoadCellAdc;
use crate::loop_timing::{self, CycleMeter};
use crate::watchdog::LoopWatchdog;

/// Masks the interrupts up to `board::DEVICE_LOCK_CEILING` (the control loop and everything
/// below it) while held; the E-stop and the time driver keep running.
pub struct DeviceLock;

// SAFETY: every context that takes the lock runs at or below the ceiling, where BASEPRI
// excludes all the others; a context above it gets a full critical section instead
// (`with_ceiling`). Single core.
unsafe impl RawMutex for DeviceLock {
    const INIT: Self = DeviceLock;

    fn lock<R>(&self, f: impl FnOnce() -> R) -> R {
        pam_fault_paths::ceiling::with_ceiling(board::DEVICE_LOCK_CEILING, f)
    }
}

/// The device service, shared with the link task. `None` only before `main` installs it.
static DEVICE: Mutex<DeviceLock, RefCell<Option<Device>>> = Mutex::new(RefCell::new(None));

/// Installs the device (once, in `main`, before the tasks start).
pub fn install_device(device: Device) {
    DEVICE.lock(|cell| cell.replace(Some(device)));
}

/// Runs `f` on the device under the device lock. `None` if no device is installed (or,
/// impossible with interrupts masked, if it were already borrowed): never panics.
pub fn with_device<R>(f: impl FnOnce(&mut Device) -> R) -> Option<R> {
    DEVICE.lock(|cell| {
        let mut guard = cell.try_borrow_mut().ok()?;
        guard.as_mut().map(f)
    })
}

pub const TELEMETRY_DEPTH: usize = 16;
/// Filled by the control task at the loop rate (or the telemetry divider's), drained by
/// the link.
pub static TELEMETRY: Channel<CriticalSectionRawMutex, Telemetry, TELEMETRY_DEPTH> = Channel::new();
/// New latched faults, for the link to report as events.
pub static FAULT_EVENTS: Channel<CriticalSectionRawMutex, FaultEvent, 4> = Channel::new();
/// Telemetry samples and fault events the control task could not queue.
pub static TELEMETRY_DROPPED: AtomicU32 = AtomicU32::new(0);
pub static FAULT_EVENTS_DROPPED: AtomicU32 = AtomicU32::new(0);

/// The peripherals the control loop owns.
pub struct ControlHardware {
    pub encoder1: QuadratureEncoder<'static, board::Encoder1Timer>,
    pub encoder2: QuadratureEncoder<'static, board::Encoder2Timer>,
    pub load_cell: LoadCellAdc,
    pub outputs: CurrentLoopOutputs,
    pub estop: EStop,
    pub watchdog: LoopWatchdog,
    pub meter: CycleMeter,
    /// Read from the straps at boot: a board whose outputs are not safe in reset is never
    /// armed (`BOARD_CHECK_OUTPUT_STAGE` keeps `SELF_CHECK` raised).
    pub board_revision: BoardRevision,
}

/// The device's period kept inside the 1–10 ms the firmware supports (the device's own
/// validation already refuses anything else).
fn bounded_period_us(period_us: u32) -> u32 {
    period_us.clamp(1_000, 10_000)
}

pub fn period_cycles(period_us: u32) -> u32 {
    period_us * (board::SYSCLK_HZ / 1_000_000)
}

fn saturating_us(cycles: u32) -> u16 {
    (loop_timing::ns(cycles) / 1_000).min(u32::from(u16::MAX)) as u16
}

#[embassy_executor::task]
pub async fn control_task(mut hw: ControlHardware) {
    let mut period_us = bounded_period_us(with_device(|d| d.period_us()).unwrap_or(1_000));
    hw.meter.set_period(period_cycles(period_us));
    let mut ticker = Ticker::every(Duration::from_micros(u64::from(period_us)));
    let mut last_exec_cycles: u32 = 0;

    loop {
        let jitter_cycles = hw.meter.cycle_start();

        // The extended counts, truncated: the device extends them again modulo 2^32, which
        // is exact for any motion below 2^31 counts per period.
        let encoder_counts =
            [hw.encoder1.read_counts(), hw.encoder2.read_counts()].map(|count| count as u32);
        let adc = hw.load_cell.read();
        hw.load_cell.vdda_tick();
        let vdda_v = hw.load_cell.vdda_v();
        let board_checks = board_checks(hw.board_revision, hw.load_cell.dual_mode_ok(), vdda_v);
        let open_loop = hw.outputs.poll_open_loop();
        let stopped = hw.estop.poll();
        let (loadcell_volts, saturated) = match adc {
            Ok(sample) => (sample.volts, sample.saturated),
            // No reading this period: NaN makes the supervisor latch NON_FINITE.
            Err(_) => ([f32::NAN; 2], false),
        };
        let raw = RawSensors {
            encoder_counts,
            loadcell_volts,
        };
        let timing = StepTiming {
            time_us: Instant::now().as_micros() as u32,
            loop_exec_us: saturating_us(last_exec_cycles),
            loop_jitter_us: saturating_us(jitter_cycles),
        };

        let stepped = with_device(|device| {
            if stopped {
                device.raise(Faults::ESTOP);
            }
            if saturated {
                device.raise(Faults::LOADCELL_SATURATED);
            }
            if open_loop.iter().any(|&open| open) {
                device.raise(Faults::OUTPUT_OPEN_LOOP);
            }
            // a failing check keeps SELF_CHECK raised (pam-device)
            device.set_board_health(BoardHealth {
                board_checks,
                vdda_v,
                ..device.board_health()
            });
            let result = device.step(raw, timing);
            (
                result,
                device.period_us(),
                device.controller().safety().overrun_fault_periods,
            )
        });

        match &stepped {
            // a press during the step wins over its result (the handler has vented already)
            Some(_) if estop::tripped() => hw.outputs.write_ma([LOOP_MIN_MA; CHANNELS]),
            Some((result, _, _)) => hw.outputs.write_ma(result.current_ma),
            // No device (cannot happen once main has run): hold the safe state.
            None => hw.outputs.write_ma([LOOP_MIN_MA; CHANNELS]),
        };
        // A press during the write above may have been overwritten by it: look again (the
        // compares are preloaded, so within a PWM period the loops never see the result).
        if estop::tripped() {
            hw.outputs.write_ma([LOOP_MIN_MA; CHANNELS]);
        }
        hw.watchdog.feed();
        if let Some(&(_, _, overrun_fault_periods)) = stepped.as_ref() {
            hw.meter.set_overrun_fault_periods(overrun_fault_periods);
        }
        let loop_timing = hw.meter.cycle_end();
        last_exec_cycles = loop_timing.exec_last_cycles;
        if loop_timing.overrun_fault {
            // the loop no longer keeps its rate: latch (vents from the next step on, which
            // also writes the outputs) and vent now
            with_device(|device| device.raise(Faults::LOOP_OVERRUN));
            hw.outputs.write_ma([LOOP_MIN_MA; CHANNELS]);
        }

        if let Some((result, wanted_period_us, _)) = stepped {
            if let Some(sample) = result.telemetry {
                if TELEMETRY.try_send(sample).is_err() {
                    TELEMETRY_DROPPED.fetch_add(1, Ordering::Relaxed);
                }
            }
            if let Some(event) = result.fault_event {
                if FAULT_EVENTS.try_send(event).is_err() {
                    FAULT_EVENTS_DROPPED.fetch_add(1, Ordering::Relaxed);
                }
            }
            let wanted = bounded_period_us(wanted_period_us);
            if wanted != period_us {
                period_us = wanted;
                hw.meter.set_period(period_cycles(period_us));
                ticker = Ticker::every(Duration::from_micros(u64::from(period_us)));
            }
        }

        ticker.next().await;
    }
}
