//! Real test data, read in place from `../shared/data` (never copied into the repo).

#![cfg(test)]

use std::path::PathBuf;

use crate::grid::Grid;

pub fn shared_data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel)
}

/// N44W072.hgt (SRTM3, White Mountains): 1201×1201 big-endian int16 metres.
pub fn n44w072() -> Grid<f64> {
    let bytes = std::fs::read(shared_data("dem/N44W072.hgt")).expect("shared/data/dem/N44W072.hgt");
    let data = bytes
        .chunks_exact(2)
        .map(|b| f64::from(i16::from_be_bytes([b[0], b[1]])))
        .collect();
    Grid::new(1201, 1201, data).expect("1201² samples")
}

/// A square crop of N44W072.
pub fn n44w072_crop(row: usize, col: usize, size: usize) -> Grid<f64> {
    n44w072()
        .crop(row, col, size, size)
        .expect("crop inside the tile")
}

/// A fresh, empty scratch folder for the test `name` (see [`crate::scratch`]).
pub fn scratch_dir(name: &str) -> PathBuf {
    crate::scratch::scratch(name)
}
