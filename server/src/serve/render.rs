//! A decoded tile or its mesh, written in each client format. Pure functions over codec
//! types; the routes choose which and add the HTTP around them.

use std::borrow::Cow;

use anyhow::{Context, Result};
use glam::DVec3;
use zerotile_codec::container::TileId;
use zerotile_codec::formats::layer_json::AvailableRange;
use zerotile_codec::formats::mesh_bin::{self, MeshCrs};
use zerotile_codec::formats::quantized_mesh::{self, Diagonals, QmOptions};
use zerotile_codec::formats::terrain_rgb::{self, PngCompression, RgbOptions};
use zerotile_codec::geo::geoid;
use zerotile_codec::geo::{self, EnuFrame, Scheme, TileGeo};
use zerotile_codec::mesh::{io, Format, TriMesh};
use zerotile_codec::raster::Encoding;
use zerotile_codec::tile::Neighbourhood;
use zerotile_codec::zerotree::TerrainMesh;
use zerotile_codec::Grid;

use super::dataset::Dataset;
use super::frame;

fn geo_id(id: TileId) -> geo::TileId {
    geo::TileId::new(id.z, id.x, id.y)
}

/// A quantized-mesh-1.0 tile (the tiling must be georeferenced). With the decodes `mesh`
/// was stitched from (and the corner neighbours'), its normals come from their height grid,
/// so they agree across tile borders and corners (`quantized_mesh::grid_normals`);
/// without, from its own triangles.
pub fn quantized_mesh(
    d: &Dataset,
    id: TileId,
    mesh: &TerrainMesh,
    opts: &QmOptions,
    around: Option<(Neighbourhood, Diagonals)>,
) -> Result<Vec<u8>> {
    let tile = d.tiling.tile_geo(geo_id(id))?;
    // The geoid's slope (under 10⁻⁴) leaves the normals as the heights give them.
    let normals = around
        .filter(|_| opts.octvertexnormals)
        .map(|(n, diagonals)| quantized_mesh::grid_normals(&tile, &n, &diagonals, mesh));
    Ok(quantized_mesh::encode_with_normals(
        &above_ellipsoid(d, &tile, mesh),
        &tile,
        opts,
        normals.as_deref(),
    )?)
}

/// `mesh` with heights above the WGS84 ellipsoid, which Cesium draws quantized-mesh on:
/// raised by the geoid's undulation where the dataset's are above EGM96 (the tile's zoom's
/// lattice, so tiles that share an edge raise it alike), as they are otherwise.
fn above_ellipsoid<'a>(d: &Dataset, tile: &TileGeo, mesh: &'a TerrainMesh) -> Cow<'a, TerrainMesh> {
    match frame::geoid(d, [tile.west, tile.south, tile.east, tile.north]) {
        Some(geoid) => {
            let mut raised = mesh.clone();
            geoid::raise(&mut raised, tile, &geoid);
            Cow::Owned(raised)
        }
        None => Cow::Borrowed(mesh),
    }
}

/// Two triangles at one height over a whole tile: what a root tile without data holds
/// (Cesium needs every root tile to exist).
pub fn flat_mesh(side: usize, height: f64) -> TerrainMesh {
    let last = (side - 1) as f64;
    TerrainMesh {
        rows: side,
        cols: side,
        positions: vec![
            [0.0, 0.0, height],
            [last, 0.0, height],
            [0.0, last, height],
            [last, last, height],
        ],
        // Counter-clockwise seen from above, north up.
        triangles: vec![[2, 3, 1], [2, 1, 0]],
    }
}

/// The metadata extension's child availability: which of the tile's four children exist,
/// as TMS ranges (Cesium counts y from the south in every scheme).
pub fn child_availability(d: &Dataset, id: TileId) -> Result<serde_json::Value> {
    let mut ranges = Vec::new();
    if let Some(children) = geo_id(id).children() {
        let z = id.z.saturating_add(1);
        let ny = match d.tiling.tiles_per_axis(z) {
            Ok((_, ny)) => ny,
            Err(_) => 0,
        };
        for c in children {
            let cid = TileId {
                z: c.z,
                x: c.x,
                y: c.y,
            };
            if !d.has_tile(cid) {
                continue;
            }
            let y = match d.tiling.scheme() {
                Scheme::Geodetic => c.y,
                _ => ny.saturating_sub(1).saturating_sub(c.y),
            };
            ranges.push(AvailableRange {
                start_x: c.x,
                start_y: y,
                end_x: c.x,
                end_y: y,
            });
        }
    }
    Ok(serde_json::json!({ "available": [ranges] }))
}

