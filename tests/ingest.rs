//! `zerotile ingest` run as a user would, on real SRTM data.
#![allow(
    clippy::unwrap_used,
    reason = "test helpers: a failure to spawn the binary should fail the test loudly"
)]

use std::path::{Path, PathBuf};
use std::process::Command;

use zerotile_codec::container::{Container, Limits, TileId, TileRecord};
use zerotile_codec::ezw::{self, DecodeLimit};
use zerotile_tests::{shared_data, zerotile_bin};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("zerotile-e2e-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn ingest(input: &Path, name: &str, data: &Path, extra: &[&str]) -> std::process::Output {
    Command::new(zerotile_bin())
        .arg("ingest")
        .arg(input)
        .args(["--name", name, "--quiet", "--data"])
        .arg(data)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn ingest_builds_a_pyramid_whose_tiles_decode_to_the_source() {
    let data = scratch("pyramid");
    let hgt = shared_data().join("dem/N44W072.hgt");
    let out = ingest(&hgt, "n44", &data, &["--precision", "0.5"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let bytes = std::fs::read(data.join("n44.ztd")).unwrap();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    // 1201 samples = 4.7 tiles of 256 steps: 5×5, 3×3, 2×2, 1×1.
    assert_eq!(c.metadata.max_zoom, 3);
    assert_eq!(c.len(), 25 + 9 + 4 + 1);

    // A full-resolution tile decodes to the source within the stated precision.
    let source: Vec<f64> = std::fs::read(&hgt)
        .unwrap()
        .chunks_exact(2)
        .map(|b| f64::from(i16::from_be_bytes([b[0], b[1]])))
        .collect();
    let id = TileId { z: 3, x: 2, y: 1 };
    let e = c.entry(id).unwrap();
    let rec = TileRecord::parse(id, &bytes[e.offset as usize..][..e.len as usize], &e).unwrap();
    let d = ezw::decode(rec.stream, DecodeLimit::All, ezw::DEFAULT_MAX_SAMPLES).unwrap();
    let mut worst = 0f64;
    for r in 0..257 {
        for col in 0..257 {
            let s = source[(256 + r) * 1201 + 512 + col];
            worst = worst.max((d.heights.get(r, col) - s).abs());
        }
    }
    assert!(
        worst <= 0.5,
        "max error {worst} above the requested precision"
    );
    assert_eq!(rec.corners[0], source[256 * 1201 + 512]);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn a_failed_ingest_leaves_the_previous_dataset_intact() {
    let data = scratch("atomic");
    let good = shared_data().join("dem/terra_elev.tif");
    assert!(ingest(&good, "lux", &data, &[]).status.success());
    let before = std::fs::read(data.join("lux.ztd")).unwrap();

    let bad = data.join("broken.hgt");
    std::fs::write(&bad, [0u8; 1000]).unwrap();
    let out = ingest(&bad, "lux", &data, &[]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("broken.hgt"));
    assert_eq!(std::fs::read(data.join("lux.ztd")).unwrap(), before);
    let leftovers: Vec<_> = std::fs::read_dir(&data)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left behind");
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn bad_names_and_schemes_are_refused_with_a_message() {
    let data = scratch("names");
    let hgt = shared_data().join("dem/terra_elev.tif");
    for (name, extra, needle) in [
        ("../escape", &[][..], "dataset name"),
        ("ok", &["--scheme", "geodetic"][..], "--scheme geodetic"),
        ("ok", &["--precision", "0"][..], "--precision"),
    ] {
        let out = ingest(&hgt, name, &data, extra);
        assert_eq!(out.status.code(), Some(1), "{name} {extra:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{name} {extra:?}: {err}");
    }
    assert!(!data.join("ok.ztd").exists());
}
