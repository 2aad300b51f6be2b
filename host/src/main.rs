use clap::Parser;

fn main() {
    let cli = pamctl::Cli::parse();
    if let Err(e) = pamctl::run(cli) {
        eprintln!("{}", pamctl::report::render(&e));
        std::process::exit(1);
    }
}
