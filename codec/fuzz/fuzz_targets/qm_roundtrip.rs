//! The quantized-mesh writer on arbitrary meshes, tiles and extensions: it either refuses the
//! input with an error or writes a tile that the tests' independent reader (written from the
//! format's README alone) accepts, holding exactly the triangles and quantised positions it
//! was given. The codec's own decoder must read the same tile the same way.
#![no_main]

use libfuzzer_sys::arbitrary::{Arbitrary, Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use zerotile_codec::formats::quantized_mesh::{decode, encode, QmOptions, WaterMask};
use zerotile_codec::geo::TileGeo;
use zerotile_codec::zerotree::TerrainMesh;

#[derive(Debug)]
struct Case {
    mesh: TerrainMesh,
    tile: TileGeo,
    opts: QmOptions,
}

impl<'a> Arbitrary<'a> for Case {
    fn arbitrary(u: &mut Unstructured<'a>) -> Result<Self> {
        // Small grids keep each run fast; degenerate ones (fewer than 2 samples a side) must
        // be refused, so they are generated too.
        let rows = usize::from(u.int_in_range(1u8..=65)?);
        let cols = usize::from(u.int_in_range(1u8..=65)?);
        let n = usize::from(u.int_in_range(1u16..=300)?);
        let mut positions = Vec::with_capacity(n);
        for _ in 0..n {
            // Mostly on the grid (as the mesher writes), sometimes anywhere, NaN included.
            let p = if u.ratio(7u8, 8)? {
                let x = f64::from(u.int_in_range(0u16..=1024)?) / 1024.0 * (cols as f64 - 1.0);
                let y = f64::from(u.int_in_range(0u16..=1024)?) / 1024.0 * (rows as f64 - 1.0);
                let z = f64::from(u.arbitrary::<i16>()?) * 0.25;
                [x, y, z]
            } else {
                [u.arbitrary()?, u.arbitrary()?, u.arbitrary()?]
            };
            positions.push(p);
        }
        let t = usize::from(u.int_in_range(0u16..=400)?);
        let mut triangles = Vec::with_capacity(t);
        for _ in 0..t {
            // Indices past the vertices now and then: the writer must refuse them.
            let bound = if u.ratio(1u8, 64)? {
                n as u32 + 3
            } else {
                n as u32 - 1
            };
            triangles.push([
                u.int_in_range(0..=bound)?,
                u.int_in_range(0..=bound)?,
                u.int_in_range(0..=bound)?,
            ]);
        }
        let west = f64::from(u.int_in_range(-1800i16..=1790)?) / 10.0;
        let south = f64::from(u.int_in_range(-900i16..=890)?) / 10.0;
        let width = f64::from(u.int_in_range(1u16..=3600)?) / 10.0;
        let height = f64::from(u.int_in_range(1u16..=1800)?) / 10.0;
        let tile = TileGeo::geodetic(west, south, west + width, (south + height).min(90.0));
        let opts = QmOptions {
            octvertexnormals: u.arbitrary()?,
            watermask: match u.int_in_range(0u8..=3)? {
                0 => None,
                1 => Some(WaterMask::Uniform(u.arbitrary()?)),
                2 => Some(WaterMask::Grid(vec![u.arbitrary()?; 256 * 256])),
                // A wrong-sized grid must be refused.
                _ => Some(WaterMask::Grid(vec![0; usize::from(u.arbitrary::<u8>()?)])),
            },
            metadata: None,
        };
        Ok(Self {
            mesh: TerrainMesh {
                rows,
                cols,
                positions,
                triangles,
            },
            tile,
            opts,
        })
    }
}

fn quantize(t: f64) -> i64 {
    (t * 32767.0).round().clamp(0.0, 32767.0) as i64
}

fuzz_target!(|case: Case| {
    let Ok(bytes) = encode(&case.mesh, &case.tile, &case.opts) else {
        return;
    };
    let m = &case.mesh;
    let tile = zerotile_tests::qm::read(&bytes)
        .unwrap_or_else(|e| panic!("the independent reader refuses our tile: {e}"));
    let ours = decode(&bytes).unwrap_or_else(|e| panic!("our own decoder refuses it: {e}"));
    assert_eq!(tile.u.len(), m.positions.len(), "vertex count");
    assert_eq!(tile.triangles.len(), m.triangles.len(), "triangle count");
    assert_eq!(ours.u, tile.u);
    assert_eq!(ours.v, tile.v);
    assert_eq!(ours.height, tile.h);
    assert_eq!(ours.triangles, tile.triangles);
    assert_eq!(ours.normals.is_some(), case.opts.octvertexnormals);

    // Triangle by triangle, corner by corner: the position written is the one given. Heights
    // are quantised over the header's f32 range (the mesh's range rounded outwards): the
    // height a client reconstructs is within one quantisation step of the one given.
    let (min_h, max_h) = (f64::from(tile.min_height), f64::from(tile.max_height));
    let step = (max_h - min_h) / 32767.0;
    let (cols1, rows1) = ((m.cols - 1) as f64, (m.rows - 1) as f64);
    for (given, read) in m.triangles.iter().zip(&tile.triangles) {
        for (&g, &r) in given.iter().zip(read) {
            let [x, y, z] = m.positions[g as usize];
            let r = r as usize;
            assert_eq!(i64::from(tile.u[r]), quantize(x / cols1), "u of vertex {g}");
            assert_eq!(
                i64::from(tile.v[r]),
                quantize((rows1 - y) / rows1),
                "v of vertex {g}"
            );
            let back = min_h + f64::from(tile.h[r]) * step;
            assert!(
                (back - z).abs() <= step + z.abs() * 1e-12,
                "height of vertex {g}: {z} written, {back} read (range {min_h}..{max_h})"
            );
        }
    }
});
