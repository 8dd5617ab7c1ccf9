//! The object-mesh routes of `zerotile serve`, over HTTP on the classic test meshes.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test helpers: a failure to spawn the binary should fail the test loudly"
)]

use std::path::PathBuf;

use zerotile_tests::server::Server;
use zerotile_tests::shared_data;

fn data_dir(name: &str) -> PathBuf {
    let dir = zerotile_tests::fresh_dir(&format!("meshes-{name}"));
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    for m in ["fandisk.obj", "uv-sphere-5002.obj"] {
        std::fs::copy(
            shared_data().join("meshes").join(m),
            dir.join("meshes").join(m),
        )
        .unwrap();
    }
    dir
}

/// Vertex and face counts of an OBJ body, read here line by line.
fn obj_counts(body: &[u8]) -> (usize, usize) {
    let text = String::from_utf8_lossy(body);
    let v = text.lines().filter(|l| l.starts_with("v ")).count();
    let f = text.lines().filter(|l| l.starts_with("f ")).count();
    (v, f)
}

#[test]
fn lods_come_in_every_format_with_their_counts() {
    let data = data_dir("lods");
    let s = Server::start(&data);
    let list = s.get("/v1/meshes", &[]).json();
    let names: Vec<&str> = list["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["fandisk", "uv-sphere-5002"]);
    let d = s.get("/v1/meshes/fandisk", &[]).json();
    assert_eq!(
        (d["vertices"].as_u64(), d["faces"].as_u64()),
        (Some(6475), Some(12946))
    );

    // Curvature level 1 (ε = 0.15) as OBJ: the headers say what the body holds.
    let r = s.get(
        "/v1/meshes/uv-sphere-5002/curvature?level=1&format=obj",
        &[],
    );
    assert_eq!(r.status, 200);
    let (v, f) = obj_counts(&r.body);
    assert_eq!(
        (v as f64, f as f64),
        (r.number("x-vertices"), r.number("x-faces"))
    );
    assert!(f < 10_000 && f > 1_000, "{f}");
    assert_eq!(r.number("x-error"), 0.15);
    // The documented defaults: curvature without a parameter is level 1, octree level 2.
    let bare = s.get("/v1/meshes/uv-sphere-5002/curvature?format=obj", &[]);
    assert_eq!(bare.number("x-error"), 0.15);
    assert_eq!(bare.number("x-faces"), r.number("x-faces"));
    let octree = s.get("/v1/meshes/uv-sphere-5002/octree", &[]);
    assert_eq!((octree.status, octree.number("x-error")), (200, 2.0));
    // The levelled methods name their deepest level; the others have none to name.
    assert!(octree.number("x-max-level") > 2.0);
    assert_eq!(
        (r.number("x-max-level"), bare.number("x-max-level")),
        (3.0, 3.0)
    );
    let by_error = s.get("/v1/meshes/uv-sphere-5002/curvature?error=0.2", &[]);
    assert_eq!(
        (by_error.status, by_error.header("x-max-level")),
        (200, None)
    );
    let qem = s.get("/v1/meshes/uv-sphere-5002/qem?ratio=0.5", &[]);
    assert_eq!((qem.status, qem.header("x-max-level")), (200, None));
    // An ε between two rungs is cut at the lower, and X-Error names that rung: 0.26 is
    // level 3 (0.25), face for face.
    let between = s.get("/v1/meshes/uv-sphere-5002/curvature?error=0.26", &[]);
    let level3 = s.get("/v1/meshes/uv-sphere-5002/curvature?level=3", &[]);
    assert_eq!(between.number("x-error"), 0.25);
    assert_eq!(between.number("x-faces"), level3.number("x-faces"));
    // A larger ε keeps fewer faces.
    let r3 = s.get(
        "/v1/meshes/uv-sphere-5002/curvature?level=3&format=obj",
        &[],
    );
    assert!(r3.number("x-faces") < r.number("x-faces"));
    // Levels nest: one continuing decimation removes vertices and never moves one, so every
    // vertex of level 3 is a vertex of level 1.
    let vertex_lines = |body: &[u8]| -> std::collections::HashSet<String> {
        String::from_utf8_lossy(body)
            .lines()
            .filter(|l| l.starts_with("v "))
            .map(str::to_owned)
            .collect()
    };
    let (fine, coarse) = (vertex_lines(&r.body), vertex_lines(&r3.body));
    assert!(!coarse.is_empty() && coarse.len() < fine.len());
    assert!(
        coarse.is_subset(&fine),
        "level 3 has vertices level 1 lacks"
    );

    // QEM to the fandisk's paper count, as PLY and GLB.
    let r = s.get("/v1/meshes/fandisk/qem?faces=978&format=ply", &[]);
    assert_eq!(r.status, 200);
    assert!(r.body.starts_with(b"ply"));
    assert!(r.number("x-faces") <= 978.0 && r.number("x-faces") >= 970.0);
    // ratio=0 is in range: QEM's smallest answer, never an empty mesh or an error.
    let r = s.get("/v1/meshes/fandisk/qem?ratio=0&format=obj", &[]);
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    let (v, f) = obj_counts(&r.body);
    assert!(
        f >= 1 && f as f64 == r.number("x-faces") && v >= 3,
        "{v} vertices, {f} faces"
    );
    let r = s.get("/v1/meshes/fandisk/qem?ratio=0.1&format=glb", &[]);
    assert_eq!(&r.body[..4], b"glTF");
    assert_eq!(r.header("content-type"), Some("model/gltf-binary"));

    // Silhouette for a view, as JSON: the view's refinement keeps more faces than the same
    // level drawn without a view, and the body holds what the headers say.
    let view = s.get(
        "/v1/meshes/uv-sphere-5002/silhouette?eye=10,0,0&target=0,0,0&level=2",
        &[],
    );
    assert_eq!(view.status, 200);
    let j = view.json();
    let faces = j["indices"].as_array().map_or(0, Vec::len) / 3;
    assert_eq!(faces as f64, view.number("x-faces"));
    assert!(faces > 0 && faces < 10_000, "{faces}");
    let plain = s.get("/v1/meshes/uv-sphere-5002/silhouette?level=2", &[]);
    assert!(view.number("x-faces") > plain.number("x-faces"));

    // Octree levels, and browsing: full detail inside a region, the base level elsewhere,
    // so the browsed mesh sits between the base level and the input.
    let base = s.get("/v1/meshes/fandisk/octree?level=2&format=obj", &[]);
    assert_eq!(base.status, 200);
    let bbox = &d["bbox"];
    let c: Vec<f64> = (0..3)
        .map(|k| (bbox[0][k].as_f64().unwrap() + bbox[1][k].as_f64().unwrap()) / 2.0)
        .collect();
    let far = 2.0 * d["diagonal"].as_f64().unwrap();
    let browse = |aspect: &str| {
        s.get(
            &format!(
                "/v1/meshes/fandisk/octree?level=2&roi=-0.3,-0.3,0.3,0.3&eye={},{},{}&target={},{},{}&fov=40&format=obj{aspect}",
                c[0] + far, c[1], c[2], c[0], c[1], c[2]
            ),
            &[],
        )
    };
    let browsed = browse("");
    // An aspect as the docs write it, W/H, is the number it names.
    let wide = browse("&aspect=16/9");
    assert_eq!(wide.status, 200, "{}", String::from_utf8_lossy(&wide.body));
    assert_eq!(
        wide.body,
        browse(&format!("&aspect={}", 16.0f64 / 9.0)).body
    );
    assert_eq!(
        browsed.status,
        200,
        "{}",
        String::from_utf8_lossy(&browsed.body)
    );
    let (b, f) = (base.number("x-faces"), browsed.number("x-faces"));
    assert!(b < f && f < 12_946.0, "base {b}, browsed {f}");
    assert_eq!(obj_counts(&browsed.body).1 as f64, f);

    // ETag: the same ask again is 304.
    let r = s.get("/v1/meshes/fandisk/qem?faces=978&format=ply", &[]);
    let etag = r.header("etag").unwrap().to_string();
    // Weak: gzip and br re-encode the body under the same tag.
    assert!(etag.starts_with("W/\""), "{etag}");
    let again = s.get(
        "/v1/meshes/fandisk/qem?faces=978&format=ply",
        &[("if-none-match", &etag)],
    );
    assert_eq!(again.status, 304);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn bad_asks_get_specific_json_errors() {
    let data = data_dir("errors");
    let s = Server::start(&data);
    for (path, status, code) in [
        ("/v1/meshes/nope", 404, "mesh_not_found"),
        ("/v1/meshes/nope/qem?faces=10", 404, "mesh_not_found"),
        ("/v1/meshes/fandisk/marching", 404, "unknown_method"),
        ("/v1/meshes/fandisk/qem?faces=abc", 400, "bad_number"),
        ("/v1/meshes/fandisk/qem?faces=-3", 400, "out_of_range"),
        ("/v1/meshes/fandisk/qem?faces=1.5", 400, "out_of_range"),
        (
            "/v1/meshes/fandisk/silhouette?level=1.5",
            400,
            "out_of_range",
        ),
        ("/v1/meshes/fandisk/qem?faces=1e9", 400, "out_of_range"),
        (
            "/v1/meshes/fandisk/qem?faces=10&ratio=0.5",
            400,
            "bad_query",
        ),
        ("/v1/meshes/fandisk/qem?error=NaN", 400, "out_of_range"),
        ("/v1/meshes/fandisk/curvature?level=4", 400, "out_of_range"),
        (
            "/v1/meshes/fandisk/curvature?error=0.2&level=1",
            400,
            "bad_query",
        ),
        ("/v1/meshes/fandisk/curvature?faces=10", 400, "bad_query"),
        ("/v1/meshes/fandisk/silhouette", 400, "bad_query"),
        (
            "/v1/meshes/fandisk/silhouette?eye=1,2&target=0,0,0",
            400,
            "bad_vector",
        ),
        (
            "/v1/meshes/fandisk/silhouette?eye=inf,0,0&target=0,0,0",
            400,
            "out_of_range",
        ),
        (
            "/v1/meshes/fandisk/silhouette?eye=1,1,1&target=1,1,1",
            400,
            "bad_mesh_query",
        ),
        ("/v1/meshes/fandisk/original?format=stl", 400, "bad_format"),
        // The description is JSON only: asking it for a model is an error, not a 200 JSON.
        ("/v1/meshes/fandisk?format=glb", 400, "bad_query"),
        ("/v1/meshes/fandisk/octree?level=1.5", 400, "out_of_range"),
        (
            "/v1/meshes/fandisk/octree?level=2&roi=0,0,1,1",
            400,
            "bad_query",
        ),
        (
            "/v1/meshes/fandisk/octree?roi=0,0,1&eye=0,0,9&target=0,0,0",
            400,
            "bad_vector",
        ),
        (
            "/v1/meshes/fandisk/octree?roi=0,0,2,1&eye=0,0,9&target=0,0,0",
            400,
            "out_of_range",
        ),
        (
            "/v1/meshes/fandisk/octree?roi=0.5,0,0.1,1&eye=0,0,9&target=0,0,0",
            400,
            "bad_mesh_query",
        ),
    ] {
        s.get(path, &[]).error(status, code);
    }
    let _ = std::fs::remove_dir_all(&data);
}

/// `serve --read-only` refuses every upload, new name or old, and stores nothing; the
/// meshes it has are served as before.
#[test]
fn a_read_only_server_takes_no_uploads() {
    let data = data_dir("read-only");
    let s = Server::start_flags(&data, &["--read-only"]);
    let cow = std::fs::read(shared_data().join("meshes/cow.obj")).unwrap();
    let before = std::fs::read(data.join("meshes/fandisk.obj")).unwrap();
    for name in ["cow", "fandisk"] {
        let r = s.post(&format!("/v1/meshes/{name}"), "model/obj", &cow);
        r.error(403, "read_only");
        let msg = r.json()["message"].to_string();
        assert!(msg.contains("--read-only"), "{msg}");
    }
    assert!(!data.join("meshes/cow.obj").exists());
    assert_eq!(
        std::fs::read(data.join("meshes/fandisk.obj")).unwrap(),
        before
    );
    assert_eq!(s.get("/v1/meshes/cow/original", &[]).status, 404);
    assert_eq!(s.get("/v1/meshes/fandisk/original", &[]).status, 200);
    let _ = std::fs::remove_dir_all(&data);
}

/// Uploads stop at `serve --mesh-quota` faces held in all: each is kept in memory, so
/// uploads under new names would otherwise grow the server without bound. A mesh replaced
/// frees its own room; a refused upload stores nothing.
#[test]
fn uploads_stop_at_the_mesh_quota() {
    let data = data_dir("quota");
    // fandisk 12,946 faces + the sphere 10,000 = 22,946 held; the cow's 5,804 count as
    // 10,000 (the smallest charge), so one cow fits under 35,000 and a second does not.
    let s = Server::start_flags(&data, &["--mesh-quota", "35000"]);
    let cow = std::fs::read(shared_data().join("meshes/cow.obj")).unwrap();
    assert_eq!(s.post("/v1/meshes/cow", "model/obj", &cow).status, 201);
    let r = s.post("/v1/meshes/cow2", "model/obj", &cow);
    r.error(507, "mesh_quota");
    let msg = r.json()["message"].to_string();
    assert!(
        msg.contains("32946") && msg.contains("--mesh-quota"),
        "{msg}"
    );
    assert!(!data.join("meshes/cow2.obj").exists());
    assert_eq!(s.get("/v1/meshes/cow2/original", &[]).status, 404);
    // Replacing a mesh is charged for the difference only (and is a 200: nothing new).
    assert_eq!(s.post("/v1/meshes/cow", "model/obj", &cow).status, 200);
    assert_eq!(s.post("/v1/meshes/fandisk", "model/obj", &cow).status, 200);
    s.post("/v1/meshes/cow2", "model/obj", &cow)
        .error(507, "mesh_quota");
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn uploads_are_validated_limited_and_never_replace_a_mesh_with_a_bad_one() {
    let data = data_dir("upload");
    let s = Server::start(&data);
    let cow = std::fs::read(shared_data().join("meshes/cow.obj")).unwrap();
    let r = s.post("/v1/meshes/cow", "model/obj", &cow);
    assert_eq!(r.status, 201, "{}", String::from_utf8_lossy(&r.body));
    // Relative to the URL posted to: the mesh is there.
    assert_eq!(r.header("location"), Some("cow"));
    assert!(data.join("meshes/cow.obj").exists());
    assert_eq!(s.get("/v1/meshes/cow/original?format=obj", &[]).status, 200);

    // Garbage under an existing name: refused, the old mesh still served and on disk.
    let before = std::fs::read(data.join("meshes/fandisk.obj")).unwrap();
    s.post("/v1/meshes/fandisk", "model/obj", b"v 1 2\nf 1 2 3\n")
        .error(422, "invalid_mesh");
    assert_eq!(
        std::fs::read(data.join("meshes/fandisk.obj")).unwrap(),
        before
    );
    assert_eq!(s.get("/v1/meshes/fandisk", &[]).json()["faces"], 12946);

    // Faces but no surface (three copies of one point): nothing to simplify or view.
    s.post(
        "/v1/meshes/g10",
        "model/obj",
        b"v 1 2 3\nv 1 2 3\nv 1 2 3\nf 1 2 3\n",
    )
    .error(422, "invalid_mesh");
    assert!(!data.join("meshes/g10.obj").exists());

    // Documented: text/plain is read as OBJ.
    let r = s.post("/v1/meshes/plain", "text/plain", &cow);
    assert_eq!(r.status, 201, "{}", String::from_utf8_lossy(&r.body));
    assert!(data.join("meshes/plain.obj").exists());

    // A replacement is served at once: an answer cached for the old mesh under the same
    // ask never comes back, and its ETag no longer matches.
    let old = s.get("/v1/meshes/plain/original?format=obj", &[]);
    let old_faces = obj_counts(&old.body).1;
    let tri = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let r = s.post("/v1/meshes/plain", "model/obj", tri);
    assert_eq!((r.status, r.header("location")), (200, None));
    assert_eq!(r.json()["faces"], 1);
    let new = s.get("/v1/meshes/plain/original?format=obj", &[]);
    assert_eq!((old_faces > 1, obj_counts(&new.body).1), (true, 1));
    assert_ne!(new.header("etag"), old.header("etag"));
    // One triangle's octree stops above the default level 2: without `level` that is the
    // deepest level there is; asked for by name, a level past it is still refused.
    let octree = s.get("/v1/meshes/plain/octree", &[]);
    assert_eq!(
        octree.status,
        200,
        "{}",
        String::from_utf8_lossy(&octree.body)
    );
    assert!(octree.header("x-error").unwrap().parse::<f64>().unwrap() < 2.0);
    // X-Max-Level names that deepest level (a client sizes its level control by it): it is
    // served, one past it is refused.
    let deepest = octree.number("x-max-level");
    assert_eq!(deepest, octree.number("x-error"));
    let at = s.get(&format!("/v1/meshes/plain/octree?level={deepest}"), &[]);
    assert_eq!((at.status, at.number("x-error")), (200, deepest));
    s.get(
        &format!("/v1/meshes/plain/octree?level={}", deepest + 1.0),
        &[],
    )
    .error(400, "bad_mesh_query");
    s.get("/v1/meshes/plain/octree?level=2", &[])
        .error(400, "bad_mesh_query");
    s.post("/v1/meshes/cow2", "image/png", b"\x89PNG")
        .error(415, "unsupported_media_type");
    // The JSON `?format=json` answers goes back in, labelled or sniffed, and stays.
    let json = s.get("/v1/meshes/plain/original?format=json", &[]).body;
    for (name, media) in [
        ("j1", "application/json"),
        ("j2", "application/octet-stream"),
    ] {
        let r = s.post(&format!("/v1/meshes/{name}"), media, &json);
        assert_eq!(
            r.status,
            201,
            "{media}: {}",
            String::from_utf8_lossy(&r.body)
        );
        assert!(data.join(format!("meshes/{name}.json")).exists(), "{media}");
    }
    s.post("/v1/meshes/cow3?format=ply", "model/obj", &cow)
        .error(400, "bad_query");
    assert!(!data.join("meshes/cow3.obj").exists());
    let restarted = Server::start(&data);
    for name in ["j1", "j2"] {
        let r = restarted.get(&format!("/v1/meshes/{name}"), &[]);
        assert_eq!(r.status, 200, "{name} after a restart");
        assert_eq!(r.json()["faces"], 1, "{name}");
    }
    s.post("/v1/meshes/..%2Fescape", "model/obj", &cow)
        .error(400, "bad_name");
    s.post("/v1/meshes/empty", "model/obj", b"")
        .error(400, "empty_body");
    let huge = vec![b' '; (64 << 20) + 1];
    s.post("/v1/meshes/huge", "model/obj", &huge)
        .error(413, "too_large");
    assert!(!data.join("meshes/huge.obj").exists());
    let _ = std::fs::remove_dir_all(&data);
}
