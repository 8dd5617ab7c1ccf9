//! Datasets read from an S3-compatible object store: a real `moto_server` (PyPI `moto[server]`)
//! on loopback holds a real SRTM dataset, and `zerotile serve --data s3://…` must answer byte
//! for byte what the same file answers locally, reading byte ranges, never the whole object.
//!
//! Without `moto_server` on PATH the test skips with a message; with `ZEROTILE_E2E=1` (set
//! by `.ci/run`, which installs it) its absence fails the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "integration test: a failed step should stop the test loudly"
)]

use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use zerotile_tests::server::Server;
use zerotile_tests::{ingest_n44_geodetic_as, tools_ready, zerotile_bin};

/// A `moto_server` on a free loopback port, stopped on drop.
struct Moto {
    child: Child,
    base: String,
}

impl Moto {
    fn start() -> Option<Self> {
        let port = TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let child = Command::new("moto_server")
            .args(["-H", "127.0.0.1", "-p", &port.to_string()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn();
        let child = match child {
            Ok(c) => c,
            Err(e) => {
                let missing = [format!(
                    "moto_server, runnable ({e}; `pip install 'moto[server]'`)"
                )];
                tools_ready("the object-store test", &missing);
                return None;
            }
        };
        let moto = Self {
            child,
            base: format!("http://127.0.0.1:{port}"),
        };
        let start = Instant::now();
        while ureq::get(&moto.base).call().is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "moto_server did not come up"
            );
            std::thread::sleep(Duration::from_millis(200));
        }
        Some(moto)
    }

    fn put(&self, path: &str, body: &[u8]) {
        let r = ureq::put(format!("{}{path}", self.base))
            .send(body)
            .unwrap();
        assert_eq!(r.status(), 200, "PUT {path}");
    }
}

impl Drop for Moto {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A loopback TCP relay to a store, between it and the server under test.
struct Relay {
    base: String,
    /// Bytes the store sent back, measured outside the server under test.
    served: std::sync::Arc<std::sync::atomic::AtomicU64>,
    /// While set, requests are swallowed: the store stops answering, on connections already
    /// open too.
    hang: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

fn relay(upstream: String) -> Relay {
    use std::io::{Read, Write};
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
    use std::sync::Arc;
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    let served = Arc::new(AtomicU64::new(0));
    let hang = Arc::new(AtomicBool::new(false));
    let (count, hung) = (served.clone(), hang.clone());
    let up = upstream.trim_start_matches("http://").to_string();
    std::thread::spawn(move || {
        for client in listener.incoming().flatten() {
            let Ok(server) = std::net::TcpStream::connect(&up) else {
                continue;
            };
            let (mut c_in, mut s_out) = (client.try_clone().unwrap(), server.try_clone().unwrap());
            let hung = hung.clone();
            std::thread::spawn(move || {
                let mut buf = [0u8; 16384];
                while let Ok(n) = c_in.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    if !hung.load(Relaxed) && s_out.write_all(&buf[..n]).is_err() {
                        break;
                    }
                }
                let _ = s_out.shutdown(std::net::Shutdown::Write);
            });
            let (mut s_in, mut c_out, count) = (server, client, count.clone());
            std::thread::spawn(move || {
                let mut buf = [0u8; 16384];
                while let Ok(n) = s_in.read(&mut buf) {
                    if n == 0 || c_out.write_all(&buf[..n]).is_err() {
                        break;
                    }
                    count.fetch_add(n as u64, Relaxed);
                }
                let _ = c_out.shutdown(std::net::Shutdown::Write);
            });
        }
    });
    Relay { base, served, hang }
}

/// The N44W072 dataset ingested by the real binary into a folder of its own, and its bytes.
fn srtm(tag: &str) -> (PathBuf, Vec<u8>) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(tag);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    ingest_n44_geodetic_as(&dir, "srtm");
    let file = std::fs::read(dir.join("srtm.ztd")).unwrap();
    (dir, file)
}

/// `serve --data s3://tiles/prod` through `endpoint`.
fn serve_bucket(endpoint: &str) -> Server {
    Server::start_with(
        "s3://tiles/prod".as_ref(),
        &[
            ("AWS_ENDPOINT", endpoint),
            ("AWS_ALLOW_HTTP", "true"),
            ("AWS_ACCESS_KEY_ID", "test"),
            ("AWS_SECRET_ACCESS_KEY", "test"),
            ("AWS_REGION", "us-east-1"),
        ],
    )
}

