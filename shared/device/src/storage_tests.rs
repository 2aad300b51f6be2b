//! Host tests of the configuration in flash as the device uses it (a RAM flash with the
//! G4's rules). The storage format itself is tested in pam-config-store.

use super::*;
use crate::{RawSensors, StepTiming};
use pam_config_store::{PowerCut, RamFlash};
use pam_protocol::{ConfigSection, ReplyData, Status, BOARD_CHECK_VDDA};

type Flash = RamFlash<4096>;

// the device the service's own checks use
use crate::checks::{device, OPTIONS, SESSION};

fn step(d: &mut Device) -> crate::StepResult {
    d.step(
        RawSensors {
            encoder_counts: [1000, 2000],
            loadcell_volts: [0.02, -0.01],
        },
        StepTiming::default(),
    )
}

fn ask(
    d: &mut Device,
    store: &mut ConfigStore<Flash>,
    body: RequestBody,
) -> Result<ReplyData, ErrorCode> {
    d.handle_with_store(
        store,
        &Request {
            id: 9,
            body,
            session: SESSION,
        },
    )
    .result
}

fn status(d: &mut Device) -> Status {
    match d
        .handle(&Request {
            id: 1,
            body: RequestBody::GetStatus,
            session: SESSION,
        })
        .result
    {
        Ok(ReplyData::Status(s)) => s,
        other => panic!("{other:?}"),
    }
}

/// A tare and a timeout that are not the defaults.
fn customise(d: &mut Device) {
    step(d);
    let mut cal = d.calibration();
    cal.load_cell.offset_v = [0.125, -0.25];
    cal.output[2].offset_ma = 0.05;
    let mut limits: pam_protocol::wire::SafetyConfig = (*d.controller().safety()).into();
    limits.command_timeout_s = 0.25;
    for c in [Config::Calibration(cal), Config::Limits(limits)] {
        let r = d.handle(&Request {
            id: 2,
            body: RequestBody::SetConfig(c),
            session: SESSION,
        });
        assert_eq!(r.result, Ok(ReplyData::Done));
    }
}

fn store() -> ConfigStore<Flash> {
    ConfigStore::new(Flash::new(), 0).unwrap()
}

/// A reboot: a new device over the same flash bytes.
fn reboot(flash: &Flash) -> (Device, ConfigStore<Flash>) {
    let mut store = ConfigStore::new(Flash::from_bytes(flash.as_bytes()), 0).unwrap();
    let mut d = device();
    d.boot_config(store.load());
    (d, store)
}

#[test]
fn a_persisted_configuration_is_back_after_a_reboot() {
    let mut s = store();
    let mut d = device();
    d.boot_config(s.load());
    assert_eq!(status(&mut d).config, ConfigOrigin::DefaultsNoRecord);
    assert_eq!(
        d.controller().faults(),
        Faults::NONE,
        "no record is not a fault"
    );
    customise(&mut d);
    assert!(status(&mut d).config_unsaved);
    assert_eq!(
        ask(&mut d, &mut s, RequestBody::PersistConfig),
        Ok(ReplyData::Done)
    );
    let st = status(&mut d);
    assert!(!st.config_unsaved && st.config == ConfigOrigin::Flash);

    let (mut again, _) = reboot(s.flash());
    assert_eq!(again.stored_config(), d.stored_config());
    assert_eq!(again.calibration().load_cell.offset_v, [0.125, -0.25]);
    assert_eq!(again.controller().safety().command_timeout_s, 0.25);
    let st = status(&mut again);
    assert_eq!(
        (st.config, st.config_unsaved, st.faults),
        (ConfigOrigin::Flash, false, 0)
    );
}

#[test]
fn a_corrupt_record_boots_to_the_defaults_with_self_check() {
    let mut s = store();
    let mut d = device();
    customise(&mut d);
    ask(&mut d, &mut s, RequestBody::PersistConfig).unwrap();
    s.flash_mut().as_bytes_mut()[40] ^= 0x10;

    let (mut d, _) = reboot(s.flash());
    assert_eq!(
        d.stored_config(),
        device().stored_config(),
        "the thesis defaults"
    );
    assert_eq!(d.controller().state(), State::Faulted);
    let st = status(&mut d);
    assert_eq!(st.config, ConfigOrigin::DefaultsCorrupt);
    assert_eq!(st.faults, Faults::SELF_CHECK.0);
    // acknowledged like any latched fault
    step(&mut d);
    let r = d.handle(&Request {
        id: 3,
        body: RequestBody::ClearFaults,
        session: SESSION,
    });
    assert_eq!(r.result, Ok(ReplyData::Done));
    step(&mut d);
    assert_eq!(d.controller().faults(), Faults::NONE);
}

#[test]
fn a_record_of_another_layout_and_an_unreadable_flash_are_faults_too() {
    let mut d = device();
    d.boot_config(Ok(Loaded::OtherVersion));
    assert_eq!(status(&mut d).config, ConfigOrigin::DefaultsOtherVersion);
    assert!(d.controller().faults().contains(Faults::SELF_CHECK));

    let mut d = device();
    d.boot_config(Err(StoreError::Flash(
        embedded_storage::nor_flash::NorFlashErrorKind::Other,
    )));
    assert_eq!(status(&mut d).config, ConfigOrigin::DefaultsNoStorage);
    assert!(d.controller().faults().contains(Faults::SELF_CHECK));
}

