//! The store's checks that also run on the Cortex-M4F under QEMU (`qemu-tests/`): the same
//! code, the target's integer widths and alignment. The host tests (`tests.rs`) go further.

use crate::*;
use pam_control::SafetyConfig;
use pam_model::checks::{holds_that as holds, CheckResult, Failure};
use pam_model::RobotParams;

type Flash = RamFlash<4096>;

fn config(tare_v: f32) -> StoredConfig {
    let p = RobotParams::<f32>::thesis();
    let mut c = StoredConfig {
        robot: p.into(),
        calibration: pam_protocol::Calibration {
            encoder: Default::default(),
            load_cell: p.load_cell.into(),
            output: Default::default(),
            output_of_channel: pam_protocol::IDENTITY_CHANNEL_MAP,
        },
        limits: SafetyConfig::default_1khz().into(),
    };
    c.calibration.load_cell.offset_v = [tare_v, -tare_v];
    c
}

fn store() -> Result<ConfigStore<Flash>, Failure> {
    ConfigStore::new(Flash::new(), 0).map_err(|_| Failure {
        what: "a store over two pages",
        got: 0.0,
        expected: 1.0,
        tolerance: 0.0,
        index: 0,
    })
}

pub fn a_saved_record_loads_back() -> CheckResult {
    let mut s = store()?;
    holds("erased is missing", s.load() == Ok(Loaded::Missing))?;
    holds("saved", s.save(&config(0.25)).is_ok())?;
    holds("loads back", s.load() == Ok(Loaded::Record(config(0.25))))?;
    holds("saved again", s.save(&config(0.5)).is_ok())?;
    holds(
        "the newest wins",
        s.load() == Ok(Loaded::Record(config(0.5))),
    )
}

pub fn a_flipped_bit_is_corrupt() -> CheckResult {
    let mut s = store()?;
    holds("saved", s.save(&config(0.25)).is_ok())?;
    s.flash_mut().as_bytes_mut()[HEADER_BYTES + 5] ^= 0x01;
    holds("corrupt", s.load() == Ok(Loaded::Corrupt))
}

pub fn a_power_cut_keeps_the_old_or_the_new_record() -> CheckResult {
    // every 61st byte of a save (an erase of 2048 plus a record of about 350)
    let mut budget = 0;
    while budget < 2600 {
        let mut s = store()?;
        holds("first save", s.save(&config(0.25)).is_ok())?;
        s.flash_mut().cut_power(PowerCut::AfterBytes(budget));
        let _ = s.save(&config(0.5));
        s.flash_mut().restore_power();
        let loaded = s.load();
        holds(
            "old or new record after the cut",
            loaded == Ok(Loaded::Record(config(0.25))) || loaded == Ok(Loaded::Record(config(0.5))),
        )?;
        budget += 61;
    }
    Ok(())
}

pam_model::register_checks!(
    a_saved_record_loads_back,
    a_flipped_bit_is_corrupt,
    a_power_cut_keeps_the_old_or_the_new_record,
);
