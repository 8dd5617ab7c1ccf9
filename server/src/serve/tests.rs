//! The router in-process (`oneshot`), on a one-tile dataset written to a scratch folder:
//! status codes, headers and the error shape, without a socket.

use std::sync::atomic::Ordering::Relaxed;

use axum::body::{to_bytes, Body};
use axum::http::{header, Method, Request, StatusCode};
use axum::Router;
use tower::ServiceExt;
use zerotile_codec::container::{Availability, Metadata, TileId, ViewParams, Writer};
use zerotile_codec::ezw::{self, EncodeParams};
use zerotile_codec::wavelet::Wavelet;
use zerotile_codec::Grid;

use super::{app, AppState, Catalog, Config};
use crate::serve::dataset::Dataset;
use crate::serve::{pipeline, render, threshold};

/// The root tile of a zoom-0 pyramid.
pub(super) const ROOT: TileId = TileId { z: 0, x: 0, y: 0 };

pub(super) fn id(z: u8, x: u32, y: u32) -> TileId {
    TileId { z, x, y }
}

/// The ranges one stored level holds: tiles x0..=x1, y0..=y1 in the scheme's own rows.
fn stored(x0: u32, y0: u32, x1: u32, y1: u32) -> Vec<Availability> {
    vec![Availability {
        start_x: x0,
        start_y: y0,
        end_x: x1,
        end_y: y1,
    }]
}

/// A smooth 257² hill, as every tile of a dataset of `scheme` holding `tiles`.
pub(super) fn hill_dataset(tag: &str, scheme: &str, tiles: &[TileId]) -> Dataset {
    hill_dataset_in(tag, scheme, tiles, default_bounds(scheme))
}

/// The bounds [`hill_dataset`] gives a scheme: the grid's own, or the world's.
fn default_bounds(scheme: &str) -> [f64; 4] {
    if scheme == "local" {
        [0.0, 256.0, 256.0, 0.0]
    } else {
        [-180.0, -85.0, 180.0, 85.0]
    }
}

/// [`hill_dataset`] with its metadata bounds set to `bounds` (west, south, east, north).
fn hill_dataset_in(tag: &str, scheme: &str, tiles: &[TileId], bounds: [f64; 4]) -> Dataset {
    Dataset::open(&hill_file_in(tag, scheme, tiles, bounds)).unwrap()
}

/// [`hill_dataset`]'s container file, `TMP/…/TAG.ztd`, not opened.
pub(super) fn hill_file(tag: &str, scheme: &str, tiles: &[TileId]) -> std::path::PathBuf {
    hill_file_in(tag, scheme, tiles, default_bounds(scheme))
}

/// [`hill_file`] with its metadata bounds set to `bounds`.
fn hill_file_in(tag: &str, scheme: &str, tiles: &[TileId], bounds: [f64; 4]) -> std::path::PathBuf {
    hill_file_with(tag, scheme, tiles, |m| m.bounds = bounds)
}

/// [`hill_file`] with its metadata changed by `edit` before it is written.
pub(super) fn hill_file_with(
    tag: &str,
    scheme: &str,
    tiles: &[TileId],
    edit: impl FnOnce(&mut Metadata),
) -> std::path::PathBuf {
    let dir = crate::fixtures::scratch(&format!("router-{tag}"));
    let g = Grid::new(
        257,
        257,
        (0..257 * 257)
            .map(|k| {
                let (r, c) = ((k / 257) as f64, (k % 257) as f64);
                100.0 + 40.0 * (r / 30.0).sin() * (c / 45.0).cos()
            })
            .collect(),
    )
    .unwrap();
    let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 0.01)).unwrap();
    let mut w = Writer::new();
    let corners = [
        *g.get(0, 0),
        *g.get(0, 256),
        *g.get(256, 0),
        *g.get(256, 256),
    ];
    for &id in tiles {
        w.add(id, corners, &enc.bytes);
    }
    let max_zoom = tiles.iter().map(|t| t.z).max().unwrap_or(0);
    let mut m = Metadata {
        name: tag.into(),
        scheme: scheme.into(),
        tile_side: 257,
        min_zoom: 0,
        max_zoom,
        bounds: default_bounds(scheme),
        source_size: [257, 257],
        wavelet: Wavelet::Cdf97,
        step: 0.01,
        precision: None,
        height_range: [60.0, 140.0],
        source_height_range: None,
        vertical_datum: None,
        fill: 60.0,
        view: ViewParams { a: 2.5, b: 0.0 },
        // Set below unless `edit` sets it.
        available: Vec::new(),
        source: "synthetic".into(),
        source_crs: "none".into(),
        samples: 257 * 257,
        stream_bytes: enc.bytes.len() as u64,
        created: "2026-01-01T00:00:00Z".into(),
    };
    edit(&mut m);
    // Every zoom from min_zoom lists tiles (a header is refused otherwise): the box of the
    // tiles stored there, or the first tile where a zoom holds none.
    if m.available.is_empty() {
        m.available = (m.min_zoom..=m.max_zoom)
            .map(|z| {
                let at: Vec<&TileId> = tiles.iter().filter(|t| t.z == z).collect();
                let x = at.iter().map(|t| t.x);
                let y = at.iter().map(|t| t.y);
                match (x.clone().min(), x.max(), y.clone().min(), y.max()) {
                    (Some(x0), Some(x1), Some(y0), Some(y1)) => stored(x0, y0, x1, y1),
                    _ => stored(0, 0, 0, 0),
                }
            })
            .collect();
    }
    let path = dir.join(format!("{tag}.ztd"));
    std::fs::write(&path, w.finish(&m).unwrap()).unwrap();
    path
}

/// The router over a one-tile local dataset named `hill`.
fn router(tag: &str) -> Router {
    router_of(tag, "local")
}

/// The router over a one-tile (root) dataset of `scheme` named `hill`.
fn router_of(tag: &str, scheme: &str) -> Router {
    router_over(hill_dataset(tag, scheme, &[ROOT]))
}

/// The router over `d`, renamed `hill`.
pub(super) fn router_over(d: Dataset) -> Router {
    app(state_over(d, Config::default()))
}

/// A server state holding `d`, renamed `hill`, with `config`.
fn state_over(mut d: Dataset, config: Config) -> AppState {
    d.name = "hill".into();
    let mut catalog = Catalog::default();
    catalog.insert(d);
    AppState::new(catalog, config).unwrap()
}

pub(super) async fn send(
    app: &Router,
    method: Method,
    uri: &str,
    headers: &[(&str, &str)],
) -> (StatusCode, axum::http::HeaderMap, Vec<u8>) {
    let mut req = Request::builder().method(method).uri(uri);
    for (k, v) in headers {
        req = req.header(*k, *v);
    }
    let res = app
        .clone()
        .oneshot(req.body(Body::empty()).unwrap())
        .await
        .unwrap();
    let (parts, body) = res.into_parts();
    let bytes = to_bytes(body, 64 << 20).await.unwrap().to_vec();
    (parts.status, parts.headers, bytes)
}

/// A GET without extra headers, the common case.
pub(super) async fn get(app: &Router, uri: &str) -> (StatusCode, axum::http::HeaderMap, Vec<u8>) {
    send(app, Method::GET, uri, &[]).await
}

pub(super) fn error_code(body: &[u8]) -> String {
    let v: serde_json::Value = serde_json::from_slice(body).unwrap();
    assert!(v["message"].as_str().is_some_and(|m| !m.is_empty()));
    v["error"].as_str().unwrap().to_string()
}

/// GETs `uri`, checks it is refused with `status` and the JSON error `code`, and returns
/// the error body.
async fn refused(app: &Router, uri: &str, status: StatusCode, code: &str) -> serde_json::Value {
    let (s, _, body) = get(app, uri).await;
    assert_eq!(s, status, "{uri}");
    assert_eq!(error_code(&body), code, "{uri}");
    serde_json::from_slice(&body).unwrap()
}

#[tokio::test]
async fn tiles_carry_threshold_triangles_and_cache_headers() {
    let app = router("headers");
    let (s, h, body) = get(&app, "/v1/datasets/hill/tiles/0/0/0.bin?threshold=2").await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "application/vnd.zerotile.ztm1");
    assert_eq!(h["x-threshold"], "2");
    let n: usize = h["x-triangles"].to_str().unwrap().parse().unwrap();
    assert!(n >= 2);
    assert_eq!(&body[..4], b"ZTM1");
    assert!(h[header::CACHE_CONTROL]
        .to_str()
        .unwrap()
        .contains("max-age"));
    assert_eq!(h[header::ACCESS_CONTROL_ALLOW_ORIGIN], "*");

    // The same tile again: 304 for the tag, and HEAD without a body.
    let etag = h[header::ETAG].to_str().unwrap().to_string();
    let uri = "/v1/datasets/hill/tiles/0/0/0.bin?threshold=2";
    let (s, _, body) = send(&app, Method::GET, uri, &[("if-none-match", &etag)]).await;
    assert_eq!((s, body.len()), (StatusCode::NOT_MODIFIED, 0));
    let (s, h, body) = send(&app, Method::HEAD, uri, &[]).await;
    assert_eq!((s, body.len()), (StatusCode::OK, 0));
    assert_eq!(h[header::ETAG].to_str().unwrap(), etag);

    // The default threshold is the zoom's geometric error, capped at the relief.
    let (_, h, _) = get(&app, "/v1/datasets/hill/tiles/0/0/0.json").await;
    let t: f64 = h["x-threshold"].to_str().unwrap().parse().unwrap();
    assert!(t > 0.0 && t <= 80.0, "{t}");
}

#[tokio::test]
async fn default_threshold_is_the_geometric_error_capped_at_the_relief() {
    // Local 257² grid, one zoom: Cesium's 0.25 · 256 samples / 65, below the 80 m relief.
    let local = router("default-t");
    let (_, h, _) = get(&local, "/v1/datasets/hill/tiles/0/0/0.json").await;
    let t: f64 = h["x-threshold"].to_str().unwrap().parse().unwrap();
    assert!((t - 0.25 * 256.0 / 65.0).abs() < 1e-12, "{t}");
    // A geodetic root: ~77 km of geometric error, capped at the relief (140 - 60 m).
    let geodetic = router_of("default-geo", "geodetic");
    let (s, h, _) = get(&geodetic, "/v1/datasets/hill/tiles/0/0/0.json").await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h["x-threshold"], "80");
}

/// A CORS preflight (an upload's, with its Content-Type) is answered for any origin with the
/// methods and a max age, so a browser does not ask again before every request.
#[tokio::test]
async fn cors_preflights_are_answered_and_may_be_cached() {
    let app = router("preflight");
    let (s, h, _) = send(
        &app,
        Method::OPTIONS,
        "/v1/meshes/upload",
        &[
            ("origin", "https://example.org"),
            ("access-control-request-method", "POST"),
            ("access-control-request-headers", "content-type"),
        ],
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h["access-control-allow-origin"], "*");
    let methods = h["access-control-allow-methods"].to_str().unwrap();
    assert!(
        methods.contains("POST") && methods.contains("GET"),
        "{methods}"
    );
    assert_eq!(
        h["access-control-max-age"],
        super::CORS_MAX_AGE.as_secs().to_string()
    );
}

/// A preflight lists POST only where the route takes one: an address of every route, asked
/// both ways, so `preflight::takes_uploads` cannot drift from the route table.
#[tokio::test]
async fn preflights_name_each_routes_methods() {
    let app = router("preflight-routes");
    for path in [
        "/",
        "/assets/viewer.js",
        "/openapi.json",
        "/healthz",
        "/metrics",
        "/v1/datasets",
        "/v1/datasets/hill",
        "/v1/datasets/hill/layer.json",
        "/v1/datasets/hill/tiles.json",
        "/v1/datasets/hill/view",
        "/v1/datasets/hill/tiles/0/0/0.png",
        "/v1/meshes",
        "/v1/meshes/bunny",
        "/v1/meshes/bunny/qem",
    ] {
        let uploads = super::preflight::takes_uploads(path);
        let (s, h, _) = send(
            &app,
            Method::OPTIONS,
            path,
            &[
                ("origin", "https://example.org"),
                ("access-control-request-method", "POST"),
            ],
        )
        .await;
        assert_eq!(s, StatusCode::OK, "{path}");
        let methods = h["access-control-allow-methods"].to_str().unwrap();
        assert_eq!(methods.contains("POST"), uploads, "{path}: {methods}");
        assert!(methods.contains("GET"), "{path}: {methods}");
        // The route itself: a POST is refused by method exactly where the preflight says so.
        let (s, _, _) = send(&app, Method::POST, path, &[]).await;
        assert_eq!(
            s == StatusCode::METHOD_NOT_ALLOWED,
            !uploads,
            "{path}: POST got {s}"
        );
    }
}

/// `zerotile_response_bytes_total` counts body bytes as they go out: a tile whole, gzipped
/// (compressed when rendered), br (compressed on the fly), none for a HEAD. Counted from the
/// handler's body it was the plain size for br and the full size for a HEAD.
#[tokio::test]
async fn response_bytes_count_what_is_sent() {
    let state = state_over(
        hill_dataset("bytes-sent", "local", &[ROOT]),
        Config::default(),
    );
    let app = app(state.clone());
    let sent = || state.metrics.bytes_out.load(Relaxed);
    let tile = "/v1/datasets/hill/tiles/0/0/0.json?threshold=1";
    for (method, coding) in [
        (Method::GET, "identity"),
        (Method::GET, "gzip"),
        (Method::GET, "br"),
        (Method::HEAD, "gzip"),
        (Method::HEAD, "identity"),
    ] {
        let before = sent();
        let (s, h, body) = send(&app, method.clone(), tile, &[("accept-encoding", coding)]).await;
        assert_eq!(s, StatusCode::OK, "{method} {coding}");
        assert_eq!(sent() - before, body.len() as u64, "{method} {coding}");
        let encoding = h.get("content-encoding").map(|v| v.to_str().unwrap());
        if method == Method::HEAD {
            assert!(body.is_empty());
        } else {
            assert_eq!(encoding.unwrap_or("identity"), coding);
            assert!(body.len() > 100, "{coding}: {} bytes", body.len());
        }
    }
}

/// The CORS layer answers any OPTIONS itself: a plain one (no preflight headers) was told
/// POST on a tile route whose Allow said GET, HEAD, one to a path with no route got a 200,
/// and neither was counted in /metrics.
#[tokio::test]
async fn plain_options_name_the_routes_methods_and_unrouted_ones_are_404() {
    let app = router("options-plain");
    let tile = "/v1/datasets/hill/tiles/0/0/0.png";
    let (s, h, _) = send(&app, Method::OPTIONS, tile, &[]).await;
    assert_eq!(s, StatusCode::OK);
    let methods = h["access-control-allow-methods"].to_str().unwrap();
    assert!(
        !methods.contains("POST") && methods.contains("GET"),
        "{methods}"
    );
    let (s, h, _) = send(&app, Method::OPTIONS, "/v1/meshes/bunny", &[]).await;
    assert_eq!(s, StatusCode::OK);
    assert!(h["access-control-allow-methods"]
        .to_str()
        .unwrap()
        .contains("POST"));
    let preflight = [
        ("origin", "https://example.org"),
        ("access-control-request-method", "GET"),
    ];
    for headers in [&[][..], &preflight[..]] {
        for uri in ["/nope", "/v1/datasets/hill/tiles/0/0", "/v1/datasets/"] {
            let (s, h, body) = send(&app, Method::OPTIONS, uri, headers).await;
            assert_eq!(s, StatusCode::NOT_FOUND, "{uri} {headers:?}");
            assert_eq!(error_code(&body), "not_found", "{uri}");
            assert!(!h.contains_key("access-control-allow-methods"), "{uri}");
        }
    }
    for _ in 0..3 {
        let (s, _, _) = send(&app, Method::OPTIONS, "/healthz", &preflight).await;
        assert_eq!(s, StatusCode::OK);
    }
    let (_, _, body) = get(&app, "/metrics").await;
    let text = String::from_utf8(body).unwrap();
    assert!(
        text.contains("zerotile_requests_total{route=\"/healthz\",status=\"200\"} 3"),
        "{text}"
    );
    assert!(
        text.contains("zerotile_requests_total{route=\"unmatched\",status=\"404\"} 6"),
        "{text}"
    );
}

