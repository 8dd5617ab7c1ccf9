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

/// How often a data folder is rescanned unless `--rescan` says otherwise.
pub const DEFAULT_RESCAN: Duration = Duration::from_secs(5);

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
            .rescan(self.scan()?)
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

fn scan_dir(dir: &std::path::Path) -> Result<Vec<Found>> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("data folder {}", dir.display()))?;
    let mut found: Vec<Found> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        // Any case, as mesh files are read: a `.ZTD` copied from elsewhere was neither
        // opened nor listed as skipped.
        .filter(|p| {
            p.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case(EXTENSION))
        })
        .filter_map(|path| {
            // Through a link to the file it names, as opening it does; a link to nothing is
            // still listed, and its open says why it is skipped.
            let meta = std::fs::metadata(&path)
                .or_else(|_| std::fs::symlink_metadata(&path))
                .ok()?;
            let file = path.file_name()?.to_string_lossy().into_owned();
            // `/v1/datasets` lists why a file is skipped: by its name in the folder, not the
            // server's path to it.
            let folder = format!("{}/", dir.display());
            Some(Found {
                file,
                stamp: file_stamp(&meta),
                open: Box::new(move || {
                    Dataset::open(&path)
                        .map_err(|e| anyhow::anyhow!("{}", format!("{e:#}").replace(&folder, "")))
                }),
            })
        })
        .collect();
    found.sort_by(|a, b| a.file.cmp(&b.file));
    Ok(found)
}

fn file_stamp(meta: &std::fs::Metadata) -> Stamp {
    use std::os::unix::fs::MetadataExt;
    let modified = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(UNIX_EPOCH).ok());
    Stamp::of(
        Some((meta.dev(), meta.ino())),
        (meta.len(), modified, meta.is_dir()),
    )
}

/// Rescans `origin` every `every` (never when `None`) and on SIGHUP, swapping a changed
/// catalog into `state`; runs until the server stops. A scan that fails (the folder gone,
/// the store unreachable) is logged and the datasets served stay as they were.
pub async fn watch(state: AppState, origin: Origin, every: Option<Duration>) {
    let mut hangup = hangups();
    loop {
        let tick = async {
            match every {
                Some(d) => tokio::time::sleep(d).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            () = tick => {},
            () = next_hangup(&mut hangup) => tracing::info!("SIGHUP: rescanning the datasets"),
        }
        let current = state.catalog_now();
        let origin = origin.clone();
        let scanned =
            tokio::task::spawn_blocking(move || origin.scan().map(|found| current.rescan(found)))
                .await;
        match scanned {
            Ok(Ok(Some((catalog, changes)))) => {
                state.replace_catalog(catalog);
                tracing::info!("datasets rescanned: {changes}");
            }
            Ok(Ok(None)) => {}
            Ok(Err(e)) => {
                tracing::warn!("rescanning the datasets: {e:#} (serving them as they were)")
            }
            Err(e) => tracing::error!("rescanning the datasets: {e}"),
        }
    }
}

/// SIGHUP's stream, `None` if it cannot be had (then only the timer rescans). Unix only,
/// as the storage's positioned reads are.
fn hangups() -> Option<tokio::signal::unix::Signal> {
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
