//! PAM rehabilitation robot firmware for the NUCLEO-G474RE (STM32G474RE, Cortex-M4F).
//!
//! Two executors, after embassy's `multiprio` example:
//! * a high-priority interrupt executor (`board::CONTROL_IRQ`) runs the control loop
//!   ([`control`]), so the link and logging can never delay it;
//! * the thread-mode executor runs the low-priority work: heartbeat LED, telemetry.
//!
//! Boot order puts the outputs in the safe state first: until the timer is configured the
//! hardware holds 0 mA (vent); the first driver set up is the output stage, at 4 mA (vent).
//! Every board choice is in [`board`]; each driver is a module of its own.

#![no_std]
#![no_main]

mod board;
mod control;
mod convert;
mod current_output;
mod encoder;
mod load_cell_adc;
mod loop_timing;
mod panic;
mod watchdog;

use cortex_m_rt::entry;
use defmt::{info, unwrap, warn};
use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor};
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::InterruptExt;
use embassy_time::Timer;
use pam_control::{Controller, Faults, SafetyConfig};
use pam_model::RobotModel;
use static_cell::StaticCell;

use crate::board::Board;
use crate::control::{ControlHardware, CONTROLLER, TELEMETRY, TELEMETRY_DROPPED};
use crate::convert::SensorConversion;
use crate::current_output::CurrentLoopOutputs;
use crate::encoder::QuadratureEncoder;
use crate::load_cell_adc::LoadCellAdc;
use crate::loop_timing::{CycleMeter, LoopTiming};
use crate::watchdog::{LoopWatchdog, ResetCause};

/// Log a telemetry summary every this many samples (1 s at 1 kHz).
const LOG_EVERY_SAMPLES: u32 = 1000;

static CONTROL_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
static THREAD_EXECUTOR: StaticCell<Executor> = StaticCell::new();

#[interrupt]
unsafe fn UART4() {
    unsafe { CONTROL_EXECUTOR.on_interrupt() }
}

/// Low-priority heartbeat on LD2: 1 Hz blink while the thread-mode executor is alive.
#[embassy_executor::task]
async fn heartbeat(mut led: Output<'static>) {
    loop {
        led.toggle();
        Timer::after_millis(500).await;
    }
}

/// Drains the telemetry channel and logs a summary once per second over defmt. The USB
/// link task replaces it as the channel's consumer when the protocol crate lands.
#[embassy_executor::task]
async fn telemetry_log() {
    loop {
        let s = TELEMETRY.receive().await;
        if s.seq % LOG_EVERY_SAMPLES == 0 {
            // The maxima from the shared summary (the path a reader without the channel
            // uses), this period's execution time from the sample.
            let t = loop_timing::snapshot();
            info!(
                "seq {} state {} faults {=u16:#x} counts {} alpha {} rad U {} V F_sensor {} N I {} mA | exec {} ns (max {}), jitter max {} ns, overruns {}, dropped {}",
                s.seq,
                s.output.state as u8,
                s.output.faults.0,
                s.encoder_counts,
                s.sensors.alpha_rad,
                s.load_cell_volts,
                s.sensors.force_sensor_n,
                s.applied_ma,
                LoopTiming::cycles_to_ns(s.timing.exec_last_cycles),
                LoopTiming::cycles_to_ns(t.exec_max_cycles),
                LoopTiming::cycles_to_ns(t.jitter_max_cycles),
                t.overruns,
                TELEMETRY_DROPPED.load(core::sync::atomic::Ordering::Relaxed),
            );
        }
    }
}

#[entry]
fn main() -> ! {
    // Before anything can reset again: why did the last reset happen?
    let reset_cause = ResetCause::take();
    let board = Board::new(embassy_stm32::init(board::clock_config()));

    // Outputs first: from here the loops carry 4 mA (vent) until the controller says more.
    let outputs = CurrentLoopOutputs::new(board.outputs);
    info!("pam-firmware: STM32G474RE at 170 MHz, reset cause {}", reset_cause);

    let encoder1 = QuadratureEncoder::new(
        board.encoder1.timer,
        board.encoder1.ch_a,
        board.encoder1.ch_b,
    );
    let encoder2 = QuadratureEncoder::new(
        board.encoder2.timer,
        board.encoder2.ch_a,
        board.encoder2.ch_b,
    );
    let load_cell = LoadCellAdc::new(board.load_cell);

    let mut controller = Controller::new(RobotModel::<f32>::thesis(), SafetyConfig::default_1khz());
    if reset_cause.is_watchdog() {
        warn!("the last reset was a watchdog reset: latched WATCHDOG_RESET");
        controller.raise(Faults::WATCHDOG_RESET);
    }
    let period_cycles = control::period_cycles(1_000);
    CONTROLLER.lock(|c| c.replace(Some(controller)));

    let mut core = unwrap!(cortex_m::Peripherals::take());
    let meter = CycleMeter::new(&mut core.DCB, &mut core.DWT, period_cycles);

    // Last before the loop starts: from here only the control task keeps the MCU alive.
    let watchdog = LoopWatchdog::start(board.watchdog);
    let hardware = ControlHardware {
        encoder1,
        encoder2,
        load_cell,
        outputs,
        watchdog,
        meter,
    };

    board::CONTROL_IRQ.set_priority(board::CONTROL_PRIORITY);
    let spawner = CONTROL_EXECUTOR.start(board::CONTROL_IRQ);
    spawner.spawn(unwrap!(control::control_task(
        hardware,
        SensorConversion::at_power_up()
    )));

    // Thread mode: everything else.
    let led = Output::new(board.led, Level::Low, Speed::Low);
    let executor = THREAD_EXECUTOR.init(Executor::new());
    executor.run(|spawner| {
        spawner.spawn(unwrap!(heartbeat(led)));
        spawner.spawn(unwrap!(telemetry_log()));
    })
}
