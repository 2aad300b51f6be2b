//! `cargo xtask soak [--hours H] [--seed S]`: the soak test (`pam_emulator::soak`) for hours
//! of emulated operation, fast-forwarded; prints its figures, exits 1 on any problem.

use pam_emulator::soak::{run, SoakConfig};

fn main() {
    let mut hours = 1.0;
    let mut seed = 1;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let value = args.next();
        let parsed = match (a.as_str(), value.as_deref()) {
            ("--hours", Some(v)) => v
                .parse::<f64>()
                .ok()
                .filter(|h| h.is_finite() && *h > 0.0)
                .map(|h| hours = h),
            ("--seed", Some(v)) => v.parse::<u64>().ok().map(|s| seed = s),
            _ => None,
        };
        if parsed.is_none() {
            eprintln!("usage: soak [--hours H (> 0)] [--seed S]");
            std::process::exit(2);
        }
    }
    let config = SoakConfig {
        emulated_s: hours * 3600.0,
        seed,
    };
    println!("soak: {hours} h emulated, seed {seed}");
    let report = run(config, |r| {
        println!(
            "  {:.0} s emulated in {:.0} s: {} frames, {} lost, {} faults injected, {} problems",
            r.emulated_s,
            r.wall_s,
            r.telemetry_frames,
            r.lost_frames,
            r.faults_injected(),
            r.problems.len()
        )
    });
    match report {
        Ok(r) => {
            print!("{r}");
            std::process::exit(i32::from(!r.problems.is_empty()));
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
