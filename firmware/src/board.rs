//! Every board choice of the NUCLEO-G474RE build, in one place: pins, peripherals, clocks,
//! the analogue front ends the drivers assume and the register blocks reached directly.
//! Porting to another STM32 means rewriting this file (and nothing else, as long as the
//! new chip has the same kinds of peripheral).
//!
//! | Function                         | Peripheral        | Pins (alternate function)     | Nucleo connector |
//! |----------------------------------|-------------------|-------------------------------|------------------|
//! | Joint 1 encoder (A/B quadrature) | TIM2, 32-bit      | PA0 CH1 (AF1), PA1 CH2 (AF1)  | Arduino A0, A1   |
//! | Joint 2 encoder (A/B quadrature) | TIM5, 32-bit      | PB2 CH1 (AF2), PC12 CH2 (AF1) | morpho           |
//! | Load cell X (eq. 2.1 volts)      | ADC1 (master)     | PC0 = ADC12_IN6               | Arduino A5       |
//! | Load cell Z                      | ADC2 (slave)      | PC1 = ADC12_IN7               | Arduino A4       |
//! | 4–20 mA channels 1–4 (I/P conv.) | TIM3 PWM CH1–CH4  | PC6, PC7, PC8, PC9 (AF2)      | morpho           |
//! | XTR111 error flags, ch. 1–4      | GPIO in, pull-up  | PB12, PB13, PB14, PB15        | morpho           |
//! | USB FS device                    | USB               | PA12 DP, PA11 DM              | morpho           |
//! | Heartbeat LED (LD2)              | GPIO              | PA5                           | Arduino D13      |
//! | Emergency stop (NC contact)      | EXTI0, GPIO in    | PB0, pull-up; high = stop     | Arduino A3       |
//! | Output buffers enable (OUT_EN#)  | GPIO out          | PB1, low = enabled            | morpho           |
//! | Board revision straps 0, 1       | GPIO in, pull-up  | PC10, PC11 (read at boot)     | morpho CN7       |
//! | embassy-time driver              | TIM15             | none                          | —                |
//! | Control-loop executor            | UART4 IRQ vector  | none (UART4 unused)           | —                |
//! | Loop watchdog                    | IWDG (LSI clock)  | none                          | —                |
//!
//! (Connector positions: check UM2505, the NUCLEO-G474RE user manual, before wiring.)
//!
//! * Both encoders sit on the two 32-bit timers; the driver reads the low 16 bits and
//!   extends them in software, so a 16-bit timer would do as well on another chip.
//! * The load cell's two channels are converted by two ADCs in dual injected-simultaneous
//!   mode (ADC1 master, ADC2 slave), so both are sampled at the same instant. PC0 and PC1
//!   reach both ADC1 and ADC2 (`ADC12_IN6/7`), which is why the pair is on them.
//! * The four outputs are PWM channels of one timer (same period, updated together);
//!   each feeds a 2nd-order RC filter and an XTR111 voltage-to-current stage
//!   (`docs/output-stage.md`). Channel *n* is channel *n* of
//!   `RobotModel::channel_pressures_bar`. The on-chip DACs cannot serve: only three DAC
//!   outputs reach pins (PA4, PA5, PA6) and PA5 is LD2.
//! * PA2/PA3 stay free for the ST-LINK virtual COM port (USART2); PA13/PA14 are SWD.
//!
//! The `pin_map_is_valid` function below makes the compiler check every pin against the
//! chip's alternate-function tables (stm32-metapac), so a wrong pin fails the build.

use embassy_stm32::gpio::Pull;
use embassy_stm32::interrupt::Priority;
use embassy_stm32::pac;
use embassy_stm32::peripherals::{
    ADC1, ADC2, FLASH, IWDG, PA0, PA1, PA11, PA12, PA5, PB0, PB1, PB12, PB13, PB14, PB15, PB2, PC0,
    PC1, PC10, PC11, PC12, PC6, PC7, PC8, PC9, RNG, TIM2, TIM3, TIM5, USB,
};
use embassy_stm32::time::Hertz;
use embassy_stm32::{Peri, Peripherals};
use pam_firmware_logic::adc_scale::AdcFrontEnd;

// ---------------------------------------------------------------------------------------
// Clocks

/// Core clock; also the clock of the timers (APB prescalers at 1) and of the ADC kernel.
pub const SYSCLK_HZ: u32 = 170_000_000;

