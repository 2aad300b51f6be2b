//! `cargo run -p pam-emulator --example fault_table [-- --seed S]`: the
//! fault-consequence table (`pam_emulator::soak::fault_table`), fast-forwarded; prints it in
//! markdown with the date, the commit and the command.

use pam_emulator::soak::fault_table::{markdown, run, TableConfig};

fn main() {
    let mut cfg = TableConfig::default();
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.as_slice() {
        [] => {}
        [flag, v] if flag == "--seed" => match v.parse() {
            Ok(s) => cfg.seed = s,
            Err(_) => usage(),
        },
        _ => usage(),
    }
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    let date = std::process::Command::new("date")
        .args(["-u", "+%Y-%m-%d %H:%M UTC"])
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    let cells = run(&cfg, |c| {
        eprintln!("{} / {} / {}", c.kind.name(), c.mode, c.hand.name())
    });
    match cells {
        Ok(cells) => {
            println!(
                "Measured {date} at commit {commit} with `cargo run -p pam-emulator --example fault_table -- --seed {}` \
                 (settle {} s, hand on {} s before the fault, watched {} s after it):\n",
                cfg.seed, cfg.settle_s, cfg.hold_s, cfg.watch_s
            );
            print!("{}", markdown(&cells, &cfg));
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}

fn usage() -> ! {
    eprintln!("usage: fault_table [--seed S]");
    std::process::exit(2);
}
