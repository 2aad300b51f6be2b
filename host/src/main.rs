use clap::Parser;

fn main() {
    let cli = pamctl::Cli::parse();
    if let Err(e) = pamctl::run(cli) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