/// A trailing slash is a 404 whose message gives the path without it, which works.
#[tokio::test]
async fn a_trailing_slash_is_named_in_the_404() {
    let app = router("trailing-slash");
    for (slashed, bare) in [
        ("/v1/datasets/", "/v1/datasets"),
        ("/v1/datasets/hill/", "/v1/datasets/hill"),
    ] {
        let v = refused(&app, slashed, StatusCode::NOT_FOUND, "not_found").await;
        let message = v["message"].as_str().unwrap();
        assert!(message.contains(&format!("try {bare};")), "{message}");
        assert_eq!(get(&app, bare).await.0, StatusCode::OK, "{bare}");
    }
    // Without its slash it is still no route: no hint to a second 404.
    for uri in ["/nope", "/v1/", "/nope/", "/v1/datasets/hill/tiles/"] {
        let v = refused(&app, uri, StatusCode::NOT_FOUND, "not_found").await;
        assert!(
            !v["message"].as_str().unwrap().contains("try"),
            "{uri}: {v}"
        );
    }
    let v = refused(
        &app,
        "/v1/meshes/a/qem/",
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    assert!(
        v["message"]
            .as_str()
            .unwrap()
            .contains("try /v1/meshes/a/qem;"),
        "{v}"
    );
}

#[tokio::test]
async fn errors_are_json_with_their_codes() {
    let app = router("errors");
    for (method, uri, status, code) in [
        (Method::GET, "/nope", StatusCode::NOT_FOUND, "not_found"),
        (
            Method::POST,
            "/healthz",
            StatusCode::METHOD_NOT_ALLOWED,
            "method_not_allowed",
        ),
        (
            Method::GET,
            "/v1/datasets/hill/tiles/0/0/0.png?threshold=nan",
            StatusCode::BAD_REQUEST,
            "out_of_range",
        ),
        (
            Method::GET,
            "/v1/datasets/hill/tiles/0/0/0.png?ratio=1e9",
            StatusCode::BAD_REQUEST,
            "out_of_range",
        ),
        (
            Method::GET,
            "/v1/datasets/hill/tiles/0/1/0.png",
            StatusCode::NOT_FOUND,
            "tile_not_found",
        ),
        (
            Method::GET,
            "/v1/datasets/hill/tiles/300/0/0.png",
            StatusCode::BAD_REQUEST,
            "bad_tile_address",
        ),
        (
            Method::GET,
            "/v1/datasets/hill/tiles/0/0/0.terrain",
            StatusCode::NOT_FOUND,
            "not_georeferenced",
        ),
        (
            Method::GET,
            "/v1/datasets/hill/view?eye=0,0,1&target=0,0,1&fov=60",
            StatusCode::BAD_REQUEST,
            "bad_view",
        ),
    ] {
        let (s, h, body) = send(&app, method, uri, &[]).await;
        assert_eq!(s, status, "{uri}");
        assert_eq!(h[header::CONTENT_TYPE], "application/json", "{uri}");
        assert_eq!(error_code(&body), code, "{uri}");
    }
}

/// On a world dataset `eye` and `target` are longitude, latitude and height: past ±180° or
/// ±90° is a 400 naming the coordinate, for a view and for a tile's threshold alike; a view
/// of the pole is answered with a footprint that stops at the pole and at one turn of
/// longitude round the target.
#[tokio::test]
async fn a_world_datasets_cameras_stay_on_the_globe() {
    let app = router_of("globe", "geodetic");
    for (uri, what) in [
        (
            "/v1/datasets/hill/view?eye=500,44,1000&target=-90,44,0&fov=60",
            "eye's longitude",
        ),
        (
            "/v1/datasets/hill/view?eye=-90,95,1000&target=-90,44,0&fov=60",
            "eye's latitude",
        ),
        (
            "/v1/datasets/hill/tiles/0/0/0.json?eye=-90,44,1000&target=-181,44,0&fov=60",
            "target's longitude",
        ),
        // Not a number: the range quoted is the globe's, not the ±1e8 of a local dataset.
        (
            "/v1/datasets/hill/view?eye=nan,44,1000&target=-90,44,0&fov=60",
            "eye's longitude (degrees, on a world dataset) must be in [-180, 180], got nan",
        ),
        (
            "/v1/datasets/hill/view?eye=-90,44,1000&target=-90,inf,0&fov=60",
            "target's latitude (degrees, on a world dataset) must be in [-90, 90], got inf",
        ),
    ] {
        let v = refused(&app, uri, StatusCode::BAD_REQUEST, "out_of_range").await;
        assert!(v["message"].as_str().unwrap().contains(what), "{uri}: {v}");
    }
    let (s, _, body) = get(
        &app,
        "/v1/datasets/hill/view?eye=-90,80,2000000&target=-90,90,0&fov=90",
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let footprint = v["footprint"].as_array().unwrap();
    assert!(footprint.len() >= 3, "{v}");
    for p in footprint {
        let (lon, lat) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
        // One turn round the target's −90°: longitudes run on round it, past ±180°.
        assert!((lon + 90.0).abs() <= 180.0 && lat.abs() <= 90.0, "{p}");
    }
}

/// Tile addresses are plain decimal (`03` or `+3` would be a second URL, and cache entry,
/// for tile 3), and a zoom outside the dataset's is named as such rather than as a missing
/// tile.
#[tokio::test]
async fn tile_addresses_are_canonical_and_zooms_checked_against_the_dataset() {
    let app = router("addresses");
    for uri in [
        "/v1/datasets/hill/tiles/00/0/0.png",
        "/v1/datasets/hill/tiles/0/01/0.png",
        "/v1/datasets/hill/tiles/0/0/+0.png",
        "/v1/datasets/hill/tiles/0/-0/0.png",
        "/v1/datasets/hill/tiles/%30/0/0.png",
        "/v1/datasets/hill/tiles/0/0/0%2Epng",
    ] {
        refused(&app, uri, StatusCode::BAD_REQUEST, "bad_tile_address").await;
    }
    let uri = "/v1/datasets/hill/tiles/1/0/0.png";
    let v = refused(&app, uri, StatusCode::NOT_FOUND, "tile_not_found").await;
    assert_eq!(v["message"], "zoom 1 is outside 0..=0 of hill");
    // The name too: `%68ill` is hill under a second URL (it was served as hill).
    for uri in [
        "/v1/datasets/%68ill",
        "/v1/datasets/h%69ll/tiles/0/0/0.png",
        "/v1/datasets/hill%2Dx/view?ratio=1",
    ] {
        refused(&app, uri, StatusCode::BAD_REQUEST, "bad_name").await;
    }
    let (s, _, _) = get(&app, "/v1/datasets/hill/tiles/0/0/0.png").await;
    assert_eq!(s, StatusCode::OK);
    // A base URL without the dataset's trailing slash asks for these: said so.
    for uri in ["/v1/datasets/layer.json", "/v1/datasets/tiles.json"] {
        let v = refused(&app, uri, StatusCode::NOT_FOUND, "unknown_dataset").await;
        assert!(
            v["message"].as_str().unwrap().contains("trailing slash"),
            "{v}"
        );
    }
    let v = refused(
        &app,
        "/v1/datasets/nope",
        StatusCode::NOT_FOUND,
        "unknown_dataset",
    )
    .await;
    assert_eq!(v["message"], "no dataset named \"nope\"");
}

#[tokio::test]
async fn metrics_count_by_route_template() {
    let app = router("metrics");
    get(&app, "/v1/datasets/hill/tiles/0/0/0.png?threshold=4").await;
    get(&app, "/v1/datasets/hill/tiles/0/0/0.png?threshold=4").await;
    let (_, _, body) = get(&app, "/metrics").await;
    let text = String::from_utf8(body).unwrap();
    assert!(
        text.contains(
            "zerotile_requests_total{route=\"/v1/datasets/{name}/tiles/{z}/{x}/{y}\",status=\"200\"} 2"
        ),
        "{text}"
    );
    assert!(text.contains("zerotile_tiles_decoded_total 1"), "{text}");
    assert!(
        text.contains("zerotile_response_cache_hits_total 1"),
        "{text}"
    );
}

/// Paths no route matches share one label: a scanner walking random URLs must not grow the
/// exposition (and the scraper's series count) by one line per path.
#[tokio::test]
async fn unmatched_requests_share_one_label() {
    let app = router("metrics-unmatched");
    for uri in ["/no/such/path", "/wp-login.php", "/v2/anything"] {
        let (s, _, _) = get(&app, uri).await;
        assert_eq!(s, StatusCode::NOT_FOUND, "{uri}");
    }
    let (_, _, body) = get(&app, "/metrics").await;
    let text = String::from_utf8(body).unwrap();
    assert!(
        text.contains("zerotile_requests_total{route=\"unmatched\",status=\"404\"} 3"),
        "{text}"
    );
    assert!(!text.contains("wp-login"), "{text}");
}

#[tokio::test]
async fn errors_made_by_layers_become_json_too() {
    let app = Router::new()
        .route(
            "/slow",
            axum::routing::get(|| async { StatusCode::SERVICE_UNAVAILABLE }),
        )
        .layer(axum::middleware::from_fn(super::error::json_errors));
    let (s, h, body) = get(&app, "/slow").await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(h[header::CONTENT_TYPE], "application/json");
    assert_eq!(error_code(&body), "unavailable");
}

/// Log lines captured from a test's own subscriber.
#[derive(Clone, Default)]
struct Captured(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);

impl std::io::Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A request shed by an overload writes nothing at WARN or above: a burst of them used to
/// be an ERROR line each, without the URI, drowning the log (the 503s are counted by route in
/// /metrics). A fault on our side still logs its cause at ERROR.
#[tokio::test]
async fn shed_requests_do_not_flood_the_log() {
    let state = state_over(
        hill_dataset("shed-log", "local", &[ROOT]),
        Config {
            cpu_jobs: 1,
            cpu_queue: 0,
            ..Config::default()
        },
    );
    let held = state.admit_render().unwrap();
    let app = app(state);
    let logs = Captured::default();
    let writer = logs.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_max_level(tracing::Level::WARN)
        .finish();
    let _guard = tracing::subscriber::set_default(subscriber);
    let (s, _, body) = get(&app, "/v1/datasets/hill/tiles/0/0/0.json?threshold=1").await;
    assert_eq!(
        (s, error_code(&body)),
        (StatusCode::SERVICE_UNAVAILABLE, "overloaded".into())
    );
    let text = |l: &Captured| String::from_utf8(l.0.lock().unwrap().clone()).unwrap();
    assert_eq!(text(&logs), "");
    let _ = super::error::ApiError::internal("a corrupt tile");
    assert!(text(&logs).contains("ERROR") && text(&logs).contains("a corrupt tile"));
    drop(held);
}

#[tokio::test]
async fn renders_past_the_queue_are_shed_with_503() {
    let state = AppState::new(
        Catalog::default(),
        Config {
            cpu_jobs: 1,
            cpu_queue: 0,
            ..Config::default()
        },
    )
    .unwrap();
    let held = state.admit_render().unwrap();
    let shed = state.admit_render().unwrap_err();
    assert_eq!(
        (shed.status, shed.code),
        (StatusCode::SERVICE_UNAVAILABLE, "overloaded")
    );
    // Clients and CDNs are told when to come back.
    let res = axum::response::IntoResponse::into_response(shed);
    assert_eq!(
        res.headers()
            .get(axum::http::header::RETRY_AFTER)
            .map(|v| v.as_bytes()),
        Some(&b"1"[..])
    );
    drop(held);
    let again = state.admit_render().expect("admitted once a place is free");
    drop(again);
    assert_eq!(state.renders.admitted(), 0);
}

#[test]
fn neighbours_follow_each_scheme_row_direction() {
    // Geodetic zoom 1 is 4 × 2 tiles counted from the south: north of row 0 is row 1.
    let all: Vec<TileId> = (0..4)
        .flat_map(|x| (0..2).map(move |y| id(1, x, y)))
        .collect();
    let d = hill_dataset("geo-neighbours", "geodetic", &all);
    assert_eq!(
        pipeline::neighbours(&d, id(1, 1, 0)),
        [
            Some(id(1, 1, 1)),
            None,
            Some(id(1, 0, 0)),
            Some(id(1, 2, 0))
        ]
    );
    // Mercator zoom 1 is 2 × 2 tiles counted from the north: south of row 0 is row 1.
    let all: Vec<TileId> = (0..2)
        .flat_map(|x| (0..2).map(move |y| id(1, x, y)))
        .collect();
    let d = hill_dataset("merc-neighbours", "mercator", &all);
    // Across the antimeridian the world goes round: west of column 0 is the last column.
    assert_eq!(
        pipeline::neighbours(&d, id(1, 0, 0)),
        [
            None,
            Some(id(1, 0, 1)),
            Some(id(1, 1, 0)),
            Some(id(1, 1, 0))
        ]
    );
    let roots = [id(0, 0, 0), id(0, 1, 0)];
    let d = hill_dataset("geo-roots", "geodetic", &roots);
    assert_eq!(
        pipeline::neighbours(&d, id(0, 0, 0)),
        [None, None, Some(id(0, 1, 0)), Some(id(0, 1, 0))]
    );
    // Corner neighbours follow the same rows and columns (the normals read them).
    let geo_all: Vec<TileId> = (0..4)
        .flat_map(|x| (0..2).map(move |y| id(1, x, y)))
        .collect();
    let d = hill_dataset("geo-diagonals", "geodetic", &geo_all);
    assert_eq!(
        pipeline::diagonal_neighbours(&d, id(1, 1, 0)),
        [Some(id(1, 0, 1)), Some(id(1, 2, 1)), None, None]
    );
    assert_eq!(
        pipeline::diagonal_neighbours(&d, id(1, 3, 1)),
        [None, None, Some(id(1, 2, 0)), Some(id(1, 0, 0))]
    );
    let d = hill_dataset("merc-diagonals", "mercator", &all);
    assert_eq!(
        pipeline::diagonal_neighbours(&d, id(1, 0, 0)),
        [None, None, Some(id(1, 1, 1)), Some(id(1, 1, 1))]
    );
    // East of the last column is the first, on both world schemes.
    let d = hill_dataset("merc-neighbours-east", "mercator", &all);
    assert_eq!(pipeline::neighbours(&d, id(1, 1, 1))[3], Some(id(1, 0, 1)));
    let d = hill_dataset("geo-roots-east", "geodetic", &roots);
    assert_eq!(
        pipeline::neighbours(&d, id(0, 1, 0)),
        [None, None, Some(id(0, 0, 0)), Some(id(0, 0, 0))]
    );
    // A local grid does not go round.
    let d = hill_dataset("local-neighbours", "local", &[id(0, 0, 0)]);
    assert_eq!(pipeline::neighbours(&d, id(0, 0, 0)), [None; 4]);
}

#[tokio::test]
async fn cors_allows_any_origin_unless_configured() {
    let open = router("cors-open");
    let (_, h, _) = send(
        &open,
        Method::GET,
        "/healthz",
        &[("origin", "https://a.example")],
    )
    .await;
    assert_eq!(
        h.get("access-control-allow-origin").map(|v| v.as_bytes()),
        Some(&b"*"[..])
    );

    let state = AppState::new(
        Catalog::default(),
        Config {
            cors_origins: vec!["https://a.example".into()],
            ..Config::default()
        },
    )
    .unwrap();
    let closed = app(state);
    let (_, h, _) = send(
        &closed,
        Method::GET,
        "/healthz",
        &[("origin", "https://a.example")],
    )
    .await;
    assert_eq!(
        h.get("access-control-allow-origin").map(|v| v.as_bytes()),
        Some(&b"https://a.example"[..])
    );
    let (_, h, _) = send(
        &closed,
        Method::GET,
        "/healthz",
        &[("origin", "https://b.example")],
    )
    .await;
    assert!(h.get("access-control-allow-origin").is_none());
}

/// A mesh for a gzip or br client is compressed once, when rendered, so the response cache
/// holds the compressed body and a hit costs no compression (the compression layer would
/// otherwise compress it again on every request, with the same bytes on the wire).
#[test]
fn gzip_variants_are_rendered_compressed_for_the_cache() {
    use super::codings::Coding;
    use super::routes::tiles::{render_tile, TileFormat, Variant};
    let d = hill_dataset("gzip-render", "local", &[ROOT]);
    let state = AppState::new(Catalog::default(), Config::default()).unwrap();
    let render = |coding| {
        let v = Variant::Mesh {
            coding,
            frame: super::frame::Frame::Scheme,
        };
        render_tile(
            &state,
            &d,
            ROOT,
            4.0,
            TileFormat::Json,
            v,
            false,
            &Default::default(),
        )
        .unwrap()
        .bytes
    };
    let (zipped, plain) = (render(Coding::Gzip), render(Coding::Identity));
    assert_eq!(zipped[..2], [0x1f, 0x8b], "a gzip member");
    assert_eq!(plain[0], b'{');
    assert!(zipped.len() < plain.len());
    let br = render(Coding::Br);
    assert!(br.len() < plain.len());
    assert_eq!(unbrotli(&br), plain);
}

fn unbrotli(b: &[u8]) -> Vec<u8> {
    use std::io::Read;
    let mut out = Vec::new();
    brotli::Decompressor::new(b, 4096)
        .read_to_end(&mut out)
        .unwrap();
    out
}

/// Every content coding of an answer has its own ETag, so a cache holding several copies
/// never takes a 304 for one coding as one for another's copy. A br tile was compressed by
/// the layer under the uncompressed body's tag (gzip had its own): an identity request
/// revalidating with the br copy's tag got a 304. The answers the layer compresses
/// (descriptions, views, mesh LODs, assets) shared one weak tag for every coding.
#[tokio::test]
async fn each_content_coding_has_its_own_etag() {
    /// GET `uri` accepting `coding`, with `If-None-Match: tag` if given.
    async fn coded(
        app: &Router,
        uri: &str,
        coding: &str,
        tag: Option<&str>,
    ) -> (StatusCode, axum::http::HeaderMap, Vec<u8>) {
        let mut h = vec![("accept-encoding", coding)];
        h.extend(tag.map(|t| ("if-none-match", t)));
        send(app, Method::GET, uri, &h).await
    }
    let data = one_triangle_data("codings-etag");
    let local = router_with_meshes("codings-etag", &data);
    let geo = router_of("codings-etag-geo", "geodetic");
    for (app, uri) in [
        (&local, "/v1/datasets/hill/tiles/0/0/0.json?threshold=4"),
        (&local, "/v1/datasets/hill/tiles/0/0/0.bin?threshold=4"),
        (&local, "/v1/datasets/hill/tiles/0/0/0.obj?threshold=4"),
        (&geo, "/v1/datasets/hill/tiles/0/0/0.terrain?threshold=4"),
        (&local, "/v1/datasets"),
        (&local, "/v1/datasets/hill"),
        (&local, "/v1/meshes/a"),
        (&local, "/v1/meshes/a/original"),
        (
            &geo,
            "/v1/datasets/hill/view?eye=0,0,3850000&target=0,0,0&fov=60",
        ),
        (&local, "/assets/viewer.js"),
    ] {
        let (s, plain_h, plain) = coded(app, uri, "identity", None).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
        assert!(plain_h.get(header::CONTENT_ENCODING).is_none(), "{uri}");
        let (_, gzip_h, _) = coded(app, uri, "gzip", None).await;
        assert_eq!(gzip_h[header::CONTENT_ENCODING], "gzip", "{uri}");
        let (_, br_h, br) = coded(app, uri, "br", None).await;
        assert_eq!(br_h[header::CONTENT_ENCODING], "br", "{uri}");
        assert_eq!(unbrotli(&br), plain, "{uri}");
        let tags =
            [&plain_h, &gzip_h, &br_h].map(|h| h[header::ETAG].to_str().unwrap().to_string());
        assert!(
            tags[0] != tags[1] && tags[1] != tags[2] && tags[0] != tags[2],
            "{uri}: {tags:?}"
        );
        // The br copy's tag is no validator of the identity body; it is of the br one.
        let (s, _, body) = coded(app, uri, "identity", Some(&tags[2])).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
        assert_eq!(body, plain, "{uri}");
        let (s, h, _) = coded(app, uri, "br", Some(&tags[2])).await;
        assert_eq!(s, StatusCode::NOT_MODIFIED, "{uri}");
        assert_eq!(h[header::ETAG], tags[2].as_str(), "{uri}");
        for h in [&plain_h, &gzip_h, &br_h, &h] {
            let vary = h[header::VARY].to_str().unwrap().to_ascii_lowercase();
            assert!(vary.contains("accept-encoding"), "{uri}: {vary}");
        }
    }
    // A body under the layer's 32 bytes goes out uncompressed, but under the tag of the
    // coding asked for, so it varies on Accept-Encoding too (it had no Vary).
    let (s, h, body) = coded(&geo, "/v1/meshes", "br", None).await;
    assert_eq!(s, StatusCode::OK);
    assert!(body.len() < 32, "{}", String::from_utf8_lossy(&body));
    assert!(h.get(header::CONTENT_ENCODING).is_none());
    assert!(
        h[header::ETAG].to_str().unwrap().ends_with("-br\""),
        "{h:?}"
    );
    assert_eq!(h[header::VARY], "accept-encoding");
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn a_cancelled_render_decodes_nothing_more() {
    let d = hill_dataset("cancel-before", "local", &[ROOT]);
    let state = AppState::new(Catalog::default(), Config::default()).unwrap();
    let cancel = pipeline::Cancel::default();
    drop(cancel.on_drop());
    let Err(err) = pipeline::stitched(&state, &d, ROOT, 1.0, &cancel) else {
        panic!("a cancelled render stops");
    };
    assert!(err.is::<pipeline::Cancelled>(), "{err:#}");
    assert_eq!(state.metrics.tiles_decoded.load(Relaxed), 0);
    // Not cancelled, the same call renders.
    pipeline::stitched(&state, &d, ROOT, 1.0, &Default::default()).expect("renders");
    assert_eq!(state.metrics.tiles_decoded.load(Relaxed), 1);
}

/// A client that goes away mid-render (its request future dropped, as hyper does on a
/// disconnect) stops the render before its next tile decode instead of decoding all five.
/// The decodes under way when it leaves finish and no other starts. One render thread (a
/// server whose other threads are busy) decodes one tile at a time, so the abort has four
/// decodes' time to arrive; on two, the first two decodes run at once and it had less than
/// one (CI saw all five finish). (On a tile with fewer than four neighbours fewer than five
/// decodes would pass uncancelled too.) Still a race with the scheduler: with the other
/// tests' work on both cores the abort came late once in five runs, so it gets three tries,
/// and a render that is never stopped early fails all three.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dropping_a_request_stops_its_decode_work() {
    let mut seen = Vec::new();
    for attempt in 0..3 {
        let decoded = decodes_after_the_client_left(&format!("cancel-drop-{attempt}")).await;
        if decoded < 5 {
            return;
        }
        seen.push(decoded);
    }
    panic!("every try decoded all 5 tiles after the client left: {seen:?}");
}

/// Tiles decoded by a render whose client left after its first decode.
async fn decodes_after_the_client_left(tag: &str) -> u64 {
    // Geodetic zoom 2 (8 × 4 tiles): tile (1, 1) has all four neighbours, five decodes.
    let all: Vec<TileId> = (0..8)
        .flat_map(|x| (0..4).map(move |y| id(2, x, y)))
        .collect();
    let d = hill_dataset(tag, "geodetic", &all);
    let name = d.name.clone();
    let mut catalog = Catalog::default();
    catalog.insert(d);
    let config = Config {
        render_threads: 1,
        ..Config::default()
    };
    let state = AppState::new(catalog, config).unwrap();
    let app = app(state.clone());
    // The finest threshold: every pass decoded, milliseconds a tile.
    let uri = format!("/v1/datasets/{name}/tiles/2/1/1.terrain?threshold=0.01");
    let req = tokio::spawn(async move { get(&app, &uri).await });
    let metrics = state.metrics.clone();
    let started = std::time::Instant::now();
    while metrics.tiles_decoded.load(Relaxed) == 0 {
        assert!(started.elapsed().as_secs() < 30, "the render never started");
        tokio::time::sleep(std::time::Duration::from_micros(100)).await;
    }
    req.abort();
    while metrics.renders_cancelled.load(Relaxed) == 0 {
        assert!(
            started.elapsed().as_secs() < 30,
            "the render was not cancelled"
        );
        tokio::time::sleep(std::time::Duration::from_millis(1)).await;
    }
    metrics.tiles_decoded.load(Relaxed)
}

/// Serves `app` on a free local port, for tests that need a real connection (a body that
/// stalls or breaks off cannot be made with `oneshot`).
async fn serve_locally(app: Router) -> std::net::SocketAddr {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    tokio::spawn(async move { axum::serve(listener, app).await });
    addr
}

/// Writes `head` then `body` raw, half-closes the socket if `close`, and reads the status and
/// JSON body of the answer, failing after 10 s.
async fn raw_exchange(
    addr: std::net::SocketAddr,
    head: &str,
    body: &[u8],
    close: bool,
) -> (u16, serde_json::Value, std::time::Duration) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let started = std::time::Instant::now();
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    s.write_all(head.as_bytes()).await.unwrap();
    s.write_all(body).await.unwrap();
    if close {
        s.shutdown().await.unwrap();
    }
    let mut out = Vec::new();
    let mut buf = [0u8; 4096];
    let answer = tokio::time::timeout(std::time::Duration::from_secs(10), async {
        // The answer is whole once its JSON body is: hyper need not close the socket.
        loop {
            let n = s.read(&mut buf).await.unwrap();
            out.extend_from_slice(&buf[..n]);
            let text = String::from_utf8_lossy(&out);
            if n == 0 || text.contains("\r\n\r\n{") && text.ends_with('}') {
                break;
            }
        }
    })
    .await;
    assert!(answer.is_ok(), "no answer within 10 s");
    let text = String::from_utf8_lossy(&out).into_owned();
    let status = text[9..12].parse().unwrap();
    let json = &text[text.find("\r\n\r\n").unwrap() + 4..];
    (
        status,
        serde_json::from_str(json).unwrap(),
        started.elapsed(),
    )
}

#[tokio::test]
async fn an_upload_declaring_more_than_the_limit_is_refused_at_once() {
    // A server that takes uploads: one without a mesh folder refuses before reading.
    let data = one_triangle_data("upload-declared");
    let addr = serve_locally(router_with_meshes("upload-declared", &data)).await;
    // A small body under a huge declared length: nothing more will come, so waiting for it
    // ran into the request timeout (503 after 30 s).
    let head = "POST /v1/meshes/g6 HTTP/1.1\r\nhost: x\r\ncontent-type: model/obj\r\n\
                content-length: 999999999999\r\n\r\n";
    let (status, json, took) = raw_exchange(addr, head, b"v 0 0 0\n", false).await;
    assert_eq!((status, json["error"].as_str()), (413, Some("too_large")));
    assert!(json["message"].as_str().unwrap().contains("999999999999"));
    assert!(took.as_secs() < 5, "{took:?}");
}

#[tokio::test]
async fn an_upload_that_breaks_off_is_the_clients_fault() {
    // A server that takes uploads: one without a mesh folder refuses before reading.
    let data = one_triangle_data("upload-short");
    let addr = serve_locally(router_with_meshes("upload-short", &data)).await;
    let head = "POST /v1/meshes/g6 HTTP/1.1\r\nhost: x\r\ncontent-type: model/obj\r\n\
                content-length: 100\r\n\r\n";
    let (status, json, _) = raw_exchange(addr, head, b"v 0 0 0\n", true).await;
    assert_eq!(
        (status, json["error"].as_str()),
        (400, Some("incomplete_body"))
    );
    assert!(
        json["message"].as_str().unwrap().contains("8 of 100"),
        "{json}"
    );
}

/// The limit is 64 MiB exactly, whether the body declares its length or not: the byte after
/// it is refused (413), by the declared length before a byte is read, else by the first
/// frame that would pass it.
#[tokio::test]
async fn an_upload_may_be_64_mib_and_not_a_byte_more() {
    use super::meshes::MAX_UPLOAD_BYTES;
    use super::routes::meshes::read_upload;
    let declaring = |n: usize| {
        let mut h = axum::http::HeaderMap::new();
        h.insert(header::CONTENT_LENGTH, n.into());
        h
    };
    let second = std::time::Duration::from_secs(5);
    let over = read_upload(
        &declaring(MAX_UPLOAD_BYTES + 1),
        Body::from("v 0 0 0\n"),
        second,
    )
    .await
    .unwrap_err();
    assert_eq!(over.status, StatusCode::PAYLOAD_TOO_LARGE);
    assert!(over.to_string().contains("declares"), "{over}");
    let whole = vec![b' '; MAX_UPLOAD_BYTES];
    let at = read_upload(
        &declaring(MAX_UPLOAD_BYTES),
        Body::from(whole.clone()),
        second,
    )
    .await;
    assert_eq!(at.map(|b| b.len()), Ok(MAX_UPLOAD_BYTES));

    let none = axum::http::HeaderMap::new();
    let at = read_upload(&none, Body::from(whole), second).await;
    assert_eq!(at.map(|b| b.len()), Ok(MAX_UPLOAD_BYTES));
    let big = Body::from(vec![b' '; MAX_UPLOAD_BYTES + 1]);
    let over = read_upload(&none, big, second).await.unwrap_err();
    assert_eq!(over.status, StatusCode::PAYLOAD_TOO_LARGE);
}

#[tokio::test]
async fn an_upload_that_stalls_is_a_408_not_a_503() {
    // The upload's own reader with a short deadline: the route's is 20 s.
    let app = Router::new().route(
        "/up",
        axum::routing::post(|h: axum::http::HeaderMap, b: Body| async move {
            super::routes::meshes::read_upload(&h, b, std::time::Duration::from_millis(200))
                .await
                .map(|b| b.len().to_string())
        }),
    );
    let addr = serve_locally(app).await;
    let head = "POST /up HTTP/1.1\r\nhost: x\r\ncontent-length: 100\r\n\r\n";
    let (status, json, _) = raw_exchange(addr, head, b"v 0 0 0\n", false).await;
    assert_eq!((status, json["error"].as_str()), (408, Some("timeout")));
    assert!(
        json["message"].as_str().unwrap().contains("8 of 100"),
        "{json}"
    );
    // The route's deadline is under the request timeout, so a stall never becomes its 503.
    assert!(super::routes::meshes::UPLOAD_READ_TIMEOUT < super::REQUEST_TIMEOUT);
}

#[tokio::test]
async fn a_wrong_method_is_told_to_see_allow_not_a_fixed_list() {
    let app = router("allow");
    for (uri, allowed) in [("/v1/meshes/x", "GET,HEAD,POST"), ("/healthz", "GET,HEAD")] {
        let (s, h, body) = send(&app, Method::PUT, uri, &[]).await;
        assert_eq!(s, StatusCode::METHOD_NOT_ALLOWED, "{uri}");
        assert_eq!(h[header::ALLOW], allowed, "{uri}");
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert_eq!(v["error"], "method_not_allowed");
        // The old fixed "GET (and HEAD) only" contradicted Allow on the upload route.
        assert_eq!(
            v["message"],
            "this route does not answer PUT; its Allow header lists the methods it does",
            "{uri}"
        );
    }
}

/// A fresh data folder holding one object mesh, `meshes/a.obj`: a single triangle.
fn one_triangle_data(tag: &str) -> std::path::PathBuf {
    let data = crate::fixtures::scratch(tag);
    std::fs::create_dir_all(data.join("meshes")).unwrap();
    std::fs::write(
        data.join("meshes/a.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    data
}

/// The router over the object meshes of `data/meshes` (and the one-tile `hill`).
fn router_with_meshes(tag: &str, data: &std::path::Path) -> Router {
    app(state_with_meshes(tag, "local", data))
}

/// A one-tile `hill` of `scheme` beside the meshes of `data`, with the default config.
fn state_with_meshes(tag: &str, scheme: &str, data: &std::path::Path) -> AppState {
    state_over(hill_dataset(tag, scheme, &[ROOT]), Config::default())
        .with_meshes(crate::serve::meshes::MeshCatalog::open(data, 1 << 20))
}

/// A mesh replaced on disk while the server was down is a new mesh after the restart: a
/// client revalidating its copy of the old one gets the new one, not a 304. (Tags counted
/// loads from 1 at every start, so the replacement came back under its predecessor's.)
#[tokio::test]
async fn a_mesh_replaced_across_a_restart_gets_new_etags() {
    let data = one_triangle_data("lod-restart");
    let meshes = data.join("meshes");
    let uri = "/v1/meshes/a/original?format=obj";
    let (s, h, _) = get(&router_with_meshes("mesh-restart-1", &data), uri).await;
    assert_eq!(s, StatusCode::OK);
    let old = h[header::ETAG].to_str().unwrap().to_string();

    std::fs::write(
        meshes.join("a.obj"),
        "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let restarted = router_with_meshes("mesh-restart-2", &data);
    let (s, h, body) = send(&restarted, Method::GET, uri, &[("if-none-match", &old)]).await;
    assert_eq!(s, StatusCode::OK, "a 304 would keep the old mesh");
    assert_ne!(h[header::ETAG].to_str().unwrap(), old);
    assert_eq!(
        String::from_utf8_lossy(&body).matches("\nf ").count(),
        2,
        "the new mesh"
    );
    // The same files after another restart: the same tags, so copies stay valid.
    let again = router_with_meshes("mesh-restart-3", &data);
    let (s, _, _) = send(
        &again,
        Method::GET,
        uri,
        &[("if-none-match", h[header::ETAG].to_str().unwrap())],
    )
    .await;
    assert_eq!(s, StatusCode::NOT_MODIFIED);
    let _ = std::fs::remove_dir_all(&data);
}

/// Every object-mesh route refuses a parameter it does not take, the list too (which
/// answered `?x=1` with the list), while the dataset list, which map clients may call with
/// their own parameters, ignores it.
#[tokio::test]
async fn the_mesh_list_refuses_parameters_and_the_dataset_list_ignores_them() {
    let data = one_triangle_data("list-query");
    let app = router_with_meshes("list-query", &data);
    for uri in ["/v1/meshes?x=1", "/v1/meshes/a?x=1", "/v1/meshes/a/qem?x=1"] {
        refused(&app, uri, StatusCode::BAD_REQUEST, "bad_query").await;
    }
    for uri in ["/v1/meshes", "/v1/datasets?x=1"] {
        assert_eq!(get(&app, uri).await.0, StatusCode::OK, "{uri}");
    }
    let _ = std::fs::remove_dir_all(&data);
}

/// `fov` and `aspect` only shape a browse: without `roi`, `eye` and `target` they were
/// dropped and the plain level answered, as if the camera had been used.
#[tokio::test]
async fn an_octree_camera_without_a_region_is_refused() {
    let data = one_triangle_data("octree-camera");
    let app = router_with_meshes("octree-camera", &data);
    for q in ["fov=60", "aspect=2", "level=1&fov=60&aspect=2"] {
        let e = refused(
            &app,
            &format!("/v1/meshes/a/octree?{q}"),
            StatusCode::BAD_REQUEST,
            "bad_query",
        )
        .await;
        assert!(
            e["message"]
                .as_str()
                .unwrap()
                .contains("roi, eye and target"),
            "{e}"
        );
    }
    let (s, _, _) = get(&app, "/v1/meshes/a/octree?level=1").await;
    assert_eq!(s, StatusCode::OK);
    let browse = "/v1/meshes/a/octree?level=1&roi=-1,-1,1,1&eye=0,0,5&target=0,0,0&fov=60&aspect=2";
    let (s, _, _) = get(&app, browse).await;
    assert_eq!(s, StatusCode::OK);
    let _ = std::fs::remove_dir_all(&data);
}

/// An upload replaces a mesh at the same URLs and is served at once, so its LODs are
/// revalidated on every use (`no-cache`, on the 304 too), not kept fresh for an hour: a
/// browser holding the old answer asks again and gets the new mesh.
#[tokio::test]
async fn mesh_lods_are_revalidated_since_an_upload_replaces_them() {
    let data = one_triangle_data("lod-cache-control");
    let app = router_with_meshes("mesh-no-cache", &data);
    for uri in [
        "/v1/meshes/a/original",
        "/v1/meshes/a/qem?faces=1&format=glb",
    ] {
        let (s, h, _) = get(&app, uri).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
        assert_eq!(h[header::CACHE_CONTROL], "public, no-cache", "{uri}");
        let tag = h[header::ETAG].to_str().unwrap().to_string();
        let (s, h, _) = send(&app, Method::GET, uri, &[("if-none-match", &tag)]).await;
        assert_eq!(s, StatusCode::NOT_MODIFIED, "{uri}");
        assert_eq!(h[header::CACHE_CONTROL], "public, no-cache", "{uri}");
    }
    let _ = std::fs::remove_dir_all(&data);
}

/// A face without area is no valid face, yet the QA pass's tetrahedron with a face along one
/// of its edges (`f 1 5 2`) was served with it in every LOD. Repair drops it, and a mesh's
/// summary counts what it dropped: for a file of the folder and for an upload alike.
#[tokio::test]
async fn faces_without_area_are_dropped_and_counted() {
    const WITH_A_FLAT_FACE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0.5 0 0\n\
                                    f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 1 5 2\n";
    let data = one_triangle_data("flat-face");
    std::fs::write(data.join("meshes/t.obj"), WITH_A_FLAT_FACE).unwrap();
    let app = router_with_meshes("mesh-flat-face", &data);
    let json = |body: &[u8]| serde_json::from_slice::<serde_json::Value>(body).unwrap();
    let counts = |m: &serde_json::Value| (m["faces"].clone(), m["faces_dropped"].clone());
    let (s, _, body) = get(&app, "/v1/meshes").await;
    assert_eq!(s, StatusCode::OK);
    let listed = json(&body)["meshes"].clone();
    assert_eq!(listed[0]["name"], "a");
    assert_eq!(counts(&listed[0]), (1.into(), 0.into()));
    assert_eq!(listed[1]["name"], "t");
    assert_eq!(counts(&listed[1]), (4.into(), 1.into()));
    let (s, body) = post_obj(&app, "/v1/meshes/u", WITH_A_FLAT_FACE).await;
    assert_eq!(s, StatusCode::CREATED);
    assert_eq!(counts(&json(&body)), (4.into(), 1.into()));
    let (_, _, body) = get(&app, "/v1/meshes/u/original").await;
    let original = json(&body);
    assert_eq!(original["indices"].as_array().unwrap().len(), 12);
    assert_eq!(original["positions"].as_array().unwrap().len(), 12);
    let _ = std::fs::remove_dir_all(&data);
}

/// `curl --data-binary @mesh.obj URL`, the first upload a curl user tries, labels the body
/// a form: still a 415 (a form is not a mesh), but one that says which header to add. No
/// `Accept-Encoding`: a 415 that is not about the content coding must not carry one.
#[tokio::test]
async fn a_form_labelled_upload_is_told_to_set_its_content_type() {
    let app = router("upload-form");
    let (s, h, body) = send(
        &app,
        Method::POST,
        "/v1/meshes/a",
        &[("content-type", "application/x-www-form-urlencoded")],
    )
    .await;
    assert_eq!(s, StatusCode::UNSUPPORTED_MEDIA_TYPE);
    assert!(h.get(header::ACCEPT_ENCODING).is_none(), "{h:?}");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["error"], "unsupported_media_type");
    let m = v["message"].as_str().unwrap();
    assert!(m.contains("-H 'Content-Type: model/obj'"), "{m}");
    // Other types keep the plain message.
    let (_, _, body) = send(
        &app,
        Method::POST,
        "/v1/meshes/a",
        &[("content-type", "image/png")],
    )
    .await;
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert!(!v["message"].as_str().unwrap().contains("curl"), "{v}");
}

/// Two Content-Type lines name no one format: a 400 naming both, where the first was taken
/// silently; nothing is stored.
#[tokio::test]
async fn an_upload_with_two_content_types_is_refused() {
    let data = one_triangle_data("upload-two-types");
    let app = router_with_meshes("upload-two-types", &data);
    let req = Request::builder()
        .method(Method::POST)
        .uri("/v1/meshes/b")
        .header(header::CONTENT_TYPE, "model/obj")
        .header(header::CONTENT_TYPE, "application/ply")
        .body(Body::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"))
        .unwrap();
    let res = app.clone().oneshot(req).await.unwrap();
    assert_eq!(res.status(), StatusCode::BAD_REQUEST);
    let body = to_bytes(res.into_body(), 1 << 20).await.unwrap();
    assert_eq!(error_code(&body), "bad_header");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let m = v["message"].as_str().unwrap();
    assert!(
        m.contains("model/obj") && m.contains("application/ply"),
        "{m}"
    );
    let (s, _, _) = get(&app, "/v1/meshes/b").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
}

/// Nothing decodes a compressed upload, so a gzipped OBJ reached the parser as it came and
/// was a 422 "OBJ: read error"; it is a 415 naming Content-Encoding, and stores nothing. Its
/// `Accept-Encoding: identity` says which coding would do (RFC 9110 §15.5.16); it was absent.
#[tokio::test]
async fn a_compressed_upload_is_told_to_send_the_mesh_uncompressed() {
    let data = one_triangle_data("upload-gzip");
    let app = router_with_meshes("upload-gzip", &data);
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut gz, obj).unwrap();
    let gz = gz.finish().unwrap();
    for coding in ["gzip", "br", "x-gzip, identity"] {
        let req = Request::builder()
            .method(Method::POST)
            .uri("/v1/meshes/b")
            .header(header::CONTENT_TYPE, "model/obj")
            .header(header::CONTENT_ENCODING, coding)
            .body(Body::from(gz.clone()))
            .unwrap();
        let res = app.clone().oneshot(req).await.unwrap();
        assert_eq!(res.status(), StatusCode::UNSUPPORTED_MEDIA_TYPE, "{coding}");
        assert_eq!(
            res.headers()[header::ACCEPT_ENCODING],
            "identity",
            "{coding}"
        );
        let body = to_bytes(res.into_body(), 1 << 20).await.unwrap();
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert_eq!(v["error"], "unsupported_media_type", "{coding}");
        assert!(
            v["message"].as_str().unwrap().contains("Content-Encoding"),
            "{v}"
        );
    }
    // Two header lines count as one list: identity, then gzip, is gzip.
    let req = Request::builder()
        .method(Method::POST)
        .uri("/v1/meshes/b")
        .header(header::CONTENT_TYPE, "model/obj")
        .header(header::CONTENT_ENCODING, "identity")
        .header(header::CONTENT_ENCODING, "gzip")
        .body(Body::from(gz.clone()))
        .unwrap();
    let res = app.clone().oneshot(req).await.unwrap();
    assert_eq!(res.status(), StatusCode::UNSUPPORTED_MEDIA_TYPE);
    assert_eq!(res.headers()[header::ACCEPT_ENCODING], "identity");
    let (s, _, _) = get(&app, "/v1/meshes/b").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    // identity is no coding.
    let req = Request::builder()
        .method(Method::POST)
        .uri("/v1/meshes/b")
        .header(header::CONTENT_TYPE, "model/obj")
        .header(header::CONTENT_ENCODING, "identity")
        .body(Body::from(&obj[..]))
        .unwrap();
    assert_eq!(
        app.clone().oneshot(req).await.unwrap().status(),
        StatusCode::CREATED
    );
    let _ = std::fs::remove_dir_all(&data);
}

/// `POST URI` with an OBJ body.
async fn post_obj(app: &Router, uri: &str, obj: &str) -> (StatusCode, Vec<u8>) {
    let req = Request::builder()
        .method(Method::POST)
        .uri(uri)
        .header(header::CONTENT_TYPE, "model/obj")
        .body(Body::from(obj.to_string()))
        .unwrap();
    let res = app.clone().oneshot(req).await.unwrap();
    let status = res.status();
    (
        status,
        to_bytes(res.into_body(), 1 << 20).await.unwrap().to_vec(),
    )
}

/// An upload the server cannot keep is not the client's fault: a server without a mesh
/// folder (its data in an object store) says so with a 403, a failed write is a 500 whose
/// detail (a path on the server) is logged, not sent. Both were 422 `invalid_mesh` with the
/// server's message, though the mesh was fine.
#[tokio::test]
async fn an_upload_the_server_cannot_keep_is_not_an_invalid_mesh() {
    const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let (s, body) = post_obj(&router("upload-no-folder"), "/v1/meshes/b", TRI).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    assert_eq!(error_code(&body), "read_only");
    // Said before the body is read: an empty one is the same 403, not 400 empty_body.
    let (s, body) = post_obj(&router("upload-no-folder-empty"), "/v1/meshes/b", "").await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    assert_eq!(error_code(&body), "read_only");

    let data = one_triangle_data("upload-store");
    // A folder where the file goes: the rename over it fails.
    std::fs::create_dir_all(data.join("meshes/b.obj/inside")).unwrap();
    let app = router_with_meshes("upload-store", &data);
    let (s, body) = post_obj(&app, "/v1/meshes/b", TRI).await;
    assert_eq!(s, StatusCode::INTERNAL_SERVER_ERROR);
    assert_eq!(error_code(&body), "internal");
    let text = String::from_utf8_lossy(&body);
    assert!(!text.contains(data.to_str().unwrap()), "{text}");
    // The mesh itself was fine: under a name the server can write it is a 201.
    let (s, _) = post_obj(&app, "/v1/meshes/c", TRI).await;
    assert_eq!(s, StatusCode::CREATED);
    let (s, body) = post_obj(&app, "/v1/meshes/c", "v 0 0 0\n").await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert_eq!(error_code(&body), "invalid_mesh");
}

/// Uploads are admitted before their body is read, at most `UPLOAD_JOBS + UPLOAD_QUEUE` at
/// once: eight 2M-face uploads at once all ran into the request timeout (503, none stored)
/// with 3.4 GB held. Past the budget a 503 `overloaded` comes at once and stores nothing;
/// the place given back, the same upload is a 201.
#[tokio::test]
async fn uploads_past_their_budget_are_shed_before_the_body_is_read() {
    use crate::serve::state::{UPLOAD_JOBS, UPLOAD_QUEUE};
    const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let data = one_triangle_data("upload-budget");
    let state = state_with_meshes("upload-budget", "local", &data);
    let app = app(state.clone());
    let held: Vec<_> = (0..UPLOAD_JOBS + UPLOAD_QUEUE)
        .map(|_| state.uploads.admit().expect("a place"))
        .collect();
    let (s, body) = post_obj(&app, "/v1/meshes/b", TRI).await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(error_code(&body), "overloaded");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let m = v["message"].as_str().unwrap();
    assert!(m.contains("this server takes at once; retry"), "{m}");
    assert!(!data.join("meshes/b.obj").exists());
    drop(held);
    let (s, _) = post_obj(&app, "/v1/meshes/b", TRI).await;
    assert_eq!(s, StatusCode::CREATED);
    assert_eq!(state.uploads.admitted(), 0, "every ticket given back");
    let _ = std::fs::remove_dir_all(&data);
}

/// `text/plain` is how many clients label any text file: a JSON mesh so labelled was read as
/// OBJ and refused as "no faces"; it is sniffed now, OBJ when nothing is recognised. An empty
/// Content-Type says as little as none, and is sniffed too (it was a 415).
#[tokio::test]
async fn text_and_empty_content_types_are_sniffed() {
    let data = one_triangle_data("upload-labels");
    let app = router_with_meshes("upload-labels", &data);
    let json = r#"{"positions":[0,0,0,1,0,0,0,1,0],"indices":[0,1,2]}"#;
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    // An OBJ whose first line is no OBJ statement sniffs as nothing: still OBJ as text.
    let odd_obj = "s off\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    for (name, ct, body, stored) in [
        ("j", "text/plain; charset=utf-8", json, "j.json"),
        ("o", "text/plain", odd_obj, "o.obj"),
        ("e", "", obj, "e.obj"),
    ] {
        let req = Request::builder()
            .method(Method::POST)
            .uri(format!("/v1/meshes/{name}"))
            .header(header::CONTENT_TYPE, ct)
            .body(Body::from(body))
            .unwrap();
        let res = app.clone().oneshot(req).await.unwrap();
        assert_eq!(res.status(), StatusCode::CREATED, "{ct:?}");
        assert!(data.join("meshes").join(stored).is_file(), "{stored}");
    }
    let _ = std::fs::remove_dir_all(&data);
}

#[tokio::test]
async fn a_bad_mesh_name_is_called_a_mesh_name() {
    let app = router("mesh-name");
    let (s, _, body) = send(&app, Method::POST, "/v1/meshes/a.b", &[]).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["error"], "bad_name");
    assert!(
        v["message"]
            .as_str()
            .unwrap()
            .starts_with("mesh name \"a.b\""),
        "{v}"
    );
    // Percent-encoded, a name or a method is a second URL for one mesh: refused by name.
    for (method, uri, status, code) in [
        (
            Method::GET,
            "/v1/meshes/%63ow",
            StatusCode::BAD_REQUEST,
            "bad_name",
        ),
        (
            Method::POST,
            "/v1/meshes/c%6Fw",
            StatusCode::BAD_REQUEST,
            "bad_name",
        ),
        (
            Method::GET,
            "/v1/meshes/cow/%63urvature",
            StatusCode::NOT_FOUND,
            "unknown_method",
        ),
    ] {
        let (s, _, body) = send(&app, method, uri, &[]).await;
        assert_eq!((s, error_code(&body).as_str()), (status, code), "{uri}");
    }
}

/// tiles.json's tile URLs by the server's setting: the request's Host by default (proxy
/// headers ignored: any client can send them, and the answer is cached), the nearest proxy's
/// `X-Forwarded-*` with `--trust-forwarded`, and `--public-url` over both.
#[tokio::test]
async fn tilejson_urls_follow_the_configured_origin() {
    let served = |config: Config| {
        let mut d = hill_dataset("tilejson-origin", "mercator", &[ROOT]);
        d.name = "merc".into();
        let mut catalog = Catalog::default();
        catalog.insert(d);
        app(AppState::new(catalog, config).unwrap())
    };
    let headers = [
        ("host", "10.0.0.7:8080"),
        ("x-forwarded-proto", "https"),
        ("x-forwarded-host", "spoofed.example, tiles.example.org"),
        ("x-forwarded-prefix", "/dem"),
    ];
    let template = |body: &[u8]| {
        let v: serde_json::Value = serde_json::from_slice(body).unwrap();
        v["tiles"][0].as_str().unwrap().to_string()
    };
    let uri = "/v1/datasets/merc/tiles.json";
    let cases = [
        (Config::default(), "http://10.0.0.7:8080/v1/", Some("Host")),
        (
            Config {
                trust_forwarded: true,
                ..Config::default()
            },
            "https://tiles.example.org/dem/v1/",
            Some("Host, X-Forwarded-Proto, X-Forwarded-Host, X-Forwarded-Prefix"),
        ),
        (
            Config {
                public_url: Some("https://cdn.example/t".into()),
                trust_forwarded: true,
                ..Config::default()
            },
            "https://cdn.example/t/v1/",
            None,
        ),
    ];
    for (config, starts, vary) in cases {
        let (status, h, body) = send(&served(config), Method::GET, uri, &headers).await;
        assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
        let t = template(&body);
        assert!(t.starts_with(starts), "{t} does not start with {starts}");
        let varies: Vec<&str> = h
            .get_all(header::VARY)
            .iter()
            .filter_map(|v| v.to_str().ok())
            .collect();
        match vary {
            Some(v) => assert!(varies.contains(&v), "{varies:?}"),
            None => assert!(!varies.iter().any(|v| v.contains("Host")), "{varies:?}"),
        }
    }
}

/// `layer.json`'s availability, level by level, as (startX, startY, endX, endY).
async fn layer_availability(app: &Router) -> Vec<Vec<[u64; 4]>> {
    let (s, _, body) = get(app, "/v1/datasets/hill/layer.json").await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let corner = |r: &serde_json::Value, k: &str| r[k].as_u64().unwrap();
    v["available"]
        .as_array()
        .unwrap()
        .iter()
        .map(|level| {
            level
                .as_array()
                .unwrap()
                .iter()
                .map(|r| ["startX", "startY", "endX", "endY"].map(|k| corner(r, k)))
                .collect()
        })
        .collect()
}

/// Stored availability starts at the dataset's min zoom and, on mercator, counts rows from
/// the north; layer.json lists every level from 0 with rows from the south (TMS), and the
/// levels above the min zoom are the bounds' tiles.
#[tokio::test]
async fn layer_json_shifts_stored_availability_by_the_min_zoom_and_flips_mercator_rows() {
    let path = hill_file_with(
        "layer-minzoom",
        "mercator",
        &[id(1, 0, 0), id(2, 1, 2), id(2, 1, 3)],
        |m| {
            m.min_zoom = 1;
            m.available = vec![stored(0, 0, 0, 0), stored(1, 2, 1, 3)];
        },
    );
    let app = router_over(Dataset::open(&path).unwrap());
    let levels = layer_availability(&app).await;
    assert_eq!(levels.len(), 3, "{levels:?}");
    // Level 0: the one mercator root, from the tiling.
    assert_eq!(levels[0], vec![[0, 0, 0, 0]]);
    // Level 1 of 2×2: row 0 from the north is row 1 from the south.
    assert_eq!(levels[1], vec![[0, 1, 0, 1]]);
    // Level 2 of 4×4: rows 2..=3 from the north are 0..=1 from the south.
    assert_eq!(levels[2], vec![[1, 0, 1, 1]]);
}

/// Cesium needs every root tile: a geodetic dataset storing one of its two roots still
/// lists both at level 0, while deeper levels are the stored ranges as they are (geodetic
/// rows count from the south already).
#[tokio::test]
async fn layer_json_keeps_every_root_and_geodetic_rows_as_stored() {
    let path = hill_file_with(
        "layer-roots",
        "geodetic",
        &[id(0, 0, 0), id(1, 1, 0)],
        |m| m.available = vec![stored(0, 0, 0, 0), stored(1, 0, 1, 0)],
    );
    let app = router_over(Dataset::open(&path).unwrap());
    let levels = layer_availability(&app).await;
    assert_eq!(levels, vec![vec![[0, 0, 1, 0]], vec![[1, 0, 1, 0]]]);
}

/// The description tells a client what it can ask for: quantized-mesh and layer.json only
/// on a georeferenced dataset, TileJSON only on mercator.
#[tokio::test]
async fn describe_lists_the_formats_and_manifests_the_scheme_allows() {
    for (scheme, terrain, layer, tilejson) in [
        ("local", false, false, false),
        ("geodetic", true, true, false),
        ("mercator", true, true, true),
    ] {
        let app = router_of(&format!("describe-{scheme}"), scheme);
        let (s, _, body) = get(&app, "/v1/datasets/hill").await;
        assert_eq!(s, StatusCode::OK, "{scheme}");
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        let formats: Vec<&str> = v["formats"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f.as_str().unwrap())
            .collect();
        assert_eq!(
            formats.contains(&"terrain"),
            terrain,
            "{scheme}: {formats:?}"
        );
        assert!(
            formats.contains(&"png") && formats.contains(&"ezw"),
            "{formats:?}"
        );
        assert_eq!(
            v["layer_json"].as_str(),
            layer.then_some("/v1/datasets/hill/layer.json"),
            "{scheme}"
        );
        assert_eq!(
            v["tilejson"].as_str(),
            tilejson.then_some("/v1/datasets/hill/tiles.json"),
            "{scheme}"
        );
    }
}

/// A mercator source reaching past ±85.0511° is stored as it came, but TileJSON's bounds end
/// where the XYZ tiles do.
#[tokio::test]
async fn tilejson_bounds_stop_at_the_mercator_latitude_limit() {
    let d = hill_dataset_in(
        "tilejson-clamp",
        "mercator",
        &[ROOT],
        [-10.0, -89.0, 20.0, 89.5],
    );
    let (s, _, body) = send(
        &router_over(d),
        Method::GET,
        "/v1/datasets/hill/tiles.json",
        &[("host", "tiles.example")],
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let b: Vec<f64> = v["bounds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let limit = zerotile_codec::formats::tilejson::MAX_MERCATOR_LATITUDE;
    assert_eq!(b, vec![-10.0, -limit, 20.0, limit]);
}

/// Every tile format answers with its own media type and the bytes its readers expect
/// first, so no extension is routed to another's encoder.
#[tokio::test]
async fn every_format_answers_with_its_media_type_and_magic() {
    let local = router("formats-local");
    let cases: [(&str, &str, &[u8]); 6] = [
        ("png", "image/png", b"\x89PNG"),
        ("json", "application/json", b"{"),
        ("bin", "application/vnd.zerotile.ztm1", b"ZTM1"),
        ("obj", "model/obj", b""),
        ("glb", "model/gltf-binary", b"glTF"),
        ("ezw", "application/vnd.zerotile.ezw", b""),
    ];
    for (ext, media, magic) in cases {
        let uri = format!("/v1/datasets/hill/tiles/0/0/0.{ext}?threshold=4");
        let (s, h, body) = get(&local, &uri).await;
        assert_eq!(
            s,
            StatusCode::OK,
            "{uri}: {}",
            String::from_utf8_lossy(&body)
        );
        assert_eq!(h[header::CONTENT_TYPE], media, "{uri}");
        assert!(body.starts_with(magic) && !body.is_empty(), "{uri}");
        // Only the stream prefix takes byte ranges.
        let ranges = h.get(header::ACCEPT_RANGES).map(|v| v.to_str().unwrap());
        assert_eq!(ranges, (ext == "ezw").then_some("bytes"), "{uri}");
        if ext == "obj" {
            let text = String::from_utf8(body).unwrap();
            assert!(
                text.lines().any(|l| l.starts_with("v ")),
                "OBJ has vertex lines"
            );
        }
    }

    let geo = router_of("formats-geodetic", "geodetic");
    let uri = "/v1/datasets/hill/tiles/0/0/0.terrain?threshold=4";
    let (s, h, _) = get(&geo, uri).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "application/vnd.quantized-mesh");
    // `Accept` decides a .terrain answer, its 406 too: each says so in Vary.
    let (s, h, body) = send(&geo, Method::GET, uri, &[("accept", "image/png")]).await;
    assert_eq!(s, StatusCode::NOT_ACCEPTABLE);
    assert_eq!(error_code(&body), "not_acceptable");
    let vary: Vec<String> = h
        .get_all(header::VARY)
        .iter()
        .flat_map(|v| v.to_str().unwrap().split(','))
        .map(|v| v.trim().to_ascii_lowercase())
        .collect();
    assert!(vary.iter().any(|v| v == "accept"), "{vary:?}");
    // Extensions asked for are named in the media type, as CesiumJS checks.
    let uri = "/v1/datasets/hill/tiles/0/0/0.terrain?threshold=4&extensions=octvertexnormals";
    let (s, h, _) = get(&geo, uri).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(
        h[header::CONTENT_TYPE],
        "application/vnd.quantized-mesh;extensions=octvertexnormals"
    );
}

/// `.ezw` prefixes honour byte ranges (206 with Content-Range, 416 past the end); other
/// formats ignore `Range` and send the whole body.
#[tokio::test]
async fn only_stream_prefixes_are_ranged() {
    let app = router("ranges");
    let ezw = "/v1/datasets/hill/tiles/0/0/0.ezw?threshold=4";
    let (_, _, whole) = get(&app, ezw).await;
    let len = whole.len();
    let (s, h, part) = send(&app, Method::GET, ezw, &[("range", "bytes=2-9")]).await;
    assert_eq!(s, StatusCode::PARTIAL_CONTENT);
    assert_eq!(
        h[header::CONTENT_RANGE],
        format!("bytes 2-9/{len}").as_str()
    );
    assert_eq!(part, whole[2..=9]);
    let past = format!("bytes={len}-");
    let (s, h, body) = send(&app, Method::GET, ezw, &[("range", &past)]).await;
    assert_eq!(s, StatusCode::RANGE_NOT_SATISFIABLE);
    assert_eq!(h[header::CONTENT_RANGE], format!("bytes */{len}").as_str());
    assert_eq!(error_code(&body), "range_not_satisfiable");

    // If-Range: the stream's own (strong) tag keeps the range; another tag, its weak form or
    // a date get the whole body, so a resumed download never splices two builds.
    let (_, h, _) = get(&app, ezw).await;
    let etag = h[header::ETAG].to_str().unwrap().to_string();
    assert!(!etag.starts_with("W/"), "{etag}");
    // The tag names the bytes: T = 5 reads to the same depth as T = 4 (2^-1 m), T = 8 deeper
    // passes only to 2^0 m.
    let tag = |t: &'static str| {
        let app = app.clone();
        async move {
            let uri = format!("/v1/datasets/hill/tiles/0/0/0.ezw?threshold={t}");
            let (_, h, body) = get(&app, &uri).await;
            (h[header::ETAG].to_str().unwrap().to_string(), body)
        }
    };
    assert_eq!(tag("5").await, (etag.clone(), whole.clone()));
    let (eight, eight_body) = tag("8").await;
    assert!(eight != etag && eight_body.len() < len, "{eight}");
    let weak = format!("W/{etag}");
    for (if_range, status) in [
        (etag.as_str(), StatusCode::PARTIAL_CONTENT),
        (weak.as_str(), StatusCode::OK),
        ("\"0000000000000000\"", StatusCode::OK),
        ("Fri, 04 Dec 2026 17:00:00 GMT", StatusCode::OK),
    ] {
        let (s, _, body) = send(
            &app,
            Method::GET,
            ezw,
            &[("range", "bytes=2-9"), ("if-range", if_range)],
        )
        .await;
        assert_eq!(s, status, "If-Range: {if_range}");
        let want = if s == StatusCode::OK {
            &whole[..]
        } else {
            &whole[2..=9]
        };
        assert_eq!(body, want, "If-Range: {if_range}");
    }

    let json = "/v1/datasets/hill/tiles/0/0/0.json?threshold=4";
    let (_, _, full) = get(&app, json).await;
    let (s, h, body) = send(&app, Method::GET, json, &[("range", "bytes=2-9")]).await;
    assert_eq!(s, StatusCode::OK);
    assert!(h.get(header::CONTENT_RANGE).is_none());
    assert_eq!(body, full);
}

/// A client that refuses every coding the server has (`identity;q=0` and nothing else) gets a
/// 406 JSON error, not the answer it was going to get under a 406 status: no tile body, and
/// none of the tile's ETag, Cache-Control or X-Threshold (a cache would keep them).
#[tokio::test]
async fn refusing_every_coding_is_a_406_error_not_a_tile() {
    let app = router("identity-refused");
    // An error answer, too, is the 406's own: not a 404 body under a 406 status.
    for uri in [
        "/v1/datasets/hill/tiles/0/0/0.json?threshold=4",
        "/healthz",
        "/v1/datasets/nope",
    ] {
        let (s, h, body) = send(
            &app,
            Method::GET,
            uri,
            &[("accept-encoding", "identity;q=0")],
        )
        .await;
        assert_eq!(s, StatusCode::NOT_ACCEPTABLE, "{uri}");
        assert_eq!(h[header::CONTENT_TYPE], "application/json", "{uri}");
        assert_eq!(error_code(&body), "not_acceptable", "{uri}");
        for k in [header::ETAG, header::CACHE_CONTROL] {
            assert!(h.get(&k).is_none(), "{uri}: {k}");
        }
        assert!(h.get("x-threshold").is_none(), "{uri}");
    }
    // Counted as what went out: the compression layer's 406 was counted as the handler's 200.
    let (_, _, body) = get(&app, "/metrics").await;
    let text = String::from_utf8(body).unwrap();
    for route in ["/v1/datasets/{name}/tiles/{z}/{x}/{y}", "/healthz"] {
        let series = |status: u16| {
            format!("zerotile_requests_total{{route=\"{route}\",status=\"{status}\"}} 1")
        };
        assert!(text.contains(&series(406)), "{route}: {text}");
        assert!(!text.contains(&series(200)), "{route}: {text}");
    }
    // Refused before the handler: no tile was decoded to be dropped.
    assert!(text.contains("zerotile_tiles_decoded_total 0"), "{text}");
}

/// Meshes and quantized-mesh are gzipped once, when the client accepts it, and say so; the
/// body is the same mesh either way. Other bodies are sent as they are.
#[tokio::test]
async fn meshes_are_gzipped_for_clients_that_accept_it() {
    use std::io::Read;
    let gunzip = |b: &[u8]| {
        let mut out = Vec::new();
        flate2::read::GzDecoder::new(b)
            .read_to_end(&mut out)
            .unwrap();
        out
    };
    let gzip = [("accept-encoding", "gzip")];
    let local = router("gzip-local");
    let geo = router_of("gzip-geodetic", "geodetic");
    for (app, uri, compressed) in [
        (
            &local,
            "/v1/datasets/hill/tiles/0/0/0.json?threshold=4",
            true,
        ),
        (
            &local,
            "/v1/datasets/hill/tiles/0/0/0.obj?threshold=4",
            true,
        ),
        (
            &geo,
            "/v1/datasets/hill/tiles/0/0/0.terrain?threshold=4",
            true,
        ),
        (
            &local,
            "/v1/datasets/hill/tiles/0/0/0.glb?threshold=4",
            false,
        ),
    ] {
        let (_, plain_h, plain) = get(app, uri).await;
        assert!(plain_h.get(header::CONTENT_ENCODING).is_none(), "{uri}");
        let (s, h, body) = send(app, Method::GET, uri, &gzip).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
        if compressed {
            assert_eq!(h[header::CONTENT_ENCODING], "gzip", "{uri}");
            assert!(h[header::VARY]
                .to_str()
                .unwrap()
                .contains("Accept-Encoding"));
            assert_eq!(gunzip(&body), plain, "{uri}");
            assert_ne!(h[header::ETAG], plain_h[header::ETAG], "{uri}");
        } else {
            assert!(h.get(header::CONTENT_ENCODING).is_none(), "{uri}");
            assert_eq!(body, plain, "{uri}");
        }
    }
}

/// `If-Match` is a precondition (RFC 9110 §13.1.1; it was ignored: `"stale"` got a 200, or a
/// 206 with Range): a stream prefix's own strong tag or `*` lets the request (and its range)
/// through; another tag, or a weak one, is a 412 JSON error, before any tile is decoded. The
/// routes whose tags are all weak pass only `*`; an upload with `*` is one over a mesh that
/// exists, and with a tag never passes.
#[tokio::test]
async fn if_match_is_a_precondition() {
    let data = one_triangle_data("if-match");
    let state = state_with_meshes("if-match", "local", &data);
    let app = app(state.clone());
    let failed = |s: StatusCode, h: &axum::http::HeaderMap, body: &[u8], what: &str| {
        assert_eq!(s, StatusCode::PRECONDITION_FAILED, "{what}");
        assert_eq!(h[header::CONTENT_TYPE], "application/json", "{what}");
        assert_eq!(error_code(body), "precondition_failed", "{what}");
    };

    // Refused before the render: nothing decoded.
    let json = "/v1/datasets/hill/tiles/0/0/0.json?threshold=4";
    let (s, h, body) = send(&app, Method::GET, json, &[("if-match", "\"stale\"")]).await;
    failed(s, &h, &body, json);
    assert_eq!(state.metrics.tiles_decoded.load(Relaxed), 0);

    let ezw = "/v1/datasets/hill/tiles/0/0/0.ezw?threshold=4";
    let (_, h, whole) = get(&app, ezw).await;
    let tag = h[header::ETAG].to_str().unwrap().to_string();
    let listed = format!("\"stale\", {tag}");
    let weak = format!("W/{tag}");
    for (if_match, range, status) in [
        (tag.as_str(), None, StatusCode::OK),
        (tag.as_str(), Some("bytes=2-9"), StatusCode::PARTIAL_CONTENT),
        ("*", None, StatusCode::OK),
        (listed.as_str(), None, StatusCode::OK),
        ("\"stale\"", None, StatusCode::PRECONDITION_FAILED),
        (
            "\"stale\"",
            Some("bytes=2-9"),
            StatusCode::PRECONDITION_FAILED,
        ),
        (weak.as_str(), None, StatusCode::PRECONDITION_FAILED),
    ] {
        let mut headers = vec![("if-match", if_match)];
        headers.extend(range.map(|r| ("range", r)));
        let (s, h, body) = send(&app, Method::GET, ezw, &headers).await;
        let what = format!("If-Match: {if_match}, Range: {range:?}");
        match s {
            StatusCode::PRECONDITION_FAILED if status == s => failed(s, &h, &body, &what),
            StatusCode::OK => assert_eq!((s, body), (status, whole.clone()), "{what}"),
            _ => assert_eq!((s, body), (status, whole[2..=9].to_vec()), "{what}"),
        }
    }

    for uri in [
        json,
        "/v1/datasets",
        "/v1/datasets/hill",
        "/v1/meshes/a",
        "/v1/meshes/a/original",
        "/v1/datasets/hill/view?eye=128,128,1000&target=128,129,0&fov=60",
        "/assets/viewer.js",
    ] {
        let (s, h, _) = get(&app, uri).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
        let tag = h[header::ETAG].to_str().unwrap().to_string();
        assert!(tag.starts_with("W/"), "{uri}: {tag}");
        let (s, h, body) = send(&app, Method::GET, uri, &[("if-match", &tag)]).await;
        failed(s, &h, &body, uri);
        let (s, _, _) = send(&app, Method::GET, uri, &[("if-match", "*")]).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
    }

    // The upload: `*` replaces a mesh that exists and creates none; a tag is weak.
    let obj = "v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n";
    let post_with = |name: header::HeaderName, uri: &str, value: &str| {
        let req = Request::builder()
            .method(Method::POST)
            .uri(uri)
            .header(header::CONTENT_TYPE, "model/obj")
            .header(name, value)
            .body(Body::from(obj))
            .unwrap();
        let app = app.clone();
        async move {
            let (parts, body) = app.oneshot(req).await.unwrap().into_parts();
            let body = to_bytes(body, 1 << 20).await.unwrap();
            (parts.status, parts.headers, body)
        }
    };
    let post = |uri: &str, if_match: &str| post_with(header::IF_MATCH, uri, if_match);
    let (s, h, body) = post("/v1/meshes/b", "*").await;
    failed(s, &h, &body, "POST a new mesh, If-Match: *");
    assert_eq!(get(&app, "/v1/meshes/b").await.0, StatusCode::NOT_FOUND);
    let (_, h, _) = get(&app, "/v1/meshes/a").await;
    let (s, h, body) = post("/v1/meshes/a", h[header::ETAG].to_str().unwrap()).await;
    failed(s, &h, &body, "POST over a mesh, If-Match its tag");
    let (s, _, _) = post("/v1/meshes/a", "*").await;
    assert_eq!(s, StatusCode::OK);

    // If-None-Match on an upload (RFC 9110 §13.1.2): `*` creates only, and the
    // description's tag refuses the upload over it; another tag passes.
    let (s, h, body) = post_with(header::IF_NONE_MATCH, "/v1/meshes/a", "*").await;
    failed(s, &h, &body, "POST over a mesh, If-None-Match: *");
    // The tag as read with br refuses a POST sent without Accept-Encoding too.
    let (_, h, _) = send(
        &app,
        Method::GET,
        "/v1/meshes/a",
        &[("accept-encoding", "br")],
    )
    .await;
    let tag = h[header::ETAG].to_str().unwrap().to_string();
    assert!(tag.ends_with("-br\""), "{tag}");
    let (s, h, body) = post_with(header::IF_NONE_MATCH, "/v1/meshes/a", &tag).await;
    failed(s, &h, &body, "POST over a mesh, If-None-Match its br tag");
    let (s, _, _) = post_with(header::IF_NONE_MATCH, "/v1/meshes/a", "\"other\"").await;
    assert_eq!(s, StatusCode::OK);
    let (s, _, _) = post_with(header::IF_NONE_MATCH, "/v1/meshes/c", "*").await;
    assert_eq!(s, StatusCode::CREATED);
    let _ = std::fs::remove_dir_all(&data);
}

/// A request that fails without its `If-Match` (or `If-None-Match: *`) gets its own error
/// with it too, not a 412 (or a 304: RFC 9110 §13.2.1): a view over tiles the dataset lacks
/// (404, known only after its tiles were meshed) and an octree level past the mesh's deepest
/// (400). The same requests that would succeed still get the 412 (or 304).
#[tokio::test]
async fn a_request_failing_anyway_gets_its_error_not_412() {
    let path = hill_file_with("if-match-4xx", "geodetic", &[ROOT], |_| {});
    let data = one_triangle_data("if-match-4xx");
    let state = state_over(Dataset::open(&path).unwrap(), Config::default())
        .with_meshes(crate::serve::meshes::MeshCatalog::open(&data, 1 << 20));
    let app = app(state);
    for (uri, status, code) in [
        (
            "/v1/datasets/hill/view?eye=90,0,1000&target=90,0.01,0&fov=60",
            StatusCode::NOT_FOUND,
            "empty_view",
        ),
        (
            "/v1/meshes/a/octree?level=30",
            StatusCode::BAD_REQUEST,
            "bad_mesh_query",
        ),
        (
            "/v1/datasets/hill/view?eye=-90,0,1000&target=-90,0.01,0&fov=60",
            StatusCode::OK,
            "",
        ),
        ("/v1/meshes/a/octree?level=0", StatusCode::OK, ""),
    ] {
        let (s, _, body) = get(&app, uri).await;
        assert_eq!(s, status, "{uri}: {}", String::from_utf8_lossy(&body));
        let (s, _, body) = send(&app, Method::GET, uri, &[("if-match", "\"stale\"")]).await;
        if status == StatusCode::OK {
            assert_eq!(s, StatusCode::PRECONDITION_FAILED, "{uri}");
            assert_eq!(error_code(&body), "precondition_failed", "{uri}");
        } else {
            assert_eq!(s, status, "{uri} with If-Match");
            assert_eq!(error_code(&body), code, "{uri} with If-Match");
        }
        // `*` matches any representation, and these have none: their error, not a 304.
        let (s, h, body) = send(&app, Method::GET, uri, &[("if-none-match", "*")]).await;
        if status == StatusCode::OK {
            assert_eq!(s, StatusCode::NOT_MODIFIED, "{uri}");
            assert!(body.is_empty() && h.contains_key(header::ETAG), "{uri}");
        } else {
            assert_eq!(s, status, "{uri} with If-None-Match: *");
            assert_eq!(error_code(&body), code, "{uri} with If-None-Match: *");
        }
    }
    let _ = std::fs::remove_dir_all(&data);
}

/// A world scheme's missing root tile is a flat quantized-mesh tile (Cesium asks for every
/// root); in any other format, off the tiling, or below the roots, a missing tile is a 404.
/// A root that exists is meshed, not flattened.
#[tokio::test]
async fn only_a_missing_world_root_is_served_flat() {
    let geo = router_of("flat-root", "geodetic");
    let (s, h, _) = get(&geo, "/v1/datasets/hill/tiles/0/1/0.terrain?threshold=4").await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(
        h["x-triangles"], "2",
        "the missing root is two flat triangles"
    );
    let (s, h, _) = get(&geo, "/v1/datasets/hill/tiles/0/0/0.terrain?threshold=4").await;
    assert_eq!(s, StatusCode::OK);
    let n: usize = h["x-triangles"].to_str().unwrap().parse().unwrap();
    assert!(
        n > 2,
        "the stored root is the hill's mesh, got {n} triangles"
    );
    for uri in [
        "/v1/datasets/hill/tiles/0/1/0.json?threshold=4",
        "/v1/datasets/hill/tiles/0/2/0.terrain?threshold=4",
        "/v1/datasets/hill/tiles/0/0/1.terrain?threshold=4",
    ] {
        refused(&geo, uri, StatusCode::NOT_FOUND, "tile_not_found").await;
    }
}

/// The metadata extension counts child rows from the south (TMS) on every scheme, as
/// CesiumJS reads it; mercator tile rows count from the north.
#[test]
fn child_availability_counts_rows_from_the_south() {
    let rows = |v: serde_json::Value| -> Vec<(u64, u64)> {
        v["available"][0]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| {
                assert_eq!(
                    (r["startX"].clone(), r["startY"].clone()),
                    (r["endX"].clone(), r["endY"].clone())
                );
                (r["startX"].as_u64().unwrap(), r["startY"].as_u64().unwrap())
            })
            .collect()
    };
    // XYZ (1, 0, 0) is the north-west child: TMS row 1. (1, 1, 1) is south-east: row 0.
    let tiles = [id(0, 0, 0), id(1, 0, 0), id(1, 1, 1)];
    let d = hill_dataset("merc-children", "mercator", &tiles);
    let got = rows(render::child_availability(&d, id(0, 0, 0)).unwrap());
    assert_eq!(got, [(0, 1), (1, 0)]);
    // Geodetic rows already count from the south.
    let tiles = [id(0, 0, 0), id(1, 0, 0), id(1, 1, 1)];
    let d = hill_dataset("geo-children", "geodetic", &tiles);
    let mut got = rows(render::child_availability(&d, id(0, 0, 0)).unwrap());
    got.sort_unstable();
    assert_eq!(got, [(0, 0), (1, 1)]);
}

