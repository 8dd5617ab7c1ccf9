//! What several test modules build the same way.

#![cfg(test)]

use std::path::PathBuf;

use zerotile_codec::container::{Availability, Metadata, ViewParams};
use zerotile_codec::wavelet::Wavelet;

/// A file under `../shared/data` beside the repository (read in place, never copied).
pub fn shared_data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel)
}

#[path = "../../codec/src/scratch.rs"]
mod scratch_dirs;
/// A fresh, empty folder for the test `name`, its own on every call; see the codec's
/// `scratch.rs` for where it lives and when it goes.
pub use scratch_dirs::scratch;

/// The metadata of a one-tile local 257² dataset named `t` (1-unit steps, heights 0–512)
/// whose streams total `stream_bytes`.
pub fn local_257(stream_bytes: u64) -> Metadata {
    Metadata {
        name: "t".into(),
        scheme: "local".into(),
        tile_side: 257,
        min_zoom: 0,
        max_zoom: 0,
        bounds: [0.0, 256.0, 256.0, 0.0],
        source_size: [257, 257],
        wavelet: Wavelet::Cdf97,
        step: 1.0,
        precision: None,
        height_range: [0.0, 512.0],
        source_height_range: None,
        vertical_datum: None,
        fill: 0.0,
        view: ViewParams { a: 1.0, b: 0.0 },
        available: vec![vec![Availability {
            start_x: 0,
            start_y: 0,
            end_x: 0,
            end_y: 0,
        }]],
        source: "test".into(),
        source_crs: "none".into(),
        samples: 257 * 257,
        stream_bytes,
        created: "2026-11-25T00:00:00Z".into(),
    }
}

/// Makes a FIFO at `path`: what a server must skip without opening, since an open (or a
/// read) waits for a writer that never comes.
pub fn mkfifo(path: &std::path::Path) {
    let made = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .unwrap();
    assert!(made.success(), "mkfifo {}", path.display());
}

/// `f`'s result, failing the test with `hung` if it takes more than `secs`: a blocked open
/// fails the test instead of hanging the suite.
pub fn within<T: Send + 'static>(
    secs: u64,
    hung: &str,
    f: impl FnOnce() -> T + Send + 'static,
) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(std::time::Duration::from_secs(secs))
        .expect(hung)
}
