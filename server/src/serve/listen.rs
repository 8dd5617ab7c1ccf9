//! The accept loop: hyper's HTTP/1 and HTTP/2 server with a header-read timeout, a
//! write-stall timeout, and a graceful stop with a deadline.
//!
//! `axum::serve` runs hyper without a timer, which leaves hyper's header-read timeout off: a
//! client that never finished its request headers held its connection (and a task) for as
//! long as it liked. Here a connection whose request headers have not all arrived within
//! [`HEADER_READ_TIMEOUT`] is closed. Hyper's timer starts only once the connection is known
//! to be HTTP/1, and the auto builder first reads for the HTTP/2 preface with no timer: a
//! client that sent nothing (or part of the preface) was never closed, and 330 of them took a
//! 320-descriptor process off the air. [`FirstRequest`] times the first request from the
//! accept.
//!
//! A client that asks and then stops reading held its answer, a tile of up to a few MB, for
//! as long as it kept the connection open: 400 such clients asking for distinct tiles held
//! 1.3 GB, and one of them kept SIGTERM from ending the process. An HTTP/1 connection whose
//! writes make no progress for [`WRITE_STALL_TIMEOUT`] is closed (a slow reader that takes
//! some bytes in that time is not), and a stop waits at most [`DRAIN_TIMEOUT`] for the
//! connections to finish. HTTP/2 leaves pacing to flow control, which the client owns: its
//! streams are capped at [`HTTP2_MAX_STREAMS`] a connection.
//!
//! Hyper also serves an HTTP/1.1 request without a `Host` header, or with two, which RFC 9112
//! §3.2 has a server refuse (such a request names no origin, or an ambiguous one, to the
//! caches and proxies on its way). The rule sits here, on the wire, and not in the router,
//! whose in-process tests build requests without one.

use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll};
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
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::TcpListener;
use tokio::time::Sleep;
use tokio_io_timeout::TimeoutStream;
use tower::ServiceExt;

/// How long a client may take to send a request's headers, the first request's counted from
/// the accept (hyper's own default, which it applies only with a timer). Bodies have their
/// own limit (`408` after 20 s).
pub const HEADER_READ_TIMEOUT: Duration = Duration::from_secs(30);

/// How long a write to a client may wait for the client to take bytes before the connection
/// is closed: nginx's `send_timeout` is 60 s; a tile is a few MB at most, and a client that
/// takes none of it for 30 s has gone.
pub const WRITE_STALL_TIMEOUT: Duration = Duration::from_secs(30);

/// How long a stop waits for open connections to finish their requests before closing them:
/// under the 30 s an orchestrator commonly gives a process between SIGTERM and SIGKILL, and
/// long enough for any render (tiles take milliseconds, a 2M-face upload seconds).
pub const DRAIN_TIMEOUT: Duration = Duration::from_secs(10);

/// Streams one HTTP/2 connection may have open at once (nginx's `http2_max_concurrent_streams`;
/// hyper's own default is 200).
pub const HTTP2_MAX_STREAMS: u32 = 128;

/// The accept loop's time limits.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    pub header_read: Duration,
    pub write_stall: Duration,
    pub drain: Duration,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            header_read: HEADER_READ_TIMEOUT,
            write_stall: WRITE_STALL_TIMEOUT,
            drain: DRAIN_TIMEOUT,
        }
    }
}

/// Serves `app` on `listener` until `stop` resolves, then stops accepting and waits for the
/// connections' in-flight requests to finish, at most [`DRAIN_TIMEOUT`]. Whether they all
/// did.
pub async fn serve(listener: TcpListener, app: Router, stop: impl Future<Output = ()>) -> bool {
    serve_with(listener, app, stop, Limits::default())
        .await
        .drained
}

/// How a stop went.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stopped {
    /// Every connection finished within the drain deadline.
    pub drained: bool,
    /// Requests whose handler was still running when the deadline cut them off (a long
    /// build, or an upload whose body is still arriving), as against answers a client was
    /// not taking.
    pub answering: usize,
}

/// Counts a request as being answered until its handler returns (or is dropped).
struct Answering(Arc<AtomicUsize>);

impl Answering {
    fn start(n: &Arc<AtomicUsize>) -> Self {
        n.fetch_add(1, Ordering::Relaxed);
        Self(Arc::clone(n))
    }
}

