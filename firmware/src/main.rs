//! PAM rehabilitation robot firmware for the NUCLEO-G474RE (STM32G474RE, Cortex-M4F).
//!
//! Two executors, after embassy's `multiprio` example:
//! * a high-priority interrupt executor (`board::CONTROL_IRQ`) runs the control loop
//!   ([`control`]), so the link and logging can never delay it;
//! * the thread-mode executor runs the low-priority work: the USB link ([`link`]), the
//!   heartbeat LED and a once-per-second status log.
//!
//! The hardware-independent work (sensor front end, controller, supervisor, request
//! handling) is `pam_device::Device`; this crate only wires it to the peripherals.
//!
//! Boot order puts the outputs in the safe state first: until the timer is configured the
//! hardware holds 0 mA (vent); the first driver set up is the output stage, at 4 mA (vent).
//! Every board choice is in [`board`]; each driver is a module of its own.

#![no_std]
#![no_main]

mod board;
mod config_flash;
mod control;
mod current_output;
mod encoder;
mod estop;
mod fault_board;
mod link;
mod load_cell_adc;
mod loop_timing;
mod watchdog;

use core::sync::atomic::Ordering;

use cortex_m_rt::entry;
use defmt::{info, unwrap, warn};
use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor};
use embassy_stm32::gpio::{Input, Level, Output, Speed};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::InterruptExt;
use embassy_stm32::usb::Driver;
use embassy_time::Timer;
use embassy_usb::class::cdc_acm::{CdcAcmClass, State};
use pam_control::{Faults, SafetyConfig};
use pam_device::{BoardHealth, Device, DeviceOptions};
use pam_firmware_logic::board_revision::BoardRevision;
use pam_model::RobotParams;
use pam_protocol::Version;
use static_cell::StaticCell;

use crate::board::Board;
use crate::control::{ControlHardware, FAULT_EVENTS_DROPPED, TELEMETRY_DROPPED};
use crate::current_output::{CurrentLoopOutputs, CHANNELS};
use crate::encoder::QuadratureEncoder;
use crate::loop_timing::CycleMeter;
use crate::watchdog::{LoopWatchdog, ResetCause};

static CONTROL_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
static THREAD_EXECUTOR: StaticCell<Executor> = StaticCell::new();

/// Buffers of the USB stack (descriptors, control transfers, CDC-ACM state).
static USB_CONFIG_DESCRIPTOR: StaticCell<[u8; 256]> = StaticCell::new();
static USB_BOS_DESCRIPTOR: StaticCell<[u8; 256]> = StaticCell::new();
static USB_CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
static USB_CDC_STATE: StaticCell<State> = StaticCell::new();

#[interrupt]
unsafe fn UART4() {
    unsafe { CONTROL_EXECUTOR.on_interrupt() }
}

/// The crate version, for the protocol's handshake.
const FIRMWARE_VERSION: Version = Version {
    major: parse_u16(env!("CARGO_PKG_VERSION_MAJOR")),
    minor: parse_u16(env!("CARGO_PKG_VERSION_MINOR")),
    patch: parse_u16(env!("CARGO_PKG_VERSION_PATCH")),
};

const fn parse_u16(digits: &str) -> u16 {
    let bytes = digits.as_bytes();
    let mut value: u16 = 0;
    let mut i = 0;
    while i < bytes.len() {
        value = value * 10 + (bytes[i] - b'0') as u16;
        i += 1;
    }
    value
}

/// Low-priority heartbeat on LD2: 1 Hz blink while the thread-mode executor is alive.
#[embassy_executor::task]
async fn heartbeat(mut led: Output<'static>) {
    loop {
        led.toggle();
        Timer::after_millis(500).await;
    }
}

