//! The viewer page at `/`, its assets and the OpenAPI description: static bytes compiled into
//! the binary, so `zerotile serve` needs no files beside it and the page works offline.
//!
//! The vendored libraries under `server/assets/vendor/` are copied from npm packages pinned in
//! `web/package-lock.json` by `web/vendor.mjs` (see `web/README.md`); a fresh `cargo build`
//! reads them from the repository and never runs npm.

use std::hash::{DefaultHasher, Hash, Hasher};
use std::sync::OnceLock;

use axum::extract::rejection::PathRejection;
use axum::extract::Path;
use axum::http::header::{CACHE_CONTROL, CONTENT_TYPE};
use axum::http::HeaderMap;
use axum::response::{IntoResponse, Response};

use crate::serve::codings;
use crate::serve::error::{echo, ApiError, ApiResult};
use crate::serve::revalidate;

/// One embedded file: its name under `/assets/`, media type and bytes.
struct Asset {
    name: &'static str,
    media: &'static str,
    bytes: &'static [u8],
}

const JS: &str = "text/javascript; charset=utf-8";

/// Every file under `/assets/`. The vendor files are what `web/vendor.mjs` copies.
const ASSETS: &[Asset] = &[
    Asset {
        name: "viewer.js",
        media: JS,
        bytes: include_bytes!("../../../assets/viewer.js"),
    },
    Asset {
        name: "viewer.css",
        media: "text/css; charset=utf-8",
        bytes: include_bytes!("../../../assets/viewer.css"),
    },
    Asset {
        name: "vendor/three.module.min.js",
        media: JS,
        bytes: include_bytes!("../../../assets/vendor/three.module.min.js"),
    },
    Asset {
        name: "vendor/OrbitControls.js",
        media: JS,
        bytes: include_bytes!("../../../assets/vendor/OrbitControls.js"),
    },
    Asset {
        name: "vendor/LICENSE-three.txt",
        media: "text/plain; charset=utf-8",
        bytes: include_bytes!("../../../assets/vendor/LICENSE-three.txt"),
    },
];

const INDEX_HTML: &str = include_str!("../../../assets/index.html");

/// The OpenAPI 3 description of every route; `serve::tests` fails when the router registers
/// a path this document does not describe (or the reverse).
pub const OPENAPI_JSON: &str = include_str!("../../../assets/openapi.json");

/// The page is small and changes with the binary: revalidate it every time.
pub async fn index() -> Response {
    (
        [
            (CONTENT_TYPE, "text/html; charset=utf-8"),
            (CACHE_CONTROL, "no-cache"),
        ],
        INDEX_HTML,
    )
        .into_response()
}

pub async fn openapi() -> Response {
    (
        [
            (CONTENT_TYPE, "application/json"),
            (CACHE_CONTROL, "no-cache"),
        ],
        OPENAPI_JSON,
    )
        .into_response()
}

/// Each asset's hash of its bytes, in [`ASSETS`] order, for its ETags.
fn hashes() -> &'static [u64] {
    static HASHES: OnceLock<Vec<u64>> = OnceLock::new();
    HASHES.get_or_init(|| {
        ASSETS
            .iter()
            .map(|a| {
                let mut h = DefaultHasher::new();
                a.bytes.hash(&mut h);
                h.finish()
            })
            .collect()
    })
}

/// `/assets/{*file}`: only the embedded names; anything else (`..`, unknown files) is 404.
/// Their URLs do not change with the binary while `/` does, so they are revalidated like the
/// page (a 304 while the bytes are the same): an upgraded server never gets old scripts run
/// by its new page.
pub async fn asset(
    path: Result<Path<String>, PathRejection>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    let Path(file) = path?;
    let (a, &hash) = ASSETS
        .iter()
        .zip(hashes())
        .find(|(a, _)| a.name == file)
        .ok_or_else(|| {
            ApiError::not_found(
                "not_found",
                format!("no asset {} (GET / for the viewer)", echo(&file)),
            )
        })?;
    let etag = &revalidate::weak_tag('a', hash, codings::of_answer(&headers, a.media));
    if let Some(res) = revalidate::preconditions(&headers, etag, "no-cache")? {
        return Ok(res);
    }
    let mut res = ([(CONTENT_TYPE, a.media)], a.bytes).into_response();
    revalidate::validators(res.headers_mut(), etag, "no-cache")?;
    Ok(res)
}
