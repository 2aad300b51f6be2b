//! `pamctl sim` on the command line: its flags are checked before the emulator starts.

#[test]
fn sim_rejects_unknown_effects_and_lists_the_known_ones() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pamctl"))
        .args(["sim", "--with", "no_such_effect", "--listen", "127.0.0.1:0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no_such_effect") && err.contains("mains_hum"),
        "{err}"
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pamctl"))
        .args(["sim", "--list-effects"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("transport_delay"));
}
