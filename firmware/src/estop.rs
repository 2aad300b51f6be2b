//! The emergency-stop input. The button's normally-closed contact holds PB0 at ground; a
//! press (or a cut wire) lets the pull-up take it high. The rising edge interrupts on EXTI0
//! at a priority above the device lock's ceiling (`board::DEVICE_LOCK_CEILING`, a BASEPRI
//! lock, not a critical section): the handler pre-empts a control step or a host request in
//! progress and writes the 4 mA compares at once (constants, the same plain stores as the
//! fault paths), then latches. The control task writes its outputs and then looks at the
//! latch again, so a press during a step is never overwritten by that step's result; it
//! raises `Faults::ESTOP` every period while the latch or the pin says so, so the device
//! stays vented until the button is released and the host clears the fault. In hardware the
//! same contact disables the XTR111 outputs without the MCU (docs/output-stage.md); this is
//! the software half.

use core::sync::atomic::{AtomicBool, Ordering};

use embassy_stm32::gpio::Input;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::InterruptExt;
use embassy_stm32::pac;
use embassy_stm32::peripherals::PB0;
use embassy_stm32::Peri;

use crate::board;
use crate::current_output;

/// Set by the edge (or by a pressed button at boot); cleared by [`EStop::poll`] once the
/// pin is low again, after the control task has latched the fault in the device.
static TRIPPED: AtomicBool = AtomicBool::new(false);

fn trip() {
    current_output::drive_safe_compares();
    TRIPPED.store(true, Ordering::Release);
}

/// The stop has tripped since the control task last looked (read after the outputs are
/// written, so that a press during a step still wins).
pub fn tripped() -> bool {
    TRIPPED.load(Ordering::Acquire)
}

pub struct EStop {
    input: Input<'static>,
}

impl EStop {
    /// Configures the pin and its EXTI line (rising edge) and enables the interrupt. Call
    /// after the outputs exist (the handler writes their safe compares).
    pub fn new(pin: Peri<'static, PB0>) -> Self {
        let input = Input::new(pin, board::ESTOP_PULL);
        let line = board::ESTOP_EXTI_LINE;
        pac::RCC.apb2enr().modify(|w| w.set_syscfgen(true));
        pac::SYSCFG
            .exticr(line / 4)
            .modify(|w| w.set_exti(line % 4, board::ESTOP_EXTI_PORT));
        pac::EXTI.rtsr(0).modify(|w| w.set_line(line, true));
        pac::EXTI.ftsr(0).modify(|w| w.set_line(line, false));
        pac::EXTI.pr(0).write(|w| w.set_line(line, true));
        pac::EXTI.imr(0).modify(|w| w.set_line(line, true));
        board::ESTOP_IRQ.set_priority(board::ESTOP_PRIORITY);
        // SAFETY: the handler below only stores to the output compares and an atomic.
        unsafe { board::ESTOP_IRQ.enable() };
        if input.is_high() {
            // pressed (or unwired) at boot: no edge will come
            trip();
        }
        EStop { input }
    }

    /// Once per period, before the step: whether the stop is active (tripped since the
    /// last look, or still pressed). The trip latch is released once the pin is low: the
    /// device's `ESTOP` fault, raised on this answer, is the latch that stays.
    pub fn poll(&self) -> bool {
        let pressed = self.input.is_high();
        let tripped = TRIPPED.load(Ordering::Acquire);
        if tripped && !pressed {
            TRIPPED.store(false, Ordering::Release);
        }
        tripped || pressed
    }
}

#[interrupt]
fn EXTI0() {
    // pending bit: write 1 to clear (RM0440 EXTI_PR1)
    pac::EXTI
        .pr(0)
        .write(|w| w.set_line(board::ESTOP_EXTI_LINE, true));
    trip();
}