/// A real-looking tile mesh: the bintree mesh of `height(row, col)` at 1 m.
fn bintree_mesh(height: impl Fn(f64, f64) -> f64) -> zerotile_codec::zerotree::TerrainMesh {
    use zerotile_codec::bintree::{self, Hierarchy, TileErrors};
    let g = Grid::new(
        257,
        257,
        (0..257 * 257)
            .map(|k| height((k / 257) as f64, (k % 257) as f64))
            .collect(),
    )
    .unwrap();
    let h = Hierarchy::new(257).unwrap();
    bintree::extract(&h, &TileErrors::exact_above(&h, &g, 1.0), &g, 1.0, None)
}

/// A root without data gets two flat triangles wound like the real meshes beside it, or
/// CesiumJS culls one kind as back faces.
#[test]
fn the_flat_root_mesh_winds_like_a_real_tile_mesh() {
    let real = bintree_mesh(|r, c| (r / 9.0).sin() * 30.0 + c * 0.1);
    assert!(real.triangles.len() > 100);
    let sign = |m: &zerotile_codec::zerotree::TerrainMesh| -> Vec<f64> {
        m.triangles
            .iter()
            .map(|&t| m.signed_area2(t).signum())
            .collect()
    };
    let real_signs = sign(&real);
    let want = real_signs[0];
    assert!(want != 0.0 && real_signs.iter().all(|&s| s == want));
    let flat = render::flat_mesh(257, 5.0);
    assert_eq!(sign(&flat), [want, want]);
    assert!(flat.positions.iter().all(|p| p[2] == 5.0));
}

