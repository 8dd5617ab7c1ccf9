//! Datasets picked up while serving: a dataset ingested, replaced or removed in the data
//! folder is served, served anew or gone within `--rescan` seconds (5 by default), or at once
//! on SIGHUP, without a restart.
//!
//! A rescan stats every `*.ztd` and opens only the files whose stamp changed (the catalog's
//! other datasets, with their open handles, carry over), then swaps the whole catalog in:
//! a request sees the old one or the new one, never a mix. Requests under way keep the build
//! they started with. An object store is listed again only on SIGHUP unless `--rescan` is
//! given: a listing is a billed request, where a folder's is a few `stat`s.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, UNIX_EPOCH};

use anyhow::{Context, Result};
use object_store::path::Path as ObjectPath;
use object_store::ObjectStore;

use super::catalog::{Catalog, Found, Stamp};
use super::dataset::Dataset;
use super::state::AppState;
use super::storage;
use crate::ingest::EXTENSION;

/// Asks the watcher for a rescan now: a tile read found its dataset's file written over.
static SOON: tokio::sync::Notify = tokio::sync::Notify::const_new();

/// Asks [`watch`] to rescan now rather than at its next period (at most one rescan is
/// owed however often it is asked before it runs).
pub fn rescan_soon() {
    SOON.notify_one();
}

/// How often a data folder is rescanned unless `--rescan` says otherwise.
pub const DEFAULT_RESCAN: Duration = Duration::from_secs(5);

/// When the datasets are rescanned, besides on SIGHUP.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Rescan {
    /// A folder every [`DEFAULT_RESCAN`]; a store never (a listing is a billed request).
    #[default]
    Default,
    Every(Duration),
    /// On SIGHUP only.
    Never,
}

impl Rescan {
    /// The period for datasets from `origin`, `None` for SIGHUP only.
    pub fn period(self, origin: &Origin) -> Option<Duration> {
        match (self, origin) {
            (Self::Every(d), _) => Some(d),
            (Self::Default, Origin::Dir(_)) => Some(DEFAULT_RESCAN),
            (Self::Default, Origin::Store { .. }) | (Self::Never, _) => None,
        }
    }
}

/// Where the datasets come from.
#[derive(Clone)]
pub enum Origin {
    Dir(PathBuf),
    Store {
        store: Arc<dyn ObjectStore>,
        prefix: ObjectPath,
    },
}

impl Origin {
    /// A store URL's origin (see [`storage::open_url`]).
    pub fn url(url: &str) -> Result<Self> {
        let (store, prefix) = storage::open_url(url)?;
        Ok(Self::Store { store, prefix })
    }

    /// The catalog of what is there now.
    pub fn open(&self) -> Result<Catalog> {
        Ok(Catalog::default()
            .rescan(self.scan()?, false)
            .map(|(catalog, _)| catalog)
            .unwrap_or_default())
    }

    /// Every dataset file or object there, in name order, with its stamp. A missing or
    /// unreadable folder, or an unreachable store, is an error; a file that vanishes between
    /// the listing and its `stat` is left out (it is gone). Blocking: call it off the async
    /// threads.
    pub fn scan(&self) -> Result<Vec<Found>> {
        match self {
            Self::Dir(dir) => scan_dir(dir),
            Self::Store { store, prefix } => Ok(storage::list(store, prefix, EXTENSION)?
                .into_iter()
                .map(|meta| {
                    let store = Arc::clone(store);
                    Found {
                        file: meta.location.filename().unwrap_or_default().to_string(),
                        stamp: Stamp::of(
                            None,
                            (
                                meta.size,
                                meta.last_modified.timestamp_nanos_opt(),
                                meta.e_tag.clone(),
                            ),
                        ),
                        open: Box::new(move || Dataset::open_object(&store, &meta)),
                    }
                })
                .collect()),
        }
    }
}

/// A folder's dataset files. A file gone between the listing and its `stat` is left out;
/// any other error (EIO, ESTALE on a shared folder, permission on the folder) fails the scan,
/// which keeps the datasets served as they were rather than dropping one for a hiccup.
fn scan_dir(dir: &std::path::Path) -> Result<Vec<Found>> {
    let listing = || format!("data folder {}", dir.display());
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).with_context(listing)? {
        let path = entry.with_context(listing)?.path();
        // Any case: a `.ZTD` copied from elsewhere was neither opened nor listed as skipped.
        if !crate::ingest::is_dataset_file(&path) {
            continue;
        }
        let Some((file, meta)) = stat(&path)? else {
            continue;
        };
        let shown = file.clone();
        found.push(Found {
            file,
            stamp: file_stamp(&meta),
            open: Box::new(move || Dataset::open_as(&path, &shown)),
        });
    }
    found.sort_by(|a, b| a.file.cmp(&b.file));
    Ok(found)
}

