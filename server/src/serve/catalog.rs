//! Every dataset of a data folder (or store prefix), by name.
//!
//! A folder is scanned at start and rescanned while serving ([`super::reload`]). A file that
//! fails to open is logged and skipped: one corrupt or half-copied dataset must not take the
//! others down. A rescan reopens only the files whose stamp changed. A file renamed over
//! that does not open keeps the build opened before it in service (it still reads its own
//! file); one written over in place is refused while half written, and served once whole.

use std::collections::BTreeMap;
use std::hash::{Hash, Hasher};
use std::path::Path;
use std::sync::Arc;

use anyhow::Result;

use super::dataset::Dataset;
use super::reload::Origin;

/// Datasets a server keeps open at most: each holds its file open, and a server whose
/// datasets took every descriptor could accept no connection nor list its folder again to
/// let them go (the accept loop spun on EMFILE for good). Set at start from the open-file
/// limit, less room for connections; unlimited until then.
pub static MAX_DATASETS: std::sync::atomic::AtomicUsize =
    std::sync::atomic::AtomicUsize::new(usize::MAX);

/// The datasets a server answers for.
#[derive(Debug, Default)]
pub struct Catalog {
    datasets: BTreeMap<String, Arc<Dataset>>,
    /// Files that could not be opened, with the reason: shown by `/v1/datasets`.
    pub skipped: Vec<(String, String)>,
    /// Every dataset file as last scanned, by file name: what a rescan compares against.
    files: BTreeMap<String, Entry>,
}

/// What a file or object is, as far as a rescan can tell without reading it: for a file its
/// device, inode, length and modification time (a rename over it or a write to it changes
/// one of them); for an object its size, modification time and entity tag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stamp {
    hash: u64,
    /// A file's device and inode.
    file: Option<(u64, u64)>,
}

impl Stamp {
    pub fn of(file: Option<(u64, u64)>, parts: impl Hash) -> Self {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        file.hash(&mut h);
        parts.hash(&mut h);
        Self {
            hash: h.finish(),
            file,
        }
    }
}

/// A dataset file a scan found: its name in the folder, its stamp, and how to open it.
pub struct Found {
    pub file: String,
    pub stamp: Stamp,
    pub open: Box<dyn FnOnce() -> Result<Dataset> + Send>,
}

#[derive(Clone, Debug)]
struct Entry {
    stamp: Stamp,
    /// The dataset served for this file: the one it opened to, or, when it now fails to
    /// open, the build it opened to before.
    dataset: Option<Arc<Dataset>>,
    /// Why the file as it is now does not open.
    error: Option<String>,
}

/// What a rescan changed, by file name, for the log.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Changes {
    pub added: Vec<String>,
    pub replaced: Vec<String>,
    pub removed: Vec<String>,
    /// Files that now fail to open (a build opened before stays in service if the file was
    /// renamed over it).
    pub failed: Vec<String>,
}

impl std::fmt::Display for Changes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let parts = [
            ("added", &self.added),
            ("replaced", &self.replaced),
            ("removed", &self.removed),
            ("failed to open", &self.failed),
        ];
        let said: Vec<String> = parts
            .iter()
            .filter(|(_, files)| !files.is_empty())
            .map(|(what, files)| format!("{what} {}", files.join(", ")))
            .collect();
        f.write_str(&said.join("; "))
    }
}

impl Catalog {
    /// Opens every `*.ztd` in `dir`. A missing or unreadable folder is an error; a bad file
    /// is not.
    pub fn open_dir(dir: &Path) -> Result<Self> {
        Origin::Dir(dir.to_path_buf()).open()
    }

    /// The catalog `found` makes, reusing this one's datasets whose files kept their stamp and
    /// opening the others (blocking I/O: call it off the async threads);
    /// `None` when nothing changed (no file added, removed or restamped). `found` is in
    /// file-name order; of two files with one dataset name the later is served.
    ///
    /// With `retry_failed` (a rescan asked for by SIGHUP), files that failed to open are tried
    /// again whatever their stamp: what stopped them (the process's open-file limit, a
    /// permission) need not show in the file.
    pub fn rescan(&self, found: Vec<Found>, retry_failed: bool) -> Option<(Self, Changes)> {
        let most = MAX_DATASETS.load(std::sync::atomic::Ordering::Relaxed);
        self.rescan_within(found, retry_failed, most)
    }