/// The OBJ / glTF / JSON meshes are z up with x east and y north on every scheme, so their
/// triangles turn counter-clockwise seen from above (a local grid's rows run south: y is
/// minus the row).
#[test]
fn mesh_files_are_counter_clockwise_from_above_on_every_scheme() {
    let mesh = bintree_mesh(|_, c| (c / 7.0).cos() * 20.0);
    for scheme in ["local", "geodetic", "mercator"] {
        let root = ROOT;
        let d = hill_dataset(&format!("ccw-{scheme}"), scheme, &[root]);
        let m = render::tri_mesh(&d, root, &mesh).unwrap();
        // A face normal points up exactly when the face turns counter-clockwise from above.
        assert!(
            m.face_normals().iter().all(|n| n.z > 0.0),
            "{scheme}: a triangle turns clockwise"
        );
    }
}

/// A view query from `key=value` pairs.
fn view_query(pairs: &[(&str, &str)]) -> std::collections::HashMap<String, String> {
    pairs
        .iter()
        .map(|(k, v)| ((*k).to_string(), (*v).to_string()))
        .collect()
}

/// Paper eq. 4 is capped: the largest ratio accepted would ask for more than any relief,
/// and gets [`threshold::MAX_THRESHOLD`] rather than an unbounded T.
#[test]
fn eq4_is_capped_at_the_largest_threshold() {
    let d = hill_dataset("eq4cap", "local", &[ROOT]);
    // The hill's view parameters: a = 2.5, b = 0.
    assert_eq!(threshold::eq4(&d, 10.0), 25.0);
    assert_eq!(threshold::eq4(&d, 0.0), 0.0);
    assert_eq!(
        threshold::eq4(&d, threshold::MAX_RATIO),
        threshold::MAX_THRESHOLD
    );
}