/// A listed file's name in its folder and its metadata, through a link to the file it names
/// (as opening it does; a link to nothing is still listed, and its open says why it is
/// skipped); `None` for a file gone since the listing. Any other error is the scan's.
pub(super) fn stat(path: &std::path::Path) -> Result<Option<(String, std::fs::Metadata)>> {
    let meta = match std::fs::metadata(path).or_else(|_| std::fs::symlink_metadata(path)) {
        Ok(meta) => meta,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("{}", path.display())),
    };
    Ok(path
        .file_name()
        .map(|f| (f.to_string_lossy().into_owned(), meta)))
}

pub(super) fn file_stamp(meta: &std::fs::Metadata) -> Stamp {
    use std::os::unix::fs::MetadataExt;
    let modified = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(UNIX_EPOCH).ok());
    // The change time too: a chmod that lets the server read a file it was refused changes
    // nothing else.
    Stamp::of(
        Some((meta.dev(), meta.ino())),
        (
            meta.len(),
            modified,
            meta.ctime(),
            meta.ctime_nsec(),
            meta.is_dir(),
        ),
    )
}

/// Rescans `origin` every `every` (never when `None`) and on SIGHUP, swapping a changed
/// catalog into `state`, and the object meshes beside it ([`super::mesh_reload`]); runs
/// until the server stops. A scan that fails (the folder gone,
/// the store unreachable) is logged and the datasets served stay as they were.
pub async fn watch(
    state: AppState,
    origin: Origin,
    every: Option<Duration>,
    mut hangup: Option<tokio::signal::unix::Signal>,
) {
    let (mut failing, mut meshes_failing) = (false, false);
    loop {
        let tick = async {
            match every {
                Some(d) => tokio::time::sleep(d).await,
                None => std::future::pending().await,
            }
        };
        let asked = tokio::select! {
            () = tick => false,
            () = SOON.notified() => false,
            () = next_hangup(&mut hangup) => {
                tracing::info!("SIGHUP: rescanning the datasets");
                true
            }
        };
        let current = state.catalog_now();
        let origin = origin.clone();
        let scanned = tokio::task::spawn_blocking(move || {
            origin.scan().map(|found| current.rescan(found, asked))
        })
        .await;
        if let Some((catalog, changes)) = told("datasets", &mut failing, scanned).flatten() {
            state.replace_catalog(catalog);
            tracing::info!("datasets rescanned: {changes}");
        }
        let meshes = Arc::clone(&state.meshes);
        let scanned = tokio::task::spawn_blocking(move || meshes.rescan(asked)).await;
        if let Some(changes) = told("meshes", &mut meshes_failing, scanned).flatten() {
            tracing::info!("meshes rescanned: {changes}");
        }
    }
}

/// A rescan's result, logging a failing one when it starts failing and when it stops, not
/// at every period (a folder gone for a day would log 17,000 lines).
fn told<T>(
    what: &str,
    failing: &mut bool,
    scanned: Result<Result<T>, tokio::task::JoinError>,
) -> Option<T> {
    let was = std::mem::replace(failing, !matches!(scanned, Ok(Ok(_))));
    match scanned {
        Ok(Ok(found)) => {
            if was {
                tracing::info!("rescanning the {what} works again");
            }
            Some(found)
        }
        Ok(Err(e)) => {
            if !was {
                tracing::warn!("rescanning the {what}: {e:#} (serving them as they were)");
            }
            None
        }
        Err(e) => {
            if !was {
                tracing::error!("rescanning the {what}: {e}");
            }
            None
        }
    }
}

/// SIGHUP's stream, `None` if it cannot be had (then only the timer rescans). From the
/// moment it is made, a SIGHUP no longer ends the process (its default action, as for a
/// server run in a terminal that closes) but is held for [`watch`]. Call it inside the
/// runtime. Unix only, as the storage's positioned reads are.
pub fn hangups() -> Option<tokio::signal::unix::Signal> {
    tokio::signal::unix::signal(tokio::signal::unix::SignalKind::hangup())
        .map_err(|e| tracing::warn!("cannot listen for SIGHUP: {e}"))
        .ok()
}

async fn next_hangup(h: &mut Option<tokio::signal::unix::Signal>) {
    if let Some(s) = h {
        if s.recv().await.is_some() {
            return;
        }
    }
    std::future::pending().await
}
