//! A `zerotile serve` started as a user would, on a free port, and a small HTTP client.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test support: a server that cannot start should fail the test loudly"
)]

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

use serde_json::Value;

use crate::zerotile_bin;

/// A `zerotile serve` on a free port, killed on drop.
pub struct Server {
    child: Child,
    base: String,
    agent: ureq::Agent,
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

    pub fn number(&self, name: &str) -> f64 {
        self.header(name).unwrap().parse().unwrap()
    }

    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.body).unwrap()
    }

    pub fn error(&self, status: u16, code: &str) {
        assert_eq!(
            self.status,
            status,
            "{}",
            String::from_utf8_lossy(&self.body)
        );
        assert_eq!(self.json()["error"], code);
    }
}

impl Server {
    pub fn start(data: &Path) -> Self {
        let mut child = Command::new(zerotile_bin())
            .args(["serve", "--addr", "127.0.0.1:0", "--data"])
            .arg(data)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let at = line.find("http://").expect("the server prints its URL");
        let agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .build()
            .into();
        Self {
            child,
            base: line[at..].trim().trim_end_matches('/').to_string(),
            agent,
        }
    }

    /// `http://127.0.0.1:PORT`, without a trailing slash: for clients outside this process.
    pub fn base(&self) -> &str {
        &self.base
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

    pub fn get(&self, path: &str, headers: &[(&str, &str)]) -> Reply {
        let mut req = self.agent.get(format!("{}{path}", self.base));
        for (k, v) in headers {
            req = req.header(*k, *v);
        }
        Self::reply(req.call().unwrap())
    }

    pub fn post(&self, path: &str, content_type: &str, body: &[u8]) -> Reply {
        let req = self
            .agent
            .post(format!("{}{path}", self.base))
            .header("content-type", content_type);
        Self::reply(req.send(body).unwrap())
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
