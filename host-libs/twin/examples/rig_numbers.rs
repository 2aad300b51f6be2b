//! The identified rig's numbers (docs/closed-loop.md, "The identified rig").
fn main() {
    let m = pam_twin::MechanicsConfig::identified_rig();
    println!(
        "muscle force ratio {}, parallel stiffness {:.1?} N·m/rad, break-away {:.2?} N·m",
        m.muscle_force_ratio, m.parallel_stiffness_nm_per_rad, m.parallel_breakaway_nm
    );
}
