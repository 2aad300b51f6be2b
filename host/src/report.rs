//! How pamctl shows an error: `error: …` with its causes, then `  help: …` when a library
//! says what to do about it (pam-link, pam-emulator, pam-ident).

/// The text for the terminal.
pub fn render(e: &anyhow::Error) -> String {
    let mut text = format!("error: {e}");
    // the libraries' messages often name their cause already; show each cause once
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    if let Some(help) = help(e) {
        text.push_str("\n  help: ");
        text.push_str(help);
    }
    text
}

/// The help of the first error in the chain that has one.
pub fn help(e: &anyhow::Error) -> Option<&'static str> {
    e.chain().find_map(|c| {
        if let Some(e) = c.downcast_ref::<pam_link::LinkError>() {
            Some(e.help())
        } else if let Some(e) = c.downcast_ref::<pam_emulator::EmulatorError>() {
            Some(e.help())
        } else {
            c.downcast_ref::<pam_ident::IdentError>().map(|e| e.help())
        }
    })
}

#[cfg(test)]
mod tests {
    use super::render;
    use anyhow::Context;

    #[test]
    fn a_library_error_shows_its_cause_once_and_its_help() {
        let e: anyhow::Result<()> = Err(pam_link::LinkError::NoDevice.into());
        let text = render(&e.context("status").unwrap_err());
        assert_eq!(
            text.lines().next(),
            Some("error: status: no device given"),
            "{text}"
        );
        assert!(text.contains("\n  help: pass --device"), "{text}");
        // an io error names its cause in the context only once
        let io = std::io::Error::other("disk full");
        let e = anyhow::Error::new(io).context("cannot write run.csv: disk full");
        assert_eq!(render(&e), "error: cannot write run.csv: disk full");
    }
}
