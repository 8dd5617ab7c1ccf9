//! Prometheus counters, written out by hand in the text exposition format (version 0.0.4):
//! a handful of counters and one histogram do not need a metrics framework.

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use axum::extract::{MatchedPath, Request, State};
use axum::middleware::Next;
use axum::response::Response;

use super::state::AppState;

/// Latency histogram bucket bounds, seconds.
const BUCKETS: [f64; 12] = [
    0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 10.0,
];

/// Process-wide counters.
#[derive(Debug, Default)]
pub struct Metrics {
    /// (route template, status) → requests.
    requests: Mutex<BTreeMap<(String, u16), u64>>,
    /// Cumulative counts per bucket, then +Inf.
    latency_buckets: [AtomicU64; BUCKETS.len() + 1],
    latency_sum_micros: AtomicU64,
    latency_count: AtomicU64,
    pub tiles_decoded: AtomicU64,
    /// Renders whose client disconnected before they finished.
    pub renders_cancelled: AtomicU64,
    pub bytes_out: AtomicU64,
    pub cache_hits: AtomicU64,
    pub cache_misses: AtomicU64,
    pub response_cache_hits: AtomicU64,
}

impl Metrics {
    pub fn observe(&self, route: &str, status: u16, elapsed: Duration) {
        if let Ok(mut m) = self.requests.lock() {
            *m.entry((route.to_string(), status)).or_default() += 1;
        }
        let s = elapsed.as_secs_f64();
        for (b, bound) in self.latency_buckets.iter().zip(BUCKETS) {
            if s <= bound {
                b.fetch_add(1, Relaxed);
            }
        }
        if let Some(inf) = self.latency_buckets.last() {
            inf.fetch_add(1, Relaxed);
        }
        self.latency_sum_micros
            .fetch_add(elapsed.as_micros() as u64, Relaxed);
        self.latency_count.fetch_add(1, Relaxed);
    }

    /// The exposition text.
    pub fn render(&self) -> String {
        let mut out = String::new();
        out.push_str("# HELP zerotile_requests_total HTTP requests by route and status.\n");
        out.push_str("# TYPE zerotile_requests_total counter\n");
        if let Ok(m) = self.requests.lock() {
            for ((route, status), n) in m.iter() {
                let _ = writeln!(
                    out,
                    "zerotile_requests_total{{route=\"{}\",status=\"{status}\"}} {n}",
                    escape(route)
                );
            }
        }
        out.push_str("# HELP zerotile_request_duration_seconds Request latency.\n");
        out.push_str("# TYPE zerotile_request_duration_seconds histogram\n");
        for (b, bound) in self.latency_buckets.iter().zip(BUCKETS) {
            let _ = writeln!(
                out,
                "zerotile_request_duration_seconds_bucket{{le=\"{bound}\"}} {}",
                b.load(Relaxed)
            );
        }
        let count = self.latency_count.load(Relaxed);
        let _ = writeln!(
            out,
            "zerotile_request_duration_seconds_bucket{{le=\"+Inf\"}} {count}"
        );
        let _ = writeln!(
            out,
            "zerotile_request_duration_seconds_sum {}",
            self.latency_sum_micros.load(Relaxed) as f64 / 1e6
        );
        let _ = writeln!(out, "zerotile_request_duration_seconds_count {count}");
        for (name, help, v) in [
            (
                "zerotile_tiles_decoded_total",
                "EZW tile decodes (cache misses that decoded).",
                &self.tiles_decoded,
            ),
            (
                "zerotile_response_bytes_total",
                "Response body bytes handed to the connection (compressed where they were; none for HEAD).",
                &self.bytes_out,
            ),
            (
                "zerotile_cache_hits_total",
                "Decoded-tile cache hits.",
                &self.cache_hits,
            ),
            (
                "zerotile_cache_misses_total",
                "Decoded-tile cache misses.",
                &self.cache_misses,
            ),
            (
                "zerotile_response_cache_hits_total",
                "Tiles answered from the encoded-response cache.",
                &self.response_cache_hits,
            ),
            (
                "zerotile_storage_reads_total",
                "Byte-range reads of dataset files or objects.",
                &super::storage::READS,
            ),
            (
                "zerotile_storage_read_bytes_total",
                "Bytes those reads returned.",
                &super::storage::BYTES_READ,
            ),
            (
                "zerotile_renders_cancelled_total",
                "Tile renders stopped early because their client went away.",
                &self.renders_cancelled,
            ),
        ] {
            let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} counter");
            let _ = writeln!(out, "{name} {}", v.load(Relaxed));
        }
        out
    }
}

