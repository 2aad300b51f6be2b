//! A short soak (`pam_emulator::soak`): three emulated minutes of random targets in every
//! mode, injected faults, bad targets and noise, fast-forwarded (well under a minute of
//! wall time in a debug build). `cargo xtask soak` runs the hour.

use pam_emulator::soak::{run, SoakConfig};

#[test]
fn three_emulated_minutes_without_a_lost_frame_or_an_unsafe_sample() {
    let r = run(
        SoakConfig {
            emulated_s: 180.0,
            seed: 7,
        },
        |_| {},
    )
    .expect("the emulator starts");
    println!("{r}");
    assert!(r.problems.is_empty(), "{r}");
    assert_eq!(r.lost_frames, 0, "{r}");
    assert_eq!(r.telemetry_frames, r.periods, "{r}");
    assert!(r.emulated_s >= 180.0);
    // it did exercise something: faults, clears, re-arms, every mode
    assert!(r.faults_injected() >= 10, "{r}");
    assert!(r.clears >= 5 && r.arms >= 10, "{r}");
    assert_eq!(r.modes.len(), 6, "{r}");
    // every injected fault counted once by kind and mode, and what followed each
    // undetected one measured
    let by_mode: u64 = r.coverage.values().map(|c| c.injected).sum();
    assert_eq!(by_mode, r.faults_injected(), "{r}");
    let detected: u64 = r.coverage.values().map(|c| c.detected).sum();
    assert_eq!(r.undetected.len() as u64, by_mode - detected, "{r}");
    assert!(
        r.undetected
            .iter()
            .all(|c| c.excursion_mm.is_finite() && c.force_n.is_finite()),
        "{r}"
    );
}