/// A terrain-RGB or Terrarium PNG of `size`² pixels over the tile.
pub fn png(
    heights: &Grid<f64>,
    encoding: Encoding,
    size: u32,
    compression: PngCompression,
) -> Result<Vec<u8>> {
    let opts = RgbOptions {
        size: Some(size),
        compression,
        ..RgbOptions::new(encoding)
    };
    Ok(terrain_rgb::encode(heights, &opts)?)
}

/// The ZTM1 binary mesh.
pub fn mesh_bin(d: &Dataset, id: TileId, mesh: &TerrainMesh) -> Result<Vec<u8>> {
    let crs = match d.tiling.scheme() {
        Scheme::Geodetic => MeshCrs::Geographic,
        Scheme::Mercator => MeshCrs::WebMercator,
        Scheme::Local { .. } => MeshCrs::LocalGrid,
    };
    let bounds = d.tiling.tile_bounds(geo_id(id))?;
    Ok(mesh_bin::encode(mesh, crs, &bounds)?)
}

/// The mesh in the scheme's coordinates, z up: longitude and latitude degrees (geodetic),
/// EPSG:3857 metres (mercator), or full-resolution column and minus row (local, so y points
/// north and triangles stay counter-clockwise); heights in metres.
pub fn tri_mesh(d: &Dataset, id: TileId, mesh: &TerrainMesh) -> Result<TriMesh> {
    let b = d.tiling.tile_bounds(geo_id(id))?;
    let last = (mesh.cols.max(2) - 1) as f64;
    let (top, bottom, flip) = match d.tiling.scheme() {
        Scheme::Local { .. } => (b.min_y, b.max_y, -1.0),
        Scheme::Geodetic | Scheme::Mercator => (b.max_y, b.min_y, 1.0),
    };
    let positions = mesh
        .positions
        .iter()
        .map(|&[c, r, h]| {
            DVec3::new(
                b.min_x + c / last * (b.max_x - b.min_x),
                flip * (top + r / last * (bottom - top)),
                h,
            )
        })
        .collect();
    Ok(TriMesh::new(positions, mesh.triangles.clone()))
}

/// OBJ, GLB or JSON bytes of the mesh, in the scheme's coordinates or in `enu`.
pub fn mesh_file(
    d: &Dataset,
    id: TileId,
    mesh: &TerrainMesh,
    format: Format,
    enu: Option<&EnuFrame>,
) -> Result<Vec<u8>> {
    mesh_bytes(id, &mesh_in_frame(d, id, mesh, enu)?, format)
}

/// The tile's mesh in the scheme's coordinates or in `enu` (raised by the geoid there, see
/// [`into_enu`]): what [`mesh_file`] writes.
pub fn mesh_in_frame(
    d: &Dataset,
    id: TileId,
    mesh: &TerrainMesh,
    enu: Option<&EnuFrame>,
) -> Result<TriMesh> {
    let mut m = tri_mesh(d, id, mesh)?;
    if let Some(f) = enu {
        into_enu(d, id, &mut m, f)?;
    }
    Ok(m)
}

/// Moves `m`, tile `id`'s mesh in the scheme's coordinates ([`tri_mesh`]), into `enu`,
/// raised by the geoid there (see [`frame::to_enu`]) with the tile's lattice, as every
/// ENU tile is.
pub fn into_enu(d: &Dataset, id: TileId, m: &mut TriMesh, enu: &EnuFrame) -> Result<()> {
    let g = d.tiling.tile_geo(geo_id(id))?;
    let geoid = frame::geoid(d, [g.west, g.south, g.east, g.north]);
    frame::to_enu(m, d.tiling.scheme(), enu, geoid.as_ref());
    Ok(())
}

/// `m`, tile `id`'s mesh from [`mesh_in_frame`], as a file in `format`.
pub fn mesh_bytes(id: TileId, m: &TriMesh, format: Format) -> Result<Vec<u8>> {
    io::write_z_up_bytes(m, format)
        .with_context(|| format!("writing tile {id} as {}", format.name()))
}
