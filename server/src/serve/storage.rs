//! Where a dataset's bytes live: a local file (the default) or an object in a store reached
//! by URL (`s3://bucket/prefix` on AWS or any S3-compatible server, or `http(s)://` with
//! WebDAV listing and range support).
//!
//! Every read is one byte range: the header once at open, then one record per tile. A remote
//! dataset is never downloaded whole, and a replica needs no disk.

use std::fs::File;
use std::os::unix::fs::FileExt;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, OnceLock};

use anyhow::{Context, Result};
use object_store::path::Path as ObjectPath;
use object_store::ObjectStore;

/// A dataset's bytes.
#[derive(Debug)]
pub enum Source {
    /// A local file, held open: a re-ingest renames a new file over the path, and this handle
    /// keeps reading the very file whose index was parsed (a path-based reader would mix a new
    /// file's records with the old index).
    File(File),
    /// An object in a store. Records are CRC-checked against the index read at start, so an
    /// object replaced in place fails its tiles loudly rather than serving a mix.
    Object {
        store: Arc<dyn ObjectStore>,
        path: ObjectPath,
    },
}

/// Bytes read from every source since start, for `/metrics`: shows that tiles cost ranges,
/// not whole files.
pub static BYTES_READ: AtomicU64 = AtomicU64::new(0);
/// Reads issued, for `/metrics`.
pub static READS: AtomicU64 = AtomicU64::new(0);

impl Source {
    /// Reads `len` bytes at `offset` (blocking: call it off the async threads).
    pub fn read_at(&self, offset: u64, len: usize) -> Result<Vec<u8>> {
        READS.fetch_add(1, Relaxed);
        BYTES_READ.fetch_add(len as u64, Relaxed);
        match self {
            Self::File(f) => {
                let mut buf = vec![0u8; len];
                f.read_exact_at(&mut buf, offset)?;
                Ok(buf)
            }
            Self::Object { store, path } => {
                let end = offset.saturating_add(len as u64);
                let bytes = io_runtime()?
                    .block_on(store.get_range(path, offset..end))
                    .map_err(|e| match misanswered(&e) {
                        Some(what) => anyhow::Error::new(e).context(RangeMisanswered(what)),
                        None => anyhow::Error::new(e),
                    })
                    .with_context(|| format!("reading bytes {offset}..{end} of {path}"))?;
                if bytes.len() != len {
                    return Err(anyhow::Error::new(RangeMisanswered(
                        "a body of another length",
                    )))
                    .with_context(|| {
                        format!(
                            "reading bytes {offset}..{end} of {path}: {} bytes came",
                            bytes.len()
                        )
                    });
                }
                Ok(bytes.to_vec())
            }
        }
    }
}

/// A store answered a byte-range read with something other than that range. It will answer
/// the same way again, so the client gets a 502 (a fault upstream), not a 503 to retry.
#[derive(Debug, thiserror::Error)]
#[error("the store answered a byte-range read with {0}")]
pub struct RangeMisanswered(pub &'static str);

/// How the store misanswered a range read, when `e` says it did.
///
/// The HTTP client says "ignores ranges" in a variant of its own; the S3 client puts every
/// answer it cannot take as a range into `Generic` with a private error type, so only its
/// message tells them apart. `misanswered_ranges_are_told_from_other_failures` runs both
/// clients against a store answering each way, so a crate upgrade that rewords one fails
/// there rather than turning 502s back into 503s unnoticed.
fn misanswered(e: &object_store::Error) -> Option<&'static str> {
    const WHOLE: &str = "the whole object (it ignores Range)";
    match e {
        object_store::Error::NotSupported { .. } => Some(WHOLE),
        object_store::Error::Generic { source, .. } => {
            let said = source.to_string();
            [
                ("non-partial response when range requested", WHOLE),
                ("Content-Range header not present", "no Content-Range"),
                (
                    "value for CONTENT_RANGE header",
                    "a Content-Range it could not parse",
                ),
                (
                    "Content-Range header contained non UTF-8",
                    "a Content-Range it could not parse",
                ),
            ]
            .into_iter()
            .find(|(says, _)| said.contains(says))
            .map(|(_, what)| what)
            .or_else(|| {
                (said.starts_with("Requested ") && said.contains(", got "))
                    .then_some("another range")
            })
        }
        _ => None,
    }
}

