//! A CORS preflight names the methods its route answers. The CORS layer has one method list
//! for the whole service, which must hold the upload's POST, so on its own it told a browser
//! that every tile and listing took POST too, and the POST then met a 405.

use axum::extract::Request;
use axum::http::header::{ACCESS_CONTROL_ALLOW_METHODS, ACCESS_CONTROL_REQUEST_METHOD};
use axum::http::{HeaderValue, Method};
use axum::middleware::Next;
use axum::response::Response;

/// What every route but the upload answers, as the CORS layer spells a list.
const READ_METHODS: &str = "GET,HEAD,OPTIONS";

/// Middleware, outside the CORS layer: narrows a preflight's answer to [`READ_METHODS`] on
/// routes that take no upload.
pub async fn route_methods(req: Request, next: Next) -> Response {
    let narrow = req.method() == Method::OPTIONS
        && req.headers().contains_key(ACCESS_CONTROL_REQUEST_METHOD)
        && !takes_uploads(req.uri().path());
    let mut res = next.run(req).await;
    if narrow && res.headers().contains_key(ACCESS_CONTROL_ALLOW_METHODS) {
        res.headers_mut().insert(
            ACCESS_CONTROL_ALLOW_METHODS,
            HeaderValue::from_static(READ_METHODS),
        );
    }
    res
}

/// Whether `path` is `/v1/meshes/{name}`, the one route with a POST. The router's own test
/// (`preflights_name_each_routes_methods`) holds this to the route table.
pub fn takes_uploads(path: &str) -> bool {
    path.strip_prefix("/v1/meshes/")
        .is_some_and(|name| !name.is_empty() && !name.contains('/'))
}

#[cfg(test)]
mod tests {
    use super::takes_uploads;

    #[test]
    fn only_a_mesh_name_takes_uploads() {
        assert!(takes_uploads("/v1/meshes/bunny"));
        for path in [
            "/v1/meshes",
            "/v1/meshes/",
            "/v1/meshes/bunny/",
            "/v1/meshes/bunny/qem",
            "/v1/datasets/bunny",
            "/healthz",
        ] {
            assert!(!takes_uploads(path), "{path}");
        }
    }
}
