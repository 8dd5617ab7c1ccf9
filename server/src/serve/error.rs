//! The one HTTP error edge: every failure leaves as `{"error": code, "message": text}`.
//!
//! Client faults carry a 4xx status and a message that says what was expected. Server
//! faults (a corrupt tile, a failed encode) are logged in full and leave as a generic 500, so
//! internals never reach a client.

use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::http::{HeaderName, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;

/// Longest piece of a request quoted back in full, in characters as quoted (escapes
/// included); longer ones are cut, so an 8 KiB query value does not come back as an 8 KiB
/// message (and log line).
pub const ECHO_CHARS: usize = 64;

/// `s` quoted for an error message, cut to [`ECHO_CHARS`] with its length said. Cut after
/// escaping: 64 control characters would otherwise come back as 384.
pub fn echo(s: &str) -> String {
    let quoted: String = s.chars().flat_map(char::escape_debug).collect();
    match quoted.char_indices().nth(ECHO_CHARS) {
        None => format!("\"{quoted}\""),
        Some((cut, _)) => format!("\"{}\"… ({} bytes)", &quoted[..cut], s.len()),
    }
}

/// A request that could not be answered.
#[derive(Debug, Clone, PartialEq)]
pub struct ApiError {
    pub status: StatusCode,
    /// Stable, machine-readable: clients switch on it.
    pub code: &'static str,
    /// For people: what was wrong and what is accepted.
    pub message: String,
    /// Headers the status calls for beyond the body (a 415's `Accept-Encoding`).
    pub headers: Vec<(HeaderName, HeaderValue)>,
}

impl ApiError {
    pub fn new(status: StatusCode, code: &'static str, message: impl Into<String>) -> Self {
        Self {
            status,
            code,
            message: message.into(),
            headers: Vec::new(),
        }
    }

    /// The error with `name: value` among its response headers.
    pub fn with_header(mut self, name: HeaderName, value: HeaderValue) -> Self {
        self.headers.push((name, value));
        self
    }

    pub fn bad_request(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, code, message)
    }

    pub fn not_found(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::NOT_FOUND, code, message)
    }

    /// A fault on our side: the detail goes to the log, the client sees a generic message.
    pub fn internal(detail: impl std::fmt::Display) -> Self {
        tracing::error!("internal error: {detail}");
        Self::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            "internal",
            "the server could not produce this response; the failure is logged",
        )
    }
}

impl ApiError {
    /// A failed render: 503 (with Retry-After) when the dataset's store could not be read,
    /// so a cache in front retries another replica or later, or when its file was written
    /// over in place (the rescan it asked for serves the new one); otherwise 500.
    pub fn render(e: anyhow::Error) -> Self {
        // A context's type, which `downcast_ref` finds at any depth of contexts (a chain's
        // links are the wrappers, not the context types).
        if e.downcast_ref::<super::dataset::ChangedOnDisk>().is_some() {
            tracing::warn!("{e:#}: rescanning");
            return Self::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "dataset_changing",
                "the dataset's file is being replaced; retry shortly",
            );
        }
        if let Some(super::storage::RangeMisanswered(what)) = e.downcast_ref() {
            // A store that ignores Range, or answers another one, will not mend on a retry.
            tracing::error!("the data store cannot serve tiles: {e:#}");
            return Self::new(
                StatusCode::BAD_GATEWAY,
                "storage_unsupported",
                format!(
                    "the dataset's storage answered a byte-range read with {what}; serving \
                     from it needs byte ranges; the server's log says more"
                ),
            );
        }
        if e.chain().any(|c| c.is::<object_store::Error>()) {
            if e.chain()
                .any(|c| c.is::<super::store_breaker::NotAnswering>())
            {
                // The breaker said so once when it tripped; not a line a request.
                tracing::debug!("storage unavailable: {e:#}");
            } else {
                tracing::warn!("storage unavailable: {e:#}");
            }
            return Self::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "storage_unavailable",
                "the dataset's storage did not answer; retry shortly",
            );
        }
        Self::internal(format!("{e:#}"))
    }
}

impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}): {}", self.status, self.code, self.message)
    }
}

/// Seconds a client (or a CDN) should wait before retrying a 503: renders are tens of
/// milliseconds, so the queue drains within a second.
pub const RETRY_AFTER_SECONDS: u32 = 1;

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = serde_json::json!({ "error": self.code, "message": self.message });
        let mut res = (self.status, Json(body)).into_response();
        res.extensions_mut().insert(ErrorBody(self.status));
        for (name, value) in self.headers {
            res.headers_mut().append(name, value);
        }
        let told = res.headers().contains_key(axum::http::header::RETRY_AFTER);
        if self.status == StatusCode::SERVICE_UNAVAILABLE && !told {
            res.headers_mut().insert(
                axum::http::header::RETRY_AFTER,
                axum::http::HeaderValue::from(RETRY_AFTER_SECONDS),
            );
        }
        res
    }
}

/// Path extractor failures become the same JSON as every other error.
impl From<PathRejection> for ApiError {
    fn from(r: PathRejection) -> Self {
        Self::bad_request("bad_path", r.body_text())
    }
}

