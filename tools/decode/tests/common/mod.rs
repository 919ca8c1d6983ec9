//! What the firmware tests share: the workspace and the firmware build.

use std::path::{Path, PathBuf};
use std::process::Command;

pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Builds firmware with the cargo alias `alias` into its own target directory (the outer
/// `cargo test` holds its own) and returns the path of the ELF `binary` (built with the cargo
/// profile `profile`).
pub fn build_firmware(alias: &str, profile: &str, binary: &str) -> PathBuf {
    let target_dir = std::env::var_os("TACTILE_FW_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("target/fw"));
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(workspace())
        .env("CARGO_TARGET_DIR", &target_dir)
        .arg(alias)
        .status()
        .expect("cargo runs");
    assert!(status.success(), "the firmware ({alias}) does not build");
    target_dir
        .join("thumbv7em-none-eabihf")
        .join(profile)
        .join(binary)
}
