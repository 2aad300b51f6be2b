//! The crate's modules form layers: no module depends, through others, on itself, and no
//! file imports by glob (`pam_modgraph` says how the graph is read).

#[test]
fn no_import_circle_between_modules() {
    pam_modgraph::assert_no_cycles(concat!(env!("CARGO_MANIFEST_DIR"), "/src"));
}

#[test]
fn imports_are_explicit() {
    pam_modgraph::assert_explicit_imports(concat!(env!("CARGO_MANIFEST_DIR"), "/src"));
}
