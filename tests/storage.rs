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
use zerotile_tests::{ingest_command, run_ok, shared_data, tools_ready, zerotile_bin};

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

// A loopback TCP relay to `upstream` that counts the bytes
// the store sends back, measured outside the server under test.
fn counting_relay(upstream: String) -> (String, std::sync::Arc<std::sync::atomic::AtomicU64>) {
    use std::io::{Read, Write};
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    let served = std::sync::Arc::new(AtomicU64::new(0));
    let count = served.clone();
    let up = upstream.trim_start_matches("http://").to_string();
    std::thread::spawn(move || {
        for client in listener.incoming().flatten() {
            let Ok(server) = std::net::TcpStream::connect(&up) else {
                continue;
            };
            let (mut c_in, mut s_out) = (client.try_clone().unwrap(), server.try_clone().unwrap());
            std::thread::spawn(move || {
                let _ = std::io::copy(&mut c_in, &mut s_out);
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
    (base, served)
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
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("storage-s3");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let hgt = shared_data().join("dem/N44W072.hgt");
    run_ok(&mut ingest_command(
        &hgt,
        "srtm",
        &dir,
        &["--scheme", "geodetic"],
    ));
    let file = std::fs::read(dir.join("srtm.ztd")).unwrap();

    // The bucket: the dataset, a truncated copy (skipped, not fatal) and an unrelated object.
    moto.put("/tiles", b"");
    moto.put("/tiles/prod/srtm.ztd", &file);
    moto.put("/tiles/prod/broken.ztd", &file[..file.len() / 2]);
    moto.put("/tiles/prod/README.txt", b"not a dataset");
    moto.put("/tiles/other/elsewhere.ztd", &file);

    let local = Server::start(&dir);
    let (endpoint, from_store) = counting_relay(moto.base.clone());
    let mut remote = Server::start_with(
        "s3://tiles/prod".as_ref(),
        &[
            ("AWS_ENDPOINT", &endpoint),
            ("AWS_ALLOW_HTTP", "true"),
            ("AWS_ACCESS_KEY_ID", "test"),
            ("AWS_SECRET_ACCESS_KEY", "test"),
            ("AWS_REGION", "us-east-1"),
        ],
    );
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
    let layer = local.get("/v1/datasets/srtm/layer.json", &[]).json();
    let z9 = &layer["available"][9][0];
    let (x0, y0) = (
        z9["startX"].as_u64().unwrap(),
        z9["startY"].as_u64().unwrap(),
    );
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
