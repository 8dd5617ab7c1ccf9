//! The content codings answers go out in, and the 406 for a client that accepts none.
//!
//! The compression layer answers such a client 406 (RFC 9110 §12.5.3), but only once the
//! handler has made its answer: a tile was decoded and meshed to be dropped. The middleware
//! here gives the 406 first, on the compression layer's own decision (asked on the request's
//! `Accept-Encoding`), so the two cannot disagree on which clients get one.

use std::convert::Infallible;

use axum::body::Body;
use axum::extract::Request;
use axum::http::header::ACCEPT_ENCODING;
use axum::http::StatusCode;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use tower::{Layer, ServiceExt};
use tower_http::compression::CompressionLayer;

use super::error::ApiError;

/// What the 406 says, whichever layer made it.
pub const NOT_ACCEPTABLE_MESSAGE: &str =
    "no content coding the client accepts: this server sends gzip, br or identity";

/// The codings the server compresses with: the app's compression layer and the probe below
/// are both built from it.
pub fn layer() -> CompressionLayer {
    CompressionLayer::new()
}

/// Middleware, inside the compression layer: a request accepting no coding the server has
/// is answered 406 without running its handler.
pub async fn refuse_unacceptable(req: Request, next: Next) -> Response {
    if accepts_a_coding(&req).await {
        next.run(req).await
    } else {
        // An upload still sending would get a broken pipe instead of the answer.
        super::routes::meshes::drain(req.into_body());
        ApiError::new(
            StatusCode::NOT_ACCEPTABLE,
            "not_acceptable",
            NOT_ACCEPTABLE_MESSAGE,
        )
        .into_response()
    }
}

/// Asks the compression layer, around an empty answer, what it would do with this request.
/// Only a header with a weight can refuse identity (`identity;q=0`, `*;q=0`): without one,
/// as browsers and curl send it, there is nothing to ask, and tile requests skip the probe.
fn accepts_a_coding(req: &Request) -> impl std::future::Future<Output = bool> + Send {
    let weighted = req.headers().get_all(ACCEPT_ENCODING).iter().any(|v| {
        v.as_bytes()
            .windows(2)
            .any(|w| w.eq_ignore_ascii_case(b"q="))
    });
    // Built before the await: a `&Request` (its body is not `Sync`) cannot be held across it.
    let probe = weighted.then(|| {
        let mut probe = Request::new(Body::empty());
        for v in req.headers().get_all(ACCEPT_ENCODING) {
            probe.headers_mut().append(ACCEPT_ENCODING, v.clone());
        }
        probe
    });
    async move {
        let Some(probe) = probe else {
            return true;
        };
        let empty = tower::service_fn(|_: Request| async {
            Ok::<_, Infallible>(Response::new(Body::empty()))
        });
        layer()
            .layer(empty)
            .oneshot(probe)
            .await
            .map_or(true, |res| res.status() != StatusCode::NOT_ACCEPTABLE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    async fn accepts(values: &[&str]) -> bool {
        let mut req = Request::new(Body::empty());
        for v in values {
            req.headers_mut()
                .append(ACCEPT_ENCODING, v.parse().unwrap());
        }
        accepts_a_coding(&req).await
    }

    #[tokio::test]
    async fn only_a_client_refusing_every_coding_is_refused() {
        for ok in [
            &[][..],
            &["gzip"],
            &["identity;q=0, gzip"],
            &["*;q=0, br"],
            &["identity;q=0", "gzip"],
            &["deflate"],
            &[""],
        ] {
            assert!(accepts(ok).await, "{ok:?}");
        }
        for refused in [
            &["identity;q=0"][..],
            &["*;q=0"],
            &["identity;q=0, gzip;q=0, br;q=0"],
            &["deflate, identity;q=0"],
        ] {
            assert!(!accepts(refused).await, "{refused:?}");
        }
    }
}
