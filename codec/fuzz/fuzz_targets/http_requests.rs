//! Every query parser at once: arbitrary paths, queries and negotiation headers through the
//! whole router (in process, on the default data). A request may be refused, never answered
//! with a 5xx other than a 503 that says when to retry, and every refusal is a JSON body.
#![no_main]

use std::sync::OnceLock;

use arbitrary::Arbitrary;
use axum::body::{to_bytes, Body};
use axum::http::{header, HeaderName, HeaderValue, Method, Request, Uri};
use axum::Router;
use libfuzzer_sys::fuzz_target;
use tower::ServiceExt;
use zerotile::serve::{app, meshes::MeshCatalog, AppState, Catalog, Config};

/// Route prefixes, so the fuzzer reaches the parsers behind them rather than 404s.
const PREFIXES: &[&str] = &[
    "",
    "/v1/datasets/demo-ridges/tiles/",
    "/v1/datasets/demo-ridges/tiles/3/5/",
    "/v1/datasets/demo-ridges/view?",
    "/v1/datasets/demo-ridges/",
    "/v1/meshes/uv-sphere/curvature?",
    "/v1/meshes/vase/octree?",
    "/v1/meshes/torus/silhouette?",
    "/v1/meshes/uv-sphere/qem?",
    "/v1/meshes/",
    "/assets/",
];

const HEADERS: &[HeaderName] = &[
    header::ACCEPT,
    header::ACCEPT_ENCODING,
    header::IF_NONE_MATCH,
    header::RANGE,
    header::ORIGIN,
];

#[derive(Arbitrary, Debug)]
struct Ask {
    method: u8,
    prefix: u8,
    rest: String,
    headers: Vec<(u8, String)>,
}

struct World {
    rt: tokio::runtime::Runtime,
    app: Router,
}

fn world() -> &'static World {
    static W: OnceLock<World> = OnceLock::new();
    W.get_or_init(|| {
        // Built once and kept (`zerotile demo-data --data DIR` builds it faster, outside the
        // sanitiser): building it inside the first input would trip libFuzzer's timeout.
        let dir = std::env::var_os("ZEROTILE_FUZZ_DATA").map_or_else(
            || std::env::temp_dir().join("zerotile-fuzz-http"),
            std::path::PathBuf::from,
        );
        zerotile::demo::ensure(&dir, false, false).expect("default data");
        let catalog = Catalog::open_dir(&dir).expect("catalog");
        let config = Config {
            cache_bytes: 64 << 20,
            response_cache_bytes: 64 << 20,
            ..Config::default()
        };
        let meshes = MeshCatalog::open(&dir, config.response_cache_bytes);
        let state = AppState::new(catalog, config).with_meshes(meshes);
        World {
            rt: tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .expect("runtime"),
            app: app(state),
        }
    })
}

fuzz_target!(|ask: Ask| {
    let w = world();
    let method = match ask.method % 4 {
        0 => Method::GET,
        1 => Method::HEAD,
        2 => Method::OPTIONS,
        _ => Method::DELETE,
    };
    let prefix = PREFIXES[usize::from(ask.prefix) % PREFIXES.len()];
    // What hyper would refuse before routing never reaches us.
    let Ok(uri) = Uri::try_from(format!("{prefix}{}", ask.rest)) else {
        return;
    };
    if uri.path_and_query().is_none() || !uri.path().starts_with('/') {
        return;
    }
    let mut req = Request::builder().method(method.clone()).uri(uri);
    for (which, value) in ask.headers.iter().take(6) {
        if let Ok(v) = HeaderValue::from_str(value) {
            req = req.header(&HEADERS[usize::from(*which) % HEADERS.len()], v);
        }
    }
    let Ok(req) = req.body(Body::empty()) else {
        return;
    };
    w.rt.block_on(async {
        let resp = w.app.clone().oneshot(req).await.expect("infallible");
        let status = resp.status();
        let retry = resp.headers().contains_key(header::RETRY_AFTER);
        let json = resp
            .headers()
            .get(header::CONTENT_TYPE)
            .is_some_and(|v| v.as_bytes().starts_with(b"application/json"));
        // An `Accept-Encoding` the fuzzer sent may have compressed the body.
        let encoded = resp.headers().contains_key(header::CONTENT_ENCODING);
        let body = to_bytes(resp.into_body(), 64 << 20).await.expect("body");
        assert!(
            !status.is_server_error() || (status.as_u16() == 503 && retry),
            "{status} for {ask:?}: {}",
            String::from_utf8_lossy(&body)
        );
        // A HEAD answer has the headers of the GET and no body.
        if status.is_client_error() && method != Method::HEAD && !encoded {
            assert!(json, "{status} without a JSON body for {ask:?}");
            let v: serde_json::Value = serde_json::from_slice(&body).unwrap_or_else(|e| {
                panic!(
                    "{status} for {ask:?}: not JSON ({e}): {:?}",
                    String::from_utf8_lossy(&body)
                )
            });
            assert!(v.get("error").is_some(), "error body without `error`: {v}");
        }
    });
});
