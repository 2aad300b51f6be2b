use super::*;
use pam_control::SafetyConfig;
use pam_model::RobotParams;

const PAGE: usize = 2048;
type Flash = RamFlash<{ 2 * PAGE }>;

fn thesis() -> StoredConfig {
    StoredConfig {
        robot: RobotParams::<f32>::thesis().into(),
        calibration: Calibration {
            encoder: Default::default(),
            load_cell: RobotParams::<f32>::thesis().load_cell.into(),
            output: Default::default(),
            output_of_channel: pam_protocol::IDENTITY_CHANNEL_MAP,
        },
        limits: SafetyConfig::default_1khz().into(),
    }
}

/// The thesis configuration with a tare and a timeout of its own, told apart by `k`.
fn changed(k: f32) -> StoredConfig {
    let mut c = thesis();
    c.calibration.load_cell.offset_v = [0.1 * k, -0.2 * k];
    c.limits.command_timeout_s = 0.01 * k;
    c
}

fn store() -> ConfigStore<Flash> {
    ConfigStore::new(Flash::new(), 0).unwrap()
}

#[test]
fn an_erased_flash_is_missing_and_a_saved_record_comes_back() {
    let mut s = store();
    assert_eq!(s.load(), Ok(Loaded::Missing));
    s.save(&changed(3.0)).unwrap();
    assert_eq!(s.load(), Ok(Loaded::Record(changed(3.0))));
    // a fresh store over the same bytes (a reset) finds it too
    let mut again = ConfigStore::new(Flash::from_bytes(s.flash().as_bytes()), 0).unwrap();
    assert_eq!(again.load(), Ok(Loaded::Record(changed(3.0))));
}

#[test]
fn the_thesis_configuration_fits_with_room_to_spare() {
    let mut buf = [0u8; 1024];
    let n = postcard::to_slice(&thesis(), &mut buf).unwrap().len();
    assert!(n + 64 < PAYLOAD_MAX, "{n} B");
}

#[test]
fn saves_alternate_between_the_slots_and_the_newest_wins() {
    let mut s = store();
    for k in 1..=5 {
        s.save(&changed(k as f32)).unwrap();
        assert_eq!(s.load(), Ok(Loaded::Record(changed(k as f32))));
        // the previous record is still in the other slot
        let slot = if k % 2 == 1 { 0 } else { 1 };
        assert_ne!(s.flash().as_bytes()[slot * PAGE], 0xFF, "save {k}");
        if k > 1 {
            assert_ne!(s.flash().as_bytes()[(1 - slot) * PAGE], 0xFF, "save {k}");
        }
    }
}

#[test]
fn a_flipped_bit_is_corrupt_and_the_other_slot_takes_over() {
    let mut s = store();
    s.save(&changed(1.0)).unwrap();
    // damage the only record: corrupt
    s.flash_mut().as_bytes_mut()[HEADER_BYTES + 10] ^= 0x04;
    assert_eq!(s.load(), Ok(Loaded::Corrupt));

    let mut s = store();
    s.save(&changed(1.0)).unwrap();
    s.save(&changed(2.0)).unwrap();
    // damage the newer record (slot 1): the older one is loaded
    s.flash_mut().as_bytes_mut()[PAGE + HEADER_BYTES + 10] ^= 0x04;
    assert_eq!(s.load(), Ok(Loaded::Record(changed(1.0))));
    // damage its CRC too: nothing good is left
    s.flash_mut().as_bytes_mut()[HEADER_BYTES + 3] ^= 0x80;
    assert_eq!(s.load(), Ok(Loaded::Corrupt));
}

#[test]
fn garbage_and_a_lying_length_are_corrupt_not_a_panic() {
    let mut s = store();
    for (i, b) in s.flash_mut().as_bytes_mut().iter_mut().enumerate() {
        *b = (i * 7 + 3) as u8;
    }
    assert_eq!(s.load(), Ok(Loaded::Corrupt));
    let mut s = store();
    s.save(&thesis()).unwrap();
    s.flash_mut().as_bytes_mut()[6..8].copy_from_slice(&u16::MAX.to_le_bytes());
    assert_eq!(s.load(), Ok(Loaded::Corrupt));
}

