//! Rescans of the mesh folder: what a server picks up, keeps and drops while it runs.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, SystemTime};

use zerotile_codec::mesh::io::Format;

use super::catalog::Changes;
use super::meshes::tests::{QUAD_PLY, TRI};
use super::meshes::{MeshCatalog, MeshEntry, Put, Refuses, UploadError, MESH_DIR};
use crate::fixtures::{mkfifo, within};

const QUAD: &[u8] = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
/// Reads, but repairs to nothing: the one face repeats a vertex.
const NO_FACES: &[u8] = b"v 0 0 0\nv 1 0 0\nf 1 1 2\n";

/// A data folder with an empty `meshes/`.
fn data(tag: &str) -> PathBuf {
    let dir = crate::fixtures::scratch(&format!("meshreload-{tag}"));
    std::fs::create_dir_all(dir.join(MESH_DIR)).unwrap();
    dir
}

/// Writes `bytes` as `meshes/NAME` the way a careful operator does (a whole file renamed
/// over the name), dated `age` ago.
fn place(data: &Path, name: &str, bytes: &[u8], age: Duration) {
    let dir = data.join(MESH_DIR);
    let tmp = dir.join(format!(".{name}.tmp"));
    std::fs::write(&tmp, bytes).unwrap();
    let file = std::fs::File::options().write(true).open(&tmp).unwrap();
    file.set_modified(SystemTime::now() - age).unwrap();
    std::fs::rename(&tmp, dir.join(name)).unwrap();
}

/// Placed long enough ago for a timed rescan to read it.
fn settled(data: &Path, name: &str, bytes: &[u8]) {
    place(data, name, bytes, Duration::from_secs(10));
}

/// A data folder holding `bytes` as `meshes/NAME`, settled, and its catalog.
fn opened(tag: &str, name: &str, bytes: &[u8]) -> (PathBuf, MeshCatalog) {
    let dir = data(tag);
    settled(&dir, name, bytes);
    let cat = MeshCatalog::open(&dir, 1 << 20);
    (dir, cat)
}

fn names(cat: &MeshCatalog) -> Vec<String> {
    cat.list().iter().map(|e| e.name.clone()).collect()
}

/// A timed rescan.
fn rescan(cat: &MeshCatalog) -> Option<Changes> {
    cat.rescan(false).unwrap()
}

