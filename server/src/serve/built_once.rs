//! A structure built once, on first use, that other requests do not queue behind.
//!
//! A mesh's LOD structures (the curvature levels, the octree, the view sphere) take seconds
//! on a large mesh: the curvature levels of a 2M-face upload run past the request timeout.
//! Asked again while the first build runs, a plain `OnceLock` made each retry wait for it
//! inside a render slot, so a client retrying its 503 every second filled the slots and
//! the server shed terrain tiles for a minute. Here a second ask learns that the build is
//! under way and for how long, and is answered at once.

use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

pub struct BuiltOnce<T> {
    cell: OnceLock<Result<T, String>>,
    /// When the build under way began; `None` before the first ask and after a build that
    /// panicked, so the next ask builds again. Whoever sets it builds: the claim is taken
    /// under this lock, so two first asks cannot both go on to wait in the cell.
    started: Mutex<Option<Instant>>,
}

/// Why [`BuiltOnce::get_or_build`] has no structure to give.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BuildError {
    /// The build failed (kept: it fails the same way again).
    Failed(String),
    /// Another caller is building it, for this long so far.
    Building(Duration),
}

impl<T> Default for BuiltOnce<T> {
    fn default() -> Self {
        Self {
            cell: OnceLock::new(),
            started: Mutex::new(None),
        }
    }
}

impl<T> BuiltOnce<T> {
    /// The structure, built here by `build` if no one has built it yet, or
    /// [`BuildError::Building`] at once if another caller is building it. Checking
    /// [`Self::building_for`] first is not enough: asks admitted before the build began
    /// (two first asks at once, or any queued behind a busy render pool) would each wait
    /// for it inside a render slot.
    pub fn get_or_build(
        &self,
        build: impl FnOnce() -> Result<T, String>,
    ) -> Result<&T, BuildError> {
        if self.cell.get().is_none() {
            let mut started = self.started();
            // Checked again under the lock: the builder fills the cell without it.
            if self.cell.get().is_none() {
                if let Some(t) = *started {
                    return Err(BuildError::Building(t.elapsed()));
                }
                *started = Some(Instant::now());
            }
        }
        // A panicking build leaves the cell empty; the guard clears the start so the next
        // ask builds again instead of being told forever that a build is under way.
        struct Clear<'a, T>(&'a BuiltOnce<T>);
        impl<T> Drop for Clear<'_, T> {
            fn drop(&mut self) {
                let mut started = self.0.started();
                if self.0.cell.get().is_none() {
                    *started = None;
                }
            }
        }
        let _clear = Clear(self);
        self.cell
            .get_or_init(build)
            .as_ref()
            .map_err(|m| BuildError::Failed(m.clone()))
    }

    /// How long a build has been under way, if one is and it has not finished.
    pub fn building_for(&self) -> Option<Duration> {
        if self.cell.get().is_some() {
            return None;
        }
        self.started().map(|t| t.elapsed())
    }

    fn started(&self) -> std::sync::MutexGuard<'_, Option<Instant>> {
        // The guarded value is a plain Instant: a panic elsewhere cannot leave it torn.
        self.started
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Barrier};

    use super::*;

    #[test]
    fn a_second_ask_during_the_build_is_told_it_is_under_way() {
        let once = Arc::new(BuiltOnce::<u32>::default());
        assert_eq!(once.building_for(), None, "nothing asked yet");
        let (go, done) = (Arc::new(Barrier::new(2)), Arc::new(Barrier::new(2)));
        let builder = {
            let (once, go, done) = (once.clone(), go.clone(), done.clone());
            std::thread::spawn(move || {
                let v = once.get_or_build(|| {
                    go.wait();
                    done.wait();
                    Ok(7)
                });
                v.copied()
            })
        };
        go.wait();
        assert!(once.building_for().is_some(), "under way");
        // A second ask, even one that did not look first, is answered without waiting (on
        // a thread, so that a wait fails the test instead of hanging it).
        let (tx, rx) = std::sync::mpsc::channel();
        let asker = {
            let once = once.clone();
            std::thread::spawn(move || {
                let r = once.get_or_build(|| Ok(8)).copied();
                let _ = tx.send(r.clone());
                r
            })
        };
        let second = rx.recv_timeout(std::time::Duration::from_secs(5));
        done.wait();
        assert!(
            matches!(second, Ok(Err(BuildError::Building(_)))),
            "{second:?}"
        );
        let _ = asker.join();
        assert_eq!(builder.join().unwrap(), Ok(7));
        assert_eq!(once.building_for(), None, "built");
        assert_eq!(once.get_or_build(|| Ok(8)), Ok(&7), "built once");
    }

    #[test]
    fn a_failed_build_is_kept_and_a_panicked_one_is_not_under_way() {
        let failed = BuiltOnce::<u32>::default();
        let no = Err(BuildError::Failed("no".into()));
        assert_eq!(failed.get_or_build(|| Err("no".into())), no);
        assert_eq!(failed.building_for(), None);
        assert_eq!(failed.get_or_build(|| Ok(1)), no);

        let panicked = BuiltOnce::<u32>::default();
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            panicked.get_or_build(|| panic!("build failed"))
        }));
        assert!(r.is_err());
        assert_eq!(panicked.building_for(), None);
        assert_eq!(panicked.get_or_build(|| Ok(2)), Ok(&2), "built again");
    }
}
