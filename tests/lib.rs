//! Shared helpers for the end-to-end tests: where the binary and the shared fixtures are.
#![allow(
    clippy::expect_used,
    reason = "test support: without its own executable path the run cannot go on"
)]

use std::path::PathBuf;

pub mod qm;
pub mod server;

/// `../shared/data` beside the repository: real rasters and meshes, read in place.
pub fn shared_data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data")
}

/// The `zerotile` binary built for this test profile.
pub fn zerotile_bin() -> PathBuf {
    let mut dir = std::env::current_exe().expect("test executable path");
    dir.pop();
    if dir.ends_with("deps") {
        dir.pop();
    }
    dir.join(format!("zerotile{}", std::env::consts::EXE_SUFFIX))
}

/// Runs `cmd` to completion and returns its output, failing the test with the command and
/// its stderr unless it succeeded.
pub fn run_ok(cmd: &mut std::process::Command) -> std::process::Output {
    let out = cmd.output().expect("the command starts");
    assert!(
        out.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}