/// 170 MHz from the 16 MHz HSI: 16 / 4 × 85 / 2, Range 1 boost mode (needed above 150 MHz).
/// ADC1/2 run from SYSCLK (the HAL divides it by 4: 42.5 MHz ≤ 60 MHz). USB takes HSI48,
/// trimmed by the CRS from the host's start-of-frame packets.
pub fn clock_config() -> embassy_stm32::Config {
    use embassy_stm32::rcc::*;
    let mut config = embassy_stm32::Config::default();
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
    config.rcc.boost = true;
    config.rcc.mux.adc12sel = mux::Adcsel::SYS;
    config.rcc.hsi48 = Some(Hsi48Config {
        sync_from_usb: true,
    });
    config.rcc.mux.clk48sel = mux::Clk48sel::HSI48;
    config
}

// ---------------------------------------------------------------------------------------
// Control loop and watchdog

/// The control loop runs on an interrupt executor on this otherwise unused vector.
pub const CONTROL_IRQ: embassy_stm32::interrupt::Interrupt = embassy_stm32::interrupt::UART4;
/// Above the thread-mode executor and the USB interrupt (default priority 0 would be the
/// highest; embassy's drivers leave theirs at the reset value, so the ones we use are
/// lowered in `main`).
pub const CONTROL_PRIORITY: Priority = Priority::P2;
/// The emergency-stop input: PB0 on EXTI line 0, which has a vector of its own (EXTI0).
/// The button's normally-closed contact holds the pin at ground; pressing it, or a cut
/// wire, lets the pull-up take it high: a rising edge stops (docs/output-stage.md).
pub const ESTOP_IRQ: embassy_stm32::interrupt::Interrupt = embassy_stm32::interrupt::EXTI0;
pub const ESTOP_EXTI_LINE: usize = 0;
/// SYSCFG_EXTICR port code of GPIOB (RM0440 §9.1.3: 0 = A, 1 = B, 2 = C, …).
pub const ESTOP_EXTI_PORT: u8 = 1;
pub const ESTOP_PULL: Pull = Pull::Up;
/// Above the control loop (it must pre-empt a step in progress), below the time driver.
pub const ESTOP_PRIORITY: Priority = Priority::P1;
/// The device's lock masks the interrupts up to the control loop's priority and no further
/// (`pam_fault_paths::ceiling`): the E-stop and the time driver pre-empt a step or a request
/// in progress. NVIC priority byte of `CONTROL_PRIORITY`.
pub const DEVICE_LOCK_CEILING: u8 = CONTROL_PRIORITY as u8;
/// Priority of the peripheral interrupts the low-priority tasks use (USB).
pub const LINK_PRIORITY: Priority = Priority::P6;

/// IWDG timeout: five periods at the slowest allowed loop rate (10 ms), fifty at 1 ms. The
/// LSI (32 kHz nominal) may be off by ±10 %, which only moves the limit by 5 ms.
pub const WATCHDOG_TIMEOUT_US: u32 = 50_000;

/// Consecutive missed control periods (execution longer than the period, or a wake-up a
/// whole period late) that latch `Faults::LOOP_OVERRUN` until the first control step: from
/// then on the device's safety configuration sets it (`SafetyConfig::overrun_fault_periods`,
/// default 3, 1–100, kept in flash with the other limits). One or two can be a debugger or a
/// long USB critical section; three in a row is a loop that no longer keeps its rate.
pub const LOOP_OVERRUN_FAULT_PERIODS_AT_BOOT: u32 = pam_control::DEFAULT_OVERRUN_FAULT_PERIODS;

/// Free stack below which `Faults::STACK_LOW` latches (the painted stack's high-water
/// mark, checked once per second). The stack is the RAM above the statics (≈ 120 KiB); a
/// run that comes within 8 KiB of the statics is one deeper call from corrupting them.
pub const STACK_MIN_FREE_BYTES: u32 = 8 * 1024;

// ---------------------------------------------------------------------------------------
// Encoders (counts per revolution and direction are rig calibration: `pam-device`)

/// Encoder outputs are often open collector: the internal pull-ups (≈40 kΩ) do no harm to
/// push-pull outputs either.
pub const ENCODER_PULL: Pull = Pull::Up;

// ---------------------------------------------------------------------------------------
// Load cell front end

