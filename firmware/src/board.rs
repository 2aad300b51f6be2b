//! Every board choice of the NUCLEO-G474RE build, in one place.
//!
//! | Function                         | Peripheral       | Pins (alternate function)     | Nucleo connector |
//! |----------------------------------|------------------|-------------------------------|------------------|
//! | Joint 1 encoder (A/B quadrature) | TIM2, 32-bit     | PA0 CH1 (AF1), PA1 CH2 (AF1)  | Arduino A0, A1   |
//! | Joint 2 encoder (A/B quadrature) | TIM5, 32-bit     | PB2 CH1 (AF2), PC12 CH2 (AF1) | morpho           |
//! | Load cell X / Z (eq. 2.1 volts)  | ADC1             | PC0 IN6, PC1 IN7              | Arduino A5, A4   |
//! | 4–20 mA channels 1–4 (I/P conv.) | TIM3 PWM CH1–CH4 | PC6, PC7, PC8, PC9 (AF2)      | morpho           |
//! | USB FS device                    | USB              | PA12 DP, PA11 DM              | morpho           |
//! | Heartbeat LED (LD2)              | GPIO             | PA5                           | Arduino D13      |
//! | embassy-time driver              | TIM15            | none                          | —                |
//!
//! (Connector positions: check UM2505, the NUCLEO-G474RE user manual, before wiring.)
//!
//! * Both encoders sit on the two 32-bit timers, so the joint counts never wrap in practice.
//! * The four channels are PWM outputs of one timer (same period, updated together); each
//!   feeds an RC filter and a voltage-to-current (4–20 mA) stage on the interface board.
//!   Channel *n* here is channel *n* of `RobotModel::channel_pressures_bar` (the model's
//!   `channel_of_muscle` maps muscles to channels). The on-chip DACs cannot serve: only
//!   three DAC outputs reach pins (PA4, PA5, PA6) and PA5 is LD2.
//! * The time driver (Cargo feature `time-driver-tim15`) uses TIM15, which no pin here needs.
//! * PA2/PA3 stay free for the ST-LINK virtual COM port (USART2); PA13/PA14 are SWD.
//! * USB needs the 48 MHz clock (HSI48 + CRS) configured in `main` once the USB class is
//!   added.
//!
//! Nothing here drives hardware yet: the drivers are built on these peripherals in issue 4.
//! The `pin_map_is_valid` function below makes the compiler check every pin against the
//! chip's alternate-function table (stm32-metapac), so a wrong pin fails the build.

// The peripherals are claimed now and used by the drivers of issue 4.
#![allow(dead_code)]

use embassy_stm32::peripherals::{
    ADC1, PA0, PA1, PA11, PA12, PA5, PB2, PC0, PC1, PC12, PC6, PC7, PC8, PC9, TIM2, TIM3, TIM5, USB,
};
use embassy_stm32::{Peri, Peripherals};

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

/// The two analogue channels of the load cell amplifier (sensor frame X and Z).
pub struct LoadCell {
    pub adc: Peri<'static, ADC1>,
    pub x: Peri<'static, PC0>,
    pub z: Peri<'static, PC1>,
}

/// The four 4–20 mA current-loop outputs to the I/P converters.
pub struct CurrentOutputs {
    pub timer: Peri<'static, TIM3>,
    pub ch1: Peri<'static, PC6>,
    pub ch2: Peri<'static, PC7>,
    pub ch3: Peri<'static, PC8>,
    pub ch4: Peri<'static, PC9>,
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
                adc: p.ADC1,
                x: p.PC0,
                z: p.PC1,
            },
            outputs: CurrentOutputs {
                timer: p.TIM3,
                ch1: p.PC6,
                ch2: p.PC7,
                ch3: p.PC8,
                ch4: p.PC9,
            },
            usb: Usb {
                usb: p.USB,
                dp: p.PA12,
                dm: p.PA11,
            },
        }
    }
}

/// Never called: it only has to type-check. Each line asks the HAL's pin traits whether
/// the pin can carry that signal of that peripheral.
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
    adc_pin::<ADC1, Peri<'static, PC1>>();

    timer_pin::<TIM3, Ch1, PC6>();
    timer_pin::<TIM3, Ch2, PC7>();
    timer_pin::<TIM3, Ch3, PC8>();
    timer_pin::<TIM3, Ch4, PC9>();

    usb_pins::<USB, PA12, PA11>();
}