/// Once per second: loop timing (the shared summary), stack high-water mark and drop
/// counters over defmt; latches STACK_LOW when the free stack falls below its margin.
#[embassy_executor::task]
async fn status_log() {
    loop {
        Timer::after_secs(1).await;
        let stack = fault_board::stack_usage();
        control::with_device(|d| {
            if stack.free_min_bytes() < board::STACK_MIN_FREE_BYTES {
                d.raise(Faults::STACK_LOW);
            }
            // for `pamctl status`
            d.set_board_health(BoardHealth {
                stack: Some(fault_board::wire_stack(stack)),
                ..d.board_health()
            });
        });
        let t = loop_timing::snapshot();
        let state = control::with_device(|d| (d.controller().state(), d.controller().faults().0));
        info!(
            "loop: {} cycles, exec {} ns (max {}), jitter max {} ns, overruns {}; stack {} of {} B used (max); telemetry dropped {}, fault events dropped {}; config-page ECC errors survived {}; state {}",
            t.cycles,
            loop_timing::ns(t.exec_last_cycles),
            loop_timing::ns(t.exec_max_cycles),
            loop_timing::ns(t.jitter_max_cycles),
            t.overruns,
            stack.used_max_bytes,
            stack.size_bytes,
            TELEMETRY_DROPPED.load(Ordering::Relaxed),
            FAULT_EVENTS_DROPPED.load(Ordering::Relaxed),
            fault_board::tolerated_ecc_errors(),
            state.map(|(s, f)| (s as u8, f)),
        );
    }
}

/// The interface board's revision from its straps (pull-ups; read once, then released).
fn read_board_revision(
    strap0: embassy_stm32::Peri<'static, embassy_stm32::peripherals::PC10>,
    strap1: embassy_stm32::Peri<'static, embassy_stm32::peripherals::PC11>,
) -> BoardRevision {
    let s0 = Input::new(strap0, board::BOARD_STRAP_PULL);
    let s1 = Input::new(strap1, board::BOARD_STRAP_PULL);
    // the pull-ups charge the pins' capacitance in well under a microsecond
    cortex_m::asm::delay(1_000);
    BoardRevision::from_straps(s0.is_high(), s1.is_high())
}

/// The session tokens' nonce for this boot, from the random number generator (its driver
/// discards the first word and re-seeds on a seed or clock error; the generator is then
/// switched off).
fn draw_boot_nonce(rng: embassy_stm32::Peri<'static, embassy_stm32::peripherals::RNG>) -> u32 {
    let mut rng = embassy_stm32::rng::Rng::new(rng, board::RngIrqs);
    rng.next_u32()
}