/// 12-bit conversions.
pub const ADC_FULL_SCALE_COUNTS: u16 = 4095;
/// ADC input channel of the X and Z signals (DS12288 pin table: PC0 = ADC12_IN6,
/// PC1 = ADC12_IN7); `pin_map_is_valid` checks that both pins are ADC1 and ADC2 inputs.
pub const LOAD_CELL_X_ADC_CHANNEL: u8 = 6;
pub const LOAD_CELL_Z_ADC_CHANNEL: u8 = 7;
/// 47.5 ADC clocks of sampling (1.12 µs at 42.5 MHz): the front end's op-amp drives the
/// sample capacitor easily; conversion total 47.5 + 12.5 = 60 clocks = 1.41 µs.
pub const LOAD_CELL_SAMPLE_TIME: pac::adc::vals::SampleTime =
    pac::adc::vals::SampleTime::CYCLES47_5;
/// The amplifier's ±10 V outputs (the NI 9215's input range) reach the ADC through a
/// level shifter: V_adc = mid + gain × V_amp, with the nominal values of its resistors
/// (100 k / 30.1 k / 43.2 k, `docs/output-stage.md`, input front end). The reference is
/// the Nucleo's VDDA = VREF+ = 3.3 V. Codes within 8 of either rail are saturation.
pub const LOAD_CELL_FRONT_END: AdcFrontEnd = AdcFrontEnd {
    vref_v: 3.3,
    full_scale_counts: ADC_FULL_SCALE_COUNTS,
    gain: 0.1507,
    mid_v: 1.652,
    rail_margin_counts: 8,
};
/// Master and slave of the simultaneous pair and their common block.
pub const LOAD_CELL_ADC_MASTER: pac::adc::Adc = pac::ADC1;
pub const LOAD_CELL_ADC_SLAVE: pac::adc::Adc = pac::ADC2;
pub const LOAD_CELL_ADC_COMMON: pac::adccommon::AdcCommon = pac::ADC12_COMMON;

// ---------------------------------------------------------------------------------------
// 4–20 mA outputs

/// PWM frequency of the four outputs: 170 MHz / 20 kHz = 8500 counts per period
/// (2.8 µA per count at the stage's 24.2 mA full scale).
pub const OUTPUT_PWM_HZ: Hertz = Hertz(20_000);
/// Counts per PWM period (prescaler 1): the driver sets the timer's period to it, so the
/// compare constants below hold by construction.
pub const OUTPUT_PERIOD_COUNTS: u16 = (SYSCLK_HZ / OUTPUT_PWM_HZ.0) as u16;
const _: () =
    assert!(SYSCLK_HZ.is_multiple_of(OUTPUT_PWM_HZ.0) && SYSCLK_HZ / OUTPUT_PWM_HZ.0 <= 65_535);
/// Loop current at 100 % duty with the nominal parts of `docs/output-stage.md`:
/// 10 × 3.000 V / 1.24 kΩ (XTR111 gain 10, PWM high level from a 3.000 V reference).
pub const OUTPUT_FULL_SCALE_MA: f32 = 10.0 * 3.000 / 1.24;
/// The vent current: the I/P converters' floor, the control crate's own constant, so the
/// fault paths and the control step vent to the same current. Never a setting.
pub const OUTPUT_SAFE_MA: f32 = pam_control::VENT_CURRENT_MA;
/// The compare value of the vent current (1405 counts), computed by the compiler: the
/// fault paths and the E-stop write it without reading anything from RAM.
pub const OUTPUT_SAFE_COMPARE: u16 = pam_firmware_logic::current_loop::nominal_counts(
    OUTPUT_SAFE_MA,
    OUTPUT_FULL_SCALE_MA,
    OUTPUT_PERIOD_COUNTS,
);
const _: () = assert!(OUTPUT_SAFE_COMPARE == 1405);
/// The largest compare value the driver ever writes (7202 counts, 20.50 mA): NAMUR NE43
/// keeps loop currents above 21 mA for failure signalling, and 100 % duty would be 24.19 mA.
pub const OUTPUT_CEILING_COMPARE: u16 =
    pam_firmware_logic::current_loop::ceiling_counts(OUTPUT_FULL_SCALE_MA, OUTPUT_PERIOD_COUNTS);
