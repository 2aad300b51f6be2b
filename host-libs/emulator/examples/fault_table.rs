//! `cargo xtask fault-table`: every fault kind of the soak × every mode, a held hand and a
//! free handle, on the twin with the converters' measured rates (`pam_emulator::soak::fault_table`),
//! fast-forwarded; prints the markdown table. `--stamp TEXT` heads it with TEXT (the date
//! and commit the xtask passes).

use pam_emulator::soak::fault_table::{markdown, run_all, targets_markdown};

fn main() {
    let mut args = std::env::args().skip(1);
    let mut stamp = None;
    while let Some(a) = args.next() {
        match (a.as_str(), args.next()) {
            ("--stamp", Some(v)) => stamp = Some(v),
            _ => {
                eprintln!("usage: fault_table [--stamp TEXT]");
                std::process::exit(2);
            }
        }
    }
    let outcomes = match run_all(|o| {
        eprintln!(
            "  {} / {} / {:?}: vent {:?} s, < 0.5 bar {:?} s, {:.1} mm{}",
            o.kind.name(),
            o.mode.name(),
            o.hand,
            o.to_vent_s,
            o.to_vented_s,
            o.excursion_mm,
            o.setup_problem
                .as_deref()
                .map_or(String::new(), |p| format!(" (not run: {p})"))
        )
    }) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    if let Some(s) = stamp {
        println!("{s}\n");
    }
    println!("The targets before the fault:\n\n{}", targets_markdown());
    print!("{}", markdown(&outcomes));
}
