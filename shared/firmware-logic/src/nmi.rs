//! Which non-maskable interrupts the firmware survives. The STM32G4 raises an NMI for a
//! double-bit ECC error in flash (RM0440 §3.3.4, FLASH_ECCR.ECCD). The one flash area that
//! is ever programmed is the configuration record's: a power loss while it is written can
//! leave such a double-word there, and reading it at boot must give a record that fails its
//! CRC (defaults and `SELF_CHECK`), not a reset at every boot. An ECC error anywhere else
//! (the program, its constants, the system memory) means the code or the tables the
//! firmware runs on are corrupt, and any other NMI has no handler of its own: both end in
//! the safe state, a fault record and a reset.

/// FLASH_ECCR at the NMI, decoded (RM0440 §3.7.9).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlashEcc {
    /// ECCD: a double-bit error was detected.
    pub double_error: bool,
    /// SYSF_ECC: in the system memory (the bootloader, option bytes), not the user flash.
    pub system_flash: bool,
    /// BK_ECC: in bank 2 (dual-bank layout).
    pub bank2: bool,
    /// ADDR_ECC: the failing double-word's byte offset.
    pub address: u32,
}

impl FlashEcc {
    /// From the register's bits: ADDR_ECC 18:0, BK_ECC 21, SYSF_ECC 22, ECCD 31.
    pub fn from_eccr(eccr: u32) -> Self {
        Self {
            double_error: eccr & (1 << 31) != 0,
            system_flash: eccr & (1 << 22) != 0,
            bank2: eccr & (1 << 21) != 0,
            address: eccr & 0x0007_FFFF,
        }
    }
}

/// Where the configuration pages are: a byte range inside bank 2 of the dual-bank layout,
/// as offsets from the bank's start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConfigPages {
    pub bank2_offset: u32,
    pub bytes: u32,
    /// The size of one bank: the offset is taken modulo it, so the check holds whether
    /// ADDR_ECC counts from the bank's start or from the start of the flash.
    pub bank_bytes: u32,
}

/// What an NMI was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmiCause {
    /// A double-bit ECC error inside the configuration pages: clear it, count it, go on.
    ConfigEcc { address: u32 },
    /// A double-bit ECC error anywhere else: a fault.
    OtherEcc { address: u32 },
    /// Not a flash ECC error: a fault.
    Other,
}

/// The NMI's cause from the flash's ECC status.
pub fn classify(ecc: FlashEcc, config: ConfigPages) -> NmiCause {
    if !ecc.double_error {
        return NmiCause::Other;
    }
    let in_bank = ecc.address % config.bank_bytes.max(1);
    let in_config = ecc.bank2
        && !ecc.system_flash
        && in_bank >= config.bank2_offset
        && in_bank - config.bank2_offset < config.bytes;
    if in_config {
        NmiCause::ConfigEcc {
            address: ecc.address,
        }
    } else {
        NmiCause::OtherEcc {
            address: ecc.address,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The board's layout: 2 × 256 KiB banks, the record in bank 2's last two 2 KiB pages.
    const PAGES: ConfigPages = ConfigPages {
        bank2_offset: 0x3_F000,
        bytes: 0x1000,
        bank_bytes: 0x4_0000,
    };
    const ECCD: u32 = 1 << 31;
    const BK2: u32 = 1 << 21;
    const SYSF: u32 = 1 << 22;

    #[test]
    fn only_a_double_error_in_the_config_pages_is_tolerated() {
        for addr in [0x3_F000, 0x3_F008, 0x3_FFF8] {
            let ecc = FlashEcc::from_eccr(ECCD | BK2 | addr);
            assert_eq!(classify(ecc, PAGES), NmiCause::ConfigEcc { address: addr });
        }
        // the same pages if ADDR_ECC counted from the start of the flash
        let ecc = FlashEcc::from_eccr(ECCD | BK2 | 0x7_F010);
        assert!(matches!(classify(ecc, PAGES), NmiCause::ConfigEcc { .. }));
        // program (bank 1), the rest of bank 2, just below the pages, system memory
        for eccr in [
            ECCD | 0x3_F000,
            ECCD | 0x0_1234,
            ECCD | BK2 | 0x3_EFF8,
            ECCD | BK2 | 0x0_0008,
            ECCD | BK2 | SYSF | 0x3_F000,
        ] {
            let ecc = FlashEcc::from_eccr(eccr);
            assert_eq!(
                classify(ecc, PAGES),
                NmiCause::OtherEcc {
                    address: eccr & 0x7_FFFF
                },
                "{eccr:#x}"
            );
        }
        // no double error: some other NMI, whatever the address bits say
        assert_eq!(
            classify(FlashEcc::from_eccr(BK2 | 0x3_F000), PAGES),
            NmiCause::Other
        );
        assert_eq!(classify(FlashEcc::from_eccr(0), PAGES), NmiCause::Other);
    }
}
