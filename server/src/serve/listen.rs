//! The accept loop: hyper's HTTP/1 and HTTP/2 server with a header-read timeout, and a
//! graceful stop.
//!
//! `axum::serve` runs hyper without a timer, which leaves hyper's header-read timeout off: a
//! client that never finished its request headers held its connection (and a task) for as
//! long as it liked. Here a connection whose request headers have not all arrived within
//! [`HEADER_READ_TIMEOUT`] is closed.
//!
//! Hyper also serves an HTTP/1.1 request without a `Host` header, or with two, which RFC 9112
//! §3.2 has a server refuse (such a request names no origin, or an ambiguous one, to the
//! caches and proxies on its way). The rule sits here, on the wire, and not in the router,
//! whose in-process tests build requests without one.

use std::future::Future;
use std::time::Duration;

use axum::extract::Request;
use axum::http::{header::HOST, StatusCode, Version};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::Router;
use hyper_util::rt::{TokioExecutor, TokioIo, TokioTimer};
use hyper_util::server::conn::auto::Builder;
use hyper_util::server::graceful::GracefulShutdown;
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;

/// How long a client may take to send a request's headers (hyper's own default, which it
/// applies only with a timer). Bodies have their own limit (`408` after 20 s).
pub const HEADER_READ_TIMEOUT: Duration = Duration::from_secs(30);

/// Serves `app` on `listener` until `stop` resolves, then stops accepting and waits for the
/// connections' in-flight requests to finish.
pub async fn serve(listener: TcpListener, app: Router, stop: impl Future<Output = ()>) {
    serve_with(listener, app, stop, HEADER_READ_TIMEOUT).await;
}

/// [`serve`] with another header-read timeout (the tests').
pub async fn serve_with(
    listener: TcpListener,
    app: Router,
    stop: impl Future<Output = ()>,
    header_timeout: Duration,
) {
    let mut builder = Builder::new(TokioExecutor::new());
    builder
        .http1()
        .timer(TokioTimer::new())
        .header_read_timeout(header_timeout);
    let app = app.layer(axum::middleware::from_fn(one_host));
    let graceful = GracefulShutdown::new();
    let mut stop = std::pin::pin!(stop);
    loop {
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(e) => {
                    // Out of file descriptors and the like: pause rather than spin.
                    tracing::warn!("accepting a connection: {e}");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                    continue;
                }
            },
            () = &mut stop => break,
        };
        let service = TowerToHyperService::new(app.clone());
        let conn = builder
            .serve_connection_with_upgrades(TokioIo::new(stream), service)
            .into_owned();
        let conn = graceful.watch(conn);
        tokio::spawn(async move {
            if let Err(e) = conn.await {
                tracing::debug!("connection: {e}");
            }
        });
    }
    drop(listener);
    graceful.shutdown().await;
}

/// Middleware: 400 for an HTTP/1.1 request without a `Host` header, or any request with more
/// than one (HTTP/2 names its origin in `:authority` and needs none).
async fn one_host(req: Request, next: Next) -> Response {
    let hosts = req.headers().get_all(HOST).iter().count();
    let (code, problem) = match hosts {
        0 if req.version() == Version::HTTP_11 => {
            ("missing_host", "an HTTP/1.1 request needs a Host header")
        }
        0 | 1 => return next.run(req).await,
        _ => (
            "bad_header",
            "a request may have one Host header, not several",
        ),
    };
    super::error::ApiError::new(StatusCode::BAD_REQUEST, code, problem).into_response()
}

#[cfg(test)]
mod tests {
    use std::io::{Read, Write};
    use std::time::Instant;

    use axum::routing::get;

    use super::*;

    /// `serve_with` answering "hi" on `/` at a free local port, on its own runtime.
    struct Running {
        rt: tokio::runtime::Runtime,
        addr: std::net::SocketAddr,
        stop: tokio::sync::oneshot::Sender<()>,
        server: tokio::task::JoinHandle<()>,
    }

    impl Running {
        fn start(header_timeout: Duration) -> Self {
            let rt = tokio::runtime::Runtime::new().unwrap();
            let listener = rt.block_on(TcpListener::bind("127.0.0.1:0")).unwrap();
            let addr = listener.local_addr().unwrap();
            let (stop, rx) = tokio::sync::oneshot::channel::<()>();
            let app = Router::new().route("/", get(|| async { "hi" }));
            let stopped = async {
                let _ = rx.await;
            };
            let server = rt.spawn(serve_with(listener, app, stopped, header_timeout));
            Self {
                rt,
                addr,
                stop,
                server,
            }
        }

        /// Ends the accept loop and waits for it.
        fn stop(self) {
            self.stop.send(()).unwrap();
            self.rt.block_on(self.server).unwrap();
        }
    }

    /// A client that stops sending halfway through its headers is cut off at the timeout;
    /// one that sends a whole request is answered; the stop ends the loop.
    #[test]
    fn unfinished_headers_are_cut_off_and_whole_requests_answered() {
        let s = Running::start(Duration::from_millis(500));
        let addr = s.addr;

        let mut whole = std::net::TcpStream::connect(addr).unwrap();
        whole
            .write_all(b"GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
            .unwrap();
        let mut answer = String::new();
        whole.read_to_string(&mut answer).unwrap();
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(answer.ends_with("hi"), "{answer}");

        let mut slow = std::net::TcpStream::connect(addr).unwrap();
        slow.set_read_timeout(Some(Duration::from_secs(20)))
            .unwrap();
        slow.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n").unwrap();
        let started = Instant::now();
        let mut rest = Vec::new();
        // Closed by the server (hyper may answer 408 first): not the read timeout's error.
        slow.read_to_end(&mut rest).expect("closed, not left open");
        let waited = started.elapsed();
        assert!(waited < Duration::from_secs(10), "{waited:?}");
        assert!(
            rest.is_empty() || rest.starts_with(b"HTTP/1.1 408"),
            "{}",
            String::from_utf8_lossy(&rest)
        );

        s.stop();
    }

    /// RFC 9112 §3.2: an HTTP/1.1 request without a Host, or any with two, is a 400 with the
    /// API's JSON error; HTTP/1.0, which has no such rule, and one Host are served.
    #[test]
    fn a_request_names_one_host() {
        let server = Running::start(HEADER_READ_TIMEOUT);
        let ask = |head: &str| {
            let mut s = std::net::TcpStream::connect(server.addr).unwrap();
            s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
            s.write_all(format!("{head}Connection: close\r\n\r\n").as_bytes())
                .unwrap();
            let mut answer = String::new();
            s.read_to_string(&mut answer).unwrap();
            answer
        };
        for (head, status, body) in [
            ("GET / HTTP/1.1\r\nHost: x\r\n", "200", "hi"),
            ("GET / HTTP/1.0\r\n", "200", "hi"),
            ("GET / HTTP/1.1\r\n", "400", "\"missing_host\""),
            (
                "GET / HTTP/1.1\r\nHost: x\r\nHost: y\r\n",
                "400",
                "\"bad_header\"",
            ),
            (
                "GET / HTTP/1.0\r\nHost: x\r\nHost: x\r\n",
                "400",
                "\"bad_header\"",
            ),
        ] {
            let answer = ask(head);
            let first = answer.lines().next().unwrap_or_default();
            assert!(first.contains(&format!(" {status} ")), "{head:?}: {answer}");
            assert!(answer.contains(body), "{head:?}: {answer}");
        }
        server.stop();
    }
}