/// Degrees of longitude shrink with the cosine of the latitude: the square footprint of a
/// camera looking straight down at 60°N spans twice as many degrees east–west as
/// north–south, and its area is the square's in metres.
#[test]
fn a_nadir_view_at_60_north_spans_twice_the_degrees_east_as_north() {
    let d = hill_dataset_in("nadir60", "geodetic", &[ROOT], [10.0, 59.0, 12.0, 61.0]);
    let q = view_query(&[("eye", "11,60,1000"), ("target", "11,60,0"), ("fov", "90")]);
    let v = threshold::view_plane(&d, &q).unwrap();
    let extent = |axis: usize| {
        let (lo, hi) = v
            .footprint
            .iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), p| {
                (lo.min(p[axis]), hi.max(p[axis]))
            });
        hi - lo
    };
    // tan(45°) = 1: the square's side is twice the height, 2000 m.
    let metres_per_degree = 111_319.490_793_273_57;
    assert!(
        (extent(1) - 2000.0 / metres_per_degree).abs() < 1e-9,
        "{}",
        extent(1)
    );
    assert!(
        (extent(0) / extent(1) - 2.0).abs() < 1e-9,
        "{}",
        extent(0) / extent(1)
    );
    assert!((v.a_v - 2000.0 * 2000.0).abs() < 1e-3, "{}", v.a_v);
}

