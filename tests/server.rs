//! A `zerotile serve` started as a user would, on a free port, and a small HTTP client.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test support: a server that cannot start should fail the test loudly"
)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use serde_json::Value;

use crate::zerotile_bin;

/// A running `zerotile serve`, stopped on drop. Its log must hold no WARN or ERROR line
/// unless the test expects some.
pub struct Server {
    pub child: Child,
    pub base: String,
    pub agent: ureq::Agent,
    log: PathBuf,
    /// Set when a test provokes WARN/ERROR lines on purpose.
    pub warnings_expected: bool,
}

impl Server {
    pub fn start(data: &Path) -> Self {
        Self::start_with(data.as_os_str(), &[])
    }

    /// Serves `data` (a folder or a store URL) with extra environment variables.
    pub fn start_with(data: &std::ffi::OsStr, env: &[(&str, &str)]) -> Self {
        let mut cmd = Command::new(zerotile_bin());
        cmd.args(["serve", "--addr", "127.0.0.1:0", "--data"])
            .arg(data)
            .envs(env.iter().copied());
        Self::spawn(cmd)
    }

    /// Serves the folder `data` with extra `serve` flags.
    pub fn start_flags(data: &Path, flags: &[&str]) -> Self {
        let mut cmd = Command::new(zerotile_bin());
        cmd.args(["serve", "--addr", "127.0.0.1:0", "--data"])
            .arg(data)
            .args(flags);
        Self::spawn(cmd)
    }

    /// `zerotile serve` with no `--data`, run in `cwd`: the README's first command, which
    /// serves (and first fills in) `cwd/data`.
    pub fn start_default(cwd: &Path) -> Self {
        let mut cmd = Command::new(zerotile_bin());
        cmd.args(["serve", "--addr", "127.0.0.1:0"])
            .current_dir(cwd);
        Self::spawn(cmd)
    }

    fn spawn(mut cmd: Command) -> Self {
        static STARTED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = STARTED.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let log = crate::fresh_dir(&format!("serve-log-{n}")).join("server.log");
        let mut child = cmd
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap();
        // The first line names the URL (port 0 picks a free port).
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let at = line.find("http://").expect("the server prints its URL");
        let base = line[at..].trim().trim_end_matches('/').to_string();
        let agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .build()
            .into();
        Self {
            child,
            base,
            agent,
            log,
            warnings_expected: false,
        }
    }

    /// What the server has written to stderr so far (its log, and what it says at start).
    pub fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// `http://127.0.0.1:PORT`, without a trailing slash: for clients outside this process.
    pub fn base(&self) -> &str {
        &self.base
    }

    /// POSTs `body` with a content type.
    pub fn post(&self, path: &str, content_type: &str, body: &[u8]) -> Reply {
        let req = self
            .agent
            .post(format!("{}{path}", self.base))
            .header("content-type", content_type);
        reply(req.send(body).unwrap())
    }

    pub fn get(&self, path: &str, headers: &[(&str, &str)]) -> Reply {
        let mut req = self.agent.get(format!("{}{path}", self.base));
        for (k, v) in headers {
            req = req.header(*k, *v);
        }
        reply(req.call().unwrap())
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let log = std::fs::read_to_string(&self.log).unwrap_or_default();
        let _ = std::fs::remove_file(&self.log);
        let bad: Vec<&str> = log
            .lines()
            .filter(|l| l.contains(" WARN ") || l.contains(" ERROR "))
            .collect();
        if !self.warnings_expected && !bad.is_empty() && !std::thread::panicking() {
            panic!("unexpected server log lines:\n{}", bad.join("\n"));
        }
    }
}

pub struct Reply {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.body).unwrap_or_else(|e| {
            panic!("{e}: {}", String::from_utf8_lossy(&self.body));
        })
    }

    /// A 4xx with the JSON error shape and the given code.
    /// A header parsed as a number.
    pub fn number(&self, name: &str) -> f64 {
        self.header(name).unwrap().parse().unwrap()
    }

    /// A 4xx/5xx with the JSON error shape and the given code.
    pub fn error(&self, status: u16, code: &str) {
        self.assert_error(status, code, code);
    }

    pub fn assert_error(&self, status: u16, code: &str, what: &str) {
        assert_eq!(
            self.status,
            status,
            "{what}: {}",
            String::from_utf8_lossy(&self.body)
        );
        let v = self.json();
        assert_eq!(v["error"], code, "{what}: {v}");
        assert!(
            v["message"].as_str().is_some_and(|m| !m.is_empty()),
            "{what}"
        );
    }
}

fn reply(mut res: ureq::http::Response<ureq::Body>) -> Reply {
    let status = res.status().as_u16();
    let headers = res
        .headers()
        .iter()
        .map(|(k, v)| (k.as_str().to_string(), v.to_str().unwrap_or("").to_string()))
        .collect();
    let body = res
        .body_mut()
        .with_config()
        .limit(64 << 20)
        .read_to_vec()
        .unwrap();
    Reply {
        status,
        headers,
        body,
    }
}