impl Drop for Answering {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

/// [`serve`] with other time limits (the tests').
pub async fn serve_with(
    listener: TcpListener,
    app: Router,
    stop: impl Future<Output = ()>,
    limits: Limits,
) -> Stopped {
    let mut builder = Builder::new(TokioExecutor::new());
    builder
        .http1()
        .timer(TokioTimer::new())
        .header_read_timeout(limits.header_read);
    // Cleartext HTTP/2 is for a proxy in front. Its flow control is the client's: a stream
    // whose window the client keeps shut holds its answer while the connection lives, which
    // no write stalls to show, so the streams of one connection are capped as nginx caps them.
    builder
        .http2()
        .timer(TokioTimer::new())
        .max_concurrent_streams(HTTP2_MAX_STREAMS);
    let answering = Arc::new(AtomicUsize::new(0));
    let counted = Arc::clone(&answering);
    let app = app
        .layer(axum::middleware::from_fn(one_host))
        .layer(axum::middleware::from_fn(
            move |req: Request, next: Next| {
                let busy = Answering::start(&counted);
                async move {
                    let answer = next.run(req).await;
                    drop(busy);
                    answer
                }
            },
        ));
    let graceful = GracefulShutdown::new();
    let mut stop = std::pin::pin!(stop);
    let mut last_warned: Option<std::time::Instant> = None;
    loop {
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(e) => {
                    // Out of file descriptors and the like: pause rather than spin, and say
                    // so every 10 s, not ten times a second.
                    if last_warned.is_none_or(|t| t.elapsed() >= Duration::from_secs(10)) {
                        tracing::warn!("accepting a connection: {e}");
                        last_warned = Some(std::time::Instant::now());
                    }
                    tokio::time::sleep(Duration::from_millis(100)).await;
                    continue;
                }
            },
            () = &mut stop => break,
        };
        // A write pending this long fails the connection, which hyper then closes, dropping
        // the answer it held.
        let mut stream = TimeoutStream::new(stream);
        stream.set_write_timeout(Some(limits.write_stall));
        // A connection silent past the header limit is closed, until its first request.
        let begun = Arc::new(AtomicBool::new(false));
        let stream = FirstRequest::new(Box::pin(stream), limits.header_read, Arc::clone(&begun));
        let service = TowerToHyperService::new(app.clone().map_request(
            move |req: Request<hyper::body::Incoming>| {
                begun.store(true, Ordering::Relaxed);
                req
            },
        ));
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
    let drained = tokio::time::timeout(limits.drain, graceful.shutdown())
        .await
        .is_ok();
    let answering = answering.load(Ordering::Relaxed);
    if !drained {
        // Their tasks end with the runtime.
        let secs = limits.drain.as_secs_f64();
        if answering > 0 {
            tracing::warn!(
                "{answering} request(s) still being handled {secs} s after the stop (a long \
                 build, such as a large mesh's first LOD, or an upload still arriving): \
                 cutting them off"
            );
        } else {
            tracing::warn!(
                "connections still open {secs} s after the stop (a client not reading its \
                 answer, or a request half sent): closing them"
            );
        }
    }
    Stopped { drained, answering }
}

/// What a client opening HTTP/2 sends first; hyper-util reads up to these bytes to tell
/// HTTP/2 from HTTP/1.
const H2_PREFACE: &[u8; 24] = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n";

/// An accepted stream whose reads fail (`TimedOut`, and hyper closes the connection) when
/// its first request has not begun by a deadline from the accept. After that request, or
/// once the HTTP/2 preface has arrived, it only passes bytes through: hyper's timer covers
/// the heads of later HTTP/1 requests, and HTTP/2 is for a proxy in front, which keeps
/// connections open between requests.
struct FirstRequest<S> {
    io: S,
    /// Disarmed (`None`) once a request has begun or the preface has arrived.
    deadline: Option<Pin<Box<Sleep>>>,
    /// Bytes read so far that match the HTTP/2 preface; `None` once one did not (HTTP/1).
    preface: Option<usize>,
    /// Set by the service when it is handed a request.
    begun: Arc<AtomicBool>,
}

impl<S> FirstRequest<S> {
    fn new(io: S, limit: Duration, begun: Arc<AtomicBool>) -> Self {
        Self {
            io,
            deadline: Some(Box::pin(tokio::time::sleep(limit))),
            preface: Some(0),
            begun,
        }
    }

    /// Notes bytes just read: once they complete the HTTP/2 preface the deadline is off; one
    /// that departs from it makes the connection HTTP/1, timed until its first request.
    fn saw(&mut self, bytes: &[u8]) {
        let Some(n) = self.preface else { return };
        let rest = H2_PREFACE.get(n..).unwrap_or_default();
        let k = bytes.len().min(rest.len());
        self.preface = if bytes.get(..k) != rest.get(..k) {
            None
        } else if k == rest.len() {
            self.deadline = None;
            None
        } else {
            Some(n + k)
        };
    }
}

