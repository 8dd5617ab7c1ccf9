//! Replacing a folder by another in one step.
//!
//! Two renames (the old folder aside, the new one in) leave a moment with no folder at all:
//! a web server publishing an export answers 404 for every tile then, and a crash between
//! the two leaves the name empty. Linux exchanges two names atomically
//! (`renameat2(RENAME_EXCHANGE)`); where it cannot (another OS, a filesystem without it),
//! the two renames are the fallback.

use std::io;
use std::path::Path;

/// Puts the folder `new` at `out`, deleting what `out` held; `aside` is a free name beside
/// `out` for the fallback's old folder. On error `out` is as it was and `new` is kept.
pub fn replace(new: &Path, out: &Path, aside: &Path) -> io::Result<()> {
    if std::fs::symlink_metadata(out).is_err() {
        return std::fs::rename(new, out);
    }
    match exchange(new, out) {
        // `new` now names the old folder.
        Ok(()) => {
            let _ = std::fs::remove_dir_all(new);
            return Ok(());
        }
        Err(e) if !unsupported(&e) => return Err(e),
        Err(_) => {}
    }
    std::fs::rename(out, aside)?;
    if let Err(e) = std::fs::rename(new, out) {
        let _ = std::fs::rename(aside, out);
        return Err(e);
    }
    let _ = std::fs::remove_dir_all(aside);
    Ok(())
}

/// Whether the exchange failed because it is not offered here, not because of the names.
fn unsupported(e: &io::Error) -> bool {
    use rustix::io::Errno;
    [Errno::INVAL, Errno::NOSYS, Errno::OPNOTSUPP]
        .iter()
        .any(|n| e.raw_os_error() == Some(n.raw_os_error()))
}

#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> io::Result<()> {
    use rustix::fs::{renameat_with, RenameFlags, CWD};
    Ok(renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE)?)
}

#[cfg(not(target_os = "linux"))]
fn exchange(_: &Path, _: &Path) -> io::Result<()> {
    Err(rustix::io::Errno::NOSYS.into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_new_folder_takes_the_name_and_the_old_one_is_gone() {
        let root = crate::fixtures::scratch("swapdir");
        let (new, out, aside) = (root.join("new"), root.join("out"), root.join(".out.old"));
        std::fs::create_dir_all(&new).unwrap();
        std::fs::write(new.join("a"), "new").unwrap();
        // No `out` yet: a plain rename.
        replace(&new, &out, &aside).unwrap();
        assert_eq!(std::fs::read_to_string(out.join("a")).unwrap(), "new");
        assert!(!new.exists());

        std::fs::create_dir_all(&new).unwrap();
        std::fs::write(new.join("b"), "newer").unwrap();
        replace(&new, &out, &aside).unwrap();
        assert_eq!(std::fs::read_to_string(out.join("b")).unwrap(), "newer");
        assert!(!out.join("a").exists());
        assert!(!new.exists() && !aside.exists());

        let _ = std::fs::remove_dir_all(&root);
    }

    /// This machine's filesystem exchanges names, so the test below tries the exchange and
    /// not the fallback.
    #[cfg(target_os = "linux")]
    #[test]
    fn two_folders_exchange_names() {
        let root = crate::fixtures::scratch("swapdir-exchange");
        let (a, b) = (root.join("a"), root.join("b"));
        std::fs::create_dir_all(&a).unwrap();
        std::fs::create_dir_all(&b).unwrap();
        std::fs::write(a.join("was"), "a").unwrap();
        exchange(&a, &b).unwrap();
        assert_eq!(std::fs::read_to_string(b.join("was")).unwrap(), "a");
        assert!(!a.join("was").exists());
        let _ = std::fs::remove_dir_all(&root);
    }

    /// The exchange never leaves the name empty: a reader polling `out` all through a
    /// hundred swaps always finds a folder there.
    #[cfg(target_os = "linux")]
    #[test]
    fn the_name_is_never_missing_during_a_swap() {
        use std::sync::atomic::{AtomicBool, Ordering};
        use std::sync::Arc;
        let root = crate::fixtures::scratch("swapdir-gap");
        let (new, out, aside) = (root.join("new"), root.join("out"), root.join(".out.old"));
        std::fs::create_dir_all(&out).unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let (s, o) = (Arc::clone(&stop), out.clone());
        let watcher = std::thread::spawn(move || {
            let mut missing = 0u32;
            while !s.load(Ordering::Relaxed) {
                if !o.is_dir() {
                    missing += 1;
                }
            }
            missing
        });
        for i in 0..100 {
            std::fs::create_dir_all(&new).unwrap();
            std::fs::write(new.join("n"), i.to_string()).unwrap();
            replace(&new, &out, &aside).unwrap();
        }
        stop.store(true, Ordering::Relaxed);
        assert_eq!(watcher.join().unwrap(), 0);
        assert_eq!(std::fs::read_to_string(out.join("n")).unwrap(), "99");
        let _ = std::fs::remove_dir_all(&root);
    }
}