/// The first tile at zoom `z` of `layer.json`'s availability, and how many follow it in x.
fn first_at(s: &Server, z: usize) -> (u64, u64, u64) {
    let layer = s.get("/v1/datasets/srtm/layer.json", &[]).json();
    let range = &layer["available"][z][0];
    let x = |k: &str| range[k].as_u64().unwrap();
    (x("startX"), x("startY"), x("endX") - x("startX"))
}

fn metric(s: &Server, name: &str) -> f64 {
    let text = String::from_utf8(s.get("/metrics", &[]).body).unwrap();
    text.lines()
        .find_map(|l| l.strip_prefix(name)?.trim().parse().ok())
        .unwrap_or_else(|| panic!("{name} not in /metrics"))
}

#[test]
fn s3_datasets_serve_the_same_bytes_by_range_reads() {
    let Some(moto) = Moto::start() else { return };

    // A real dataset, ingested by the real binary.
    let (dir, file) = srtm("storage-s3");

    // The bucket: the dataset, a truncated copy (skipped, not fatal) and an unrelated object.
    moto.put("/tiles", b"");
    moto.put("/tiles/prod/srtm.ztd", &file);
    moto.put("/tiles/prod/broken.ztd", &file[..file.len() / 2]);
    moto.put("/tiles/prod/README.txt", b"not a dataset");
    moto.put("/tiles/other/elsewhere.ztd", &file);

    let local = Server::start(&dir);
    let Relay {
        base: endpoint,
        served: from_store,
        ..
    } = relay(moto.base.clone());
    let mut remote = serve_bucket(&endpoint);
    remote.warnings_expected = true; // broken.ztd is skipped with a warning

    let list = remote.get("/v1/datasets", &[]).json();
    let names: Vec<&str> = list["datasets"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|d| d["name"].as_str())
        .collect();
    assert_eq!(names, ["srtm"], "{list}");
    let skipped = list.to_string();
    assert!(
        skipped.contains("broken.ztd"),
        "the truncated copy is reported: {list}"
    );

    let before = metric(&remote, "zerotile_storage_read_bytes_total");
    let reads_before = metric(&remote, "zerotile_storage_reads_total");
    let wire_before = from_store.load(std::sync::atomic::Ordering::Relaxed);
    let (x0, y0, _) = first_at(&local, 9);
    let mut asked = 0;
    for path in [
        format!("/v1/datasets/srtm/tiles/9/{x0}/{y0}.terrain?threshold=4"),
        format!("/v1/datasets/srtm/tiles/9/{x0}/{y0}.png"),
        format!("/v1/datasets/srtm/tiles/9/{x0}/{y0}.json?threshold=16"),
        "/v1/datasets/srtm/tiles/3/4/5.terrain".to_string(),
        "/v1/datasets/srtm/layer.json".to_string(),
    ] {
        let (a, b) = (local.get(&path, &[]), remote.get(&path, &[]));
        assert_eq!(
            a.status,
            200,
            "{path}: {}",
            String::from_utf8_lossy(&a.body)
        );
        assert_eq!(
            b.status,
            200,
            "{path}: {}",
            String::from_utf8_lossy(&b.body)
        );
        assert_eq!(a.body, b.body, "{path}: bodies differ");
        assert_eq!(
            a.header("etag"),
            b.header("etag"),
            "{path}: same file, same ETag"
        );
        asked += 1;
    }
    assert_eq!(asked, 5);
    let read = metric(&remote, "zerotile_storage_read_bytes_total") - before;
    let reads = metric(&remote, "zerotile_storage_reads_total") - reads_before;
    let wire = from_store.load(std::sync::atomic::Ordering::Relaxed) - wire_before;
    assert!(
        (wire as f64) < file.len() as f64 / 4.0,
        "{wire} bytes came from the store for a few tiles of a {}-byte object",
        file.len()
    );
    assert!(read > 0.0, "tiles were read from the store");
    assert!(
        read < file.len() as f64 / 4.0,
        "{read} bytes read for a few tiles of a {}-byte object: ranges, not downloads",
        file.len()
    );
    assert!(reads >= 4.0, "one range per record: {reads} reads");

    // The store goes away: a tile it must read is a quick 503 with Retry-After (a cache in
    // front retries another replica), not a 500 or a hang.
    drop(moto);
    let started = Instant::now();
    let r = remote.get(
        &format!("/v1/datasets/srtm/tiles/9/{x0}/{y0}.terrain?threshold=0.5"),
        &[],
    );
    r.error(503, "storage_unavailable");
    assert_eq!(r.header("retry-after"), Some("1"));
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "answered in {:?}",
        started.elapsed()
    );

    // A store that does not answer is a clear startup error, not a hang or a panic.
    let out = Command::new(zerotile_bin())
        .args([
            "serve",
            "--addr",
            "127.0.0.1:0",
            "--data",
            "s3://tiles/prod",
        ])
        .envs([
            ("AWS_ENDPOINT", "http://127.0.0.1:9"),
            ("AWS_ALLOW_HTTP", "true"),
            ("AWS_ACCESS_KEY_ID", "test"),
            ("AWS_SECRET_ACCESS_KEY", "test"),
            ("AWS_REGION", "us-east-1"),
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("listing"), "{err}");
}

