//! Prints the thesis reference values as this model computes them, in f64 and f32.
use pam_model::checks::{table_4_1_stiffness, TABLE_4_1};
use pam_model::{Real, RobotModel};

fn report<R: Real>(label: &str) {
    let m = RobotModel::<R>::thesis();
    println!("== {label}");
    for j in 0..2 {
        let (lo, hi) = m.joints[j].whole_range_torque_nm(&m.params.muscle, 65);
        println!(
            "joint {}: eps0 {:.5}  anti-slack {:.3} N  whole-range torque [{:.3}, {:.3}] N m",
            j + 1,
            m.joints[j].epsilon0.to_f64(),
            m.joints[j].anti_slack_force_n.to_f64(),
            lo.to_f64(),
            hi.to_f64()
        );
    }
    println!("Table 4.1 (printed -> model):");
    for (a1, a2, printed) in TABLE_4_1 {
        let got = table_4_1_stiffness::<R>([a1, a2]);
        print!("  ({a1:6.1}, {a2:6.1})");
        for k in 0..4 {
            print!("  {:6.1}->{:6.2}", printed[k], got[k]);
        }
        println!();
    }
    let kc = m
        .cartesian_stiffness([R::ZERO; 2], [R::from_f64(59.5), R::from_f64(26.6)])
        .unwrap();
    println!(
        "K_C at point 1, K_min: {:?}",
        kc.0.map(|r| r.map(|x| (x.to_f64() * 10.0).round() / 10.0))
    );
    let mc = m.cartesian_mass([R::ZERO; 2]).unwrap();
    println!(
        "M_C at point 1: {:?}",
        mc.0.map(|r| r.map(|x| (x.to_f64() * 1000.0).round() / 1000.0))
    );
}

fn main() {
    report::<f64>("f64");
    report::<f32>("f32");
}
