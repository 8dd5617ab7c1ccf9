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
/// `out` for the fallback's old folder. On error `new` is kept, and `out` is as it was
/// unless the error says where the old folder was left.
pub fn replace(new: &Path, out: &Path, aside: &Path) -> io::Result<()> {
    match std::fs::symlink_metadata(out) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => return std::fs::rename(new, out),
        _ => {}
    }
    // Any failure of the exchange (not offered, a filter refusing the call, `out` gone since)
    // leaves both names as they were: the renames then fail, or not, on their own.
    if exchange(new, out).is_ok() {
        // `new` now names the old folder.
        remove_leftover(new);
        return Ok(());
    }
    replace_by_renames(new, out, aside)
}

/// [`replace`] with two renames: the old folder aside, the new one in.
fn replace_by_renames(new: &Path, out: &Path, aside: &Path) -> io::Result<()> {
    std::fs::rename(out, aside)?;
    if let Err(e) = std::fs::rename(new, out) {
        return match std::fs::rename(aside, out) {
            Ok(()) => Err(e),
            Err(back) => Err(io::Error::new(
                e.kind(),
                format!(
                    "{e}; and moving the old folder back failed ({back}): it is at {}",
                    aside.display()
                ),
            )),
        };
    }
    remove_leftover(aside);
    Ok(())
}

/// Deletes the old folder; one that cannot be deleted is said, not failed: the new one is in.
fn remove_leftover(old: &Path) {
    if let Err(e) = std::fs::remove_dir_all(old) {
        tracing::warn!(
            "the replaced folder could not be deleted ({e}): it is left at {}",
            old.display()
        );
    }
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

    /// The fallback on its own: the new folder in and the old one gone; when the new one
    /// cannot be moved in, the old one is put back.
    #[test]
    fn the_two_renames_swap_or_put_the_old_folder_back() {
        let root = crate::fixtures::scratch("swapdir-renames");
        let (new, out, aside) = (root.join("new"), root.join("out"), root.join(".out.old"));
        std::fs::create_dir_all(&new).unwrap();
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(new.join("n"), "new").unwrap();
        std::fs::write(out.join("o"), "old").unwrap();
        replace_by_renames(&new, &out, &aside).unwrap();
        assert_eq!(std::fs::read_to_string(out.join("n")).unwrap(), "new");
        assert!(!out.join("o").exists() && !new.exists() && !aside.exists());

        // No `new` to move in: the error, and `out` as it was.
        let e = replace_by_renames(&new, &out, &aside).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::NotFound);
        assert_eq!(std::fs::read_to_string(out.join("n")).unwrap(), "new");
        assert!(!aside.exists());
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
            let (mut polls, mut missing) = (0u64, 0u64);
            while !s.load(Ordering::Relaxed) {
                polls += 1;
                if !o.is_dir() {
                    missing += 1;
                }
            }
            (polls, missing)
        });
        for i in 0..100 {
            std::fs::create_dir_all(&new).unwrap();
            std::fs::write(new.join("n"), i.to_string()).unwrap();
            replace(&new, &out, &aside).unwrap();
        }
        stop.store(true, Ordering::Relaxed);
        let (polls, missing) = watcher.join().unwrap();
        assert!(polls > 100, "the watcher polled {polls} times");
        assert_eq!(missing, 0);
        assert_eq!(std::fs::read_to_string(out.join("n")).unwrap(), "99");
        let _ = std::fs::remove_dir_all(&root);
    }
}