/// A store that stops answering (requests swallowed, connections held open) fails a mesh
/// tile with `503 storage_unavailable` within one read's timeout, even one whose own record
/// is cached (not a tile meshed without the neighbours it could not read), and the requests
/// after it at once while the store is cut off; once it answers again (the request that
/// probes it may still fail), tiles are served as before. A mesh tile reads five records two at a time, each waiting out the 10 s
/// timeout: it took 20–30 s, the request limit's bare `unavailable` at worst.
#[test]
fn a_store_that_stops_answering_fails_tiles_in_seconds() {
    let Some(moto) = Moto::start() else { return };
    let (dir, file) = srtm("storage-hang");
    moto.put("/tiles", b"");
    moto.put("/tiles/prod/srtm.ztd", &file);
    let local = Server::start(&dir);
    let relay = relay(moto.base.clone());
    let mut remote = serve_bucket(&relay.base);
    remote.warnings_expected = true;
    let (x0, y0, across) = first_at(&local, 10);
    assert!(across >= 4, "{across}");
    let tile = |dx: u64| format!("/v1/datasets/srtm/tiles/10/{}/{y0}.terrain", x0 + dx);
    assert_eq!(
        remote.get(&tile(0), &[]).body,
        local.get(&tile(0), &[]).body
    );

    // Tile 1 was decoded as tile 0's neighbour and is cached; its own neighbours beyond
    // are not: meshed without them it would have cracks, so it is a 503 too.
    relay.hang.store(true, std::sync::atomic::Ordering::Relaxed);
    let started = Instant::now();
    remote.get(&tile(1), &[]).error(503, "storage_unavailable");
    let first = started.elapsed();
    assert!(
        first < Duration::from_secs(20),
        "the first answer took {first:?}"
    );
    let started = Instant::now();
    let r = remote.get(&tile(4), &[]);
    r.error(503, "storage_unavailable");
    assert_eq!(r.header("retry-after"), Some("1"));
    let second = started.elapsed();
    assert!(
        second < Duration::from_secs(3),
        "the store was asked again: {second:?}"
    );
    assert!(
        remote.log_text().contains("requests to it fail at once"),
        "{}",
        remote.log_text()
    );

    relay
        .hang
        .store(false, std::sync::atomic::Ordering::Relaxed);
    // After the cool-off one read asks again and the tile's others still fail at once, so
    // the request carrying the probe may be a 503 too; its answer ends the cut-off.
    std::thread::sleep(Duration::from_secs(6));
    let mut again = remote.get(&tile(4), &[]);
    for _ in 0..2 {
        if again.status == 200 {
            break;
        }
        again.error(503, "storage_unavailable");
        std::thread::sleep(Duration::from_millis(500));
        again = remote.get(&tile(4), &[]);
    }
    assert_eq!(
        again.status,
        200,
        "{}",
        String::from_utf8_lossy(&again.body)
    );
    assert_eq!(again.body, local.get(&tile(4), &[]).body);
}
