//! A CORS preflight names the methods its route answers. The CORS layer has one method list
//! for the whole service, which must hold the upload's POST, so on its own it told a browser
//! that every tile and listing took POST too, and the POST then met a 405. (A CORS layer per
//! route would miss the answers the outer layers make, a timeout's 503 or a 406, which a
//! browser could then not read.)
//!
//! The CORS layer also answers every OPTIONS itself, preflight or not, on any path: a plain
//! OPTIONS was told POST on a route whose Allow said GET, HEAD, and one to a path with no
//! route got a 200.

use axum::extract::{MatchedPath, Request};
use axum::http::header::ACCESS_CONTROL_ALLOW_METHODS;
use axum::http::{HeaderValue, Method};
use axum::middleware::Next;
use axum::response::Response;

/// Middleware, outside the CORS layer: an OPTIONS to a path with no route is the 404 the
/// request it asks about would get; on a route that takes no upload, POST is taken out of
/// the method list (the rest of the list is the CORS layer's, as it wrote it).
pub async fn route_methods(req: Request, next: Next) -> Response {
    use axum::response::IntoResponse;
    if req.method() != Method::OPTIONS {
        return next.run(req).await;
    }
    // The router marks the route it matched before the route's layers run; its fallback
    // has none.
    if req.extensions().get::<MatchedPath>().is_none() {
        return super::error::not_found(req.uri().clone())
            .await
            .into_response();
    }
    let narrow = !takes_uploads(req.uri().path());
    let mut res = next.run(req).await;
    if !narrow {
        return res;
    }
    let listed = res
        .headers()
        .get(ACCESS_CONTROL_ALLOW_METHODS)
        .and_then(|v| v.to_str().ok());
    if let Some(read) = listed.map(without_post) {
        if let Ok(v) = HeaderValue::from_str(&read) {
            res.headers_mut().insert(ACCESS_CONTROL_ALLOW_METHODS, v);
        }
    }
    res
}

/// A method list without POST.
fn without_post(list: &str) -> String {
    list.split(',')
        .map(str::trim)
        .filter(|m| *m != Method::POST.as_str())
        .collect::<Vec<_>>()
        .join(",")
}

/// Whether `path` is `/v1/meshes/{name}`, the one route with a POST. The router's own test
/// (`preflights_name_each_routes_methods`) holds this to the route table.
pub fn takes_uploads(path: &str) -> bool {
    path.strip_prefix("/v1/meshes/")
        .is_some_and(|name| !name.is_empty() && !name.contains('/'))
}

#[cfg(test)]
mod tests {
    use super::{takes_uploads, without_post};

    #[test]
    fn post_is_taken_out_of_a_list_as_written() {
        assert_eq!(without_post("GET,HEAD,OPTIONS,POST"), "GET,HEAD,OPTIONS");
        assert_eq!(without_post("POST, GET"), "GET");
        assert_eq!(without_post("GET"), "GET");
    }

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
