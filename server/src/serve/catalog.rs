//! Every dataset of a data folder, by name.
//!
//! A folder is scanned once at start. A file that fails to open is logged and skipped: one
//! corrupt or half-copied dataset must not take the others down.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};

use super::dataset::Dataset;
use super::storage;
use crate::ingest::EXTENSION;

/// The datasets a server answers for.
#[derive(Debug, Default)]
pub struct Catalog {
    datasets: BTreeMap<String, Arc<Dataset>>,
    /// Files that could not be opened, with the reason: shown by `/v1/datasets`.
    pub skipped: Vec<(String, String)>,
}

impl Catalog {
    /// Opens every `*.ztd` in `dir`. A missing or unreadable folder is an error; a bad file
    /// is not.
    pub fn open_dir(dir: &Path) -> Result<Self> {
        let entries =
            std::fs::read_dir(dir).with_context(|| format!("data folder {}", dir.display()))?;
        let mut paths: Vec<_> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            // Any case, as mesh files are read: a `.ZTD` copied from elsewhere was neither
            // opened nor listed as skipped.
            .filter(|p| {
                p.extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case(EXTENSION))
            })
            .collect();
        paths.sort();
        let mut catalog = Self::default();
        for path in paths {
            let file = path
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default();
            catalog.add(file, Dataset::open(&path));
        }
        Ok(catalog)
    }

    /// Opens every `*.ztd` object directly under a store URL's prefix (see
    /// [`storage::open_url`]). An unreachable store or prefix is an error; a bad object is
    /// not.
    pub fn open_url(url: &str) -> Result<Self> {
        let (store, prefix) = storage::open_url(url)?;
        let mut catalog = Self::default();
        for meta in storage::list(&store, &prefix, EXTENSION)? {
            let file = meta.location.filename().unwrap_or_default().to_string();
            catalog.add(file, Dataset::open_object(&store, &meta));
        }
        Ok(catalog)
    }

    fn add(&mut self, file: String, opened: Result<Dataset>) {
        match opened {
            Ok(d) => {
                tracing::info!(
                    dataset = %d.name,
                    tiles = d.container.len(),
                    scheme = %d.metadata().scheme,
                    "opened {}",
                    d.location
                );
                self.insert(d);
            }
            Err(e) => {
                tracing::warn!("skipping {file}: {e:#}");
                self.skipped.push((file, format!("{e:#}")));
            }
        }
    }

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

    /// A corrupt dataset file is listed as skipped with its reason, files that are not
    /// datasets are ignored, and neither stops the folder from opening.
    #[test]
    fn a_bad_file_is_skipped_and_other_files_ignored() {
        let dir = crate::fixtures::scratch("catalog");
        std::fs::write(dir.join(format!("broken.{EXTENSION}")), b"not a dataset").unwrap();
        let upper = format!("UPPER.{}", EXTENSION.to_ascii_uppercase());
        std::fs::write(dir.join(&upper), b"not one either").unwrap();
        std::fs::write(dir.join("README.txt"), b"notes").unwrap();
        let catalog = Catalog::open_dir(&dir).unwrap();
        let skipped: Vec<&str> = catalog.skipped.iter().map(|(f, _)| f.as_str()).collect();
        assert_eq!(skipped, [upper, format!("broken.{EXTENSION}")]);
        assert!(!catalog.skipped[0].1.is_empty());
        assert!(catalog.is_empty());
        assert_eq!(catalog.len(), 0);
        assert!(Catalog::open_dir(&dir.join("missing")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
