//! The configuration in the device's flash, end to end through pamctl: set, persist,
//! restart, the values are back; a damaged record boots the defaults with SELF_CHECK;
//! restore and erase. The restarts need the emulator (`pamctl sim --config-flash FILE`):
//! against a board (`PAM_DEVICE`) these tests do nothing and say so.

use pam_hil_tests::{exclusive, ok, pamctl, tmp_dir, Target};

/// An emulator over the flash file `flash`.
fn emulator(flash: &std::path::Path) -> Option<Target> {
    let t = Target::acquire(&["--config-flash", flash.to_str().expect("utf-8 path")]);
    if !t.is_emulator() {
        eprintln!("PAM_DEVICE is a board: the restart tests need the emulator, skipped");
        return None;
    }
    Some(t)
}

fn status(t: &Target) -> String {
    ok(&t.address, &["status"])
}

fn config_line(status: &str) -> &str {
    status
        .lines()
        .find(|l| l.starts_with("config: "))
        .unwrap_or_else(|| panic!("no config line in {status}"))
}

// as they read in `pamctl config get` without its whitespace ([`get`])
const TARE: &str = "offset_v=[0.125,-0.25,]";
const SLEW: &str = "slew_bar_per_s=7.5";
const OVERRUN: &str = "overrun_fault_periods=7";

/// `pamctl config get [SECTION]` without whitespace (arrays are printed one value a line).
fn get(t: &Target, section: &[&str]) -> String {
    let mut args = vec!["config", "get"];
    args.extend_from_slice(section);
    ok(&t.address, &args).split_whitespace().collect()
}

/// Sets a tare, a slew limit and a count of missed periods that are not the defaults, and
/// persists them.
fn set_and_persist(t: &Target) {
    let a = &t.address;
    let defaults = get(t, &[]);
    assert!(
        !defaults.contains(TARE) && !defaults.contains(SLEW) && !defaults.contains(OVERRUN),
        "{defaults}"
    );
    ok(
        a,
        &[
            "config",
            "set",
            "calibration.load_cell.offset_v=[0.125, -0.25]",
            "limits.slew_bar_per_s=7.5",
            "limits.overrun_fault_periods=7",
        ],
    );
    assert!(config_line(&status(t)).contains("changed since"));
    let out = ok(a, &["config", "persist"]);
    assert!(out.contains("written to the device's flash"), "{out}");
    assert_eq!(config_line(&status(t)), "config: from flash");
}

#[test]
fn a_persisted_configuration_is_back_after_a_restart() {
    let _g = exclusive();
    let dir = tmp_dir();
    let flash = dir.path().join("persist.flash");
    {
        let Some(t) = emulator(&flash) else { return };
        let s = status(&t);
        assert_eq!(
            config_line(&s),
            "config: thesis defaults (no record in flash)"
        );
        assert!(s.contains("faults: none"), "no record is not a fault: {s}");
        set_and_persist(&t);
    }
    let t = emulator(&flash).expect("emulator");
    let got = get(&t, &[]);
    assert!(
        got.contains(TARE) && got.contains(SLEW) && got.contains(OVERRUN),
        "{got}"
    );
    let s = status(&t);
    assert_eq!(config_line(&s), "config: from flash");
    assert!(s.contains("faults: none"), "{s}");

    // restore undoes a change made since; erase leaves the values in use alone
    ok(&t.address, &["config", "set", "limits.slew_bar_per_s=9"]);
    assert!(get(&t, &["limits"]).contains("slew_bar_per_s=9.0"));
    ok(&t.address, &["config", "restore"]);
    assert!(get(&t, &["limits"]).contains(SLEW));
    ok(&t.address, &["config", "erase"]);
    assert!(get(&t, &["limits"]).contains(SLEW));
    let (code, _, err) = pamctl(&t.address, &["config", "restore"]);
    assert_ne!(code, 0, "restore from an erased flash must fail");
    assert!(err.contains("no good configuration record"), "{err}");
    drop(t);
    let t = emulator(&flash).expect("emulator");
    assert_eq!(
        config_line(&status(&t)),
        "config: thesis defaults (no record in flash)"
    );
    assert!(!get(&t, &[]).contains(SLEW));
}

#[test]
fn a_corrupt_record_boots_the_defaults_with_the_self_check_fault() {
    let _g = exclusive();
    let dir = tmp_dir();
    let flash = dir.path().join("corrupt.flash");
    {
        let Some(t) = emulator(&flash) else { return };
        set_and_persist(&t);
    }
    // one flipped bit in the record's payload
    let mut bytes = std::fs::read(&flash).expect("the flash file");
    bytes[40] ^= 0x10;
    std::fs::write(&flash, &bytes).expect("write the flash file");

    let t = emulator(&flash).expect("emulator");
    let s = status(&t);
    assert!(config_line(&s).contains("CORRUPT"), "{s}");
    assert!(
        s.contains("state: FAULTED") && s.contains("self-check"),
        "{s}"
    );
    let got = get(&t, &[]);
    assert!(
        !got.contains(TARE) && !got.contains(SLEW),
        "defaults: {got}"
    );
    // the robot cannot be armed until someone acknowledges it
    ok(&t.address, &["home"]);
    let (code, _, _) = pamctl(&t.address, &["arm"]);
    assert_ne!(code, 0, "armed with a corrupt configuration");
    ok(&t.address, &["fault", "clear"]);
    assert!(status(&t).contains("faults: none"));
}
