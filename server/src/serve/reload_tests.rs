//! Rescans of a data folder: what a server picks up, keeps and drops while it runs.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use zerotile_codec::container::TileId;

use super::catalog::{Catalog, Changes, Found};
use super::reload::{self, Origin};
use super::tests::hill_file_with;
use super::{AppState, Config};

const ROOT: TileId = TileId { z: 0, x: 0, y: 0 };

/// A one-tile dataset file whose header (and so build) `created` tells apart.
fn build(tag: &str, created: &str) -> PathBuf {
    hill_file_with(tag, "local", &[ROOT], |m| m.created = created.into())
}

/// Puts `from` in `dir` as `name`, the way ingest does: a whole file renamed over the name.
fn place(from: &Path, dir: &Path, name: &str) {
    let tmp = dir.join(format!(".{name}.tmp"));
    std::fs::copy(from, &tmp).unwrap();
    std::fs::rename(&tmp, dir.join(name)).unwrap();
}

/// The catalog of `dir` as it is now.
fn open(dir: &Path) -> Catalog {
    Origin::Dir(dir.to_path_buf()).open().unwrap()
}

/// `dir`'s dataset files as they are now.
fn scan(dir: &Path) -> Vec<Found> {
    Origin::Dir(dir.to_path_buf()).scan().unwrap()
}

/// A periodic rescan of `dir` against `c`.
fn rescan(c: &Catalog, dir: &Path) -> Option<(Catalog, Changes)> {
    c.rescan(scan(dir), false)
}

fn names(files: &[&str]) -> Vec<String> {
    files.iter().map(|f| (*f).to_owned()).collect()
}

