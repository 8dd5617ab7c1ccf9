//! Names in URLs are sent as they are. Every character a dataset or mesh name may hold
//! (A–Z, a–z, 0–9, `-`, `_`) is unreserved, so a percent-encoded name (`%6E44` for `n44`)
//! is only a second URL for the same resource: a second entry in every cache before the
//! server, and a second ETag space. Tile addresses are held to the same rule by their
//! handler (`bad_tile_address`); a mesh's method is a fixed word and follows it too.

use axum::extract::Request;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::error::{echo, ApiError};

/// Middleware: a percent-encoded dataset or mesh name (400 `bad_name`) or mesh method (404
/// `unknown_method`, as for any other word that is not one) never reaches a handler, which
/// would see it decoded.
pub async fn plain_names(req: Request, next: Next) -> Response {
    match encoded_segment(req.uri().path()) {
        Some(e) => {
            // An upload still sending would get a broken pipe instead of the answer.
            super::routes::meshes::drain(req.into_body());
            e.into_response()
        }
        None => next.run(req).await,
    }
}

fn encoded_segment(path: &str) -> Option<ApiError> {
    let (kind, rest) = [("dataset", "/v1/datasets/"), ("mesh", "/v1/meshes/")]
        .into_iter()
        .find_map(|(kind, prefix)| Some((kind, path.strip_prefix(prefix)?)))?;
    let mut segments = rest.split('/');
    let name = segments.next().unwrap_or_default();
    if name.contains('%') {
        return Some(ApiError::bad_request(
            "bad_name",
            format!(
                "a {kind} name is sent as it is, not percent-encoded (names hold only A–Z, \
                 a–z, 0–9, '-' and '_'): got {}",
                echo(name)
            ),
        ));
    }
    let method = segments
        .next()
        .filter(|m| kind == "mesh" && m.contains('%'));
    method.map(|m| {
        ApiError::not_found(
            "unknown_method",
            format!(
                "a mesh method is sent as it is, not percent-encoded: got {}; see \
                 /v1/meshes/{name} for the methods",
                echo(m)
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn code(path: &str) -> Option<(u16, &'static str)> {
        encoded_segment(path).map(|e| (e.status.as_u16(), e.code))
    }

    #[test]
    fn only_encoded_names_and_methods_are_refused() {
        for plain in [
            "/v1/datasets/n44",
            "/v1/datasets/n44/tiles/0/0/0.png",
            "/v1/meshes/cow/curvature",
            "/v1/meshes",
            "/assets/a%20b.js",
            // The tile handler names its own address errors.
            "/v1/datasets/n44/tiles/%30/0/0.png",
        ] {
            assert_eq!(code(plain), None, "{plain}");
        }
        for (path, want) in [
            ("/v1/datasets/%6E44", (400, "bad_name")),
            ("/v1/datasets/n%344/tiles/0/0/0.png", (400, "bad_name")),
            ("/v1/meshes/c%6Fw", (400, "bad_name")),
            ("/v1/meshes/cow/%63urvature", (404, "unknown_method")),
            ("/v1/datasets/a%20b", (400, "bad_name")),
        ] {
            assert_eq!(code(path), Some(want), "{path}");
        }
    }
}