/// A_t is the area of the bounds on the sphere whose degree is 111.3 km: the degrees east
/// are scaled by the cosine of the middle latitude, not of an edge. A local grid's is its
/// size in samples.
#[test]
fn the_terrain_area_is_the_bounds_area_on_the_sphere() {
    let nadir = view_query(&[("eye", "12,55,1000"), ("target", "12,55,0"), ("fov", "60")]);
    let d = hill_dataset_in("area", "geodetic", &[ROOT], [10.0, 50.0, 14.0, 60.0]);
    let a_t = threshold::view_plane(&d, &nadir).unwrap().a_t;
    let radius = 111_319.490_793_273_57 * 180.0 / std::f64::consts::PI;
    let (south, north) = (50f64.to_radians(), 60f64.to_radians());
    let sphere = radius * radius * 4f64.to_radians() * (north.sin() - south.sin());
    assert!((a_t / sphere - 1.0).abs() < 5e-3, "{a_t} against {sphere}");

    let local = hill_dataset("area-local", "local", &[ROOT]);
    let q = view_query(&[
        ("eye", "128,128,50"),
        ("target", "128,128,0"),
        ("fov", "60"),
    ]);
    assert_eq!(
        threshold::view_plane(&local, &q).unwrap().a_t,
        256.0 * 256.0
    );
}

/// The view past the horizon stops at the terrain's own diagonal, √(2 A_t), from the eye's
/// foot: a grazing camera's footprint reaches that far (the disk's polygon, within its
/// sides' sag) and no farther.
#[test]
fn a_grazing_view_stops_at_the_terrains_diagonal() {
    let d = hill_dataset("far", "local", &[ROOT]);
    let q = view_query(&[("eye", "128,128,1"), ("target", "200,128,0"), ("fov", "60")]);
    let v = threshold::view_plane(&d, &q).unwrap();
    let reach = v
        .footprint
        .iter()
        .map(|p| (p[0] - 128.0).hypot(p[1] - 128.0))
        .fold(0.0, f64::max);
    let far = (2.0 * 256.0 * 256.0_f64).sqrt();
    let sag = (std::f64::consts::PI / 64.0).cos();
    assert!(
        reach <= far * (1.0 + 1e-12) && reach >= far * sag,
        "{reach} against {far}"
    );
}

/// A source one row high has no area: A_t is floored at one square unit, so the ratio and
/// eq. 4's T stay finite rather than infinite (or NaN with a = 0). A world dataset's: a
/// local one's bounds follow its source_size, at least 2 × 2.
#[test]
fn a_dataset_without_area_still_gets_a_finite_ratio() {
    let d = hill_dataset_in("flat", "geodetic", &[ROOT], [10.0, 45.0, 11.0, 45.0]);
    let q = view_query(&[
        ("eye", "10.5,45,10"),
        ("target", "10.5,45,0"),
        ("fov", "90"),
    ]);
    let v = threshold::view_plane(&d, &q).unwrap();
    assert_eq!(v.a_t, 1.0);
    // The view stops at the diagonal's floor, one unit: the footprint is the disk's
    // 64-gon of radius 1, area 32 · sin(2π / 64).
    let disk = 32.0 * (std::f64::consts::TAU / 64.0).sin();
    assert!((v.ratio - disk).abs() < 1e-9, "{} against {disk}", v.ratio);
}

/// A copy cut short loses its last record: refused whole at open, not per tile later.
#[test]
fn a_truncated_dataset_is_refused_at_open() {
    let path = hill_file("truncated", "local", &[ROOT]);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
    let err = format!("{:#}", Dataset::open(&path).unwrap_err());
    assert!(err.contains("past the end of the file"), "{err}");
}

