//! Two stateless replicas behind nginx `proxy_cache`, with the shipped docker/nginx.conf
//! (only hosts, ports and paths rewritten): both replicas answer the same bytes and ETags,
//! nginx answers `If-None-Match` with 304 from its cache, and killing one replica mid-run
//! loses no request (nginx retries the other); tiles.json fetched through nginx lists tiles
//! at nginx.
//!
//! Without nginx the test skips with a message; with `ZEROTILE_E2E=1` (set by `.ci/run`,
//! which installs it) its absence fails the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "integration test: a failed step should stop the test loudly"
)]

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::Arc;
use std::time::{Duration, Instant};

use zerotile_tests::server::Server;
use zerotile_tests::{run_ok, shared_data, tools_ready, zerotile_bin};

struct Nginx {
    child: Child,
    base: String,
}

impl Drop for Nginx {
    /// TERM, not KILL: nginx's master then stops its workers; a killed master left its
    /// workers and cache manager running after every test run.
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(5) {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn port_of(s: &Server) -> &str {
    s.base().rsplit(':').next().unwrap()
}

/// docker/nginx.conf with the replicas at `a` and `b`, listening on a free loopback port,
/// everything it writes under `dir`.
fn start_nginx(dir: &Path, a: &str, b: &str) -> Option<Nginx> {
    let Ok(bin) = which("nginx") else {
        let missing = ["nginx (apt-get install nginx-light)".to_string()];
        tools_ready("the replica test", &missing);
        return None;
    };
    let shipped =
        std::fs::read_to_string(zerotile_tests::repo_root().join("docker/nginx.conf")).unwrap();
    let port = free_port();
    let d = dir.display();
    let mut conf = String::new();
    // Root may run the workers as root; otherwise nginx ignores the line.
    conf.push_str(&format!(
        "daemon off;\nuser root;\npid {d}/nginx.pid;\nerror_log {d}/error.log warn;\n"
    ));
    for line in shipped.lines() {
        let line = line
            .replace("zerotile-a:8080", &format!("127.0.0.1:{a}"))
            .replace("zerotile-b:8080", &format!("127.0.0.1:{b}"))
            .replace("listen 80;", &format!("listen 127.0.0.1:{port};"))
            .replace("/var/cache/nginx/tiles", &format!("{d}/cache"));
        conf.push_str(&line);
        conf.push('\n');
        if line.trim_start().starts_with("http {") {
            for t in ["client_body", "proxy", "fastcgi", "uwsgi", "scgi"] {
                conf.push_str(&format!("  {t}_temp_path {d}/{t}_temp;\n"));
            }
            conf.push_str("  access_log off;\n");
        }
    }
    let path = dir.join("nginx.conf");
    std::fs::write(&path, conf).unwrap();
    let child = Command::new(bin)
        .arg("-p")
        .arg(dir)
        .arg("-c")
        .arg(&path)
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let n = Nginx {
        child,
        base: format!("http://127.0.0.1:{port}"),
    };
    let start = Instant::now();
    while ureq::get(format!("{}/healthz", n.base)).call().is_err() {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "nginx did not come up"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    Some(n)
}

fn which(name: &str) -> Result<PathBuf, ()> {
    ["/usr/sbin", "/usr/bin", "/usr/local/sbin", "/usr/local/bin"]
        .iter()
        .map(|d| Path::new(d).join(name))
        .find(|p| p.exists())
        .ok_or(())
}

/// (status, ETag, body) through a plain agent that returns every status.
fn get(agent: &ureq::Agent, url: &str, inm: Option<&str>) -> (u16, Option<String>, Vec<u8>) {
    let mut req = agent.get(url);
    if let Some(e) = inm {
        req = req.header("if-none-match", e);
    }
    let mut r = req.call().unwrap();
    let etag = r
        .headers()
        .get("etag")
        .and_then(|v| v.to_str().ok())
        .map(str::to_string);
    (
        r.status().as_u16(),
        etag,
        r.body_mut().read_to_vec().unwrap(),
    )
}

#[test]
fn two_replicas_behind_nginx_agree_cache_and_survive_a_kill() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("replicas");
    let _ = std::fs::remove_dir_all(&dir);
    let data = dir.join("data");
    std::fs::create_dir_all(&data).unwrap();
    run_ok(
        Command::new(zerotile_bin())
            .args(["demo-data", "--quiet", "--data"])
            .arg(&data),
    );
    // A mercator dataset too, for tiles.json through the proxy.
    run_ok(
        Command::new(zerotile_bin())
            .arg("ingest")
            .arg(shared_data().join("dem/N44W072.hgt"))
            .args(["--name", "n44m", "--scheme", "mercator", "--max-zoom", "6"])
            .args(["--quiet", "--data"])
            .arg(&data),
    );

    let mut a = Server::start(&data);
    let b = Server::start(&data);
    let Some(nginx) = start_nginx(&dir, port_of(&a), port_of(&b)) else {
        return;
    };
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .http_status_as_error(false)
        .build()
        .into();

    // Tiles from zoom 0 down as layer.json lists them, at two thresholds, ~100 paths.
    let layer = a.get("/v1/datasets/demo-ridges/layer.json", &[]).json();
    let mut paths = Vec::new();
    let levels = layer["available"].as_array().unwrap();
    for (z, level) in levels.iter().enumerate() {
        if paths.len() >= 100 {
            break;
        }
        for r in level.as_array().unwrap() {
            let n = |k: &str| r[k].as_u64().unwrap();
            for x in n("startX")..=n("endX") {
                for y in n("startY")..=n("endY") {
                    for t in ["8", "32"] {
                        paths.push(format!(
                            "/v1/datasets/demo-ridges/tiles/{z}/{x}/{y}.terrain?threshold={t}"
                        ));
                    }
                }
            }
        }
    }
    assert!(paths.len() >= 40, "{} tiles", paths.len());

    // Stateless: both replicas answer the same bytes and ETags, for tiles and for the
    // descriptions and a view (tagged by their bytes and by their view plane).
    let [w, s, e, n] = [0, 1, 2, 3].map(|i| {
        a.get("/v1/datasets/demo-ridges", &[]).json()["bounds"][i]
            .as_f64()
            .unwrap()
    });
    let (lon, lat) = ((w + e) / 2.0, (s + n) / 2.0);
    let view =
        format!("/v1/datasets/demo-ridges/view?eye={lon},{lat},20000&target={lon},{lat},0&fov=60");
    let described = [
        "/v1/datasets".to_string(),
        "/v1/datasets/demo-ridges".to_string(),
        "/v1/datasets/demo-ridges/layer.json".to_string(),
        "/v1/meshes".to_string(),
        view,
    ];
    for p in paths.iter().step_by(7).chain(&described) {
        let (sa, ea, ba) = get(&agent, &format!("{}{p}", a.base()), None);
        let (sb, eb, bb) = get(&agent, &format!("{}{p}", b.base()), None);
        assert_eq!((sa, sb), (200, 200), "{p}");
        assert!(ea.is_some(), "{p} has an ETag");
        assert_eq!(ea, eb, "{p}: ETags differ between replicas");
        assert_eq!(ba, bb, "{p}: bytes differ between replicas");
    }

    // Through nginx: the same bytes; a repeat is a cache hit; If-None-Match gives 304.
    let p = &paths[0];
    let (s1, e1, b1) = get(&agent, &format!("{}{p}", nginx.base), None);
    let (_, _, direct) = get(&agent, &format!("{}{p}", a.base()), None);
    assert_eq!(s1, 200);
    assert_eq!(b1, direct, "nginx passes the tile through unchanged");
    let r = agent.get(format!("{}{p}", nginx.base)).call().unwrap();
    assert_eq!(
        r.headers()
            .get("x-cache-status")
            .and_then(|v| v.to_str().ok()),
        Some("HIT")
    );
    let (s304, _, body) = get(&agent, &format!("{}{p}", nginx.base), e1.as_deref());
    assert_eq!(s304, 304, "ETag honoured through the cache");
    assert!(body.is_empty());

    // What nginx does not store (descriptions, views, mesh LODs: `no-cache`) passes through
    // with the client's If-None-Match, so the replica's 304 reaches it (a caching location
    // would strip the header and send the whole body every time).
    let meshes = a.get("/v1/meshes", &[]).json();
    let mesh = meshes["meshes"][0]["name"].as_str().unwrap().to_string();
    let lod = format!("/v1/meshes/{mesh}/qem?ratio=0.5");
    for p in described
        .iter()
        .filter(|p| !p.ends_with("layer.json"))
        .chain([&lod])
    {
        let url = format!("{}{p}", nginx.base);
        let (s, tag, _) = get(&agent, &url, None);
        assert_eq!(s, 200, "{p}");
        let (s, _, body) = get(&agent, &url, tag.as_deref());
        assert_eq!(s, 304, "{p}: If-None-Match through nginx");
        assert!(body.is_empty(), "{p}");
    }

    // tiles.json through nginx lists tiles at nginx, where the client asked (the shipped
    // config passes the client's Host on), and those tiles answer there.
    let tilejson = format!("{}/v1/datasets/n44m/tiles.json", nginx.base);
    let (status, _, body) = get(&agent, &tilejson, None);
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let doc: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let template = doc["tiles"][0].as_str().unwrap();
    assert!(
        template.starts_with(&format!("{}/v1/", nginx.base)),
        "{template} is not at {}",
        nginx.base
    );
    let (status, _, png) = get(&agent, &template.replace("{z}/{x}/{y}", "0/0/0"), None);
    assert_eq!((status, &png[1..4]), (200, &b"PNG"[..]));

    // Kill one replica while four clients fetch every tile through nginx.
    let ok = Arc::new(AtomicUsize::new(0));
    let failed = Arc::new(std::sync::Mutex::new(Vec::new()));
    let done = Arc::new(AtomicUsize::new(0));
    let workers: Vec<_> = (0..4)
        .map(|w| {
            let (paths, base) = (paths.clone(), nginx.base.clone());
            let (ok, failed, done, agent) =
                (ok.clone(), failed.clone(), done.clone(), agent.clone());
            std::thread::spawn(move || {
                // Every client its own thresholds: the cache cannot hide the upstreams.
                for round in 0..3 {
                    for p in &paths {
                        let url = format!("{base}{p}&v={w}-{round}");
                        match agent.get(&url).call() {
                            Ok(r) if r.status() == 200 => {
                                ok.fetch_add(1, Relaxed);
                            }
                            Ok(r) => failed
                                .lock()
                                .unwrap()
                                .push(format!("{url}: {}", r.status())),
                            Err(e) => failed.lock().unwrap().push(format!("{url}: {e}")),
                        }
                        done.fetch_add(1, Relaxed);
                    }
                }
            })
        })
        .collect();
    let total = 4 * 3 * paths.len();
    while done.load(Relaxed) < total / 4 {
        std::thread::sleep(Duration::from_millis(5));
    }
    a.child.kill().unwrap();
    a.child.wait().unwrap();
    let killed_at = done.load(Relaxed);
    for w in workers {
        w.join().unwrap();
    }
    let failed = failed.lock().unwrap();
    assert!(
        killed_at < total,
        "the kill landed mid-run ({killed_at} of {total} done)"
    );
    assert!(
        failed.is_empty(),
        "{} lost requests: {:?}",
        failed.len(),
        &failed[..failed.len().min(5)]
    );
    assert_eq!(ok.load(Relaxed), total);
    eprintln!("{total} requests through nginx, replica killed after {killed_at}: 0 lost");
}