/// Whether `e` will pass: the store did not give the bytes, or the dataset's file is being
/// written over in place (a rescan serves the new one). Not a corrupt record: the tile
/// fails rather than being meshed without this read.
pub fn passing(e: &anyhow::Error) -> bool {
    e.downcast_ref::<super::dataset::ChangedOnDisk>().is_some()
        || e.downcast_ref::<RangeMisanswered>().is_some()
        || e.chain().any(|c| c.is::<object_store::Error>())
}

/// True when `data` names a store URL rather than a local folder.
pub fn is_url(data: &str) -> bool {
    data.contains("://")
}

/// A store URL this server can open, in form only (nothing is reached): refused before
/// anything is bound, as the command line's error rather than the store's.
pub fn check_url(url: &str) -> std::result::Result<(), String> {
    parse_store_url(url).map(|_| ())
}

/// The kinds of store [`open_url`] has a client for.
enum StoreKind {
    S3,
    Http,
}

/// The URL and its store's kind, or why no store answers it.
fn parse_store_url(url: &str) -> std::result::Result<(url::Url, StoreKind), String> {
    let parsed = url::Url::parse(url).map_err(|e| format!("{e}"))?;
    let kind = match parsed.scheme() {
        "s3" | "s3a" => StoreKind::S3,
        "http" | "https" => StoreKind::Http,
        other => {
            return Err(format!(
                "scheme {other:?} is not supported (s3://, http(s)://)"
            ))
        }
    };
    if parsed.host_str().is_none_or(str::is_empty) {
        return Err(format!(
            "no {} in it",
            match kind {
                StoreKind::S3 => "bucket",
                StoreKind::Http => "host",
            }
        ));
    }
    Ok((parsed, kind))
}

/// The store and the prefix a URL names: `s3://bucket/prefix` (AWS or any S3-compatible
/// server; credentials, region and endpoint from the usual `AWS_*` variables, e.g.
/// `AWS_ENDPOINT=http://minio:9000 AWS_ALLOW_HTTP=true`) or `http(s)://host/prefix` (a
/// server that lists with WebDAV and answers ranges).
///
/// Retries are few and bounded: a store that is down must fail a tile in seconds (the
/// client retries, nginx tries the other replica) rather than hold it for minutes; one
/// that stopped answering is not asked again for a few seconds ([`super::store_breaker`]).
pub fn open_url(url: &str) -> Result<(Arc<dyn ObjectStore>, ObjectPath)> {
    let (store, prefix) = connect(url)?;
    Ok((Arc::new(super::store_breaker::Breaker::new(store)), prefix))
}

/// [`open_url`]'s store as the client crate makes it, without the breaker.
pub(super) fn connect(url: &str) -> Result<(Arc<dyn ObjectStore>, ObjectPath)> {
    use object_store::{BackoffConfig, ClientOptions, RetryConfig};
    use std::time::Duration;
    let (parsed, kind) =
        parse_store_url(url).map_err(|why| anyhow::anyhow!("data URL {url}: {why}"))?;
    let retry = RetryConfig {
        backoff: BackoffConfig::default(),
        max_retries: 2,
        retry_timeout: Duration::from_secs(5),
    };
    // These options replace the builder's own, so plain HTTP is allowed here as the
    // environment (S3) or the URL (http://) asks.
    let allow_http = parsed.scheme() == "http"
        || std::env::var("AWS_ALLOW_HTTP")
            .is_ok_and(|v| v.eq_ignore_ascii_case("true") || v == "1");
    let client = ClientOptions::new()
        .with_allow_http(allow_http)
        .with_connect_timeout(Duration::from_secs(2))
        .with_timeout(Duration::from_secs(10));
    let prefix = ObjectPath::from(parsed.path().trim_matches('/'));
    let store: Arc<dyn ObjectStore> = match kind {
        StoreKind::S3 => Arc::new(
            object_store::aws::AmazonS3Builder::from_env()
                .with_url(url)
                .with_retry(retry)
                .with_client_options(client)
                .build()
                .with_context(|| format!("data URL {url}"))?,
        ),
        StoreKind::Http => {
            let mut root = parsed.clone();
            root.set_path("/");
            Arc::new(
                object_store::http::HttpBuilder::new()
                    .with_url(root.as_str())
                    .with_retry(retry)
                    .with_client_options(client)
                    .build()
                    .with_context(|| format!("data URL {url}"))?,
            )
        }
    };
    Ok((store, prefix))
}

