//! Loop watchdog (IWDG) and the cause of the last reset.
//!
//! The IWDG runs from the LSI, independent of the main clock, and cannot be stopped once
//! started: only the control task holds [`LoopWatchdog`] and feeds it once per period, so a
//! loop that stalls (deadlock, runaway interrupt, priority inversion, a panic that halts)
//! resets the MCU within `board::WATCHDOG_TIMEOUT_US`. A reset puts every pin back to its
//! reset state, which is the vent state of the outputs (see `current_output`).

use embassy_stm32::pac;
use embassy_stm32::peripherals::IWDG;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::Peri;

use crate::board;

/// Why the MCU last reset, read from RCC_CSR before anything else clears it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct ResetCause {
    pub independent_watchdog: bool,
    pub window_watchdog: bool,
    pub software: bool,
    pub brown_out: bool,
    pub pin: bool,
    pub low_power: bool,
    pub option_bytes: bool,
}

impl ResetCause {
    /// Reads the reset flags and clears them, so that the next reset reports only its own
    /// cause. Called once at boot.
    pub fn take() -> Self {
        let rcc = pac::RCC;
        let csr = rcc.csr().read();
        let cause = ResetCause {
            independent_watchdog: csr.iwdgrstf(),
            window_watchdog: csr.wwdgrstf(),
            software: csr.sftrstf(),
            brown_out: csr.borrstf(),
            pin: csr.pinrstf(),
            low_power: csr.lpwrrstf(),
            option_bytes: csr.oblrstf(),
        };
        rcc.csr().modify(|w| w.set_rmvf(true));
        cause
    }

    /// A watchdog (independent or window) reset: the controller latches WATCHDOG_RESET.
    pub fn is_watchdog(&self) -> bool {
        self.independent_watchdog || self.window_watchdog
    }
}

pub struct LoopWatchdog {
    iwdg: IndependentWatchdog<'static, IWDG>,
}

impl LoopWatchdog {
    /// Configures and starts the watchdog. From here on [`LoopWatchdog::feed`] must be
    /// called at least every `board::WATCHDOG_TIMEOUT_US`.
    pub fn start(iwdg: Peri<'static, IWDG>) -> Self {
        // Freeze the IWDG while a debugger halts the core (no effect without one).
        pac::DBGMCU.apb1lfzr().modify(|w| w.set_iwdg(true));
        let mut iwdg = IndependentWatchdog::new(iwdg, board::WATCHDOG_TIMEOUT_US);
        iwdg.unleash();
        Self { iwdg }
    }

    pub fn feed(&mut self) {
        self.iwdg.pet();
    }
}