impl From<QueryRejection> for ApiError {
    fn from(r: QueryRejection) -> Self {
        Self::bad_request("bad_query", r.body_text())
    }
}

/// Handler result.
pub type ApiResult<T> = Result<T, ApiError>;

/// Unknown routes: JSON 404, like every other error. A trailing slash is the common slip
/// (`/v1/datasets/`), so the message names the path without it when that is a route; a
/// redirect would cost a CORS round trip and hide the slip from whoever wrote the URL.
pub async fn not_found(uri: axum::http::Uri) -> ApiError {
    let path = uri.path();
    let message = match path.strip_suffix('/') {
        Some(bare) if is_route(bare) => {
            format!("no such route; routes have no trailing slash: try {bare}; see docs/api.md")
        }
        _ => "no such route; see docs/api.md".to_string(),
    };
    ApiError::not_found("not_found", message)
}

/// Whether `path` has the shape of a route: the OpenAPI document's paths, which a test holds
/// to the router's, with a `{param}` standing for any one segment (`/v1/` once got "try /v1",
/// itself a 404).
fn is_route(path: &str) -> bool {
    static TEMPLATES: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
    let templates = TEMPLATES.get_or_init(|| {
        serde_json::from_str::<serde_json::Value>(super::routes::site::OPENAPI_JSON)
            .ok()
            .and_then(|doc| Some(doc.get("paths")?.as_object()?.keys().cloned().collect()))
            .unwrap_or_default()
    });
    templates.iter().any(|t| {
        let (mut want, mut got) = (t.split('/'), path.split('/'));
        loop {
            match (want.next(), got.next()) {
                (None, None) => return true,
                (Some(w), Some(g)) if w == g || (w.starts_with('{') && !g.is_empty()) => {}
                _ => return false,
            }
        }
    })
}

/// Known routes with the wrong method. Routes answer different methods and axum adds their
/// `Allow` header after this runs, so the message points to it rather than naming them.
pub async fn method_not_allowed(method: axum::http::Method) -> ApiError {
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        "method_not_allowed",
        format!("this route does not answer {method}; its Allow header lists the methods it does"),
    )
}

/// Marks a response whose body is an [`ApiError`]'s, with the status it was made for, so
/// [`json_errors`] leaves it alone unless a layer changed that status since.
#[derive(Clone, Copy, Debug)]
struct ErrorBody(StatusCode);

