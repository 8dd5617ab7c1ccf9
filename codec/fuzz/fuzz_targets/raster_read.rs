//! The heightmap readers must turn any file into a heightmap or an error naming it, within
//! the sample limit they are given: never a panic or an allocation sized by a hostile header
//! (a TIFF strip, a PNG chunk, an `.npy` shape, an `.npz` entry, an ASCII grid's header).
//!
//! The readers take paths (ingest reads files), so each input is written to one scratch file
//! per process; its first byte picks the extension, and for PNGs the encoding.
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use zerotile_codec::raster::{read_heightmap, Encoding, ReadOptions};

const EXTENSIONS: [&str; 6] = ["hgt", "tif", "png", "asc", "npy", "npz"];
const MAX_SAMPLES: usize = 1 << 20;

fn scratch_dir() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("zt-fuzz-raster-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir
    })
}

fuzz_target!(|input: &[u8]| {
    let Some((&pick, data)) = input.split_first() else {
        return;
    };
    let extension = EXTENSIONS[usize::from(pick) % EXTENSIONS.len()];
    let encoding = match pick / 8 % 4 {
        0 => None,
        1 => Some(Encoding::Gray),
        2 => Some(Encoding::TerrainRgb),
        _ => Some(Encoding::Terrarium),
    };
    let path = scratch_dir().join(format!("input.{extension}"));
    std::fs::write(&path, data).expect("scratch file");
    let opts = ReadOptions {
        encoding,
        npz_key: None,
        max_samples: MAX_SAMPLES,
    };
    match read_heightmap(&path, &opts) {
        Ok(map) => {
            let (rows, cols) = (map.heights.rows(), map.heights.cols());
            assert!(rows * cols <= MAX_SAMPLES, "{rows}×{cols} above the limit");
            assert_eq!(map.heights.data().len(), rows * cols);
        }
        // Every error names the file it is about.
        Err(e) => assert!(e.to_string().contains("input."), "{e}"),
    }
});
