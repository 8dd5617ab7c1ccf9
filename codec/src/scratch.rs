//! Scratch folders for tests, shared by the codec's, the server's and the end-to-end tests
//! (the other two include this file by path).
//!
//! Every folder of one test process sits under `TMP/zerotile-test-PID/`. Folders outlive their
//! test, so a failed test's files stay to look at; instead, the first folder a process makes
//! removes the roots of test processes that have exited. Repeated runs then leave the last
//! run's files behind, not every run's: before this, each `cargo test` added ~300 folders
//! (~100 MB) to the temp dir for good.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Once;

/// What every process root's name starts with; the process id follows.
const ROOT_PREFIX: &str = "zerotile-test-";

/// A fresh, empty folder for the test `name`, its own on every call (a call count keeps
/// tests that share a name apart).
pub fn scratch(name: &str) -> PathBuf {
    static SWEEP: Once = Once::new();
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    let tmp = std::env::temp_dir();
    SWEEP.call_once(|| sweep_exited(&tmp, std::process::id()));
    let n = CALLS.fetch_add(1, Ordering::Relaxed);
    let dir = process_root(&tmp, std::process::id()).join(format!("{name}-{n}"));
    // A leftover of an earlier process with the same id is stale: start empty.
    let _ = std::fs::remove_dir_all(&dir);
    if let Err(e) = std::fs::create_dir_all(&dir) {
        panic!("cannot create the scratch folder {}: {e}", dir.display());
    }
    dir
}

/// `TMP/zerotile-test-PID`: where the process `pid` keeps its scratch folders.
fn process_root(tmp: &Path, pid: u32) -> PathBuf {
    tmp.join(format!("{ROOT_PREFIX}{pid}"))
}

/// Removes the process roots under `tmp` whose process is gone, all but `me`'s. It asks
/// `/proc`, so it removes nothing where there is none (a root is then left, never a live
/// process's folder taken).
fn sweep_exited(tmp: &Path, me: u32) {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(tmp) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(ROOT_PREFIX))
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != me && !proc.join(pid.to_string()).exists() {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An exited process's root goes, a live one's and unrelated folders stay.
    #[cfg(target_os = "linux")]
    #[test]
    fn the_sweep_takes_only_exited_processes_roots() {
        let tmp = scratch("sweep");
        // A pid past Linux's pid_max (2^22) never names a running process.
        let gone = process_root(&tmp, 4_194_305);
        let live = process_root(&tmp, 1);
        let mine = process_root(&tmp, 4_194_306);
        let other = tmp.join("zerotile-test-notapid");
        for d in [&gone, &live, &mine, &other] {
            std::fs::create_dir_all(d.join("inner")).unwrap();
        }
        sweep_exited(&tmp, 4_194_306);
        assert!(!gone.exists(), "an exited process's root is removed");
        assert!(live.exists(), "pid 1 is running: its root stays");
        assert!(mine.exists(), "the sweeping process keeps its own root");
        assert!(
            other.exists(),
            "a folder not named for a pid is not ours to remove"
        );
    }

    #[test]
    fn every_call_is_a_fresh_empty_folder_of_this_process() {
        let a = scratch("same");
        std::fs::write(a.join("f"), b"x").unwrap();
        let b = scratch("same");
        assert_ne!(a, b);
        assert_eq!(std::fs::read_dir(&b).unwrap().count(), 0);
        assert!(a.starts_with(process_root(&std::env::temp_dir(), std::process::id())));
    }
}