/// Middleware: an error answer made by a layer rather than a handler (a timeout's 503, an
/// extractor's plain-text rejection) is rewritten into the same JSON shape. So is an answer
/// a layer turned into an error after the handler made it: the compression layer's 406 for
/// `Accept-Encoding: identity;q=0` keeps the handler's body and headers (a tile, its ETag
/// and Cache-Control), which must not go out as the error. ([`super::codings`] answers
/// those before the handler runs; this stays the backstop.)
pub async fn json_errors(req: axum::extract::Request, next: axum::middleware::Next) -> Response {
    use axum::http::header;
    let res = next.run(req).await;
    let status = res.status();
    if !(status.is_client_error() || status.is_server_error())
        || res
            .extensions()
            .get::<ErrorBody>()
            .is_some_and(|made| made.0 == status)
    {
        return res;
    }
    let (code, message) = match status {
        // The request limit's answer (tower's timeout layer): say which limit it was.
        StatusCode::SERVICE_UNAVAILABLE => (
            "unavailable",
            Some("the request ran past the server's 30 s limit; retry shortly"),
        ),
        StatusCode::REQUEST_TIMEOUT => ("timeout", None),
        StatusCode::PAYLOAD_TOO_LARGE => ("too_large", None),
        StatusCode::NOT_ACCEPTABLE => (
            "not_acceptable",
            Some(super::codings::NOT_ACCEPTABLE_MESSAGE),
        ),
        s if s.is_server_error() => ("internal", None),
        _ => ("bad_request", None),
    };
    let message = message
        .or(status.canonical_reason())
        .unwrap_or("request failed")
        .to_string();
    let mut out = ApiError::new(status, code, message).into_response();
    // Keep what a layer said about the answer (Vary, Retry-After, Allow); what the handler
    // said about its own body (ETag, Cache-Control, X-Threshold …) is not this body's.
    for k in [header::VARY, header::RETRY_AFTER, header::ALLOW] {
        let said: Vec<_> = res.headers().get_all(&k).iter().cloned().collect();
        if !said.is_empty() {
            out.headers_mut().remove(&k);
            for v in said {
                out.headers_mut().append(k.clone(), v);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::header;
    use axum::routing::get;
    use tower::ServiceExt;

    /// A store that does not answer is a 503 a cache retries after a second, not a 500.
    #[test]
    fn an_unreadable_store_is_a_503_with_retry_after() {
        let e = anyhow::Error::new(object_store::Error::Generic {
            store: "S3",
            source: "connection reset".into(),
        })
        .context("reading tile 3/1/2");
        let err = ApiError::render(e);
        assert_eq!(
            (err.status, err.code),
            (StatusCode::SERVICE_UNAVAILABLE, "storage_unavailable")
        );
        let res = err.into_response();
        assert_eq!(res.headers()[header::RETRY_AFTER], "1");
    }

    /// A store that ignores Range is a 502 without Retry-After: retrying will not help, and
    /// "retry shortly" sent clients round for good. (`storage.rs` tests that both store
    /// clients' ways of saying so come to this error.)
    #[test]
    fn a_store_that_takes_no_ranges_is_a_502_not_a_retry() {
        let e = anyhow::Error::new(super::super::storage::RangeMisanswered("another range"))
            .context("reading bytes 10..20 of a.ztd")
            .context("reading tile 3/1/2");
        let err = ApiError::render(e);
        assert_eq!(
            (err.status, err.code),
            (StatusCode::BAD_GATEWAY, "storage_unsupported")
        );
        assert!(
            err.message.contains("with another range"),
            "{}",
            err.message
        );
        let res = err.into_response();
        assert!(res.headers().get(header::RETRY_AFTER).is_none());
    }

    /// Any other render failure is a 500 that keeps its detail out of the answer.
    #[test]
    fn another_render_failure_is_a_500_without_its_detail() {
        let err = ApiError::render(anyhow::anyhow!("tile 3/1/2 is corrupt at byte 77"));
        assert_eq!(
            (err.status, err.code),
            (StatusCode::INTERNAL_SERVER_ERROR, "internal")
        );
        assert!(!err.message.contains("corrupt"), "{}", err.message);
        let res = err.into_response();
        assert!(res.headers().get(header::RETRY_AFTER).is_none());
    }

    /// `json_errors` rewrites a layer's plain-text error with a code for its status, keeps
    /// the layer's other headers, and leaves JSON errors and successes alone.
    #[tokio::test]
    async fn layer_errors_are_rewritten_with_their_codes_and_headers() {
        let plain = |status: StatusCode| {
            move || async move { (status, [(header::RETRY_AFTER, "5")], "plain text") }
        };
        let app = axum::Router::new()
            .route("/408", get(plain(StatusCode::REQUEST_TIMEOUT)))
            .route("/413", get(plain(StatusCode::PAYLOAD_TOO_LARGE)))
            .route("/503", get(plain(StatusCode::SERVICE_UNAVAILABLE)))
            .route("/502", get(plain(StatusCode::BAD_GATEWAY)))
            .route("/418", get(plain(StatusCode::IM_A_TEAPOT)))
            .route("/ok", get(plain(StatusCode::OK)))
            .route(
                "/json",
                get(|| async { ApiError::not_found("no_such_dataset", "no dataset x") }),
            )
            .layer(axum::middleware::from_fn(json_errors));
        let call = |uri: &'static str| {
            let app = app.clone();
            async move {
                let req = axum::extract::Request::get(uri)
                    .body(axum::body::Body::empty())
                    .unwrap();
                let res = app.oneshot(req).await.unwrap();
                let (parts, body) = res.into_parts();
                let body = axum::body::to_bytes(body, 1 << 16).await.unwrap();
                (parts.status, parts.headers, body)
            }
        };
        for (uri, code) in [
            ("/408", "timeout"),
            ("/413", "too_large"),
            ("/503", "unavailable"),
            ("/502", "internal"),
            ("/418", "bad_request"),
        ] {
            let (status, h, body) = call(uri).await;
            assert_eq!(status.as_str(), &uri[1..]);
            assert_eq!(h[header::CONTENT_TYPE], "application/json", "{uri}");
            let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
            assert_eq!(v["error"], code, "{uri}");
            if code == "unavailable" {
                // Which limit it was, not the bare reason phrase.
                assert!(v["message"].as_str().unwrap().contains("30 s"), "{v}");
            }
            // The layer's own Retry-After wins over the default one.
            assert_eq!(h[header::RETRY_AFTER], "5", "{uri}");
        }
        let (status, _, body) = call("/ok").await;
        assert_eq!((status, &body[..]), (StatusCode::OK, &b"plain text"[..]));
        let (status, _, body) = call("/json").await;
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert_eq!(
            (status, v["error"].as_str()),
            (StatusCode::NOT_FOUND, Some("no_such_dataset"))
        );
    }

    #[test]
    fn short_values_are_quoted_whole_and_long_ones_cut_on_a_char() {
        assert_eq!(echo("png8"), "\"png8\"");
        assert_eq!(echo("a\"b\n"), "\"a\\\"b\\n\"");
        let fits = "a".repeat(ECHO_CHARS);
        assert_eq!(echo(&fits), format!("{fits:?}"));
        // Two-byte characters: the cut falls between them, never inside one.
        let long = "é".repeat(ECHO_CHARS + 1);
        let e = echo(&long);
        assert!(
            e.starts_with(&format!("\"{}\"…", "é".repeat(ECHO_CHARS))),
            "{e}"
        );
        assert!(e.ends_with(&format!("({} bytes)", long.len())), "{e}");
        // Control characters are cut as escaped, not let grow sixfold.
        let controls = "\u{1}".repeat(4 * ECHO_CHARS);
        assert!(
            echo(&controls).len() < ECHO_CHARS + 30,
            "{}",
            echo(&controls)
        );
    }
}