/// A dataset's name is its file's stem and must follow the name rule, as an ingest's does.
#[test]
fn a_dataset_file_with_a_bad_name_is_refused() {
    let path = hill_file("badname", "local", &[ROOT]);
    let bad = path.with_file_name("bad name.ztd");
    std::fs::rename(&path, &bad).unwrap();
    let err = format!("{:#}", Dataset::open(&bad).unwrap_err());
    assert!(err.contains("dataset name"), "{err}");
}

/// A 257² local grid is one tile at zoom 0: a record at zoom 1 cannot be served.
#[test]
fn tiles_deeper_than_the_tiling_are_refused() {
    let path = hill_file("deep", "local", &[id(1, 0, 0)]);
    let err = format!("{:#}", Dataset::open(&path).unwrap_err());
    assert!(err.contains("deeper than the tiling"), "{err}");
}

/// A tile read returns the record's corners and exactly the EZW stream that was written.
#[test]
fn a_tile_read_returns_the_stored_corners_and_stream() {
    let id = ROOT;
    let path = hill_file("read", "local", &[id]);
    let d = Dataset::open(&path).unwrap();
    let rec = d.read_tile(id).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let e = d.container.entry(id).unwrap();
    // The stream is the record's tail: its last byte is the record's last byte.
    let end = (e.offset + u64::from(e.len)) as usize;
    assert_eq!(rec.stream.last(), bytes[..end].last());
    let g = ezw::decode(&rec.stream, ezw::DecodeLimit::All, ezw::DEFAULT_MAX_SAMPLES).unwrap();
    assert!((g.heights.get(0, 0) - 100.0).abs() < 0.01);
    assert_eq!(rec.corners[0], 100.0);
    assert!(d.read_tile(TileId { z: 0, x: 1, y: 0 }).is_err());
}

/// The version covers the file's size as well as its header: a copy with bytes appended
/// (a botched upload) is a different build to every cache.
#[test]
fn the_version_changes_with_the_file_size() {
    let path = hill_file("version", "local", &[ROOT]);
    let first = Dataset::open(&path).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.push(0);
    std::fs::write(&path, &bytes).unwrap();
    let longer = Dataset::open(&path).unwrap();
    assert_ne!(first.version, longer.version);
    assert_eq!(first.version_tag().len(), 16);
}

/// A local tiling takes rows and columns from `source_size` = [rows, cols], in that order.
#[test]
fn a_local_tiling_is_rows_by_columns() {
    use zerotile_codec::geo::Scheme;
    let mut m = hill_dataset("tiling", "local", &[ROOT]).metadata().clone();
    m.source_size = [300, 600];
    let tiling = m.tiling().unwrap();
    assert_eq!(
        tiling.scheme(),
        Scheme::Local {
            rows: 300,
            cols: 600
        }
    );
    // 599 column steps need 3 tiles of 256 across, 299 row steps 2 down.
    assert_eq!(tiling.tiles_per_axis(tiling.max_zoom()).unwrap(), (3, 2));
}

/// A store object's dataset name is its key's file stem.
#[test]
fn a_store_object_is_named_by_its_file_stem() {
    use object_store::{memory::InMemory, path::Path as ObjectPath, ObjectStore};
    let path = hill_file("object", "local", &[ROOT]);
    let store: std::sync::Arc<dyn ObjectStore> = std::sync::Arc::new(InMemory::new());
    let key = ObjectPath::from("prod/srtm-3.ztd");
    let rt = tokio::runtime::Builder::new_current_thread()
        .build()
        .unwrap();
    rt.block_on(store.put(&key, std::fs::read(&path).unwrap().into()))
        .unwrap();
    let meta = rt.block_on(store.head(&key)).unwrap();
    let d = Dataset::open_object(&store, &meta).unwrap();
    assert_eq!(d.name, "srtm-3");
    assert!(d.read_tile(ROOT).is_ok());
}

/// A view over tiles the dataset lacks meshes the ones it holds: a world dataset with only
/// the western root, seen from above (0°, 0°) across both roots, answers with triangles
/// west of the prime meridian, not an error for the missing eastern root, and welded.
#[tokio::test]
async fn a_view_over_a_missing_tile_meshes_the_tiles_that_exist() {
    let app = router_of("view-missing", "geodetic");
    let uri = "/v1/datasets/hill/view?eye=0,0,3850000&target=0,0,0&fov=60";
    let (status, _, body) = get(&app, uri).await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let xs: Vec<f64> = v["mesh"]["positions"]
        .as_array()
        .unwrap()
        .iter()
        .step_by(3)
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(v["triangles"].as_u64().unwrap() > 0);
    assert!(xs.iter().all(|&x| x <= 0.0), "a vertex east of 0°");
    // Welded: the triangles share their corners, so no two vertices sit at one place.
    let positions = v["mesh"]["positions"].as_array().unwrap();
    let places: std::collections::HashSet<[u64; 2]> = positions
        .chunks(3)
        .map(|p| {
            [
                p[0].as_f64().unwrap().to_bits(),
                p[1].as_f64().unwrap().to_bits(),
            ]
        })
        .collect();
    assert_eq!(places.len(), positions.len() / 3);
    // The footprint spans both roots: ±20° or so around the target.
    let footprint = v["footprint"].as_array().unwrap();
    assert!(footprint.iter().any(|p| p[0].as_f64().unwrap() > 10.0));
}

/// A view of the pole meshes the same zoom whatever the target's longitude: its footprint,
/// a whole turn round the target, is the globe once (it counted the tile column at the
/// turn's ends twice, so a 16-tile zoom passed the cap at some longitudes and not others).
#[tokio::test]
async fn a_view_of_the_pole_meshes_one_zoom_at_any_longitude() {
    let mut tiles = vec![ROOT, id(0, 1, 0)];
    for z in 1..=3u8 {
        for x in 0..(2u32 << z) {
            for y in 0..(1u32 << z) {
                tiles.push(id(z, x, y));
            }
        }
    }
    let app = router_over(hill_dataset("view-pole", "geodetic", &tiles));
    let mut zooms = Vec::new();
    for lon in [0.0, 10.0, -10.0, 22.5, 100.0] {
        let uri = format!("/v1/datasets/hill/view?eye={lon},89,1000000&target={lon},89,0&fov=60");
        let (status, headers, body) = get(&app, &uri).await;
        assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
        zooms.push(headers["x-zoom"].to_str().unwrap().to_string());
    }
    assert!(zooms.iter().all(|z| *z == zooms[0]), "{zooms:?}");
}

/// A footprint that holds no triangle's centroid is answered with the triangles under its
/// middle, across the seam too: with the target past the disk the view reaches and a mesh
/// of a few large triangles, the middle lies past ±180° and was looked for only among
/// triangles not moved a turn round (404 empty_view; 200 away from the seam).
#[tokio::test]
async fn a_view_too_small_for_a_centroid_finds_its_middle_across_the_seam() {
    let path = hill_file_with("view-seam-middle", "geodetic", &[ROOT, id(0, 1, 0)], |m| {
        m.bounds = [179.0, -1.0, -179.0, 1.0];
        m.view = ViewParams { a: 0.0, b: 1e5 };
    });
    let app = router_over(Dataset::open(&path).unwrap());
    for camera in [
        "eye=-177.1,0,1000&target=179.9,0,0&fov=60",
        "eye=177.1,0,1000&target=-179.9,0,0&fov=60",
        "eye=-179.5,0,1000&target=-176.4,0,0&fov=60",
    ] {
        let uri = format!("/v1/datasets/hill/view?{camera}");
        let (status, _, body) = get(&app, &uri).await;
        assert_eq!(
            status,
            StatusCode::OK,
            "{camera}: {}",
            String::from_utf8_lossy(&body)
        );
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert!(v["triangles"].as_u64().unwrap() > 0, "{camera}: {v}");
    }
}

/// A tilted camera with a tiny fov sees the triangles under its target, as a straight-down
/// one does (fov 1e-20° and 1e-300° were 404 empty_view from -71.5,44.3: the footprint's clip
/// rounded it away; 1e-15° gave the triangles). Subnormal fovs too, which were refused as
/// outside (0, 179].
#[tokio::test]
async fn a_tilted_telescope_sees_the_triangles_under_its_target() {
    let path = hill_file_with("view-telescope", "geodetic", &[ROOT], |m| {
        m.bounds = [-72.0, 44.0, -71.0, 45.0];
    });
    let app = router_over(Dataset::open(&path).unwrap());
    for fov in ["1e-15", "1e-20", "1e-300", "1e-310", "5e-324"] {
        for eye in ["-71.5,44.3,3000", "-71.45,44.3,3000", "-71.5,44.5,3000"] {
            let uri = format!("/v1/datasets/hill/view?eye={eye}&target=-71.5,44.5,300&fov={fov}");
            let (status, _, body) = get(&app, &uri).await;
            let camera = format!("eye={eye} fov={fov}");
            assert_eq!(
                status,
                StatusCode::OK,
                "{camera}: {}",
                String::from_utf8_lossy(&body)
            );
            let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
            assert!(v["triangles"].as_u64().unwrap() > 0, "{camera}: {v}");
            assert!(v["a_v"].as_f64().unwrap() < 1e-20, "{camera}: {v}");
        }
    }
}

/// A view meshes the deepest zoom whose tiles over the footprint are few enough: on a
/// world dataset holding zooms 0 and 1, a footprint about 40° wide (a few zoom-1 tiles)
/// is meshed at zoom 1.
#[tokio::test]
async fn a_view_meshes_the_deepest_zoom_that_fits() {
    let mut tiles = vec![ROOT, id(0, 1, 0)];
    for x in 0..4 {
        for y in 0..2 {
            tiles.push(id(1, x, y));
        }
    }
    let app = router_over(hill_dataset("view-zoom", "geodetic", &tiles));
    let uri = "/v1/datasets/hill/view?eye=10,10,3850000&target=10,10,0&fov=60";
    let (status, headers, body) = get(&app, uri).await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    assert_eq!(headers["x-zoom"], "1");
}

/// `png_compression` reaches the PNG route: a server set to `Best` answers with fewer bytes
/// than one set to `Fast` (the default), and both hold the same heights.
#[tokio::test]
async fn png_tiles_follow_the_configured_compression_and_keep_their_heights() {
    use zerotile_codec::formats::terrain_rgb::{self, PngCompression};
    use zerotile_codec::raster::Encoding;

    let mut tiles = Vec::new();
    for compression in [PngCompression::Fast, PngCompression::Best] {
        let config = Config {
            png_compression: compression,
            ..Config::default()
        };
        let state = state_over(hill_dataset("png-compression", "local", &[ROOT]), config);
        let (status, _, body) = get(&app(state), "/v1/datasets/hill/tiles/0/0/0.png").await;
        assert_eq!(status, StatusCode::OK, "{compression:?}");
        let heights = terrain_rgb::decode(&body, Encoding::TerrainRgb, 1 << 20).unwrap();
        tiles.push((body.len(), heights));
    }
    let [(fast_len, fast), (best_len, best)] = &tiles[..] else {
        unreachable!("two servers");
    };
    assert_eq!(Config::default().png_compression, PngCompression::Fast);
    assert!(best_len < fast_len, "best {best_len} B, fast {fast_len} B");
    assert_eq!(best.data(), fast.data());
}

/// A view's tiles are meshed side by side on the render pool: the answer is byte for byte
/// the one a single render thread gives (the weld reads the tiles in order, not as their
/// tasks finish), and no tile is decoded twice when tasks meet on a shared neighbour.
#[tokio::test]
async fn a_view_on_four_render_threads_is_the_one_thread_view_and_decodes_each_tile_once() {
    // Geodetic zoom 2 (45° tiles): a footprint about 40° wide covers a few of them, and
    // their neighbours are shared.
    let all: Vec<TileId> = (0..8)
        .flat_map(|x| (0..4).map(move |y| id(2, x, y)))
        .collect();
    let uri = "/v1/datasets/hill/view?eye=10,10,3850000&target=10,10,0&fov=60";
    let mut runs = Vec::new();
    for threads in [1, 4] {
        let d = hill_dataset(&format!("view-threads-{threads}"), "geodetic", &all);
        let config = Config {
            render_threads: threads,
            ..Config::default()
        };
        let state = state_over(d, config);
        let (status, headers, body) = get(&app(state.clone()), uri).await;
        assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
        assert_eq!(headers["x-zoom"], "2");
        runs.push((state.metrics.tiles_decoded.load(Relaxed), body));
    }
    let [(one_decoded, one_body), (four_decoded, four_body)] = &runs[..] else {
        unreachable!("two runs");
    };
    // More than one tile under the view, each with neighbours: work for the pool.
    assert!(*one_decoded > 5, "{one_decoded} decodes");
    assert_eq!(four_decoded, one_decoded);
    assert!(four_body == one_body, "the views differ");
}

/// A pyramid's shallowest zoom is meshed even when more than MAX_VIEW_TILES of its tiles lie
/// under the footprint: there is no coarser zoom to fall back on. A geodetic dataset of
/// zoom 3 only (22.5° tiles), seen from 12,000 km over (0°, 0°): a footprint of far more
/// than 16 of them, meshed at zoom 3 from the four tiles it holds.
#[tokio::test]
async fn a_view_wider_than_the_tile_cap_still_meshes_the_shallowest_zoom() {
    let tiles: Vec<TileId> = [(7, 3), (8, 3), (7, 4), (8, 4)]
        .map(|(x, y)| id(3, x, y))
        .into();
    let path = hill_file_with("view-minzoom", "geodetic", &tiles, |m| m.min_zoom = 3);
    let app = router_over(Dataset::open(&path).unwrap());
    let uri = "/v1/datasets/hill/view?eye=0,0,12000000&target=0,0,0&fov=60";
    let (status, headers, body) = get(&app, uri).await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    assert_eq!(headers["x-zoom"], "3");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let footprint: Vec<[f64; 2]> = v["footprint"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
        .collect();
    // Tiles across the footprint's box clipped to the data (±180°, ±85°), per axis.
    let span = |k: usize, limit: f64| {
        let (lo, hi) = footprint.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            (lo.min(p[k]), hi.max(p[k]))
        });
        (hi.min(limit) - lo.max(-limit)) / 22.5
    };
    assert!(
        span(0, 180.0) * span(1, 85.0) > 16.0,
        "footprint {footprint:?}"
    );
}

/// openapi.json's view answer lists each format's media type and every header a mesh file
/// comes with (it listed JSON only, and no headers but ETag).
#[tokio::test]
async fn openapi_describes_each_view_format_and_its_headers() {
    let app = router_of("view-openapi", "geodetic");
    let doc: serde_json::Value =
        serde_json::from_str(crate::serve::routes::site::OPENAPI_JSON).unwrap();
    let ok = &doc["paths"]["/v1/datasets/{name}/view"]["get"]["responses"]["200"];
    let documented: Vec<String> = ok["headers"]
        .as_object()
        .unwrap()
        .keys()
        .map(|k| k.to_ascii_lowercase())
        .collect();
    for format in ["json", "glb", "obj"] {
        let uri =
            format!("/v1/datasets/hill/view?eye=0,0,3850000&target=0,0,0&fov=60&format={format}");
        let (s, h, _) = get(&app, &uri).await;
        assert_eq!(s, StatusCode::OK, "{format}");
        let media = h[header::CONTENT_TYPE].to_str().unwrap();
        assert!(
            ok["content"][media].is_object(),
            "{format}: {media} not listed"
        );
        let custom: Vec<&str> = h
            .keys()
            .map(|k| k.as_str())
            .filter(|k| k.starts_with("x-"))
            .collect();
        if format != "json" {
            assert!(custom.contains(&"x-view-ratio"), "{format}: {custom:?}");
        }
        for k in custom {
            assert!(
                documented.iter().any(|d| d == k),
                "{format}: {k} not listed"
            );
        }
    }
}

/// A view whose camera has not moved revalidates to a 304 without touching a tile, and
/// anything that changes the mesh (the camera, the format) changes the tag.
#[tokio::test]
async fn an_unmoved_view_revalidates_without_meshing() {
    let state = state_over(
        hill_dataset("view-etag", "geodetic", &[ROOT]),
        Config::default(),
    );
    let app = app(state.clone());
    let uri = "/v1/datasets/hill/view?eye=0,0,3850000&target=0,0,0&fov=60";
    let (s, h, body) = get(&app, uri).await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    assert_eq!(h[header::CACHE_CONTROL], "public, no-cache");
    let tag = h[header::ETAG].to_str().unwrap().to_string();

    let lookups =
        || state.metrics.cache_hits.load(Relaxed) + state.metrics.cache_misses.load(Relaxed);
    let before = lookups();
    assert!(before > 0, "the first view read no tile");
    // The same camera written differently is the same view.
    let same = "/v1/datasets/hill/view?fov=60.0&target=0,0,0&eye=0,0,3.85e6";
    let (s, h, body) = send(&app, Method::GET, same, &[("if-none-match", &tag)]).await;
    assert_eq!(s, StatusCode::NOT_MODIFIED);
    assert!(body.is_empty());
    assert_eq!(h[header::ETAG], tag.as_str());
    assert_eq!(lookups(), before, "a 304 looked tiles up");
    assert_openapi_has_304("/v1/datasets/{name}/view");

    for other in [
        "/v1/datasets/hill/view?eye=0,0,3850000&target=0,0,0&fov=50",
        "/v1/datasets/hill/view?eye=0,0,3850000&target=0,0,0&fov=60&format=obj",
    ] {
        let (s, h, _) = send(&app, Method::GET, other, &[("if-none-match", &tag)]).await;
        assert_eq!(s, StatusCode::OK, "{other}");
        assert_ne!(h[header::ETAG], tag.as_str(), "{other}");
    }
}