    /// [`Self::rescan`] keeping at most `most` datasets open.
    pub fn rescan_within(
        &self,
        found: Vec<Found>,
        retry_failed: bool,
        most: usize,
    ) -> Option<(Self, Changes)> {
        let kept =
            |e: &Entry, stamp: Stamp| e.stamp == stamp && !(retry_failed && e.error.is_some());
        let unchanged = found.len() == self.files.len()
            && found
                .iter()
                .all(|f| self.files.get(&f.file).is_some_and(|e| kept(e, f.stamp)));
        if unchanged {
            return None;
        }
        let mut changes = Changes::default();
        let mut files = BTreeMap::new();
        for Found { file, stamp, open } in found {
            let before = self.files.get(&file);
            if let Some(e) = before.filter(|e| kept(e, stamp)) {
                files.insert(file, e.clone());
                continue;
            }
            // Renamed over, the build before still has its own file to read; written over in
            // place, it has lost its bytes too.
            let kept = before
                .and_then(|e| e.dataset.clone())
                .filter(|d| d.file_id().is_some_and(|id| Some(id) != stamp.file));
            let open_now = files
                .values()
                .filter(|e: &&Entry| e.dataset.is_some())
                .count();
            let opened = if open_now >= most {
                Err(anyhow::anyhow!(
                    "not opened: this server keeps at most {most} datasets open, what its \
                     open-file limit leaves beside connections (raise `ulimit -n` and send \
                     SIGHUP)"
                ))
            } else {
                open()
            };
            let entry = match opened {
                Ok(d) => {
                    tracing::info!(
                        dataset = %d.name,
                        tiles = d.container.len(),
                        scheme = %d.metadata().scheme,
                        "opened {}",
                        d.location
                    );
                    if before.is_some_and(|e| e.dataset.is_some()) {
                        changes.replaced.push(file.clone());
                    } else {
                        changes.added.push(file.clone());
                    }
                    Entry {
                        stamp,
                        dataset: Some(Arc::new(d)),
                        error: None,
                    }
                }
                Err(e) => {
                    let mut why = format!("{e:#}");
                    if kept.is_some() {
                        why.push_str(" (the build opened before is still served)");
                    }
                    tracing::warn!("skipping {file}: {why}");
                    changes.failed.push(file.clone());
                    Entry {
                        stamp,
                        dataset: kept,
                        error: Some(why),
                    }
                }
            };
            files.insert(file, entry);
        }
        changes.removed = self
            .files
            .keys()
            .filter(|f| !files.contains_key(*f))
            .cloned()
            .collect();
        let mut catalog = Self::default();
        // Two files of one dataset name (`n.ztd`, `n.ZTD`): the later in name order is
        // served, and the other listed as skipped, saying why.
        let mut served_from: BTreeMap<&str, &str> = BTreeMap::new();
        for (file, e) in &files {
            if let Some(d) = &e.dataset {
                if let Some(earlier) = served_from.insert(&d.name, file) {
                    catalog.skipped.push((
                        earlier.to_owned(),
                        format!(
                            "{file} has the same dataset name, {:?}, and is served",
                            d.name
                        ),
                    ));
                }
                catalog.datasets.insert(d.name.clone(), Arc::clone(d));
            }
            if let Some(why) = &e.error {
                catalog.skipped.push((file.clone(), why.clone()));
            }
        }
        catalog.files = files;
        Some((catalog, changes))
    }

    /// Adds a dataset that no file of the catalog's stands for (tests, `export`): a rescan
    /// does not keep it.
    pub fn insert(&mut self, d: Dataset) {
        self.datasets.insert(d.name.clone(), Arc::new(d));
    }

    pub fn get(&self, name: &str) -> Option<&Arc<Dataset>> {
        self.datasets.get(name)
    }

    pub fn iter(&self) -> impl Iterator<Item = &Arc<Dataset>> {
        self.datasets.values()
    }

    pub fn len(&self) -> usize {
        self.datasets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.datasets.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ingest::EXTENSION;

    /// A corrupt dataset file, a link to none or a FIFO is listed as skipped with its reason,
    /// files that are not datasets are ignored, and neither stops the folder from opening.
    #[test]
    fn a_bad_file_is_skipped_and_other_files_ignored() {
        let dir = crate::fixtures::scratch("catalog");
        std::fs::write(dir.join(format!("broken.{EXTENSION}")), b"not a dataset").unwrap();
        let upper = format!("UPPER.{}", EXTENSION.to_ascii_uppercase());
        std::fs::write(dir.join(&upper), b"not one either").unwrap();
        std::fs::write(dir.join("README.txt"), b"notes").unwrap();
        let dangling = format!("dangling.{EXTENSION}");
        std::os::unix::fs::symlink(dir.join("nowhere"), dir.join(&dangling)).unwrap();
        // A FIFO would block the open until something wrote to it.
        let fifo = format!("fifo.{EXTENSION}");
        crate::fixtures::mkfifo(&dir.join(&fifo));
        let d = dir.clone();
        let catalog =
            crate::fixtures::within(30, "opening the folder hung on its FIFO", move || {
                Catalog::open_dir(&d).unwrap()
            });
        let skipped: Vec<&str> = catalog.skipped.iter().map(|(f, _)| f.as_str()).collect();
        assert_eq!(
            skipped,
            [upper, format!("broken.{EXTENSION}"), dangling, fifo]
        );
        assert!(
            catalog.skipped[3]
                .1
                .ends_with("not a regular file (a FIFO)"),
            "{:?}",
            catalog.skipped[3]
        );
        assert!(!catalog.skipped[0].1.is_empty());
        // Named as the folder names them, not by the server's path.
        // The folder as given with a trailing slash, as shells complete it, too.
        for given in [dir.clone(), dir.join("")] {
            let catalog = Catalog::open_dir(&given).unwrap();
            let why = &catalog.skipped[2].1;
            assert!(why.starts_with("opening dangling.ztd: "), "{why}");
            assert!(!why.contains(&*dir.to_string_lossy()), "{why}");
        }
        assert!(catalog.is_empty());
        assert_eq!(catalog.len(), 0);
        assert!(Catalog::open_dir(&dir.join("missing")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
