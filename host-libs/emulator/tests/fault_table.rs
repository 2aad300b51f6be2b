//! The fault table's harness: one fault from one mode, fast-forwarded.

use pam_emulator::soak::fault_table::{markdown, run_case, Hand, TableMode, WATCH_S};
use pam_emulator::soak::Kind;

#[test]
fn an_estop_in_joint_mode_vents_at_once_and_the_muscles_empty_within_the_slowest_exhaust() {
    let o = run_case(Kind::EStop, TableMode::Joint, Hand::Free).expect("runs");
    assert_eq!(o.setup_problem, None);
    assert_ne!(o.faults, 0, "the E-stop latches");
    let vent = o.to_vent_s.expect("vented");
    assert!(vent <= 0.002, "vent command after {vent} s");
    // the slowest channel exhausts 5 bar in 2.412 s; the joint target needs well under
    // 5 bar, and never less than the fastest channel's share of it
    let vented = o.to_vented_s.expect("muscles below 0.5 bar");
    assert!(
        vented > 0.1 && vented < 2.5,
        "muscles below 0.5 bar after {vented} s"
    );
    // the vented arm may run to a range end, but no farther than the workspace (two
    // links of well under half a metre each)
    assert!(
        o.excursion_mm.is_finite() && o.excursion_mm < 1000.0,
        "{o:?}"
    );
    assert!(o.speed_mm_s.is_finite() && o.speed_mm_s > 0.0, "{o:?}");
    assert!(vented < WATCH_S);
    let table = markdown(&[o]);
    // the held case is absent: its cells empty; the vent command in the first period
    assert!(
        table.contains("| E-stop | joint | — / 0x1000 | | | | | 1 | "),
        "{table}"
    );
}

#[test]
fn a_held_hand_takes_force_and_keeps_the_handle_closer_than_a_free_one() {
    let held = run_case(Kind::LinkLoss, TableMode::Joint, Hand::Held).expect("runs");
    let free = run_case(Kind::LinkLoss, TableMode::Joint, Hand::Free).expect("runs");
    assert_eq!((&held.setup_problem, &free.setup_problem), (&None, &None));
    assert!(held.to_vent_s.is_some() && free.to_vent_s.is_some());
    assert!(held.hand_force_n > 0.0 && free.hand_force_n == 0.0);
    assert!(
        held.excursion_mm < free.excursion_mm,
        "held {held:?} free {free:?}"
    );
}