fn escape(s: &str) -> String {
    s.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// Middleware: counts every request by its route template (not its path, so the label set
/// stays bounded) and status, and times it.
pub async fn track(State(state): State<AppState>, req: Request, next: Next) -> Response {
    let started = Instant::now();
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map_or_else(|| "unmatched".to_string(), |p| p.as_str().to_string());
    let res = next.run(req).await;
    state
        .metrics
        .observe(&route, res.status().as_u16(), started.elapsed());
    // Outside the compression and timeout layers (a 406 from the compression layer was
    // counted as the handler's 200, and a request the timeout ended not at all), so the body
    // here is what goes out: counted as hyper takes it from the body, its bytes after any
    // compression, none for a HEAD (whose body is never read). A tile is one frame, taken as
    // its headers are queued, so one its client then fails to take still counts whole.
    // Counted from the handler's body before, it was the compressed size for tiles gzipped
    // when rendered, the plain size for those compressed on the fly, and the full size for a
    // HEAD.
    let metrics = std::sync::Arc::clone(&state.metrics);
    res.map(|inner| axum::body::Body::new(Counted { inner, metrics }))
}

/// A response body that adds its data frames to `bytes_out` as they are taken, and keeps
/// the body's size hint: hyper writes `Content-Length` from it (a wrapper without one turned
/// every answer chunked).
struct Counted {
    inner: axum::body::Body,
    metrics: std::sync::Arc<Metrics>,
}

impl http_body::Body for Counted {
    type Data = bytes::Bytes;
    type Error = axum::Error;

    fn poll_frame(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Option<Result<http_body::Frame<Self::Data>, Self::Error>>> {
        let polled = std::pin::Pin::new(&mut self.inner).poll_frame(cx);
        if let std::task::Poll::Ready(Some(Ok(frame))) = &polled {
            if let Some(data) = frame.data_ref() {
                self.metrics.bytes_out.fetch_add(data.len() as u64, Relaxed);
            }
        }
        polled
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> http_body::SizeHint {
        self.inner.size_hint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The line of `render()` for `series`, parsed as its value.
    fn value(text: &str, series: &str) -> f64 {
        let line = text
            .lines()
            .find(|l| l.strip_prefix(series).is_some_and(|r| r.starts_with(' ')))
            .unwrap_or_else(|| panic!("no {series} in\n{text}"));
        line[series.len()..].trim().parse().unwrap()
    }

    /// Prometheus buckets are "less than or equal": a request taking exactly a bound counts
    /// in that bucket, and `+Inf` and `_count` hold every request.
    #[test]
    fn a_request_on_a_bucket_bound_counts_in_that_bucket() {
        let m = Metrics::default();
        m.observe("/a", 200, Duration::from_millis(10));
        m.observe("/a", 200, Duration::from_secs(60));
        let text = m.render();
        let bucket = |le: &str| {
            value(
                &text,
                &format!("zerotile_request_duration_seconds_bucket{{le=\"{le}\"}}"),
            )
        };
        assert_eq!(bucket("0.005"), 0.0);
        assert_eq!(bucket("0.01"), 1.0);
        assert_eq!(bucket("10"), 1.0);
        assert_eq!(bucket("+Inf"), 2.0);
        assert_eq!(value(&text, "zerotile_request_duration_seconds_count"), 2.0);
    }

    /// The latency sum is in seconds, kept to the microsecond.
    #[test]
    fn latency_sums_in_seconds() {
        let m = Metrics::default();
        m.observe("/a", 200, Duration::from_micros(1_500));
        m.observe("/b", 404, Duration::from_micros(2_500));
        let text = m.render();
        let sum = value(&text, "zerotile_request_duration_seconds_sum");
        assert!((sum - 0.004).abs() < 1e-9, "{sum}");
    }

    /// Each counter is written under its own name: hits and misses are not confused.
    #[test]
    fn each_counter_reports_its_own_value() {
        let m = Metrics::default();
        m.cache_hits.store(3, Relaxed);
        m.cache_misses.store(5, Relaxed);
        m.tiles_decoded.store(7, Relaxed);
        m.renders_cancelled.store(2, Relaxed);
        m.response_cache_hits.store(11, Relaxed);
        let text = m.render();
        assert_eq!(value(&text, "zerotile_cache_hits_total"), 3.0);
        assert_eq!(value(&text, "zerotile_cache_misses_total"), 5.0);
        assert_eq!(value(&text, "zerotile_tiles_decoded_total"), 7.0);
        assert_eq!(value(&text, "zerotile_renders_cancelled_total"), 2.0);
        assert_eq!(value(&text, "zerotile_response_cache_hits_total"), 11.0);
    }

    /// A label value with a quote, backslash or newline is escaped, so one odd route cannot
    /// break the whole exposition for the scraper.
    #[test]
    fn route_labels_are_escaped() {
        let m = Metrics::default();
        m.observe("/a\"b\\c\nd", 200, Duration::ZERO);
        let text = m.render();
        assert!(
            text.contains(r#"zerotile_requests_total{route="/a\"b\\c\nd",status="200"} 1"#),
            "{text}"
        );
    }
}