/// Rewrites slot 0's header field at `at` and re-signs the record, as another firmware
/// with another layout would have written it.
fn rewrite_header(s: &mut ConfigStore<Flash>, at: usize, value: &[u8]) {
    let bytes = s.flash_mut().as_bytes_mut();
    bytes[at..at + value.len()].copy_from_slice(value);
    let len = u16::from_le_bytes([bytes[6], bytes[7]]) as usize;
    let end = HEADER_BYTES + len;
    let crc = CRC32.checksum(&bytes[..end]);
    bytes[end..end + 4].copy_from_slice(&crc.to_le_bytes());
}

#[test]
fn a_record_of_another_layout_or_format_is_another_version() {
    let mut s = store();
    s.save(&thesis()).unwrap();
    rewrite_header(&mut s, 12, &(LAYOUT_HASH ^ 1).to_le_bytes());
    assert_eq!(s.load(), Ok(Loaded::OtherVersion));

    let mut s = store();
    s.save(&thesis()).unwrap();
    rewrite_header(&mut s, 4, &(FORMAT_VERSION - 1).to_le_bytes());
    assert_eq!(s.load(), Ok(Loaded::OtherVersion));

    // saving over it works, and the new record is newer than the old one's number
    s.save(&changed(4.0)).unwrap();
    assert_eq!(s.load(), Ok(Loaded::Record(changed(4.0))));
}

#[test]
fn a_power_cut_anywhere_in_a_save_leaves_the_old_or_the_new_record() {
    // a save costs one page erase plus the record's bytes
    let old = changed(1.0);
    let new = changed(2.0);
    let mut budget = 0;
    let mut saw = (false, false);
    loop {
        let mut s = store();
        s.save(&changed(0.5)).unwrap();
        s.save(&old).unwrap();
        s.flash_mut().cut_power(PowerCut::AfterBytes(budget));
        let finished = s.save(&new).is_ok();
        s.flash_mut().restore_power();
        let loaded = s.load().unwrap();
        if finished {
            assert_eq!(loaded, Loaded::Record(new), "budget {budget}");
            break;
        }
        match loaded {
            Loaded::Record(c) if c == old => saw.0 = true,
            // the new record may be complete before its last padding byte
            Loaded::Record(c) if c == new => saw.1 = true,
            other => panic!("cut after {budget} bytes: {other:?}"),
        }
        budget += 1;
    }
    assert!(saw.0, "no cut left the old record");
    assert!(budget > PAGE, "the save never erased a page ({budget})");
}

#[test]
fn a_power_cut_in_the_first_save_is_missing_or_corrupt_and_a_retry_works() {
    for budget in [0, 1, PAGE / 2, PAGE, PAGE + 5, PAGE + 100] {
        let mut s = store();
        s.flash_mut().cut_power(PowerCut::AfterBytes(budget));
        assert_eq!(
            s.save(&thesis()),
            Err(StoreError::Flash(NorFlashErrorKind::Other))
        );
        s.flash_mut().restore_power();
        let loaded = s.load().unwrap();
        assert!(
            matches!(loaded, Loaded::Missing | Loaded::Corrupt),
            "{budget}: {loaded:?}"
        );
        s.save(&thesis()).unwrap();
        assert_eq!(s.load(), Ok(Loaded::Record(thesis())));
    }
}

#[test]
fn erase_forgets_both_records() {
    let mut s = store();
    s.save(&changed(1.0)).unwrap();
    s.save(&changed(2.0)).unwrap();
    s.erase().unwrap();
    assert_eq!(s.load(), Ok(Loaded::Missing));
    assert!(s.flash().as_bytes().iter().all(|&b| b == 0xFF));
}

#[test]
fn sequence_numbers_that_wrap_still_pick_the_newest() {
    assert!(newer(0, u32::MAX));
    assert!(newer(5, 3));
    assert!(!newer(3, 5));
    let mut s = store();
    s.save(&changed(1.0)).unwrap();
    rewrite_header(&mut s, 8, &u32::MAX.to_le_bytes());
    s.save(&changed(2.0)).unwrap(); // seq 0 after u32::MAX
    assert_eq!(s.load(), Ok(Loaded::Record(changed(2.0))));
}

#[test]
fn a_region_that_does_not_fit_is_refused() {
    assert!(matches!(
        ConfigStore::new(Flash::new(), PAGE as u32),
        Err(StoreError::Region { .. })
    ));
    assert!(matches!(
        ConfigStore::new(RamFlash::<{ 4 * PAGE }>::new(), 100),
        Err(StoreError::Region { .. })
    ));
    assert!(ConfigStore::new(RamFlash::<{ 4 * PAGE }>::new(), 2 * PAGE as u32).is_ok());
}