const _: () = assert!(OUTPUT_CEILING_COMPARE == 7202);
/// The stage's nominal mA → duty law (0 mA at 0 %, full scale at 100 %).
pub fn output_nominal_law() -> pam_firmware_logic::current_loop::ChannelLaw {
    pam_firmware_logic::current_loop::ChannelLaw::proportional(OUTPUT_FULL_SCALE_MA)
}
/// The XTR111's EF pins are open drain, low on an output error (open loop, no compliance).
pub const OUTPUT_ERROR_FLAG_PULL: Pull = Pull::Up;
/// An error flag must be seen this many consecutive periods before it is a fault (shared
/// with the emulator).
pub const OUTPUT_ERROR_DEBOUNCE_PERIODS: u16 =
    pam_firmware_logic::current_loop::OUTPUT_ERROR_DEBOUNCE_PERIODS;
/// The output timer, written directly by the fault paths and the E-stop.
pub const OUTPUT_TIMER_REGS: pac::timer::TimGp16 = pac::TIM3;
/// OUT_EN# (PB1): its port and pin, set high (outputs off) directly by the fault paths.
pub const OUTPUT_ENABLE_PORT: pac::gpio::Gpio = pac::GPIOB;
pub const OUTPUT_ENABLE_PIN: usize = 1;

// ---------------------------------------------------------------------------------------
// Board revision and the flash areas the NMI handler knows

/// The straps are read with pull-ups: open reads high (`pam_firmware_logic::board_revision`).
pub const BOARD_STRAP_PULL: Pull = Pull::Up;
/// The configuration record's pages for the NMI handler: bank 2's last two 2 KiB pages
/// (memory.x's CONFIG, `config_flash::CONFIG_FLASH_OFFSET`), as offsets in the 256 KiB bank.
pub const CONFIG_PAGES: pam_firmware_logic::nmi::ConfigPages =
    pam_firmware_logic::nmi::ConfigPages {
        bank2_offset: 0x3_F000,
        bytes: 2 * 2048,
        bank_bytes: 256 * 1024,
    };

// ---------------------------------------------------------------------------------------
// Peripheral ownership

/// Timer types, so that the rest of the firmware can name its drivers' types.
pub type Encoder1Timer = TIM2;
pub type Encoder2Timer = TIM5;
pub type OutputTimer = TIM3;
pub type LoadCellAdcMaster = ADC1;
pub type LoadCellAdcSlave = ADC2;
pub type UsbPeripheral = USB;

embassy_stm32::bind_interrupts!(
    /// The random number generator's interrupt (the boot's draw polls; the driver wants it
    /// bound).
    pub struct RngIrqs {
        RNG => embassy_stm32::rng::InterruptHandler<RNG>;
    }
);

embassy_stm32::bind_interrupts!(
    /// The USB peripheral's interrupt (low priority: `LINK_PRIORITY`).
    pub struct UsbIrqs {
        USB_LP => embassy_stm32::usb::InterruptHandler<USB>;
    }
);
/// The vector bound above, for setting its priority.
pub const USB_IRQ: embassy_stm32::interrupt::Interrupt = embassy_stm32::interrupt::USB_LP;

/// Quadrature encoder of joint 1.
pub struct Encoder1 {
    pub timer: Peri<'static, TIM2>,
    pub ch_a: Peri<'static, PA0>,
    pub ch_b: Peri<'static, PA1>,
}

/// Quadrature encoder of joint 2.
pub struct Encoder2 {
    pub timer: Peri<'static, TIM5>,
    pub ch_a: Peri<'static, PB2>,
    pub ch_b: Peri<'static, PC12>,
}

/// The two analogue channels of the load cell amplifier (sensor frame X and Z), one per
/// ADC of the simultaneous pair.
pub struct LoadCell {
    pub adc_master: Peri<'static, ADC1>,
    pub adc_slave: Peri<'static, ADC2>,
    pub x: Peri<'static, PC0>,
    pub z: Peri<'static, PC1>,
}

/// The four 4–20 mA current-loop outputs to the I/P converters and their error flags.
pub struct CurrentOutputs {
    pub timer: Peri<'static, TIM3>,
    pub ch1: Peri<'static, PC6>,
    pub ch2: Peri<'static, PC7>,
    pub ch3: Peri<'static, PC8>,
    pub ch4: Peri<'static, PC9>,
    pub error_flag1: Peri<'static, PB12>,
    pub error_flag2: Peri<'static, PB13>,
    pub error_flag3: Peri<'static, PB14>,
    pub error_flag4: Peri<'static, PB15>,
}