/// A rescan with nothing changed makes no new catalog; one with a file added, one renamed
/// over and one removed opens the first two only, keeps the untouched dataset as it was
/// (the same open handle), and says which is which.
#[test]
fn a_rescan_opens_only_what_changed() {
    let dir = crate::fixtures::scratch("rescan-changes");
    let (old, new) = (
        build("rescan-a", "2026-01-01"),
        build("rescan-b", "2026-02-02"),
    );
    place(&old, &dir, "a.ztd");
    place(&old, &dir, "b.ztd");
    let first = open(&dir);
    assert_eq!(first.len(), 2);
    // One mesher table a tile side, not one a dataset (4 MB each at 257²).
    let table = |n: &str| Arc::clone(&first.get(n).unwrap().hierarchy);
    assert!(Arc::ptr_eq(&table("a"), &table("b")));
    assert!(rescan(&first, &dir).is_none(), "nothing changed");

    place(&new, &dir, "a.ztd");
    place(&old, &dir, "c.ztd");
    std::fs::remove_file(dir.join("b.ztd")).unwrap();
    let (second, changes) = rescan(&first, &dir).unwrap();
    assert_eq!(
        changes,
        Changes {
            added: names(&["c.ztd"]),
            replaced: names(&["a.ztd"]),
            removed: names(&["b.ztd"]),
            failed: vec![],
        }
    );
    assert_eq!(
        changes.to_string(),
        "added c.ztd; replaced a.ztd; removed b.ztd"
    );
    let served: Vec<&str> = second.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(served, ["a", "c"]);
    let version = |c: &Catalog, n: &str| c.get(n).unwrap().version;
    assert_ne!(version(&second, "a"), version(&first, "a"), "a new build");
    assert_eq!(
        version(&second, "c"),
        version(&first, "a"),
        "c is a's old bytes"
    );
    assert!(second.skipped.is_empty());
    assert!(rescan(&second, &dir).is_none());

    // Untouched: carried over, not reopened.
    place(&old, &dir, "d.ztd");
    let (third, changes) = rescan(&second, &dir).unwrap();
    assert_eq!(changes.added, names(&["d.ztd"]));
    for n in ["a", "c"] {
        assert!(Arc::ptr_eq(third.get(n).unwrap(), second.get(n).unwrap()));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A file renamed over a dataset's that does not open (a half copy moved in) is listed as
/// skipped while the build before it, which still reads its own file, stays in service; a
/// bad file that stays as it was is not reopened at every rescan. Written over in place, the
/// build before has lost its bytes too and goes; once whole again the file is served anew.
#[test]
fn a_file_that_stops_opening_keeps_the_build_before_it_if_renamed_over() {
    let dir = crate::fixtures::scratch("rescan-failed");
    let good = build("rescan-good", "2026-03-03");
    place(&good, &dir, "a.ztd");
    let first = open(&dir);
    let before = Arc::clone(first.get("a").unwrap());

    let bytes = std::fs::read(&good).unwrap();
    let half = dir.join("half");
    std::fs::write(&half, &bytes[..bytes.len() / 2]).unwrap();
    place(&half, &dir, "a.ztd");
    let (second, changes) = rescan(&first, &dir).unwrap();
    assert_eq!(changes.failed, names(&["a.ztd"]));
    assert!(Arc::ptr_eq(second.get("a").unwrap(), &before));
    let (file, why) = &second.skipped[0];
    assert_eq!(file, "a.ztd");
    assert!(
        why.contains("truncated") && why.ends_with("(the build opened before is still served)"),
        "{why}"
    );
    assert!(
        rescan(&second, &dir).is_none(),
        "the same bad file is not reopened"
    );

    // Served from its own file: the path now names another.
    let cat = second.get("a").unwrap();
    assert!(cat.read_tile(ROOT).is_ok());

    // Whole again, renamed in: served anew.
    place(&good, &dir, "a.ztd");
    let (third, changes) = rescan(&second, &dir).unwrap();
    assert_eq!(changes.replaced, names(&["a.ztd"]));
    assert!(third.skipped.is_empty());
    assert!(
        !Arc::ptr_eq(third.get("a").unwrap(), &before),
        "opened anew"
    );

    // Written over in place: nothing left to serve.
    std::fs::write(dir.join("a.ztd"), &bytes[..bytes.len() / 2]).unwrap();
    let (fourth, changes) = rescan(&third, &dir).unwrap();
    assert_eq!(changes.failed, names(&["a.ztd"]));
    assert!(fourth.get("a").is_none());
    assert!(
        !fourth.skipped[0].1.contains("still served"),
        "{:?}",
        fourth.skipped
    );

    std::fs::write(dir.join("a.ztd"), &bytes).unwrap();
    let (fifth, changes) = rescan(&fourth, &dir).unwrap();
    assert_eq!(changes.added, names(&["a.ztd"]));
    assert!(fifth.skipped.is_empty());
    assert_eq!(fifth.get("a").unwrap().version, before.version);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Waits until `state` serves a dataset named `name`, failing after 20 s.
async fn until_served(state: &AppState, name: &str) {
    let deadline = Instant::now() + Duration::from_secs(20);
    while state.catalog().get(name).is_none() {
        assert!(Instant::now() < deadline, "{name} not picked up in 20 s");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

/// The watcher swaps a changed catalog into the state the handlers read; a scan that fails
/// (the folder gone) leaves the datasets served as they were, and the watcher goes on to
/// pick up the folder once it is back.
#[tokio::test]
async fn the_watcher_swaps_the_catalog_in_and_outlives_a_failed_scan() {
    let dir = crate::fixtures::scratch("rescan-watch");
    let file = build("rescan-watch", "2026-04-04");
    place(&file, &dir, "a.ztd");
    let origin = Origin::Dir(dir.clone());
    let state = AppState::new(origin.open().unwrap(), Config::default()).unwrap();
    let watcher = tokio::spawn(reload::watch(
        state.clone(),
        origin,
        Some(Duration::from_millis(20)),
        None,
    ));
    place(&file, &dir, "b.ztd");
    until_served(&state, "b").await;
    std::fs::remove_dir_all(&dir).unwrap();
    // Several periods with the folder gone: still served.
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(state.catalog().len(), 2);
    std::fs::create_dir_all(&dir).unwrap();
    place(&file, &dir, "c.ztd");
    until_served(&state, "c").await;
    assert_eq!(state.catalog().len(), 1, "a and b went with the folder");
    assert!(!watcher.is_finished());
    watcher.abort();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// What stopped a file from opening need not show in its length or modification time: a
/// change of its metadata (a chmod, or here bytes put right under the old mtime) reopens it,
/// and a SIGHUP's rescan tries every failed file again.
#[test]
fn a_failed_file_is_tried_again_when_its_metadata_changes_or_on_sighup() {
    let dir = crate::fixtures::scratch("rescan-retry");
    let good = std::fs::read(build("rescan-retry", "2026-05-05")).unwrap();
    let path = dir.join("a.ztd");
    std::fs::write(&path, vec![0u8; good.len()]).unwrap();
    let first = open(&dir);
    assert_eq!(first.skipped.len(), 1);
    assert!(rescan(&first, &dir).is_none());
    let (again, changes) = first.rescan(scan(&dir), true).expect("SIGHUP retries it");
    assert_eq!(changes.failed, names(&["a.ztd"]));
    assert!(
        again.rescan(scan(&dir), false).is_none(),
        "not at every period"
    );

    let mtime = std::fs::metadata(&path).unwrap().modified().unwrap();
    std::fs::write(&path, &good).unwrap();
    std::fs::File::options()
        .write(true)
        .open(&path)
        .unwrap()
        .set_modified(mtime)
        .unwrap();
    let (fixed, changes) = rescan(&again, &dir).expect("the change time moved");
    assert_eq!(changes.added, names(&["a.ztd"]));
    assert!(fixed.skipped.is_empty() && fixed.get("a").is_some());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Two files of one dataset name: the later in name order is served and the other listed as
/// skipped, saying which file took the name (one was dropped without a word).
#[test]
fn two_files_of_one_name_are_told() {
    let dir = crate::fixtures::scratch("rescan-same-name");
    let file = build("rescan-same-name", "2026-06-06");
    place(&file, &dir, "n.ztd");
    place(&file, &dir, "n.ZTD");
    let c = open(&dir);
    assert_eq!(c.len(), 1);
    assert_eq!(c.skipped.len(), 1, "{:?}", c.skipped);
    let (file, why) = &c.skipped[0];
    assert_eq!(file, "n.ZTD");
    assert_eq!(why, "n.ztd has the same dataset name, \"n\", and is served");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Past the datasets the open-file limit leaves room for, a file is skipped saying what to do,
/// not opened (datasets that took every descriptor wedged the server: no connection could be
/// accepted, nor the folder listed to let them go); once there is room, SIGHUP opens it.
#[test]
fn datasets_past_the_open_file_room_are_skipped() {
    let dir = crate::fixtures::scratch("rescan-room");
    let file = build("rescan-room", "2026-07-07");
    for name in ["a.ztd", "b.ztd", "c.ztd"] {
        place(&file, &dir, name);
    }
    let (two, _) = Catalog::default()
        .rescan_within(scan(&dir), false, 2)
        .unwrap();
    assert_eq!(two.len(), 2);
    let (file, why) = &two.skipped[0];
    assert_eq!(file, "c.ztd");
    assert!(
        why.contains("at most 2 datasets open") && why.contains("ulimit -n"),
        "{why}"
    );
    let (three, changes) = two.rescan_within(scan(&dir), true, 3).unwrap();
    assert_eq!(changes.added, names(&["c.ztd"]));
    assert_eq!(three.len(), 3);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A dataset written over in place (`cp` onto it) fails its uncached tiles' checks: that is
/// a 503 `dataset_changing` to retry, not a 500, and it asks the watcher for a rescan at once,
/// which then serves the new build (here with no period: only that ask can rescan).
#[tokio::test]
async fn a_dataset_written_over_in_place_is_retried_and_rescanned_at_once() {
    use axum::body::Body;
    use axum::http::{Request, StatusCode};
    use tower::ServiceExt;
    let dir = crate::fixtures::scratch("rescan-in-place");
    place(&build("rescan-in-place-a", "2026-08-08"), &dir, "a.ztd");
    let origin = Origin::Dir(dir.clone());
    let state = AppState::new(origin.open().unwrap(), Config::default()).unwrap();
    let before = state.catalog().get("a").unwrap().version;
    let watcher = tokio::spawn(reload::watch(state.clone(), origin, None, None));
    // Another build whose longer header moves every record.
    let newer = build("rescan-in-place-b", "2026-09-09T10:11:12Z and more");
    std::fs::write(dir.join("a.ztd"), std::fs::read(newer).unwrap()).unwrap();
    let app = super::app(state.clone());
    let ask = || {
        let req = Request::get("/v1/datasets/a/tiles/0/0/0.json?threshold=1")
            .body(Body::empty())
            .unwrap();
        app.clone().oneshot(req)
    };
    let first = ask().await.unwrap();
    assert_eq!(first.status(), StatusCode::SERVICE_UNAVAILABLE);
    let body = axum::body::to_bytes(first.into_body(), 1 << 20)
        .await
        .unwrap();
    assert!(String::from_utf8_lossy(&body).contains("\"dataset_changing\""));
    let deadline = Instant::now() + Duration::from_secs(20);
    while state.catalog().get("a").unwrap().version == before {
        assert!(Instant::now() < deadline, "no rescan was asked for");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert_eq!(ask().await.unwrap().status(), StatusCode::OK);
    watcher.abort();
    std::fs::remove_dir_all(&dir).unwrap();
}
