//! The latched fault bits and their numbered codes (the table in firmware/README.md).

/// Latched fault bits, reported with their code.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Faults(pub u16);

impl Faults {
    pub const NONE: Faults = Faults(0);
    pub const COMMAND_TIMEOUT: Faults = Faults(1 << 0);
    pub const NON_FINITE: Faults = Faults(1 << 1);
    pub const ANGLE_OUT_OF_RANGE: Faults = Faults(1 << 2);
    pub const ENCODER_JUMP: Faults = Faults(1 << 3);
    pub const LOADCELL_SATURATED: Faults = Faults(1 << 4);
    pub const LOADCELL_STUCK: Faults = Faults(1 << 5);
    pub const OUTPUT_NON_FINITE: Faults = Faults(1 << 6);
    /// Set by the firmware when the watchdog caused the last reset.
    pub const WATCHDOG_RESET: Faults = Faults(1 << 7);
    /// Set by the firmware when the current-loop stage reports an open loop.
    pub const OUTPUT_OPEN_LOOP: Faults = Faults(1 << 8);
    /// Set by the firmware at boot when a CPU fault exception (HardFault, MemManage,
    /// BusFault, UsageFault, an unexpected interrupt) ended the last run: the handler vented
    /// the outputs and left a record in no-init RAM.
    pub const CPU_FAULT: Faults = Faults(1 << 9);
    /// Set by the firmware when the control loop missed this many consecutive periods
    /// (execution longer than the period, or a wake-up a whole period late).
    pub const LOOP_OVERRUN: Faults = Faults(1 << 10);
    /// Set by the firmware when the stack's high-water mark came within its margin of the
    /// stack's end (painted-stack measurement).
    pub const STACK_LOW: Faults = Faults(1 << 11);
    /// Set by the firmware while the emergency-stop input is active (the EXTI handler has
    /// already vented the outputs); re-raised every period until the button is released.
    pub const ESTOP: Faults = Faults(1 << 12);
    /// A joint at rest whose commanded muscle torque the handle force does not balance,
    /// beyond the model's error (`plausibility`): a stuck or unplugged encoder, a converter
    /// that no longer follows its current.
    pub const STATIC_IMBALANCE: Faults = Faults(1 << 13);
    /// Set by the closed force loop's guard: sustained oscillation or a persistent error.
    pub const CONTROL_UNSTABLE: Faults = Faults(1 << 14);
    /// A self-check of the device failed; `status` says which (protocol 4's `Status`):
    /// the configuration record in flash was corrupt, of another layout or refused, or the
    /// flash unreadable, so the thesis defaults are in use (latched once at boot, cleared by
    /// `clear`); or a board check fails (VDDA out of range, ADC dual mode not set), which
    /// the device re-raises every period while it lasts.
    pub const SELF_CHECK: Faults = Faults(1 << 15);

    pub const fn with(self, o: Faults) -> Faults {
        Faults(self.0 | o.0)
    }
    pub const fn contains(self, o: Faults) -> bool {
        self.0 & o.0 == o.0 && o.0 != 0
    }
    pub const fn is_none(self) -> bool {
        self.0 == 0
    }
}
