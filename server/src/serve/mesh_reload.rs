//! Object meshes picked up while serving: a mesh file added to `DATA/meshes`, replaced or
//! removed is served, served anew or gone at the datasets' rescan (every `--rescan` seconds,
//! 5 by default, and at once on SIGHUP), without a restart.
//!
//! A rescan stats every mesh file and reads only those whose stamp (device, inode, length,
//! times) changed; the others keep their entries and the LOD structures built for them. A
//! file changed less than [`SETTLE`] ago is left for the next rescan unless the rescan was
//! asked for: a mesh is read whole, and an OBJ cut short by a copy still under way parses
//! as a smaller mesh, where a dataset's records carry checksums. A file that now fails to
//! read leaves the mesh read from it before served (it is whole, in memory) unless another
//! file of the name reads: the served mesh is the one a restart would serve.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, PoisonError};
use std::time::{Duration, SystemTime};

use anyhow::{Context, Result};
use zerotile_codec::mesh::io::Format;

use super::catalog::{Changes, Stamp};
use super::meshes::{load, MeshCatalog, MeshEntry};
use super::reload::{file_stamp, stat};

/// How long a changed mesh file must have been left alone before a timed rescan reads it.
pub const SETTLE: Duration = Duration::from_secs(1);

/// What the last rescan made of the folder's files (kept under the catalog's store lock).
#[derive(Debug, Default)]
pub struct Seen {
    /// Files read, by name in the folder, with their stamp then and why they did not read.
    read: BTreeMap<String, (Stamp, Option<String>)>,
}

/// A mesh file of the folder as listed.
struct Listed {
    file: String,
    path: PathBuf,
    meta: std::fs::Metadata,
}

impl MeshCatalog {
    /// Takes the file an upload wrote (its mesh the one the upload inserted) for read as it
    /// is now, and forgets the files of the name it removed. Under the store lock.
    pub(super) fn uploaded(&self, seen: &mut Seen, name: &str, path: &Path) {
        let ours = |file: &str| Path::new(file).file_stem().and_then(|s| s.to_str()) == Some(name);
        seen.read.retain(|file, _| !ours(file));
        self.skipped
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .retain(|(file, _)| !ours(file));
        if let (Ok(meta), Some(file)) = (std::fs::metadata(path), path.file_name()) {
            let file = file.to_string_lossy().into_owned();
            seen.read.insert(file, (file_stamp(&meta), None));
        }
    }