#[test]
fn a_mesh_added_replaced_or_removed_is_served_so_after_the_next_rescan() {
    let (dir, cat) = opened("cycle", "a.obj", TRI);
    assert_eq!(names(&cat), ["a"]);
    assert_eq!(rescan(&cat), None, "nothing changed");

    settled(&dir, "b.ply", QUAD_PLY);
    let changes = rescan(&cat).expect("b added");
    assert_eq!(changes.added, ["b.ply"]);
    assert_eq!(names(&cat), ["a", "b"]);
    assert_eq!(cat.get("b").unwrap().mesh.face_count(), 2);

    let a = cat.get("a").unwrap();
    settled(&dir, "a.obj", QUAD);
    let changes = rescan(&cat).expect("a replaced");
    assert_eq!(changes.replaced, ["a.obj"]);
    let new_a = cat.get("a").unwrap();
    assert_eq!(new_a.mesh.face_count(), 2);
    assert_ne!(
        new_a.content, a.content,
        "a new mesh, new answers and ETags"
    );

    std::fs::remove_file(dir.join(MESH_DIR).join("b.ply")).unwrap();
    let changes = rescan(&cat).expect("b removed");
    assert_eq!(changes.removed, ["b.ply"]);
    assert_eq!(names(&cat), ["a"]);
    assert!(cat.get("b").is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Unchanged files are not read again, and a file rewritten with the same mesh keeps its
/// entry: the LOD structures built for it are not built again.
#[test]
fn an_unchanged_mesh_keeps_its_entry_and_its_lod_structures() {
    let (dir, cat) = opened("keep", "a.obj", QUAD);
    let a = cat.get("a").unwrap();
    a.octree().unwrap();
    assert_eq!(rescan(&cat), None);
    settled(&dir, "a.obj", QUAD);
    assert_eq!(rescan(&cat), None, "the same mesh in a new file");
    assert!(Arc::ptr_eq(&a, &cat.get("a").unwrap()));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A file changed under [`super::mesh_reload::SETTLE`] ago may be a copy under way (an OBJ
/// cut short still reads): a timed rescan leaves it, the mesh served so far stays, and the
/// rescan asked for (SIGHUP) reads it.
#[test]
fn a_file_just_changed_waits_for_the_next_rescan_unless_one_is_asked_for() {
    let (dir, cat) = opened("settle", "a.obj", TRI);
    place(&dir, "a.obj", QUAD, Duration::ZERO);
    place(&dir, "b.obj", QUAD, Duration::ZERO);
    assert_eq!(rescan(&cat), None);
    assert_eq!(names(&cat), ["a"]);
    assert_eq!(cat.get("a").unwrap().mesh.face_count(), 1);

    let changes = cat.rescan(true).unwrap().expect("read when asked");
    assert_eq!(
        (changes.added, changes.replaced),
        (vec!["b.obj".to_owned()], vec!["a.obj".to_owned()])
    );
    assert_eq!(cat.get("a").unwrap().mesh.face_count(), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A mesh is held whole in memory, so a file that no longer reads leaves the mesh read from
/// it served (listed as skipped, saying so) until it reads again. One that never read is
/// skipped alone.
#[test]
fn a_file_that_no_longer_reads_leaves_its_mesh_served() {
    let (dir, cat) = opened("broken", "a.obj", QUAD);
    let a = cat.get("a").unwrap();
    settled(&dir, "a.obj", NO_FACES);
    settled(&dir, "b.obj", NO_FACES);
    let changes = rescan(&cat).expect("two files failed");
    assert_eq!(changes.failed, ["a.obj", "b.obj"]);
    assert!(changes.replaced.is_empty() && changes.added.is_empty());
    assert!(Arc::ptr_eq(&a, &cat.get("a").unwrap()));
    assert_eq!(rescan(&cat), None, "not read again while unchanged");
    assert_eq!(names(&cat), ["a"]);
    let skipped = cat.skipped();
    let files: Vec<&str> = skipped.iter().map(|(f, _)| f.as_str()).collect();
    assert_eq!(files, ["a.obj", "b.obj"]);
    assert!(skipped[0]
        .1
        .ends_with("(the mesh read from it before is still served)"));
    assert!(skipped[1].1.contains("no valid faces"), "{}", skipped[1].1);

    settled(&dir, "a.obj", TRI);
    assert_eq!(rescan(&cat).expect("a reads again").replaced, ["a.obj"]);
    assert_eq!(cat.get("a").unwrap().mesh.face_count(), 1);
    let files: Vec<String> = cat.skipped().into_iter().map(|(f, _)| f).collect();
    assert_eq!(files, ["b.obj"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// What is not a mesh file to read is skipped with its reason and not opened: a FIFO would
/// block the start (and every rescan) until something wrote to it.
#[test]
fn fifos_folders_dangling_links_bad_names_and_shadowed_files_are_skipped() {
    let dir = data("odd");
    let meshes = dir.join(MESH_DIR);
    settled(&dir, "t.obj", TRI);
    settled(&dir, "t.ply", QUAD_PLY);
    settled(&dir, "bad name.obj", TRI);
    std::fs::create_dir(meshes.join("d.obj")).unwrap();
    std::os::unix::fs::symlink(meshes.join("nowhere"), meshes.join("l.obj")).unwrap();
    mkfifo(&meshes.join("f.obj"));
    let d = dir.clone();
    let cat = within(30, "opening the folder hung on its FIFO", move || {
        MeshCatalog::open(&d, 1 << 20)
    });
    assert_eq!(names(&cat), ["t"]);
    let skipped: Vec<(String, String)> = cat.skipped();
    let files: Vec<&str> = skipped.iter().map(|(f, _)| f.as_str()).collect();
    assert_eq!(files, ["bad name.obj", "d.obj", "f.obj", "l.obj", "t.ply"]);
    let why = |i: usize| skipped[i].1.as_str();
    assert!(why(0).contains("mesh name"), "{}", why(0));
    assert_eq!(why(1), "not a regular file (a folder)");
    assert_eq!(why(2), "not a regular file (a FIFO)");
    assert_eq!(why(3), "a link to nothing");
    assert_eq!(why(4), "the mesh t is served from t.obj");
    assert_eq!(rescan(&cat), None);

    // The shadowing file gone, the other is read.
    std::fs::remove_file(meshes.join("t.obj")).unwrap();
    let changes = rescan(&cat).expect("t from t.ply");
    assert_eq!(changes.replaced, ["t.ply"]);
    assert_eq!(cat.get("t").unwrap().mesh.face_count(), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

/// An upload's file is taken for read: the rescan after it changes nothing.
#[test]
fn an_upload_is_not_read_again_by_the_next_rescan() {
    let (dir, cat) = opened("upload", "a.ply", QUAD_PLY);
    let (e, replaced) = cat.upload("a", TRI, Some(Format::Obj), Put::Any).unwrap();
    assert!(replaced);
    assert_eq!(rescan(&cat), None);
    assert!(Arc::ptr_eq(&e, &cat.get("a").unwrap()));
    assert_eq!(cat.get("a").unwrap().mesh.face_count(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A replace-only upload (`If-Match: *`) after a rescan removed its mesh is refused and
/// writes nothing; over a mesh still served it replaces it. A create-only one (`If-None-Match:
/// *`) is refused over a mesh served, whoever placed it.
#[test]
fn a_replace_after_the_rescan_removed_the_mesh_creates_nothing() {
    let (dir, cat) = opened("replace", "a.ply", QUAD_PLY);
    std::fs::remove_file(dir.join(MESH_DIR).join("a.ply")).unwrap();
    assert!(rescan(&cat).is_some());
    assert!(matches!(
        cat.upload("a", TRI, Some(Format::Obj), Put::Replace),
        Err(UploadError::Gone)
    ));
    assert!(cat.get("a").is_none());
    assert!(!dir.join(MESH_DIR).join("a.obj").exists());

    let (_, replaced) = cat
        .upload("a", QUAD_PLY, Some(Format::Ply), Put::Any)
        .unwrap();
    assert!(!replaced);
    let (e, replaced) = cat
        .upload("a", TRI, Some(Format::Obj), Put::Replace)
        .unwrap();
    assert!(replaced);
    assert_eq!(e.mesh.face_count(), 1);

    settled(&dir, "b.obj", TRI);
    assert!(rescan(&cat).is_some());
    assert!(matches!(
        cat.upload("b", QUAD_PLY, Some(Format::Ply), Put::Create),
        Err(UploadError::Exists)
    ));
    assert!(!dir.join(MESH_DIR).join("b.ply").exists());
    assert_eq!(cat.get("b").unwrap().mesh.face_count(), 1);
    let (_, replaced) = cat
        .upload("c", TRI, Some(Format::Obj), Put::Create)
        .unwrap();
    assert!(!replaced);

    // An If-None-Match of tags is judged on the mesh served when the upload is stored:
    // refused over one it names (placed after the route's first look, say), taken where
    // none is served or the one served is another.
    let names_one_face = || -> Refuses { Box::new(|e: &MeshEntry| e.mesh.face_count() == 1) };
    assert!(matches!(
        cat.upload_unless(
            "c",
            QUAD_PLY,
            Some(Format::Ply),
            Put::Any,
            Some(names_one_face())
        ),
        Err(UploadError::Matched)
    ));
    assert_eq!(cat.get("c").unwrap().mesh.face_count(), 1);
    assert!(!dir.join(MESH_DIR).join("c.ply").exists());
    let (_, replaced) = cat
        .upload_unless(
            "d",
            TRI,
            Some(Format::Obj),
            Put::Any,
            Some(names_one_face()),
        )
        .unwrap();
    assert!(!replaced);
    cat.upload("e", QUAD_PLY, Some(Format::Ply), Put::Any)
        .unwrap();
    assert_ne!(cat.get("e").unwrap().mesh.face_count(), 1);
    let (_, replaced) = cat
        .upload_unless(
            "e",
            TRI,
            Some(Format::Obj),
            Put::Replace,
            Some(names_one_face()),
        )
        .unwrap();
    assert!(replaced);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `meshes/` removed: no meshes. The data folder gone (an unmounted volume): an error, and
/// the meshes stay as the datasets do.
#[test]
fn without_meshes_there_are_none_and_without_the_data_folder_they_stay() {
    let (dir, cat) = opened("gone", "a.obj", TRI);
    std::fs::rename(&dir, dir.with_extension("moved")).unwrap();
    assert!(cat.rescan(false).is_err());
    assert_eq!(names(&cat), ["a"]);
    std::fs::rename(dir.with_extension("moved"), &dir).unwrap();
    std::fs::remove_dir_all(dir.join(MESH_DIR)).unwrap();
    assert_eq!(rescan(&cat).expect("a removed").removed, ["a.obj"]);
    assert!(cat.list().is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Of two files of one name, the first that reads serves it: one that does not read, or is
/// a FIFO, leaves the name to the next instead of serving nothing (t.obj unreadable shadowed
/// a good t.ply, and the skip said t was "served from" it).
#[test]
fn a_file_that_does_not_read_leaves_its_name_to_the_next() {
    let dir = data("shadow");
    let meshes = dir.join(MESH_DIR);
    settled(&dir, "t.obj", NO_FACES);
    settled(&dir, "t.ply", QUAD_PLY);
    mkfifo(&meshes.join("u.obj"));
    settled(&dir, "u.ply", QUAD_PLY);
    let cat = MeshCatalog::open(&dir, 1 << 20);
    assert_eq!(names(&cat), ["t", "u"]);
    assert_eq!(cat.get("t").unwrap().mesh.face_count(), 2);
    let skipped = cat.skipped();
    let files: Vec<&str> = skipped.iter().map(|(f, _)| f.as_str()).collect();
    assert_eq!(files, ["t.obj", "u.obj"]);
    assert!(skipped[0].1.contains("no valid faces"), "{}", skipped[0].1);
    // The listing is public: the server's folder is not in it.
    let folder = meshes.display().to_string();
    assert!(!skipped[0].1.contains(&folder), "{}", skipped[0].1);
    assert_eq!(skipped[1].1, "not a regular file (a FIFO)");
    // Nothing changed: the failed file is not read again, and t stays t.ply's.
    assert_eq!(rescan(&cat), None);

    // The first file mended takes its name back; then t.ply is the shadowed one.
    settled(&dir, "t.obj", TRI);
    assert_eq!(rescan(&cat).expect("t from t.obj").replaced, ["t.obj"]);
    assert_eq!(cat.get("t").unwrap().mesh.face_count(), 1);
    let skipped = cat.skipped();
    assert!(
        skipped.contains(&("t.ply".into(), "the mesh t is served from t.obj".into())),
        "{skipped:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The read a rescan makes of a file it listed as a regular file refuses a FIFO at once,
/// should the file have been swapped for one since the listing: it opened it blocking, and
/// the rescan (and every one after it) waited for a writer. (The swap itself is not timed
/// here: the read is given the FIFO directly.)
#[test]
fn the_read_of_a_listed_file_refuses_a_fifo_at_once() {
    let dir = data("swap");
    let fifo = dir.join(MESH_DIR).join("s.obj");
    mkfifo(&fifo);
    let read = move || super::meshes::load(&fifo).map_err(|e| format!("{e:#}"));
    let e = within(10, "reading the FIFO blocked", read).unwrap_err();
    assert_eq!(e, "not a regular file (a FIFO)");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A served mesh's file turned into a FIFO, a folder or a link to nothing keeps the mesh
/// served, as a file that no longer reads does (and as a dataset does): they answered 404.
#[test]
fn a_mesh_whose_file_becomes_no_file_stays_served() {
    let (dir, cat) = opened("nofile", "a.obj", TRI);
    let file = dir.join(MESH_DIR).join("a.obj");
    type Swap = fn(&Path);
    let swaps: [(&str, Swap); 3] = [
        ("not a regular file (a FIFO)", |p| mkfifo(p)),
        ("not a regular file (a folder)", |p| {
            std::fs::create_dir(p).unwrap()
        }),
        ("a link to nothing", |p| {
            std::os::unix::fs::symlink(p.with_extension("gone"), p).unwrap()
        }),
    ];
    for (why, swap) in swaps {
        let _ = std::fs::remove_file(&file).or_else(|_| std::fs::remove_dir(&file));
        swap(&file);
        assert_eq!(cat.rescan(true).unwrap(), None, "{why}");
        assert_eq!(cat.get("a").unwrap().mesh.face_count(), 1, "{why}");
        assert_eq!(
            cat.skipped(),
            [(
                "a.obj".to_string(),
                format!("{why} (the mesh read from it before is still served)")
            )]
        );
    }
    // A file again: read anew.
    std::fs::remove_file(&file).unwrap();
    settled(&dir, "a.obj", QUAD);
    assert_eq!(rescan(&cat).expect("a reads").replaced, ["a.obj"]);
    assert_eq!(cat.get("a").unwrap().mesh.face_count(), 2);
    assert!(cat.skipped().is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Of two files of one name the served mesh is the one a fresh start would serve: when the
/// first stops reading, the next that reads takes the name (the first's old mesh stayed,
/// and a restart then served the other); while a new first file settles, the file serving
/// the name goes on serving it and is not listed as skipped.
#[test]
fn two_files_of_one_name_serve_what_a_start_would() {
    let (dir, cat) = opened("two", "t.ply", QUAD_PLY);
    assert_eq!(cat.get("t").unwrap().mesh.face_count(), 2);
    // A new t.obj, just written: t.ply goes on serving t until it settles.
    place(&dir, "t.obj", TRI, Duration::ZERO);
    assert_eq!(rescan(&cat), None);
    assert_eq!(cat.get("t").unwrap().mesh.face_count(), 2);
    assert_eq!(cat.skipped(), []);
    // Settled, it takes the name.
    settled(&dir, "t.obj", TRI);
    assert_eq!(rescan(&cat).expect("t from t.obj").replaced, ["t.obj"]);
    assert_eq!(cat.get("t").unwrap().mesh.face_count(), 1);
    // t.obj no longer reads: t.ply, which does, serves t, as after a restart.
    settled(&dir, "t.obj", NO_FACES);
    assert_eq!(rescan(&cat).expect("t from t.ply").replaced, ["t.ply"]);
    assert_eq!(cat.get("t").unwrap().mesh.face_count(), 2);
    let restarted = MeshCatalog::open(&dir, 1 << 20);
    assert_eq!(restarted.get("t").unwrap().mesh.face_count(), 2);
    let skipped = cat.skipped();
    assert_eq!(skipped.len(), 1, "{skipped:?}");
    assert_eq!(skipped[0].0, "t.obj");
    assert!(!skipped[0].1.contains("still served"), "{skipped:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// While a new first file of a name is being written and a later one serves the name, a
/// file between them does not take it meanwhile: it did, then lost it to the first at the
/// next rescan (two replacements, LODs built twice).
#[test]
fn a_file_between_a_settling_first_and_the_served_one_waits_too() {
    const JSON_TRI: &[u8] = b"{\"positions\": [0, 0, 0, 1, 0, 0, 0, 1, 0], \"indices\": [0, 1, 2]}";
    let (dir, cat) = opened("settle3", "t.ply", QUAD_PLY);
    place(&dir, "t.json", JSON_TRI, Duration::ZERO);
    settled(&dir, "t.obj", TRI);
    assert_eq!(rescan(&cat), None);
    assert!(cat.get("t").unwrap().source.ends_with("t.ply"));
    assert_eq!(
        cat.skipped(),
        [(
            "t.obj".to_string(),
            "the mesh t is read from t.json once its writing settles".to_string()
        )]
    );
    settled(&dir, "t.json", JSON_TRI);
    assert_eq!(rescan(&cat).expect("t from t.json").replaced, ["t.json"]);
    assert!(cat.get("t").unwrap().source.ends_with("t.json"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// While a new first file settles, the file serving the name failing to read keeps its
/// mesh served: the name is not left empty until the first settles.
#[test]
fn a_served_file_failing_while_a_first_settles_keeps_its_mesh() {
    let (dir, cat) = opened("settle-fail", "t.ply", QUAD_PLY);
    place(&dir, "t.obj", TRI, Duration::ZERO);
    settled(&dir, "t.ply", b"ply\nnot a mesh\n");
    assert_eq!(rescan(&cat).expect("t.ply fails").failed, ["t.ply"]);
    assert_eq!(cat.get("t").unwrap().mesh.face_count(), 2);
    let skipped = cat.skipped();
    assert!(
        skipped.len() == 1
            && skipped[0]
                .1
                .ends_with("(the mesh read from it before is still served)"),
        "{skipped:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
