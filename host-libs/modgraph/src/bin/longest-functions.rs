//! `longest-functions N DIR...`: the N longest functions of the non-test code under each
//! source folder, longest first, as `lines  file:line  name`.

use pam_modgraph::function_lengths;
use std::path::Path;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = match args.next().map(|a| a.parse()) {
        Some(Ok(n)) => n,
        _ => {
            eprintln!("usage: longest-functions N DIR...");
            std::process::exit(2);
        }
    };
    let mut all: Vec<_> = args.flat_map(|d| function_lengths(Path::new(&d))).collect();
    all.sort_by(|a, b| b.lines.cmp(&a.lines).then(a.file.cmp(&b.file)));
    for f in all.iter().take(n) {
        println!("{:5}  {}:{}  {}", f.lines, f.file.display(), f.line, f.name);
    }
}
