//! `pamctl ports`: serial ports that may be the robot.

use pam_link::list_ports;

pub fn run(out: &mut dyn std::io::Write) -> anyhow::Result<()> {
    let ports = list_ports()?;
    if ports.is_empty() {
        writeln!(
            out,
            "no serial port found: plug the board's USB link cable (the NUCLEO-G474RE has no user USB \
             connector: a cable wired to PA11/PA12, see firmware/README.md \"USB link\"; the ST-LINK \
             port only flashes), or use the emulator with --device tcp://127.0.0.1:PORT"
        )?;
    }
    for (name, what) in ports {
        writeln!(out, "{name}\t{what}")?;
    }
    Ok(())
}
