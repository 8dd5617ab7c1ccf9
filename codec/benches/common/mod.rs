//! Inputs every bench reads: real data from `../shared/data`, through the codec's own readers.
#![allow(
    dead_code,
    clippy::expect_used,
    reason = "each bench uses part of this; a bench without its data file should stop loudly"
)]

use std::path::PathBuf;

use zerotile_codec::bintree::{self, Hierarchy, TileErrors};
use zerotile_codec::ezw::{self, DecodeLimit, EncodeParams};
use zerotile_codec::mesh::io::{read_path, MeshLimits};
use zerotile_codec::mesh::TriMesh;
use zerotile_codec::raster::{self, ReadOptions};
use zerotile_codec::wavelet::Wavelet;
use zerotile_codec::zerotree::TerrainMesh;
use zerotile_codec::Grid;

/// A file under `../shared/data` beside the repository.
pub fn shared(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel)
}

/// The `side`² window of N44W072 from row 300, column 500: the tile the tests use too.
pub fn n44w072_tile(side: usize) -> Grid<f64> {
    let map = raster::read_heightmap(shared("dem/N44W072.hgt"), &ReadOptions::default())
        .expect("../shared/data/dem/N44W072.hgt");
    map.heights.crop(300, 500, side, side).expect("crop")
}

/// The three 257² tiles `../shared/bench/terrain_mesh.py` meshes (its defaults), by the
/// names it prints, with the height step `eval terrain` codes each at (the source's
/// quantum, else 0.01): N44W072 (SRTM, rows 300.., cols 500..), fuji (terrain-RGB PNG) and
/// jacksboro (npz), the last two from their top-left corner.
pub fn terrain_mesh_tiles() -> Vec<(&'static str, Grid<f64>, f64)> {
    let read = |rel: &str, encoding, (row, col): (usize, usize)| {
        let opts = ReadOptions {
            encoding,
            ..ReadOptions::default()
        };
        let map = raster::read_heightmap(shared(rel), &opts).expect(rel);
        let tile = map.heights.crop(row, col, 257, 257).expect("crop");
        (tile, map.step.unwrap_or(0.01))
    };
    let (n44, n44_step) = read("dem/N44W072.hgt", None, (300, 500));
    let (fuji, fuji_step) = read("dem/fuji.png", Some(raster::Encoding::TerrainRgb), (0, 0));
    let (jacksboro, j_step) = read("dem/jacksboro_fault_dem.npz", None, (0, 0));
    vec![
        ("N44W072", n44, n44_step),
        ("fuji", fuji, fuji_step),
        ("jacksboro", jacksboro, j_step),
    ]
}

/// A classic test mesh from `../shared/data/meshes`.
pub fn mesh(name: &str) -> TriMesh {
    read_path(&shared(&format!("meshes/{name}")), &MeshLimits::default())
        .expect("../shared/data/meshes")
}

/// The budgets T (m) the decode + mesh benches time: powers of two × 8, so the server's
/// floor for each decode depth is the mesh tolerance.
pub const BUDGETS: [f64; 3] = [4.0, 16.0, 64.0];

/// [`terrain_mesh_tiles`] encoded with each wavelet at the tile's step: what
/// `decode_and_mesh_257` and `terrain_rounds` decode.
pub fn terrain_mesh_streams() -> Vec<(&'static str, Wavelet, Vec<u8>)> {
    let mut out = Vec::new();
    for (tile, heights, step) in terrain_mesh_tiles() {
        for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
            let enc = ezw::encode(&heights, &EncodeParams::new(wavelet, step)).expect("encode");
            out.push((tile, wavelet, enc.bytes));
        }
    }
    out
}

/// One request's work for budget T, as the server does it: read the stream to T · `share`
/// and mesh within the rest, with errors exact above that tolerance (at the benched budgets,
/// powers of two × 8, the server's floor for the decode depth is the tolerance).
pub fn decode_and_mesh_at(
    bytes: &[u8],
    hierarchy: &Hierarchy,
    budget: f64,
    share: f64,
) -> TerrainMesh {
    let (limit, tolerance) = split(budget, share);
    let d = ezw::decode_heights(bytes, limit, ezw::DEFAULT_MAX_SAMPLES).expect("decode");
    let errors = TileErrors::exact_above(hierarchy, &d.heights, tolerance);
    bintree::extract(hierarchy, &errors, &d.heights, tolerance, None)
}

/// The server's split of budget T: read the stream to T · `share`, mesh within
/// T · (1 − `share`).
pub fn split(budget: f64, share: f64) -> (DecodeLimit, f64) {
    (
        DecodeLimit::Threshold(budget * share),
        budget * (1.0 - share),
    )
}

/// A bench binary's timed runs per case: its first argument that is not a flag (cargo bench
/// appends `--bench`, which is skipped) or the word `parts` (terrain_rounds' switch),
/// default 31.
pub fn iterations_arg() -> usize {
    std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-') && a != "parts")
        .map(|a| a.parse::<usize>().expect("ITERATIONS: a positive integer"))
        .unwrap_or(31)
        .max(1)
}

/// The median wall time of `iterations` runs of `f` (ms), after 5 untimed ones.
pub fn median_ms(iterations: usize, mut f: impl FnMut()) -> f64 {
    for _ in 0..5 {
        f();
    }
    let mut ms: Vec<f64> = (0..iterations)
        .map(|_| {
            let t = std::time::Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    ms[ms.len() / 2]
}