    /// Brings the served meshes in line with the folder; `None` when nothing changed (no mesh
    /// added, replaced or removed, no file newly failing to read). With
    /// `asked` (start, SIGHUP), files are read however recently they changed and those that
    /// failed are read again. Blocking I/O: call it off the async threads. A data folder gone
    /// or unreadable is an error and leaves the meshes as they were; a data folder without
    /// `meshes/` has none.
    pub fn rescan(&self, asked: bool) -> Result<Option<Changes>> {
        if self.dir.as_os_str().is_empty() {
            return Ok(None);
        }
        // The store lock before the listing: an upload between the two would be in the
        // served meshes but not in the listing, and taken for removed. A poisoned lock (a
        // reader that panicked) leaves only a cache of stamps: carry on with it.
        let mut seen = self.store.lock().unwrap_or_else(PoisonError::into_inner);
        let listed = list(&self.dir)?;
        let current = self.served().clone();
        let mut next: BTreeMap<String, Arc<MeshEntry>> = BTreeMap::new();
        let mut read = BTreeMap::new();
        let mut skipped = Vec::new();
        let mut changes = Changes::default();
        // Each name's candidate files in name order (json, obj, ply, stl).
        let mut named: BTreeMap<String, Vec<Listed>> = BTreeMap::new();
        for listed in listed {
            let stem = listed
                .path
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or_default()
                .to_owned();
            if let Err(e) = crate::ingest::check_name_of("mesh", &stem) {
                skipped.push((listed.file, format!("{e:#}")));
                continue;
            }
            named.entry(stem).or_default().push(listed);
        }
        let now = SystemTime::now();
        for (stem, files) in named {
            let old = current.get(&stem);
            // The first file that reads serves the name, as a fresh start would: one that
            // does not leaves it to the next. Only when none reads does a mesh read before
            // from one of them stay served (`stale`). Two files of one name only come from
            // outside (an upload removes the other formats').
            let old_listed = old.is_some_and(|e| files.iter().any(|l| l.path == e.source));
            // The file serving the name; a first file still being written, which no later
            // file takes the name from meanwhile but the one the mesh served so far came
            // from (any other would take it, then lose it at the next rescan).
            let mut claimed: Option<String> = None;
            let mut settling: Option<String> = None;
            let mut stale: Option<(usize, Arc<MeshEntry>)> = None;
            for Listed { file, path, meta } in files {
                if let Some(first) = &claimed {
                    skipped.push((file, format!("the mesh {stem} is served from {first}")));
                    continue;
                }
                let from_this = old.filter(|e| e.source == path).cloned();
                if let (Some(first), None) = (&settling, &from_this) {
                    let why =
                        format!("the mesh {stem} is read from {first} once its writing settles");
                    skipped.push((file, why));
                    continue;
                }
                // Not read: a FIFO would block the rescan until something wrote to it
                // ([`load`] opens without blocking too, for a file swapped for one since this
                // stat). Not a removal either: a link swapped to a target not yet there.
                if let Some(what) = crate::regular_file::kind(&meta) {
                    let why = if meta.is_symlink() {
                        what.to_string()
                    } else {
                        format!("not a regular file ({what})")
                    };
                    skipped.push((file, why));
                    stale = from_this.map(|e| (skipped.len() - 1, e)).or(stale);
                    continue;
                }
                let stamp = file_stamp(&meta);
                match seen.read.get(&file) {
                    Some((s, None)) if *s == stamp => {
                        if let Some(e) = from_this {
                            next.insert(stem.clone(), e);
                            read.insert(file.clone(), (stamp, None));
                            claimed = Some(file);
                            continue;
                        }
                    }
                    Some((s, Some(why))) if *s == stamp && !asked => {
                        skipped.push((file.clone(), why.clone()));
                        read.insert(file, (stamp, Some(why.clone())));
                        stale = from_this.map(|e| (skipped.len() - 1, e)).or(stale);
                        continue;
                    }
                    _ => {}
                }
                let changed = meta
                    .modified()
                    .ok()
                    .and_then(|t| now.duration_since(t).ok());
                if !asked && changed.is_some_and(|age| age < SETTLE) {
                    // Still being written, perhaps: the mesh served so far stays until it
                    // settles, from the file it came from when that is a later one.
                    match (from_this, old) {
                        (Some(e), _) => {
                            next.insert(stem.clone(), e);
                            claimed = Some(file);
                        }
                        // From a file no longer listed: kept here, as no later file has it.
                        (None, Some(e)) if !old_listed => {
                            next.insert(stem.clone(), Arc::clone(e));
                            settling = Some(file);
                        }
                        (None, _) => settling = Some(file),
                    }
                    continue;
                }
                match load(&path) {
                    Ok(repaired) => {
                        let entry = MeshEntry::new(stem.clone(), repaired, path);
                        // The same mesh (a file touched, or copied again) keeps its LOD
                        // structures.
                        let same = |e: &MeshEntry| {
                            (e.content, &e.source, e.faces_dropped)
                                == (entry.content, &entry.source, entry.faces_dropped)
                        };
                        let entry = match old {
                            Some(e) if same(e) => Arc::clone(e),
                            Some(_) => {
                                changes.replaced.push(file.clone());
                                Arc::new(entry)
                            }
                            None => {
                                changes.added.push(file.clone());
                                Arc::new(entry)
                            }
                        };
                        next.insert(stem.clone(), entry);
                        read.insert(file.clone(), (stamp, None));
                        claimed = Some(file);
                    }
                    Err(e) => match from_this {
                        // An open that may pass (out of descriptors under load, an I/O error)
                        // does not move the name: the mesh read from the file stays, and the
                        // file is read again at the next rescan.
                        Some(kept) if passing(&e) => {
                            tracing::warn!(
                                "reading mesh {file}: {e:#}; serving the mesh read before"
                            );
                            next.insert(stem.clone(), kept);
                            claimed = Some(file);
                        }
                        from_this => {
                            let why = format!("{e:#}");
                            changes.failed.push(file.clone());
                            skipped.push((file.clone(), why.clone()));
                            read.insert(file, (stamp, Some(why)));
                            stale = from_this.map(|e| (skipped.len() - 1, e)).or(stale);
                        }
                    },
                }
            }
            if let (None, Some((at, e))) = (&claimed, stale) {
                if let Some((_, why)) = skipped.get_mut(at) {
                    why.push_str(" (the mesh read from it before is still served)");
                }
                next.insert(stem, e);
            }
        }
        // Skipped files in name order, as the folder lists them.
        skipped.sort();
        changes.removed = current
            .iter()
            .filter(|(name, _)| !next.contains_key(*name))
            .filter_map(|(_, e)| e.source.file_name())
            .map(|f| f.to_string_lossy().into_owned())
            .collect();
        // Each reason once, when it first shows (a file skipped for good is not logged at
        // every period).
        {
            let mut shown = self.skipped.write().unwrap_or_else(PoisonError::into_inner);
            let before: BTreeSet<&(String, String)> = shown.iter().collect();
            for (file, why) in skipped.iter().filter(|s| !before.contains(s)) {
                tracing::warn!("skipping mesh {file}: {why}");
            }
            *shown = skipped;
        }
        seen.read = read;
        if changes == Changes::default() {
            return Ok(None);
        }
        *self.served_mut() = next;
        Ok(Some(changes))
    }
}

/// Whether `e` is an open the system may let through on another try (see
/// [`crate::regular_file::OpenError::may_pass`]).
fn passing(e: &anyhow::Error) -> bool {
    e.downcast_ref::<crate::regular_file::OpenError>()
        .is_some_and(crate::regular_file::OpenError::may_pass)
}

/// The mesh files of `dir` in name order, as [`stat`] sees them.
fn list(dir: &Path) -> Result<Vec<Listed>> {
    let listing = || format!("mesh folder {}", dir.display());
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        // No `meshes/` in a data folder that is there: no meshes. With the data folder gone
        // too (an unmounted volume), the meshes stay as the datasets do.
        Err(e)
            if e.kind() == std::io::ErrorKind::NotFound
                && dir.parent().is_some_and(Path::is_dir) =>
        {
            return Ok(Vec::new())
        }
        Err(e) => return Err(e).with_context(listing),
    };
    let mut listed = Vec::new();
    for entry in entries {
        let path = entry.with_context(listing)?.path();
        if Format::from_path(&path).is_none() {
            continue;
        }
        let Some((file, meta)) = stat(&path)? else {
            continue;
        };
        listed.push(Listed { file, path, meta });
    }
    listed.sort_by(|a, b| a.file.cmp(&b.file));
    Ok(listed)
}
