//! The workspace's `memory.x` (one for both boards) on the linker's search path, and every
//! firmware relinked when it changes: cargo does not track a linker script by itself (a layout
//! change had left a stale image that zeroed past the end of RAM at reset).
use std::path::{Path, PathBuf};

fn main() {
    // Read when the script runs, not baked in when it is built: a script built in another
    // checkout of the workspace and reused from a shared target folder copies this one's.
    let dir = std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let src = Path::new(&dir).join("../../memory.x");
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::copy(&src, out.join("memory.x")).expect("memory.x copied to OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", src.display());
}
