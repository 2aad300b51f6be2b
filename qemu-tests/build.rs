use std::{env, fs, path::PathBuf};

fn main() {
    // Put this crate's memory map first on the linker path so it wins over the board's
    // memory.x at the repository root.
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap());
    fs::write(out.join("memory.x"), include_bytes!("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rustc-link-arg=-Tlink.x");
}
