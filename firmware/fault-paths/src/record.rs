//! The fault record: what a fault path leaves in no-init RAM for the next boot.

/// Which path ended the last run. Numbered once and for all: the numbers are logged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum FaultKind {
    HardFault = 1,
    MemManage = 2,
    BusFault = 3,
    UsageFault = 4,
    /// An interrupt or exception without a handler (`address`: its IRQ number).
    UnexpectedInterrupt = 5,
    /// An NMI that was not a double-bit ECC error in the configuration pages (`address`:
    /// the ECC error's flash offset, or `u32::MAX` if there was none).
    Nmi = 6,
    /// A panic (`address`: the source line).
    Panic = 7,
}

impl FaultKind {
    pub fn from_u32(v: u32) -> Option<Self> {
        Some(match v {
            1 => Self::HardFault,
            2 => Self::MemManage,
            3 => Self::BusFault,
            4 => Self::UsageFault,
            5 => Self::UnexpectedInterrupt,
            6 => Self::Nmi,
            7 => Self::Panic,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::HardFault => "HardFault",
            Self::MemManage => "MemManage",
            Self::BusFault => "BusFault",
            Self::UsageFault => "UsageFault",
            Self::UnexpectedInterrupt => "unexpected interrupt",
            Self::Nmi => "NMI",
            Self::Panic => "panic",
        }
    }
}

/// A decoded record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultRecord {
    pub kind: FaultKind,
    /// Stacked PC, 0 where no valid exception frame exists (a failed stacking, a panic).
    pub pc: u32,
    /// SCB CFSR (MemManage | BusFault | UsageFault status) at the fault.
    pub cfsr: u32,
    /// SCB HFSR at the fault.
    pub hfsr: u32,
    /// MMFAR or BFAR when valid; see [`FaultKind`] for the other kinds.
    pub address: u32,
}

const RECORD_MAGIC: u32 = 0xFA17_C0DE;

/// The record as stored: a magic word and a check word, so that the random content of RAM
/// after power-up is not taken for a record.
#[repr(C)]
pub struct RecordSlot {
    magic: u32,
    kind: u32,
    pc: u32,
    cfsr: u32,
    hfsr: u32,
    address: u32,
    check: u32,
}

impl RecordSlot {
    const EMPTY: RecordSlot = RecordSlot {
        magic: 0,
        kind: 0,
        pc: 0,
        cfsr: 0,
        hfsr: 0,
        address: 0,
        check: 0,
    };

    fn check_word(&self) -> u32 {
        (self.magic ^ self.kind ^ self.pc ^ self.cfsr ^ self.hfsr ^ self.address).rotate_left(7)
    }

    fn of(r: &FaultRecord) -> Self {
        let mut slot = RecordSlot {
            magic: RECORD_MAGIC,
            kind: r.kind as u32,
            pc: r.pc,
            cfsr: r.cfsr,
            hfsr: r.hfsr,
            address: r.address,
            check: 0,
        };
        slot.check = slot.check_word();
        slot
    }
}

/// Writes the record.
///
/// # Safety
/// `slot` points to RAM reserved for the record; nothing else writes it meanwhile
/// (interrupts masked).
pub unsafe fn write(slot: *mut RecordSlot, record: &FaultRecord) {
    // SAFETY: the caller's
    unsafe { slot.write_volatile(RecordSlot::of(record)) };
}

/// The record left before the last reset, if any; clears the slot so that the next boot
/// reports only its own. Called once at boot.
///
/// # Safety
/// `slot` points to RAM reserved for the record, word-aligned (any content).
pub unsafe fn take(slot: *mut RecordSlot) -> Option<FaultRecord> {
    // SAFETY: the caller's; every bit pattern is a valid `RecordSlot` (plain u32s)
    let raw = unsafe { slot.read_volatile() };
    unsafe { slot.write_volatile(RecordSlot::EMPTY) };
    if raw.magic != RECORD_MAGIC || raw.check != raw.check_word() {
        return None;
    }
    Some(FaultRecord {
        kind: FaultKind::from_u32(raw.kind)?,
        pc: raw.pc,
        cfsr: raw.cfsr,
        hfsr: raw.hfsr,
        address: raw.address,
    })
}