impl<S: AsyncRead + Unpin> AsyncRead for FirstRequest<S> {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        if this.deadline.is_some() && this.begun.load(Ordering::Relaxed) {
            this.deadline = None;
        }
        let before = buf.filled().len();
        let read = Pin::new(&mut this.io).poll_read(cx, buf);
        let Some(deadline) = this.deadline.as_mut() else {
            return read;
        };
        match read {
            Poll::Ready(Ok(())) => {
                this.saw(buf.filled().get(before..).unwrap_or_default());
                Poll::Ready(Ok(()))
            }
            Poll::Pending if deadline.as_mut().poll(cx).is_ready() => {
                Poll::Ready(Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    "no request within the header limit",
                )))
            }
            other => other,
        }
    }
}

impl<S: AsyncWrite + Unpin> AsyncWrite for FirstRequest<S> {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.get_mut().io).poll_write(cx, buf)
    }

    fn poll_write_vectored(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.get_mut().io).poll_write_vectored(cx, bufs)
    }

    fn is_write_vectored(&self) -> bool {
        self.io.is_write_vectored()
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().io).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().io).poll_shutdown(cx)
    }
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

    /// `/slow` handlers started (only the test that asks for it does).
    static SLOW_STARTED: AtomicUsize = AtomicUsize::new(0);

    /// `serve_with` answering "hi" on `/` at a free local port, on its own runtime.
    struct Running {
        rt: tokio::runtime::Runtime,
        addr: std::net::SocketAddr,
        stop: tokio::sync::oneshot::Sender<()>,
        server: tokio::task::JoinHandle<Stopped>,
    }

    impl Running {
        fn start(limits: Limits) -> Self {
            let rt = tokio::runtime::Runtime::new().unwrap();
            let listener = rt.block_on(TcpListener::bind("127.0.0.1:0")).unwrap();
            let addr = listener.local_addr().unwrap();
            let (stop, rx) = tokio::sync::oneshot::channel::<()>();
            let app = Router::new()
                .route("/", get(|| async { "hi" }))
                .route("/big", get(|| async { vec![b'x'; BIG] }))
                .route(
                    "/pause",
                    get(|| async {
                        tokio::time::sleep(PAUSE).await;
                        "paused"
                    }),
                )
                .route(
                    "/slow",
                    get(|| async {
                        SLOW_STARTED.fetch_add(1, Ordering::Relaxed);
                        tokio::time::sleep(Duration::from_secs(30)).await;
                        "late"
                    }),
                );
            let stopped = async {
                let _ = rx.await;
            };
            let server = rt.spawn(serve_with(listener, app, stopped, limits));
            Self {
                rt,
                addr,
                stop,
                server,
            }
        }

        /// Ends the accept loop and waits for it.
        fn stop(self) -> Stopped {
            self.stop.send(()).unwrap();
            self.rt.block_on(self.server).unwrap()
        }
    }

    /// A client that stops sending halfway through its headers is cut off at the timeout;
    /// one that sends a whole request is answered; the stop ends the loop.
    #[test]
    fn unfinished_headers_are_cut_off_and_whole_requests_answered() {
        let s = Running::start(Limits {
            header_read: Duration::from_millis(500),
            ..Limits::default()
        });
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

    /// How long `/pause` takes to answer.
    const PAUSE: Duration = Duration::from_millis(1500);

    /// A client that connects and sends nothing, or only the start of the HTTP/2 preface, is
    /// cut off at the header limit (hyper's timer waits for the HTTP version to be known:
    /// both were left open for good). The limit is on a request's arrival: one whose handler
    /// outlasts it is answered, and so is a second request on the connection.
    #[test]
    fn a_connection_that_sends_no_request_is_cut_off() {
        let s = Running::start(Limits {
            header_read: Duration::from_millis(500),
            ..Limits::default()
        });
        for sent in [&b""[..], b"PRI * HTTP/2"] {
            let mut c = std::net::TcpStream::connect(s.addr).unwrap();
            c.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
            c.write_all(sent).unwrap();
            let started = Instant::now();
            let mut rest = Vec::new();
            c.read_to_end(&mut rest)
                .unwrap_or_else(|e| panic!("{sent:?}: not closed: {e}"));
            let waited = started.elapsed();
            assert!(waited < Duration::from_secs(10), "{sent:?}: {waited:?}");
            assert!(rest.is_empty(), "{}", String::from_utf8_lossy(&rest));
        }

        let mut c = ask(s.addr, "/pause");
        let mut answer = Vec::new();
        let mut chunk = [0; 4096];
        while !answer.ends_with(b"paused") {
            match c.read(&mut chunk).unwrap() {
                0 => break,
                n => answer.extend_from_slice(&chunk[..n]),
            }
        }
        let answer = String::from_utf8_lossy(&answer);
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(answer.ends_with("paused"), "{answer}");
        c.write_all(b"GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
            .unwrap();
        let mut answer = String::new();
        c.read_to_string(&mut answer).unwrap();
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(answer.ends_with("hi"), "{answer}");
        s.stop();
    }

    /// `/big`'s length: more than the socket buffers of both ends take from a client that
    /// reads none (Linux's defaults grow to 4 MB sending, 6 MB receiving).
    const BIG: usize = 32 << 20;

    /// Sends `GET path` on a new connection.
    fn ask(addr: std::net::SocketAddr, path: &str) -> std::net::TcpStream {
        let mut c = std::net::TcpStream::connect(addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        c.write_all(format!("GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").as_bytes())
            .unwrap();
        c
    }

    /// Reads until the server closes (or resets) the connection; what arrived.
    fn drain(c: &mut std::net::TcpStream) -> usize {
        let mut buf = vec![0; 1 << 20];
        let mut got = 0;
        loop {
            match c.read(&mut buf) {
                Ok(0) => return got,
                Ok(n) => got += n,
                Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => return got,
                Err(e) => panic!("not closed: {e} after {got} bytes"),
            }
        }
    }

    /// A client that asks and stops reading is cut off once its writes stall, with most of
    /// the answer never sent (the server no longer holds it); one that reads slowly, never
    /// stalling the writes that long, gets all of it.
    #[test]
    fn a_client_that_stops_reading_is_cut_off_and_a_slow_one_is_not() {
        let s = Running::start(Limits {
            // Far from the slow reader's 300 ms pauses, on a busy machine too.
            write_stall: Duration::from_millis(2000),
            ..Limits::default()
        });
        let mut gone = ask(s.addr, "/big");
        std::thread::sleep(Duration::from_millis(4000));
        let got = drain(&mut gone);
        assert!(got < BIG / 2, "{got} bytes of {BIG}");

        let mut slow = ask(s.addr, "/big");
        let mut chunk = vec![0; 4 << 20];
        let mut got = 0;
        while got < BIG {
            std::thread::sleep(Duration::from_millis(300));
            match slow.read(&mut chunk).unwrap() {
                0 => break,
                n => got += n,
            }
        }
        assert!(got > BIG, "the whole answer and its head: {got} bytes");
        s.stop();
    }

    /// A stop ends within the drain deadline while a client holds an answer it does not read
    /// and another has sent half a request (each kept the process up: 30 s and for ever).
    #[test]
    fn a_stop_waits_for_open_connections_only_so_long() {
        let s = Running::start(Limits {
            drain: Duration::from_millis(1000),
            ..Limits::default()
        });
        let _stalled = ask(s.addr, "/big");
        let mut half = std::net::TcpStream::connect(s.addr).unwrap();
        half.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n").unwrap();
        std::thread::sleep(Duration::from_millis(300));
        let started = Instant::now();
        let stopped = s.stop();
        let took = started.elapsed();
        assert!(took < Duration::from_secs(8), "{took:?}");
        assert!(
            took >= Duration::from_millis(900),
            "waited for them: {took:?}"
        );
        // Answers not taken, no handler running: the log blames the clients.
        assert_eq!(
            stopped,
            Stopped {
                drained: false,
                answering: 0
            }
        );
    }

    /// A request whose handler outlives the drain deadline is counted as being answered, so
    /// the stop's warning says a build was cut off (it blamed a client not reading). A
    /// handler that returned is not counted (the test above).
    #[test]
    fn a_stop_tells_a_long_handler_from_a_client_not_reading() {
        let s = Running::start(Limits {
            drain: Duration::from_millis(500),
            ..Limits::default()
        });
        let _slow = ask(s.addr, "/slow");
        // Until the handler has the request (2 busy cores can take a while).
        let started = Instant::now();
        while SLOW_STARTED.load(Ordering::Relaxed) == 0 {
            assert!(started.elapsed() < Duration::from_secs(10), "never handled");
            std::thread::sleep(Duration::from_millis(20));
        }
        assert_eq!(
            s.stop(),
            Stopped {
                drained: false,
                answering: 1
            }
        );
    }

    /// RFC 9112 §3.2: an HTTP/1.1 request without a Host, or any with two, is a 400 with the
    /// API's JSON error; HTTP/1.0, which has no such rule, and one Host are served.
    #[test]
    fn a_request_names_one_host() {
        let server = Running::start(Limits::default());
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
