//! Every route that answers glTF binary (GLB), checked by the Khronos glTF-Validator
//! (`tests/e2e/gltf_validate.mjs`, npm `gltf-validator` pinned in `web/package.json`):
//! terrain tiles of the three schemes at several zooms and thresholds (also chosen by `ratio`
//! and by a camera), the view route, and every object-mesh LOD method on meshes of
//! `../shared/data/meshes` and of the default data. A validator error or warning fails the test; infos and hints are printed.
//!
//! Needs `node` and `npm ci --prefix web --ignore-scripts`. Without them the test prints why
//! and passes; with `ZEROTILE_E2E=1` (set by `.ci/run`) their absence fails it. The GLB files
//! stay in `target/e2e/gltf/` for a look with other tools.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "end-to-end test: a broken step should fail loudly"
)]

use std::process::Command;

use serde_json::Value;
use zerotile_tests::server::Server;
use zerotile_tests::{
    client_data, e2e_out, node_missing, repo_root, run_in, shared_data, tools_ready,
};

/// `(zoom, x, y)` of the first tile the dataset holds at each zoom (its `available` ranges).
fn first_tiles(info: &Value) -> Vec<(usize, u64, u64)> {
    let available = info["available"].as_array().unwrap();
    available
        .iter()
        .enumerate()
        .map(|(z, ranges)| {
            let r = &ranges[0];
            (
                z,
                r["startX"].as_u64().unwrap(),
                r["startY"].as_u64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn every_glb_route_passes_the_khronos_gltf_validator() {
    if !tools_ready("the glTF validation test", &node_missing("gltf-validator")) {
        return;
    }

    // The default data (geodetic demo-ridges; torus, uv-sphere, vase), two classic meshes
    // beside them, and SRTM ingested as the README does (local: column / minus-row
    // coordinates) and on the mercator grid (EPSG:3857 metres, the largest numbers in f32).
    let data = client_data("gltf");
    for m in ["fandisk.obj", "spot.obj"] {
        std::fs::copy(
            shared_data().join("meshes").join(m),
            data.join("meshes").join(m),
        )
        .unwrap();
    }
    let hgt = shared_data().join("dem/N44W072.hgt");
    run_in(
        &["ingest", hgt.to_str().unwrap(), "--name", "n44", "--quiet"],
        &data,
    );

    let server = Server::start(&data);
    let mut urls: Vec<(String, String)> = Vec::new();
    let mut add = |name: String, url: String| urls.push((name, url));

    // Terrain tiles: every zoom of the geodetic demo at its default T, and at T = 0 (all the
    // stream holds), a mid T, a ratio and a camera on a few of them; the local dataset too.
    let geo = server.get("/v1/datasets/demo-ridges", &[]).json();
    for (z, x, y) in first_tiles(&geo) {
        let tile = format!("/v1/datasets/demo-ridges/tiles/{z}/{x}/{y}.glb");
        add(format!("tile-geo-{z}-{x}-{y}"), tile.clone());
        if z % 4 == 0 {
            add(
                format!("tile-geo-{z}-{x}-{y}-t0"),
                format!("{tile}?threshold=0"),
            );
            add(
                format!("tile-geo-{z}-{x}-{y}-t20"),
                format!("{tile}?threshold=20"),
            );
            add(
                format!("tile-geo-{z}-{x}-{y}-r"),
                format!("{tile}?ratio=0.25"),
            );
            add(
                format!("tile-geo-{z}-{x}-{y}-eye"),
                format!("{tile}?eye=7.1,46.1,5000&target=7.12,46.12,1000&fov=60"),
            );
        }
    }
    let local = server.get("/v1/datasets/n44", &[]).json();
    for (z, x, y) in first_tiles(&local) {
        let tile = format!("/v1/datasets/n44/tiles/{z}/{x}/{y}.glb");
        add(format!("tile-local-{z}-{x}-{y}"), tile.clone());
        add(
            format!("tile-local-{z}-{x}-{y}-t0"),
            format!("{tile}?threshold=0"),
        );
    }
    let mercator = server.get("/v1/datasets/n44m", &[]).json();
    for (z, x, y) in first_tiles(&mercator) {
        if z % 3 == 1 {
            let tile = format!("/v1/datasets/n44m/tiles/{z}/{x}/{y}.glb");
            add(format!("tile-mercator-{z}-{x}-{y}"), tile.clone());
            add(
                format!("tile-mercator-{z}-{x}-{y}-t0"),
                format!("{tile}?threshold=0"),
            );
        }
    }
    add(
        "tile-local-readme".into(),
        "/v1/datasets/n44/tiles/3/2/1.glb?eye=600,600,3000&target=640,520,300&fov=60".into(),
    );

    // View meshes: an oblique and a wide, high camera on each dataset.
    for (name, query) in [
        (
            "view-geo",
            "demo-ridges/view?eye=7.1,46.05,6000&target=7.12,46.12,1000&fov=60",
        ),
        (
            "view-geo-wide",
            "demo-ridges/view?eye=7.125,46.125,50000&target=7.125,46.1251,0&fov=120&aspect=2",
        ),
        (
            "view-local",
            "n44/view?eye=600,900,2000&target=600,600,300&fov=60",
        ),
        (
            "view-local-wide",
            "n44/view?eye=600,600,20000&target=600,600,300&fov=90&aspect=2",
        ),
        (
            "view-mercator",
            "n44m/view?eye=-71.5,44.3,3000&target=-71.5,44.5,300&fov=60",
        ),
    ] {
        add(name.into(), format!("/v1/datasets/{query}&format=glb"));
    }

    // Object meshes: every LOD method, at its coarsest and at finer settings. Octree level 0
    // has no face for most meshes (one cell holds the whole object): an empty scene.
    // `GET /v1/meshes/{name}` is the JSON summary in every case; it has no GLB form.
    for mesh in ["fandisk", "spot", "torus"] {
        for (name, query) in [
            ("original", "original?"),
            ("curvature-1", "curvature?level=1&"),
            ("curvature-3", "curvature?level=3&"),
            ("curvature-e", "curvature?error=0.5&"),
            ("octree-0", "octree?level=0&"),
            ("octree-3", "octree?level=3&"),
            (
                "octree-roi",
                "octree?level=1&roi=-0.5,-0.5,0.5,0.5&eye=3,3,3&target=0,0,0&",
            ),
            ("silhouette-0", "silhouette?level=0&"),
            ("silhouette-5", "silhouette?level=5&"),
            ("silhouette-eye", "silhouette?eye=3,2,1&target=0,0,0&"),
            ("qem-faces", "qem?faces=4&"),
            ("qem-ratio", "qem?ratio=0.1&"),
            ("qem-error", "qem?error=0.05&"),
        ] {
            add(
                format!("mesh-{mesh}-{name}"),
                format!("/v1/meshes/{mesh}/{query}format=glb"),
            );
        }
    }

    let out = e2e_out("gltf");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let mut files = Vec::new();
    let mut empty = 0;
    for (name, url) in &urls {
        let r = server.get(url, &[]);
        assert_eq!(r.status, 200, "{url}: {}", String::from_utf8_lossy(&r.body));
        assert_eq!(r.header("content-type"), Some("model/gltf-binary"), "{url}");
        if r.header("x-faces") == Some("0") {
            empty += 1;
        }
        let path = out.join(format!("{name}.glb"));
        std::fs::write(&path, &r.body).unwrap();
        files.push(path);
    }
    drop(server);
    let _ = std::fs::remove_dir_all(&data);
    assert!(
        empty > 0,
        "no LOD without faces: the empty-scene GLB went untested"
    );

    let report = Command::new("node")
        .arg(repo_root().join("tests/e2e/gltf_validate.mjs"))
        .arg("--strict")
        .args(&files)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&report.stdout);
    let mut failures = Vec::new();
    let mut checked = 0;
    for line in stdout.lines() {
        let v: Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
        checked += 1;
        let count = |k: &str| v[k].as_u64().unwrap_or(0);
        if v.get("fatal").is_some() || count("numErrors") + count("numWarnings") > 0 {
            failures.push(line.to_string());
        } else if count("numInfos") + count("numHints") > 0 {
            eprintln!("validator notes: {line}");
        }
    }
    eprintln!(
        "{checked} GLB files validated ({empty} empty scenes) in {}",
        out.display()
    );
    assert!(
        failures.is_empty() && report.status.success(),
        "glTF-Validator reported errors or warnings (status {}):\n{}\n{}",
        report.status,
        failures.join("\n"),
        String::from_utf8_lossy(&report.stderr)
    );
    assert_eq!(checked, files.len(), "one report line per file");
}