#[entry]
fn main() -> ! {
    // Before anything can reset again: why did the last reset happen, and did a CPU fault
    // handler leave a record?
    let reset_cause = ResetCause::take();
    let cpu_fault = fault_board::take_fault_record();
    let mut core = unwrap!(cortex_m::Peripherals::take());
    fault_board::enable_fault_exceptions(&mut core.SCB);
    let stack_guard = fault_board::enable_stack_guard(&mut core.MPU, board::STACK_MIN_FREE_BYTES);
    let board = Board::new(embassy_stm32::init(board::clock_config()));

    // Outputs first: from here the loops carry 4 mA (vent) until the controller says more.
    let outputs = CurrentLoopOutputs::new(board.outputs, [board::output_nominal_law(); CHANNELS]);
    // the buffers drive VIN only from here on, at the 4 mA compare (revised output stage;
    // on the first board /OE is tied low and the pin is unconnected). Never dropped; the
    // fault paths set it high with a plain store.
    core::mem::forget(Output::new(board.output_enable, Level::Low, Speed::Low));
    // the stop's handler writes the outputs' safe compares: after they exist
    let estop = estop::EStop::new(board.estop);
    let board_revision = read_board_revision(board.strap0, board.strap1);
    let boot_nonce = draw_boot_nonce(board.rng);
    fault_board::paint_stack();
    info!(
        "pam-firmware {}: STM32G474RE at 170 MHz, reset cause {}, stack guard {}, board revision {} (outputs safe in reset: {})",
        env!("CARGO_PKG_VERSION"),
        reset_cause,
        stack_guard,
        board_revision.number(),
        board_revision.outputs_safe_in_reset()
    );
    if !board_revision.outputs_safe_in_reset() {
        warn!("this board's output stage can drive current while the MCU is in reset: arming refused (SELF_CHECK, board check OUTPUT_STAGE)");
    }

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
    let load_cell = load_cell_adc::LoadCellAdc::new(board.load_cell);

    // The thesis parameters, then the record in flash if there is a good one
    // (`pam_device::storage` for what a missing or bad record does).
    let mut store = config_flash::open(board.flash);
    let mut device = Device::new(
        RobotParams::thesis(),
        SafetyConfig::default_1khz(),
        DeviceOptions {
            firmware_version: FIRMWARE_VERSION,
            // the encoder driver delivers 64-bit extended counts, passed on as u32
            encoder_counter_bits: 32,
            boot_nonce,
        },
    );
    device.boot_config(match store.as_mut() {
        Ok(store) => store.load(),
        Err(e) => Err(*e),
    });
    // ConfigOrigin's variant index (docs/protocol.md): 0 flash, 1 no record, 2 corrupt…
    info!("config: origin {}", device.config_origin() as u8);
    if reset_cause.is_watchdog() {
        warn!("the last reset was a watchdog reset: latched WATCHDOG_RESET");
        device.raise(Faults::WATCHDOG_RESET);
    }
    if let Some(record) = cpu_fault {
        warn!(
            "the last run ended in a fault path: latched CPU_FAULT ({=str}, pc {=u32:#010x}, cfsr {=u32:#010x}, hfsr {=u32:#010x}, address {=u32:#010x})",
            record.kind.name(),
            record.pc,
            record.cfsr,
            record.hfsr,
            record.address
        );
        device.raise(Faults::CPU_FAULT);
        device.set_board_health(BoardHealth {
            last_cpu_fault: fault_board::wire_record(record),
            ..device.board_health()
        });
    }
    if !board_revision.outputs_safe_in_reset() {
        // from the first request on, not only from the first control step
        device.set_board_health(BoardHealth {
            board_checks: pam_protocol::BOARD_CHECK_OUTPUT_STAGE,
            ..device.board_health()
        });
        device.raise(Faults::SELF_CHECK);
    }
    let period_us = device.period_us();
    control::install_device(device);

    let meter = CycleMeter::new(
        &mut core.DCB,
        &mut core.DWT,
        control::period_cycles(period_us),
    );

    // USB link (started in thread mode below; its interrupt below the control loop's).
    let driver = Driver::new(board.usb.usb, board::UsbIrqs, board.usb.dp, board.usb.dm);
    board::USB_IRQ.set_priority(board::LINK_PRIORITY);
    let mut usb_config = embassy_usb::Config::new(link::USB_VID, link::USB_PID);
    usb_config.manufacturer = Some("PAM rehabilitation robot");
    usb_config.product = Some("pam-firmware (NUCLEO-G474RE)");
    usb_config.max_power = 100;
    let mut builder = embassy_usb::Builder::new(
        driver,
        usb_config,
        USB_CONFIG_DESCRIPTOR.init([0; 256]),
        USB_BOS_DESCRIPTOR.init([0; 256]),
        &mut [], // no Microsoft OS descriptors
        USB_CONTROL_BUF.init([0; 64]),
    );
    let class = CdcAcmClass::new(
        &mut builder,
        USB_CDC_STATE.init(State::new()),
        link::USB_PACKET_BYTES as u16,
    );
    let usb = builder.build();

    // Last before the loop starts: from here only the control task keeps the MCU alive.
    let watchdog = LoopWatchdog::start(board.watchdog);
    let hardware = ControlHardware {
        encoder1,
        encoder2,
        load_cell,
        outputs,
        estop,
        watchdog,
        meter,
        board_revision,
    };

    board::CONTROL_IRQ.set_priority(board::CONTROL_PRIORITY);
    let spawner = CONTROL_EXECUTOR.start(board::CONTROL_IRQ);
    spawner.spawn(unwrap!(control::control_task(hardware)));

    // Thread mode: everything else.
    let led = Output::new(board.led, Level::Low, Speed::Low);
    let executor = THREAD_EXECUTOR.init(Executor::new());
    executor.run(|spawner| {
        spawner.spawn(unwrap!(link::usb_task(usb)));
        spawner.spawn(unwrap!(link::link_task(class, store.ok())));
        spawner.spawn(unwrap!(heartbeat(led)));
        spawner.spawn(unwrap!(status_log()));
    })
}