#[test]
fn a_record_the_device_refuses_is_not_applied_in_part() {
    let mut stored = device().stored_config();
    stored.calibration.load_cell.offset_v = [0.5, 0.5];
    stored.limits.period_s = 0.5; // beyond the 1–10 ms the device accepts
    let mut d = device();
    d.boot_config(Ok(Loaded::Record(stored)));
    assert_eq!(status(&mut d).config, ConfigOrigin::DefaultsRefused);
    assert!(d.controller().faults().contains(Faults::SELF_CHECK));
    assert_eq!(d.stored_config(), device().stored_config());
    // applied over a configuration in use: the calibration before the refused limits is
    // rolled back
    let mut d = device();
    customise(&mut d);
    let before = d.stored_config();
    assert_eq!(d.apply_stored(&stored), Err(ErrorCode::OutOfRange));
    assert_eq!(d.stored_config(), before);
}

#[test]
fn the_emulators_timeout_and_encoders_survive_a_fall_back_to_defaults() {
    let mut safety = SafetyConfig::default_1khz();
    safety.command_timeout_s = 1.0;
    let mut d = Device::new(RobotParams::thesis(), safety, OPTIONS);
    let mut cal = d.calibration();
    cal.encoder[0].counts_per_rev = 4096;
    d.handle(&Request {
        id: 1,
        body: RequestBody::SetConfig(Config::Calibration(cal)),
        session: SESSION,
    });
    d.boot_config(Ok(Loaded::Corrupt));
    assert_eq!(d.controller().safety().command_timeout_s, 1.0);
    assert_eq!(d.calibration().encoder[0].counts_per_rev, 4096);
}

#[test]
fn restore_and_erase() {
    let mut s = store();
    let mut d = device();
    assert_eq!(
        ask(&mut d, &mut s, RequestBody::RestoreConfig),
        Err(ErrorCode::NoStoredConfig)
    );
    customise(&mut d);
    let customised = d.stored_config();
    ask(&mut d, &mut s, RequestBody::PersistConfig).unwrap();
    // change the RAM copy, then restore the flash copy
    let r = d.handle(&Request {
        id: 4,
        body: RequestBody::SetConfig(Config::Calibration(device().calibration())),
        session: SESSION,
    });
    assert_eq!(r.result, Ok(ReplyData::Done));
    assert_ne!(d.stored_config(), customised);
    assert_eq!(
        ask(&mut d, &mut s, RequestBody::RestoreConfig),
        Ok(ReplyData::Done)
    );
    assert_eq!(d.stored_config(), customised);
    assert!(!status(&mut d).config_unsaved);
    // erase forgets the flash copy, not the one in use
    assert_eq!(
        ask(&mut d, &mut s, RequestBody::EraseConfig),
        Ok(ReplyData::Done)
    );
    assert_eq!(d.stored_config(), customised);
    assert!(status(&mut d).config_unsaved);
    let (mut fresh, _) = reboot(s.flash());
    assert_eq!(status(&mut fresh).config, ConfigOrigin::DefaultsNoRecord);
}

#[test]
fn storage_requests_are_refused_while_armed_and_report_flash_failures() {
    let mut s = store();
    let mut d = device();
    step(&mut d);
    d.handle(&Request {
        id: 1,
        body: RequestBody::Home,
        session: SESSION,
    });
    assert_eq!(
        d.handle(&Request {
            id: 1,
            body: RequestBody::Arm,
            session: SESSION,
        })
        .result,
        Ok(ReplyData::Done)
    );
    for body in [
        RequestBody::PersistConfig,
        RequestBody::RestoreConfig,
        RequestBody::EraseConfig,
    ] {
        assert_eq!(
            ask(&mut d, &mut s, body),
            Err(ErrorCode::WrongState),
            "{body:?}"
        );
    }
    assert!(
        s.flash().as_bytes().iter().all(|&b| b == 0xFF),
        "nothing written"
    );
    d.handle(&Request {
        id: 1,
        body: RequestBody::Disarm,
        session: SESSION,
    });
    s.flash_mut().cut_power(PowerCut::Off);
    assert_eq!(
        ask(&mut d, &mut s, RequestBody::PersistConfig),
        Err(ErrorCode::StorageFailed)
    );
    // a device without a store says so
    assert_eq!(
        d.handle(&Request {
            id: 1,
            body: RequestBody::PersistConfig,
            session: SESSION,
        })
        .result,
        Err(ErrorCode::StorageFailed)
    );
    // the config requests still answer
    assert!(matches!(
        d.handle(&Request {
            id: 1,
            body: RequestBody::GetConfig(ConfigSection::Limits),
            session: SESSION,
        })
        .result,
        Ok(ReplyData::Config(_))
    ));
}

#[test]
fn a_failing_board_check_keeps_self_check_raised_and_shows_in_status() {
    let mut d = device();
    step(&mut d);
    d.set_board_health(BoardHealth {
        board_checks: BOARD_CHECK_VDDA,
        vdda_v: Some(2.7),
        stack: Some(StackUsage {
            used_max_bytes: 100,
            size_bytes: 1000,
        }),
        last_cpu_fault: None,
    });
    let out = step(&mut d);
    assert_eq!(out.fault_event.map(|e| e.bits), Some(Faults::SELF_CHECK.0));
    d.handle(&Request {
        id: 3,
        body: RequestBody::ClearFaults,
        session: SESSION,
    });
    step(&mut d);
    assert!(
        d.controller().faults().contains(Faults::SELF_CHECK),
        "re-raised"
    );
    let st = status(&mut d);
    assert_eq!((st.board_checks, st.vdda_v), (BOARD_CHECK_VDDA, Some(2.7)));
    assert_eq!(st.stack.map(|s| s.used_max_bytes), Some(100));
    // healthy again: clear works
    d.set_board_health(BoardHealth::default());
    d.handle(&Request {
        id: 3,
        body: RequestBody::ClearFaults,
        session: SESSION,
    });
    step(&mut d);
    assert_eq!(d.controller().faults(), Faults::NONE);
}