/// The descriptions carry a tag of their bytes: a client polling them gets a 304 while
/// nothing changed, and the manifests keep their minute of freshness beside it.
#[tokio::test]
async fn descriptions_revalidate_with_a_tag_of_their_bytes() {
    let data = one_triangle_data("describe-etag");
    let state = state_with_meshes("describe-etag", "mercator", &data);
    let app = app(state);
    // Vary as a set of lower-case names.
    let vary = |h: &axum::http::HeaderMap| -> std::collections::BTreeSet<String> {
        h.get_all(header::VARY)
            .iter()
            .flat_map(|v| v.to_str().unwrap().split(','))
            .map(|v| v.trim().to_ascii_lowercase())
            .collect()
    };
    for (uri, cache) in [
        ("/v1/datasets", "public, no-cache"),
        ("/v1/datasets/hill", "public, no-cache"),
        ("/v1/datasets/hill/layer.json", "public, max-age=60"),
        ("/v1/datasets/hill/tiles.json", "public, max-age=60"),
        ("/v1/meshes", "public, no-cache"),
        ("/v1/meshes/a", "public, no-cache"),
    ] {
        let template = match uri {
            "/v1/meshes/a" => "/v1/meshes/{name}".to_string(),
            _ => uri.replace("hill", "{name}"),
        };
        assert_openapi_has_304(&template);
        // TileJSON's URLs need a host to start from.
        let host = ("host", "tiles.example");
        let gzip = ("accept-encoding", "gzip");
        let (s, h, body) = send(&app, Method::GET, uri, &[host]).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
        assert_eq!(h[header::CONTENT_TYPE], "application/json", "{uri}");
        assert_eq!(h[header::CACHE_CONTROL], cache, "{uri}");
        serde_json::from_slice::<serde_json::Value>(&body).unwrap();
        let tag = h[header::ETAG].to_str().unwrap().to_string();
        let (s, h, body) = send(&app, Method::GET, uri, &[host, ("if-none-match", &tag)]).await;
        assert_eq!(s, StatusCode::NOT_MODIFIED, "{uri}");
        assert!(body.is_empty(), "{uri}");
        assert_eq!(h[header::CACHE_CONTROL], cache, "{uri}");
        // The 304 repeats the Vary of the 200 a gzip client gets.
        let (_, zipped, _) = send(&app, Method::GET, uri, &[host, gzip]).await;
        let (_, unchanged, _) = send(
            &app,
            Method::GET,
            uri,
            &[host, gzip, ("if-none-match", &tag)],
        )
        .await;
        assert!(vary(&zipped).contains("accept-encoding"), "{uri}");
        assert_eq!(vary(&unchanged), vary(&zipped), "{uri}");
        // A tag of other bytes (a client's copy from before a change) gets the whole answer.
        let other = tag.replace('j', "k");
        let (s, _, _) = send(&app, Method::GET, uri, &[host, ("if-none-match", &other)]).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
    }
    let _ = std::fs::remove_dir_all(&data);
    // TileJSON's URLs follow the request's host: a different host is a different tag.
    let tag_for = |host: &'static str| {
        let app = app.clone();
        async move {
            let (_, h, _) = send(
                &app,
                Method::GET,
                "/v1/datasets/hill/tiles.json",
                &[("host", host)],
            )
            .await;
            h[header::ETAG].to_str().unwrap().to_string()
        }
    };
    assert_ne!(tag_for("a.example").await, tag_for("b.example").await);
}

/// openapi.json lists the 304 of a route that sends an ETag, and the ETag in its 200.
fn assert_openapi_has_304(template: &str) {
    let doc: serde_json::Value =
        serde_json::from_str(crate::serve::routes::site::OPENAPI_JSON).unwrap();
    let r = &doc["paths"][template]["get"]["responses"];
    assert!(r["304"].is_object(), "openapi.json: {template} has no 304");
    assert!(
        r["200"]["headers"]["ETag"].is_object(),
        "openapi.json: {template}'s 200 names no ETag"
    );
}

/// A long bad value is quoted cut, with its length, in every kind of message that echoes
/// one: the answer stays small whatever the client sent.
#[tokio::test]
async fn a_long_bad_value_is_echoed_cut() {
    let data = one_triangle_data("echo-cut");
    let app = router_with_meshes("echo-cut", &data);
    let long = "9".repeat(4000);
    let junk = "x".repeat(4000);
    let controls = "%01".repeat(4000);
    let (bad, missing) = (StatusCode::BAD_REQUEST, StatusCode::NOT_FOUND);
    let media = StatusCode::UNSUPPORTED_MEDIA_TYPE;
    let get = Method::GET;
    let body_type = format!("text/{junk}");
    for (method, uri, headers, status, code) in [
        (
            get.clone(),
            format!("/v1/datasets/hill/tiles/0/0/0.png?threshold={long}"),
            vec![],
            bad,
            "out_of_range",
        ),
        (
            get.clone(),
            format!("/v1/datasets/hill/tiles/0/0/0.png?threshold={junk}"),
            vec![],
            bad,
            "bad_number",
        ),
        (
            get.clone(),
            format!("/v1/datasets/hill/tiles/0/0/0.png?threshold={controls}"),
            vec![],
            bad,
            "bad_number",
        ),
        (
            get.clone(),
            format!("/v1/datasets/hill/tiles/0/0/0.{junk}"),
            vec![],
            missing,
            "unknown_format",
        ),
        (
            get.clone(),
            format!("/v1/datasets/hill/tiles/0/0/%30{junk}.png"),
            vec![],
            bad,
            "bad_tile_address",
        ),
        (
            get.clone(),
            format!("/v1/datasets/{junk}"),
            vec![],
            missing,
            "unknown_dataset",
        ),
        (
            get.clone(),
            format!("/v1/datasets/hill/view?eye={junk}&target=0,0,0&fov=60"),
            vec![],
            bad,
            "bad_vector",
        ),
        (
            Method::POST,
            format!("/v1/meshes/{junk}"),
            vec![],
            bad,
            "bad_name",
        ),
        (
            Method::POST,
            "/v1/meshes/m".to_string(),
            vec![("content-type", body_type.as_str())],
            media,
            "unsupported_media_type",
        ),
    ] {
        let (s, _, body) = send(&app, method, &uri, &headers).await;
        assert_eq!(
            s,
            status,
            "{code}: {}",
            String::from_utf8_lossy(&body[..body.len().min(200)])
        );
        assert_eq!(error_code(&body), code);
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        let m = v["message"].as_str().unwrap();
        assert!(m.len() < 300, "{code}: {} bytes", m.len());
        assert!(m.contains(" bytes)"), "{code}: {m}");
    }
    let _ = std::fs::remove_dir_all(&data);
}

#[tokio::test]
async fn a_browser_may_read_every_header_the_api_answers_with() {
    // A cross-origin script sees only the CORS-safelisted response headers and those listed
    // in Access-Control-Expose-Headers: a 503's Retry-After, a 405's Allow or an upload
    // 415's Accept-Encoding must be listed for a web client to act on them.
    let app = router("expose");
    let origin = [("origin", "https://viewer.example")];
    let (_, tile, _) = send(
        &app,
        Method::GET,
        "/v1/datasets/hill/tiles/0/0/0.bin?threshold=2",
        &origin,
    )
    .await;
    let exposed = tile["access-control-expose-headers"]
        .to_str()
        .unwrap()
        .to_ascii_lowercase();
    let exposed: Vec<&str> = exposed.split(',').map(str::trim).collect();
    let (_, wrong_method, _) = send(&app, Method::PUT, "/v1/meshes/x", &origin).await;
    let safelisted = [
        "cache-control",
        "content-language",
        "content-length",
        "content-type",
        "expires",
        "last-modified",
        "pragma",
    ];
    let plumbing = |n: &str| n.starts_with("access-control-") || ["vary", "date"].contains(&n);
    for h in [&tile, &wrong_method] {
        for name in h.keys().map(|n| n.as_str()) {
            assert!(
                safelisted.contains(&name) || plumbing(name) || exposed.contains(&name),
                "{name} is sent but not exposed: {exposed:?}"
            );
        }
    }
    for name in ["retry-after", "allow", "accept-encoding"] {
        assert!(exposed.contains(&name), "{name}: {exposed:?}");
    }
}

/// A bumpy closed sphere, 200 × 100 quads, as OBJ: its curvature levels take a fraction
/// of a second.
fn bumpy_sphere_obj() -> String {
    let (rings, segments) = (100, 200);
    let mut obj = String::from("v 0 0 1\nv 0 0 -1\n");
    for i in 1..rings {
        for j in 0..segments {
            let (t, p) = (
                std::f64::consts::PI * f64::from(i) / f64::from(rings),
                std::f64::consts::TAU * f64::from(j) / f64::from(segments),
            );
            let r = 1.0 + 0.05 * (7.0 * p).sin() * (5.0 * t).sin();
            obj += &format!(
                "v {} {} {}\n",
                r * t.sin() * p.cos(),
                r * t.sin() * p.sin(),
                r * t.cos()
            );
        }
    }
    let at = |i: u32, j: u32| 3 + (i - 1) * segments + j % segments;
    for j in 0..segments {
        obj += &format!("f 1 {} {}\n", at(1, j), at(1, j + 1));
        obj += &format!("f 2 {} {}\n", at(rings - 1, j + 1), at(rings - 1, j));
        for i in 1..rings - 1 {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
            obj += &format!("f {a} {d} {c}\nf {a} {c} {b}\n");
        }
    }
    obj
}

/// A scratch data folder holding `meshes/bumpy.obj` ([`bumpy_sphere_obj`]) and the state
/// serving it (and the one-tile `hill`).
fn bumpy_state(tag: &str, config: Config) -> (std::path::PathBuf, AppState) {
    let data = crate::fixtures::scratch(tag);
    std::fs::create_dir_all(data.join("meshes")).unwrap();
    std::fs::write(data.join("meshes/bumpy.obj"), bumpy_sphere_obj()).unwrap();
    let state = state_over(hill_dataset(tag, "local", &[ROOT]), config)
        .with_meshes(crate::serve::meshes::MeshCatalog::open(&data, 1 << 20));
    (data, state)
}

/// While one request builds a mesh's curvature levels (a minute on a 2M-face upload), an
/// ask for them is answered at once with 503 `building` and Retry-After, instead of
/// waiting for the build inside a render slot: retries every second filled the slots and
/// shed terrain tiles. Once built, the same ask is served.
#[tokio::test]
async fn an_ask_while_a_lod_is_building_is_told_to_come_back() {
    use crate::serve::meshes::Structure;
    let (data, state) = bumpy_state("lod-building", Config::default());
    let entry = state.meshes.get("bumpy").unwrap();
    let app = app(state);
    let uri = "/v1/meshes/bumpy/curvature?level=2&format=json";

    let first = tokio::spawn({
        let app = app.clone();
        async move { get(&app, uri).await }
    });
    let waited = std::time::Instant::now();
    while entry.building_for(Structure::CurvatureLevels).is_none() {
        assert!(!first.is_finished(), "built before it was seen building");
        assert!(waited.elapsed().as_secs() < 30, "the build never started");
        tokio::time::sleep(std::time::Duration::from_millis(1)).await;
    }
    let (s, h, body) = get(&app, uri).await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(error_code(&body), "building");
    assert_eq!(h[header::RETRY_AFTER], "5");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert!(
        v["message"].as_str().unwrap().contains("curvature levels"),
        "{v}"
    );
    // Other methods and terrain tiles are not held up.
    let (s, _, _) = get(&app, "/v1/datasets/hill/tiles/0/0/0.bin?threshold=2").await;
    assert_eq!(s, StatusCode::OK);

    let (s, h, _) = first.await.unwrap();
    assert_eq!(s, StatusCode::OK);
    assert_eq!(entry.building_for(Structure::CurvatureLevels), None);
    let (s, again, _) = get(&app, uri).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(again["x-faces"], h["x-faces"]);
    let _ = std::fs::remove_dir_all(&data);
}

/// Two first asks at once (curvature levels 1 and 2, as a LOD viewer sends them) both pass
/// the "is it building?" look before either build starts: with the render pool busy they
/// queue, and the second to get a slot used to wait there for the first one's build,
/// holding that slot for the whole build. It is now told `building` as soon as it runs.
#[tokio::test]
async fn asks_admitted_before_a_build_began_do_not_wait_for_it() {
    use crate::serve::meshes::Structure;
    let config = Config {
        cpu_jobs: 2,
        cpu_queue: 8,
        ..Config::default()
    };
    let (data, state) = bumpy_state("lod-building-race", config);
    let entry = state.meshes.get("bumpy").unwrap();
    // Both render slots busy until released.
    let (running_tx, running_rx) = std::sync::mpsc::channel();
    let holds: Vec<_> = (0..2)
        .map(|_| {
            let ticket = state.admit_render().unwrap();
            let (release, wait) = std::sync::mpsc::channel::<()>();
            let running = running_tx.clone();
            let held = std::thread::spawn(move || {
                ticket.run(|| {
                    running.send(()).unwrap();
                    let _ = wait.recv();
                });
            });
            (release, held)
        })
        .collect();
    for _ in 0..2 {
        running_rx.recv().unwrap();
    }
    let app = app(state.clone());
    let ask = |level: u32| {
        let app = app.clone();
        tokio::spawn(async move {
            let uri = format!("/v1/meshes/bumpy/curvature?level={level}&format=json");
            get(&app, &uri).await
        })
    };
    let asks = [ask(1), ask(2)];
    let waited = std::time::Instant::now();
    while state.renders.admitted() < 4 {
        assert!(
            waited.elapsed().as_secs() < 30,
            "the asks were not admitted"
        );
        tokio::time::sleep(std::time::Duration::from_millis(1)).await;
    }
    let mut holds = holds.into_iter();
    let (release, held) = holds.next().unwrap();
    release.send(()).unwrap();
    held.join().unwrap();
    while entry.building_for(Structure::CurvatureLevels).is_none() {
        assert!(waited.elapsed().as_secs() < 30, "the build never started");
        tokio::time::sleep(std::time::Duration::from_millis(1)).await;
    }
    let (release, held) = holds.next().unwrap();
    release.send(()).unwrap();
    held.join().unwrap();

    let mut answers = Vec::new();
    for a in asks {
        let (s, h, body) = a.await.unwrap();
        let code = if s == StatusCode::OK {
            String::new()
        } else {
            error_code(&body)
        };
        answers.push((s, code, h.get(header::RETRY_AFTER).cloned()));
    }
    answers.sort_by_key(|a| a.0);
    assert_eq!(answers[0].0, StatusCode::OK, "{answers:?}");
    assert_eq!(
        (answers[1].0, answers[1].1.as_str()),
        (StatusCode::SERVICE_UNAVAILABLE, "building"),
        "{answers:?}"
    );
    assert_eq!(answers[1].2.as_ref().unwrap(), "5");
    let _ = std::fs::remove_dir_all(&data);
}

/// An answer whose client left while it was computed (or whose request timed out, as a
/// curvature ask on a 2M-face mesh can) is cached all the same: the retry is a hit, not
/// the same work again.
#[tokio::test]
async fn an_answer_outlives_the_client_that_asked_for_it() {
    let (data, state) = bumpy_state("lod-left", Config::default());
    let app = app(state.clone());
    let uri = "/v1/meshes/bumpy/curvature?error=0.2&format=json";
    let asked = tokio::spawn({
        let app = app.clone();
        async move { get(&app, uri).await }
    });
    let waited = std::time::Instant::now();
    while state.renders.admitted() == 0 {
        assert!(
            !asked.is_finished(),
            "answered before it was seen computing"
        );
        assert!(waited.elapsed().as_secs() < 30, "the ask was not admitted");
        tokio::time::sleep(std::time::Duration::from_millis(1)).await;
    }
    asked.abort();
    assert!(asked.await.unwrap_err().is_cancelled());
    while state.renders.admitted() > 0 {
        assert!(waited.elapsed().as_secs() < 60, "the job never finished");
        tokio::time::sleep(std::time::Duration::from_millis(5)).await;
    }
    assert_eq!(state.meshes.answers.len(), 1, "the left answer was cached");
    let (s, h, _) = get(&app, uri).await;
    assert_eq!(s, StatusCode::OK);
    assert!(h["x-faces"].to_str().unwrap().parse::<usize>().unwrap() > 0);
    assert_eq!(state.meshes.answers.len(), 1, "served from the cache");
    let _ = std::fs::remove_dir_all(&data);
}
