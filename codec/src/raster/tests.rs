//! The readers through [`read_heightmap`]: dispatch, the shared data set, and bad input
//! (missing, truncated and corrupted files must give an error naming the file, never a panic).

use super::*;
use crate::fixtures::{scratch_dir, shared_data};

fn dem(name: &str) -> std::path::PathBuf {
    shared_data(&format!("dem/{name}"))
}

fn terrain_rgb() -> ReadOptions {
    ReadOptions {
        encoding: Some(Encoding::TerrainRgb),
        ..ReadOptions::default()
    }
}

/// Every shared DEM reads through the dispatcher with the size and range its README states.
#[test]
fn reads_every_shared_dem_by_extension() {
    type Case = (
        &'static str,
        ReadOptions,
        (usize, usize),
        Option<(f64, f64)>,
    );
    let cases: [Case; 7] = [
        (
            "N44W072.hgt",
            ReadOptions::default(),
            (1201, 1201),
            Some((115.0, 1908.0)),
        ),
        ("fuji.png", terrain_rgb(), (512, 512), Some((13.7, 3751.0))),
        (
            "jacksboro_fault_dem.npz",
            ReadOptions::default(),
            (344, 403),
            Some((236.0, 1076.0)),
        ),
        (
            "terra_elev.tif",
            ReadOptions::default(),
            (90, 95),
            Some((141.0, 547.0)),
        ),
        (
            "terra_elev_vinschgau.tif",
            ReadOptions::default(),
            (194, 252),
            None,
        ),
        ("pysheds_dem.tif", ReadOptions::default(), (359, 367), None),
        (
            "rio_rgbify_elev.tif",
            ReadOptions::default(),
            (512, 512),
            None,
        ),
    ];
    for (name, opts, shape, range) in cases {
        let map = read_heightmap(dem(name), &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((map.heights.rows(), map.heights.cols()), shape, "{name}");
        if let Some(range) = range {
            assert_eq!(map.min_max(), Some(range), "{name}");
        }
    }
}

/// The brief's SRTM convention end to end: row 0 col 0 is centred on (−72, 45), and a crop's
/// georeference starts at the crop's first sample.
#[test]
fn n44w072_georef_and_crop() {
    let map = read_heightmap(dem("N44W072.hgt"), &ReadOptions::default()).unwrap();
    let g = map.georef.unwrap();
    assert_eq!(
        (g.crs, g.position(0.0, 0.0)),
        (Crs::Geographic, (-72.0, 45.0))
    );

    let crop = map.crop(300, 500, 512, 512).unwrap();
    assert_eq!(crop.heights.get(0, 0), map.heights.get(300, 500));
    let (lon, lat) = crop.georef.unwrap().position(0.0, 0.0);
    assert!((lon - (-72.0 + 500.0 / 1200.0)).abs() < 1e-12, "{lon}");
    assert!((lat - (45.0 - 300.0 / 1200.0)).abs() < 1e-12, "{lat}");
    assert_eq!(crop.nodata_count, 0);
    assert!(map.crop(1000, 1000, 512, 512).is_err());
}

#[test]
fn extensions_are_case_insensitive() {
    let path = scratch_dir("raster_case").join("GRID.ASC");
    std::fs::write(&path, "ncols 1\nnrows 1\n7\n").unwrap();
    let map = read_heightmap(&path, &ReadOptions::default()).unwrap();
    assert_eq!(map.heights.data(), &[7.0]);
}

#[test]
fn an_unknown_extension_lists_the_supported_ones() {
    let err = read_heightmap("terrain.jpg", &ReadOptions::default()).unwrap_err();
    assert!(matches!(err, RasterError::Unsupported { .. }), "{err}");
    let message = err.to_string();
    assert!(
        message.contains("terrain.jpg") && message.contains(".hgt") && message.contains(".npz")
    );
}

#[test]
fn a_missing_file_is_an_io_error_naming_it() {
    for name in [
        "missing.hgt",
        "missing.tif",
        "missing.png",
        "missing.asc",
        "missing.npz",
    ] {
        let path = scratch_dir("raster_missing").join(name);
        let err = read_heightmap(&path, &ReadOptions::default()).unwrap_err();
        assert!(matches!(err, RasterError::Io { .. }), "{name}: {err}");
        assert!(err.to_string().contains(name), "{err}");
    }
}

/// A folder named like a heightmap is said to be a folder by every reader: the .hgt
/// reader, which sizes its data from the length, once reported the folder's own size.
#[test]
fn a_folder_is_not_read_as_a_heightmap() {
    let dir = scratch_dir("raster_folder");
    for name in [
        "adir.hgt", "adir.tif", "adir.png", "adir.asc", "adir.npy", "adir.npz",
    ] {
        let path = dir.join(name);
        std::fs::create_dir_all(&path).unwrap();
        let err = read_heightmap(&path, &ReadOptions::default()).unwrap_err();
        let RasterError::Io { error, .. } = &err else {
            panic!("{name}: {err}")
        };
        assert_eq!(
            error.kind(),
            std::io::ErrorKind::IsADirectory,
            "{name}: {err}"
        );
        assert!(err.to_string().contains(name), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Cuts each real file at several lengths inside its data: every cut must be an error naming
/// the file. (A PNG cut only in its IEND trailer still decodes, like other PNG readers.)
#[test]
fn truncated_files_are_errors() {
    let dir = scratch_dir("raster_truncated");
    for (name, opts) in [
        ("N44W072.hgt", ReadOptions::default()),
        ("fuji.png", terrain_rgb()),
        ("jacksboro_fault_dem.npz", ReadOptions::default()),
        ("terra_elev.tif", ReadOptions::default()),
        ("pysheds_dem.tif", ReadOptions::default()),
        ("terra_elev_vinschgau.tif", ReadOptions::default()),
    ] {
        let bytes = std::fs::read(dem(name)).unwrap();
        for cut in [0, 1, 7, 8, 100, bytes.len() / 2, bytes.len() * 9 / 10] {
            let path = dir.join(name);
            std::fs::write(&path, &bytes[..cut]).unwrap();
            match read_heightmap(&path, &opts) {
                Ok(_) => panic!("{name} cut at {cut} bytes read without error"),
                Err(e) => assert!(e.to_string().contains(name), "{name} at {cut}: {e}"),
            }
        }
    }
}

/// Overwrites bytes of small real files at pseudo-random places: the readers may fail or
/// succeed, but must not panic.
#[test]
fn corrupted_files_never_panic() {
    let dir = scratch_dir("raster_corrupt");
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        // xorshift64*: a fixed, dependency-free sequence.
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        state.wrapping_mul(0x2545_f491_4f6c_dd1d)
    };
    for (name, opts) in [
        ("terra_elev.tif", ReadOptions::default()),
        ("jacksboro_fault_dem.npz", ReadOptions::default()),
    ] {
        let original = std::fs::read(dem(name)).unwrap();
        let path = dir.join(name);
        for _ in 0..150 {
            let mut bytes = original.clone();
            // Headers and directories are where parsers go wrong: favour the first 512 bytes.
            for _ in 0..1 + next() % 4 {
                let span = if next() % 2 == 0 {
                    512.min(bytes.len())
                } else {
                    bytes.len()
                };
                let at = (next() % span as u64) as usize;
                bytes[at] = next() as u8;
            }
            std::fs::write(&path, &bytes).unwrap();
            if let Err(e) = read_heightmap(&path, &opts) {
                assert!(e.to_string().contains(name), "{e}");
            }
        }
    }
}

#[test]
fn options_default_to_the_documented_limit() {
    let opts = ReadOptions::default();
    assert_eq!(
        (opts.encoding, opts.npz_key, opts.max_samples),
        (None, None, 1 << 28)
    );
}

#[test]
#[ignore = "prints the shared DEMs' facts; run with --ignored --nocapture"]
fn print_shared_dem_facts() {
    for (name, opts) in [
        ("N44W072.hgt", ReadOptions::default()),
        ("fuji.png", terrain_rgb()),
        ("jacksboro_fault_dem.npz", ReadOptions::default()),
        ("terra_elev.tif", ReadOptions::default()),
        ("terra_elev_vinschgau.tif", ReadOptions::default()),
        ("pysheds_dem.tif", ReadOptions::default()),
        ("rio_rgbify_elev.tif", ReadOptions::default()),
    ] {
        let m = read_heightmap(dem(name), &opts).unwrap();
        println!(
            "{name}: {}x{} step {:?} nodata {} range {:?} georef {:?}",
            m.heights.rows(),
            m.heights.cols(),
            m.step,
            m.nodata_count,
            m.min_max(),
            m.georef
        );
    }
}