/// Every `.ext` object directly under `prefix`, with its size and ETag.
pub fn list(
    store: &Arc<dyn ObjectStore>,
    prefix: &ObjectPath,
    ext: &str,
) -> Result<Vec<object_store::ObjectMeta>> {
    let listing = io_runtime()?
        .block_on(store.list_with_delimiter(Some(prefix)))
        .with_context(|| format!("listing {prefix} in {store}"))?;
    let mut objects: Vec<_> = listing
        .objects
        .into_iter()
        .filter(|o| o.location.extension() == Some(ext))
        .collect();
    objects.sort_by(|a, b| a.location.cmp(&b.location));
    Ok(objects)
}

/// The runtime that drives store I/O for blocking callers (tile work on the blocking pool,
/// startup, the CLI), apart from the server's own so that a blocking read never parks an
/// async worker.
fn io_runtime() -> Result<&'static tokio::runtime::Runtime> {
    static RT: OnceLock<std::io::Result<tokio::runtime::Runtime>> = OnceLock::new();
    RT.get_or_init(|| {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("zerotile-io")
            .enable_all()
            .build()
    })
    .as_ref()
    .map_err(|e| anyhow::anyhow!("starting the storage runtime: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use object_store::memory::InMemory;

    fn bytes() -> Vec<u8> {
        (0..=255u8).cycle().take(1000).collect()
    }

    fn store_with(keys: &[&str]) -> Arc<dyn ObjectStore> {
        let store: Arc<dyn ObjectStore> = Arc::new(InMemory::new());
        for key in keys {
            io_runtime()
                .unwrap()
                .block_on(store.put(&ObjectPath::from(*key), bytes().into()))
                .unwrap();
        }
        store
    }

    /// A record is one byte range: exactly `len` bytes from `offset`, from a file or an object.
    #[test]
    fn reads_return_exactly_the_range_asked_for() {
        let path = crate::fixtures::scratch("read-at").join("records");
        std::fs::write(&path, bytes()).unwrap();
        let file = Source::File(File::open(&path).unwrap());
        let object = Source::Object {
            store: store_with(&["prod/a.ztd"]),
            path: ObjectPath::from("prod/a.ztd"),
        };
        for source in [file, object] {
            assert_eq!(
                source.read_at(300, 20).unwrap(),
                bytes()[300..320],
                "{source:?}"
            );
            assert!(source.read_at(990, 20).is_err(), "{source:?}: past the end");
        }
        let _ = std::fs::remove_file(&path);
    }

    /// One way a store can answer `Range: bytes=10-19` of a 1000-byte object.
    #[derive(Clone, Copy, Debug)]
    enum Answer {
        Right,
        Whole,
        Shifted,
        NoContentRange,
        Garbled,
        Short,
        Missing,
    }

    /// A store on loopback that answers every GET as `answer` says; its base URL.
    fn store_answering(answer: Answer) -> String {
        use std::io::{BufRead, BufReader, Write};
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let base = format!("http://{}", listener.local_addr().unwrap());
        std::thread::spawn(move || {
            for conn in listener.incoming().flatten() {
                let mut reader = BufReader::new(conn.try_clone().unwrap());
                let mut line = String::new();
                while reader.read_line(&mut line).is_ok_and(|n| n > 2) {
                    line.clear();
                }
                let all = bytes();
                let (status, range, body): (&str, Option<&str>, &[u8]) = match answer {
                    Answer::Right => (
                        "206 Partial Content",
                        Some("bytes 10-19/1000"),
                        &all[10..20],
                    ),
                    Answer::Whole => ("200 OK", None, &all),
                    Answer::Shifted => (
                        "206 Partial Content",
                        Some("bytes 11-20/1000"),
                        &all[11..21],
                    ),
                    Answer::NoContentRange => ("206 Partial Content", None, &all[10..20]),
                    Answer::Garbled => (
                        "206 Partial Content",
                        Some("bytes ten-19/1000"),
                        &all[10..20],
                    ),
                    Answer::Short => (
                        "206 Partial Content",
                        Some("bytes 10-19/1000"),
                        &all[10..15],
                    ),
                    Answer::Missing => ("404 Not Found", None, b""),
                };
                let mut head = format!(
                    "HTTP/1.1 {status}\r\nContent-Length: {}\r\nETag: \"e1\"\r\n\
                     Last-Modified: Mon, 07 Dec 2026 10:00:00 GMT\r\nConnection: close\r\n",
                    body.len()
                );
                if let Some(range) = range {
                    head += &format!("Content-Range: {range}\r\n");
                }
                let mut conn = conn;
                let _ = conn.write_all(format!("{head}\r\n").as_bytes());
                let _ = conn.write_all(body);
            }
        });
        base
    }

    /// Each way a store can answer a range read with something else is a
    /// [`RangeMisanswered`] through both store clients (the 502 in error.rs), and the
    /// store's other failures are not: this pins the S3 client's messages `misanswered`
    /// reads.
    #[test]
    fn misanswered_ranges_are_told_from_other_failures() {
        use object_store::aws::AmazonS3Builder;
        for (answer, said) in [
            (Answer::Right, None),
            (Answer::Whole, Some("the whole object (it ignores Range)")),
            (Answer::Shifted, Some("another range")),
            (Answer::NoContentRange, Some("no Content-Range")),
            (Answer::Garbled, Some("a Content-Range it could not parse")),
            (Answer::Short, Some("a body of another length")),
            (Answer::Missing, None),
        ] {
            let base = store_answering(answer);
            let s3: Arc<dyn ObjectStore> = Arc::new(
                AmazonS3Builder::new()
                    .with_bucket_name("tiles")
                    .with_region("us-east-1")
                    .with_endpoint(&base)
                    .with_allow_http(true)
                    .with_skip_signature(true)
                    .build()
                    .unwrap(),
            );
            let (http, _) = connect(&format!("{base}/prod")).unwrap();
            for (client, store) in [("s3", s3), ("http", http)] {
                let source = Source::Object {
                    store,
                    path: ObjectPath::from("prod/a.ztd"),
                };
                let read = source.read_at(10, 10);
                let got = read
                    .as_ref()
                    .err()
                    .and_then(|e| e.downcast_ref::<RangeMisanswered>())
                    .map(|m| m.0);
                assert_eq!(got, said, "{answer:?} through {client}: {read:?}");
                match answer {
                    Answer::Right => assert_eq!(read.unwrap(), bytes()[10..20]),
                    _ => assert!(read.is_err(), "{answer:?} through {client}"),
                }
            }
        }
    }

    /// /metrics counts the bytes of each read, so it shows ranges rather than downloads.
    #[test]
    fn reads_count_their_bytes() {
        let object = Source::Object {
            store: store_with(&["prod/a.ztd"]),
            path: ObjectPath::from("prod/a.ztd"),
        };
        let (bytes_before, reads_before) = (BYTES_READ.load(Relaxed), READS.load(Relaxed));
        object.read_at(100, 700).unwrap();
        // Other tests may read meanwhile: the counters only grow, so at least this read shows.
        assert!(BYTES_READ.load(Relaxed) - bytes_before >= 700);
        assert!(READS.load(Relaxed) - reads_before >= 1);
    }

    /// A store listing is the `.ztd` objects directly under the prefix, in name order.
    #[test]
    fn listing_keeps_the_extension_directly_under_the_prefix() {
        let store = store_with(&[
            "prod/b.ztd",
            "prod/a.ztd",
            "prod/README.txt",
            "prod/sub/c.ztd",
            "other/d.ztd",
        ]);
        let names: Vec<String> = list(&store, &ObjectPath::from("prod"), "ztd")
            .unwrap()
            .iter()
            .map(|o| o.location.to_string())
            .collect();
        assert_eq!(names, ["prod/a.ztd", "prod/b.ztd"]);
    }

    /// Store URLs have a scheme; folder paths, even odd ones, do not.
    #[test]
    fn urls_are_told_from_folders() {
        for url in [
            "s3://tiles/prod",
            "https://cdn.example/dem",
            "http://127.0.0.1:9000/x",
        ] {
            assert!(is_url(url), "{url}");
        }
        for dir in ["data", "/srv/tiles", "./s3", "C:/data", "s3:tiles"] {
            assert!(!is_url(dir), "{dir}");
        }
    }

    #[test]
    fn store_urls_are_checked_in_form_before_anything_is_reached() {
        for url in [
            "s3://tiles/prod",
            "s3a://tiles",
            "https://cdn.example/dem",
            "http://127.0.0.1:9000/x",
        ] {
            assert_eq!(check_url(url), Ok(()), "{url}");
        }
        for (url, says) in [
            ("ftp://x/y", "scheme \"ftp\" is not supported"),
            ("file:///srv/tiles", "scheme \"file\" is not supported"),
            ("s3://", "no bucket"),
            ("s3:///prefix", "no bucket"),
            ("https://", "empty host"),
            ("http://[::1", "invalid IPv6"),
        ] {
            let e = check_url(url).unwrap_err();
            assert!(e.contains(says), "{url}: {e}");
        }
    }
}
