//! The viewer page, its assets and `/openapi.json`, in-process; and the check that the
//! OpenAPI document describes exactly the paths `app()` registers.

use std::collections::BTreeSet;

use axum::body::{to_bytes, Body};
use axum::http::{header, Request, StatusCode};
use tower::ServiceExt;

use super::{app, AppState, Catalog, Config};

async fn get(uri: &str) -> (StatusCode, String, Vec<u8>) {
    let res = app(AppState::new(Catalog::default(), Config::default()).unwrap())
        .oneshot(Request::get(uri).body(Body::empty()).unwrap())
        .await
        .unwrap();
    let status = res.status();
    let media = res
        .headers()
        .get(header::CONTENT_TYPE)
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    let body = to_bytes(res.into_body(), 8 << 20).await.unwrap().to_vec();
    (status, media, body)
}

/// The paths registered in `app()`: every `.route("…"` literal of mod.rs, with axum's
/// catch-all `{*file}` written as OpenAPI's `{file}`. Reading the source keeps one list (the
/// router) instead of a second one that could drift from it.
fn registered_paths() -> BTreeSet<String> {
    let src = include_str!("mod.rs");
    let mut out = BTreeSet::new();
    for piece in src.split(".route(").skip(1) {
        let lit = piece
            .trim_start()
            .strip_prefix('"')
            .and_then(|s| s.split('"').next())
            .expect("every .route( in app() takes a string literal path");
        out.insert(lit.replace("{*", "{"));
    }
    out
}

#[test]
fn openapi_describes_every_registered_route_and_no_other() {
    let registered = registered_paths();
    // Guards the scan itself: single-line and multi-line `.route(` calls are both found.
    for known in [
        "/",
        "/healthz",
        "/v1/datasets/{name}/layer.json",
        "/v1/meshes/{name}",
    ] {
        assert!(
            registered.contains(known),
            "scan missed {known}: {registered:?}"
        );
    }
    let doc: serde_json::Value = serde_json::from_str(super::routes::site::OPENAPI_JSON).unwrap();
    assert!(doc["openapi"].as_str().unwrap().starts_with("3."));
    let documented: BTreeSet<String> = doc["paths"].as_object().unwrap().keys().cloned().collect();
    let missing: Vec<_> = registered.difference(&documented).collect();
    assert!(
        missing.is_empty(),
        "routes missing from assets/openapi.json: {missing:?}"
    );
    let stale: Vec<_> = documented.difference(&registered).collect();
    assert!(
        stale.is_empty(),
        "assets/openapi.json describes routes app() does not register: {stale:?}"
    );
}

