//! PAM rehabilitation robot firmware for the NUCLEO-G474RE (STM32G474RE, Cortex-M4F).
//!
//! Two executors, after embassy's `multiprio` example:
//! * a high-priority interrupt executor (on the otherwise unused UART4 vector) runs the
//!   1 kHz control loop, so it preempts everything else;
//! * the thread-mode executor runs the low-priority work (for now: the LD2 heartbeat).
//!
//! The pin map and every other board choice is in [`board`].

#![no_std]
#![no_main]

mod board;

use core::hint::black_box;

use cortex_m_rt::entry;
use defmt::{info, unwrap, warn};
use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor};
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::Config;
use embassy_time::{Duration, Instant, Ticker, Timer};
use pam_model::RobotModel;
use panic_probe as _;
use static_cell::StaticCell;

use crate::board::Board;

/// Control period (1 kHz).
const CONTROL_PERIOD: Duration = Duration::from_millis(1);
/// Log the control state every this many periods (1 s).
const LOG_EVERY: u32 = 1000;
/// Neutral pose: both joint angles zero (handle at the user-frame origin).
const NEUTRAL_ALPHA_RAD: [f32; 2] = [0.0, 0.0];
/// A safe, soft joint stiffness: just above the lowest attainable at the neutral pose
/// (Table 4.1 row 1: K_low = 60.8 and 26.6 N·m/rad).
const SAFE_STIFFNESS_NM_PER_RAD: [f32; 2] = [65.0, 30.0];

static CONTROL_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
static THREAD_EXECUTOR: StaticCell<Executor> = StaticCell::new();

#[interrupt]
unsafe fn UART4() {
    unsafe { CONTROL_EXECUTOR.on_interrupt() }
}

/// The 1 kHz control loop. For now it evaluates the model at the neutral pose with zero
/// torque and logs the channel currents once per second.
#[embassy_executor::task]
async fn control_loop() {
    let model = RobotModel::<f32>::thesis();
    let ip = model.params.ip;

    let mut ticker = Ticker::every(CONTROL_PERIOD);
    let mut tick: u32 = 0;
    let mut max_eval_us: u64 = 0;
    let mut overruns: u32 = 0;

    loop {
        let start = Instant::now();

        // TODO(issue 4): read the two joint encoders (board::Encoder1/Encoder2, TIM2/TIM5
        // in encoder mode) and convert counts to joint angles. Until then: neutral pose.
        let alpha_rad = black_box(NEUTRAL_ALPHA_RAD);
        // TODO(issue 4): read the load cell (board::LoadCell, ADC1 on PC0/PC1), convert
        // with model.params.load_cell.forces_n and turn the force request into joint
        // torques. Until then: zero torque.
        let torque_nm = black_box([0.0f32; 2]);

        let joints = model.inverse(alpha_rad, torque_nm, SAFE_STIFFNESS_NM_PER_RAD);
        let channel_bar =
            model.channel_pressures_bar([joints[0].pressure_bar, joints[1].pressure_bar]);
        let commands = channel_bar.map(|p| ip.current_for(p));

        // TODO(issue 4): write commands[n].current_ma to 4–20 mA channel n+1
        // (board::CurrentOutputs, TIM3 PWM CH1–CH4 on PC6–PC9).
        let commands = black_box(commands);

        let eval_us = start.elapsed().as_micros();
        max_eval_us = max_eval_us.max(eval_us);
        if eval_us >= CONTROL_PERIOD.as_micros() {
            overruns += 1;
        }

        if tick.is_multiple_of(LOG_EVERY) {
            info!(
                "control t={}s: P={} bar, I={} mA, limited=[{},{}], saturated={}, eval max {} us, overruns {}",
                tick / LOG_EVERY,
                channel_bar,
                commands.map(|c| c.current_ma),
                joints[0].limited.0,
                joints[1].limited.0,
                commands.map(|c| c.saturated),
                max_eval_us,
                overruns,
            );
            if !(joints[0].limited.is_none() && joints[1].limited.is_none()) {
                warn!("inverse model limited the neutral-pose request");
            }
            max_eval_us = 0;
        }
        tick = tick.wrapping_add(1);

        ticker.next().await;
    }
}

/// Low-priority heartbeat on LD2: 1 Hz blink while the thread-mode executor is alive.
#[embassy_executor::task]
async fn heartbeat(mut led: Output<'static>) {
    loop {
        led.toggle();
        Timer::after_millis(500).await;
    }
}

#[entry]
fn main() -> ! {
    let mut config = Config::default();
    {
        // 170 MHz from the 16 MHz HSI: 16 / 4 * 85 / 2 (the G4's maximum, boost mode).
        use embassy_stm32::rcc::*;
        config.rcc.hsi = true;
        config.rcc.pll = Some(Pll {
            source: PllSource::HSI,
            prediv: PllPreDiv::DIV4,
            mul: PllMul::MUL85,
            divp: None,
            divq: None,
            divr: Some(PllRDiv::DIV2),
        });
        config.rcc.sys = Sysclk::PLL1_R;
    }
    let board = Board::new(embassy_stm32::init(config));
    info!("pam-firmware: STM32G474RE at 170 MHz");

    // High priority: the control loop, preempting the thread-mode executor.
    interrupt::UART4.set_priority(Priority::P6);
    let spawner = CONTROL_EXECUTOR.start(interrupt::UART4);
    spawner.spawn(unwrap!(control_loop()));

    // Thread mode: everything else.
    let led = Output::new(board.led, Level::Low, Speed::Low);
    let executor = THREAD_EXECUTOR.init(Executor::new());
    executor.run(|spawner| {
        spawner.spawn(unwrap!(heartbeat(led)));
    })
}