/// USB full-speed device (host link).
pub struct Usb {
    pub usb: Peri<'static, USB>,
    pub dp: Peri<'static, PA12>,
    pub dm: Peri<'static, PA11>,
}

/// Every peripheral the firmware uses, claimed from the chip's singletons.
pub struct Board {
    pub led: Peri<'static, PA5>,
    pub encoder1: Encoder1,
    pub encoder2: Encoder2,
    pub load_cell: LoadCell,
    pub outputs: CurrentOutputs,
    pub usb: Usb,
    pub watchdog: Peri<'static, IWDG>,
    pub estop: Peri<'static, PB0>,
    /// OUT_EN#: the four output buffers' /OE (pulled high on the board: disabled until the
    /// firmware drives it low, after the outputs run at 4 mA; docs/output-stage.md).
    pub output_enable: Peri<'static, PB1>,
    /// The configuration record's pages (`config_flash`).
    pub flash: Peri<'static, FLASH>,
    /// The board revision's straps (read once at boot).
    pub strap0: Peri<'static, PC10>,
    pub strap1: Peri<'static, PC11>,
    /// The random number generator (on the 48 MHz clock): the session tokens' nonce, drawn
    /// once at boot.
    pub rng: Peri<'static, RNG>,
}

impl Board {
    pub fn new(p: Peripherals) -> Self {
        Self {
            led: p.PA5,
            encoder1: Encoder1 {
                timer: p.TIM2,
                ch_a: p.PA0,
                ch_b: p.PA1,
            },
            encoder2: Encoder2 {
                timer: p.TIM5,
                ch_a: p.PB2,
                ch_b: p.PC12,
            },
            load_cell: LoadCell {
                adc_master: p.ADC1,
                adc_slave: p.ADC2,
                x: p.PC0,
                z: p.PC1,
            },
            outputs: CurrentOutputs {
                timer: p.TIM3,
                ch1: p.PC6,
                ch2: p.PC7,
                ch3: p.PC8,
                ch4: p.PC9,
                error_flag1: p.PB12,
                error_flag2: p.PB13,
                error_flag3: p.PB14,
                error_flag4: p.PB15,
            },
            usb: Usb {
                usb: p.USB,
                dp: p.PA12,
                dm: p.PA11,
            },
            watchdog: p.IWDG,
            estop: p.PB0,
            output_enable: p.PB1,
            flash: p.FLASH,
            strap0: p.PC10,
            strap1: p.PC11,
            rng: p.RNG,
        }
    }
}

/// Never called: it only has to type-check. Each line asks the HAL's pin traits whether
/// the pin can carry that signal of that peripheral.
#[allow(dead_code)]
fn pin_map_is_valid() {
    use embassy_stm32::adc::{self, AdcChannel};
    use embassy_stm32::timer::{
        Ch1, Ch2, Ch3, Ch4, GeneralInstance32bit4Channel, GeneralInstance4Channel, TimerChannel,
        TimerPin,
    };
    use embassy_stm32::usb::{self, DmPin, DpPin};

    fn timer_pin<T: GeneralInstance4Channel, C: TimerChannel, P: TimerPin<T, C>>() {}
    fn counter_32bit<T: GeneralInstance32bit4Channel>() {}
    fn adc_pin<T: adc::Instance, P: AdcChannel<T>>() {}
    fn usb_pins<T: usb::Instance, P: DpPin<T>, M: DmPin<T>>() {}

    counter_32bit::<TIM2>();
    timer_pin::<TIM2, Ch1, PA0>();
    timer_pin::<TIM2, Ch2, PA1>();

    counter_32bit::<TIM5>();
    timer_pin::<TIM5, Ch1, PB2>();
    timer_pin::<TIM5, Ch2, PC12>();

    adc_pin::<ADC1, Peri<'static, PC0>>();
    adc_pin::<ADC2, Peri<'static, PC1>>();

    timer_pin::<TIM3, Ch1, PC6>();
    timer_pin::<TIM3, Ch2, PC7>();
    timer_pin::<TIM3, Ch3, PC8>();
    timer_pin::<TIM3, Ch4, PC9>();

    usb_pins::<USB, PA12, PA11>();
}