/// Every parameter an LOD method takes is described, so a client generated from the spec
/// can send it (fov and aspect of the octree camera were missing once).
#[test]
fn openapi_lists_every_parameter_the_mesh_lods_take() {
    let doc: serde_json::Value = serde_json::from_str(super::routes::site::OPENAPI_JSON).unwrap();
    let described: BTreeSet<&str> = doc["paths"]["/v1/meshes/{name}/{method}"]["get"]["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["in"] == "query")
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert!(described.contains("format"));
    for (method, takes) in super::routes::meshes::TAKES {
        for p in takes {
            assert!(
                described.contains(p),
                "{method} takes {p}, which openapi.json does not list"
            );
        }
    }
}

/// The tile route's bounds and media types in the spec are the ones the server holds to, so
/// a client validating against the spec refuses what the server would, and no more.
#[test]
fn openapi_gives_the_tile_route_the_servers_bounds_and_media_types() {
    use super::routes::tiles::{TileFormat, PNG_DEFAULT_SIZE, PNG_MAX_SIZE, PNG_MIN_SIZE};
    use super::threshold::{MAX_RATIO, MAX_THRESHOLD};
    let doc: serde_json::Value = serde_json::from_str(super::routes::site::OPENAPI_JSON).unwrap();
    let get = &doc["paths"]["/v1/datasets/{name}/tiles/{z}/{x}/{y}"]["get"];
    let schema = |name: &str| {
        get["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("{name} is not described"))["schema"]
            .clone()
    };
    let num = |v: &serde_json::Value| v.as_f64().unwrap();
    assert_eq!(num(&schema("threshold")["maximum"]), MAX_THRESHOLD);
    assert_eq!(num(&schema("ratio")["maximum"]), MAX_RATIO);
    let z_max = zerotile_codec::geo::MAX_ZOOM;
    assert_eq!(num(&schema("z")["maximum"]), f64::from(z_max));
    let size = schema("size");
    assert_eq!(
        [&size["minimum"], &size["maximum"], &size["default"]].map(num),
        [PNG_MIN_SIZE, PNG_MAX_SIZE, PNG_DEFAULT_SIZE].map(f64::from)
    );
    let content = get["responses"]["200"]["content"].as_object().unwrap();
    for f in TileFormat::ALL {
        assert!(
            content.contains_key(f.media_type()),
            "{f:?}: {} is not among the 200's media types",
            f.media_type()
        );
    }
    assert_eq!(content.len(), TileFormat::ALL.len(), "{content:?}");
}

#[tokio::test]
async fn the_viewer_page_and_its_assets_are_served() {
    let (status, media, body) = get("/").await;
    assert_eq!(status, StatusCode::OK);
    assert!(media.starts_with("text/html"), "{media}");
    let html = String::from_utf8(body).unwrap();
    // Every asset the page names must be served, or the page loads half-broken.
    for asset in [
        "/assets/viewer.js",
        "/assets/viewer.css",
        "/assets/vendor/three.module.min.js",
    ] {
        assert!(html.contains(asset), "index.html names {asset}");
        let (status, media, body) = get(asset).await;
        assert_eq!(status, StatusCode::OK, "{asset}");
        assert!(media.starts_with("text/"), "{asset}: {media}");
        assert!(body.len() > 500, "{asset} is {} bytes", body.len());
    }
    let (status, media, _) = get("/assets/vendor/OrbitControls.js").await;
    assert_eq!(
        (status, media.starts_with("text/javascript")),
        (StatusCode::OK, true)
    );
}

/// Assets keep their URLs across upgrades while the page changes, so they are revalidated
/// as the page is: `no-cache` with an ETag of their bytes, 304 while it still matches.
#[tokio::test]
async fn assets_are_revalidated_by_their_etag() {
    let send = |h: Option<String>| async move {
        let mut req = Request::get("/assets/viewer.js");
        if let Some(tag) = h {
            req = req.header(header::IF_NONE_MATCH, tag);
        }
        app(AppState::new(Catalog::default(), Config::default()).unwrap())
            .oneshot(req.body(Body::empty()).unwrap())
            .await
            .unwrap()
    };
    let res = send(None).await;
    assert_eq!(res.status(), StatusCode::OK);
    assert_eq!(res.headers()[header::CACHE_CONTROL], "no-cache");
    let etag = res.headers()[header::ETAG].to_str().unwrap().to_string();
    let again = send(Some(etag.clone())).await;
    assert_eq!(again.status(), StatusCode::NOT_MODIFIED);
    assert_eq!(again.headers()[header::ETAG], etag.as_str());
    let other = send(Some("\"0000000000000000\"".into())).await;
    assert_eq!(other.status(), StatusCode::OK);
}

#[tokio::test]
async fn unknown_assets_are_json_404s() {
    for uri in [
        "/assets/nope.js",
        "/assets/../Cargo.toml",
        "/assets/vendor/%2e%2e/viewer.js",
    ] {
        let (status, media, body) = get(uri).await;
        assert_eq!(status, StatusCode::NOT_FOUND, "{uri}");
        assert!(media.starts_with("application/json"), "{uri}: {media}");
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert_eq!(v["error"], "not_found", "{uri}");
    }
}

#[tokio::test]
async fn openapi_json_is_served() {
    let (status, media, body) = get("/openapi.json").await;
    assert_eq!(status, StatusCode::OK);
    assert!(media.starts_with("application/json"), "{media}");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert!(v["paths"]["/v1/meshes/{name}/{method}"]["get"].is_object());
}

/// The `"x-…"` string literals of a source file: the custom headers its routes set.
fn custom_headers(src: &str) -> BTreeSet<String> {
    src.split("\"x-")
        .skip(1)
        .filter_map(|rest| {
            let name = rest.split('"').next()?;
            let ok = !name.is_empty() && name.bytes().all(|b| b.is_ascii_lowercase() || b == b'-');
            ok.then(|| format!("x-{name}"))
        })
        .collect()
}

/// A browser client reads a response header only when CORS exposes it, so every custom
/// header a route sets is exposed, and docs/api.md names exactly the exposed set (X-Max-Level
/// was once set by the mesh routes without being listed).
#[tokio::test]
async fn cors_exposes_every_header_the_routes_set_and_the_api_documents_them() {
    let res = app(AppState::new(Catalog::default(), Config::default()).unwrap())
        .oneshot(
            Request::get("/healthz")
                .header(header::ORIGIN, "https://a.example")
                .body(Body::empty())
                .unwrap(),
        )
        .await
        .unwrap();
    let exposed: BTreeSet<String> = res
        .headers()
        .get(header::ACCESS_CONTROL_EXPOSE_HEADERS)
        .expect("CORS exposes headers")
        .to_str()
        .unwrap()
        .split(',')
        .map(|s| s.trim().to_ascii_lowercase())
        .collect();

    let set: BTreeSet<String> = [
        include_str!("routes/tiles.rs"),
        include_str!("routes/view.rs"),
        include_str!("routes/meshes.rs"),
    ]
    .into_iter()
    .flat_map(custom_headers)
    .collect();
    assert!(set.len() >= 9, "scan found too few headers: {set:?}");
    let hidden: Vec<_> = set.difference(&exposed).collect();
    assert!(hidden.is_empty(), "set by a route, not exposed: {hidden:?}");

    // The API reference's CORS paragraph: every backticked header name in it.
    let api = include_str!("../../../docs/api.md");
    let para = api
        .split("CORS allows")
        .nth(1)
        .and_then(|s| s.split("Compression:").next())
        .expect("docs/api.md has the CORS paragraph");
    let documented: BTreeSet<String> = para
        .split('`')
        .skip(1)
        .step_by(2)
        // Header names: letters and hyphens, capitalised, not a method's capitals (`GET`).
        .filter(|w| {
            w.bytes().all(|b| b.is_ascii_alphabetic() || b == b'-')
                && w.starts_with(|c: char| c.is_ascii_uppercase())
                && !w.bytes().all(|b| b.is_ascii_uppercase())
        })
        .map(str::to_ascii_lowercase)
        .collect();
    assert_eq!(
        documented, exposed,
        "docs/api.md's CORS paragraph against the server"
    );
}
