//! What the integration tests share: the `tactile` command run as a user runs it.

use std::ffi::OsStr;

/// Runs `tactile` with `args`: its exit code (None: killed by a signal), stdout and stderr.
pub fn tactile<S: AsRef<OsStr>>(
    args: impl IntoIterator<Item = S>,
) -> (Option<i32>, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_tactile"))
        .args(args)
        .output()
        .expect("tactile runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A path for a test's scratch file or folder `name`, under Cargo's scratch folder for tests
/// in `target/` (named for this process: test binaries may run side by side).
pub fn scratch(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{}-{name}", std::process::id()))
}

/// The shared records' folder (`labels.json`, the development records, `real/`): beside the
/// project (`../shared/data`, as on CI), or where `TACTILE_SHARED_DATA` says. A clone without
/// it fails the tests that read it with this reason, not a bare file error.
pub fn shared_data() -> std::path::PathBuf {
    let dir = std::env::var_os("TACTILE_SHARED_DATA").map_or_else(
        || std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"),
        std::path::PathBuf::from,
    );
    assert!(
        dir.join("labels.json").is_file(),
        "the shared records are not in {}: clone the project beside ../shared, or set \
         TACTILE_SHARED_DATA to the folder that holds labels.json and real/",
        dir.display()
    );
    dir
}
