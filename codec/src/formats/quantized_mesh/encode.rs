//! quantized-mesh-1.0 encoder for a tile's [`TerrainMesh`].
//!
//! References: see the module doc (quantized-mesh README, CesiumJS' reader); the header's
//! bounding volumes follow `geo::bounds` (Ritter's sphere, Cesium's horizon occlusion point).
//! Header values are computed from the positions a client will reconstruct (the quantised
//! ones), so the sphere and the occlusion point hold for what is drawn.

use glam::DVec3;

use super::{
    oct_encode, QmError, QmOptions, WaterMask, EXTENSION_METADATA, EXTENSION_OCT_NORMALS,
    EXTENSION_WATER_MASK, HEADER_BYTES, MAX_VERTICES_16_BIT, QUANTIZED_MAX, WATER_MASK_SIDE,
};
use crate::geo::{horizon_occlusion_point, BoundingSphere, Ellipsoid, RowSpacing, TileGeo};
use crate::zerotree::TerrainMesh;

/// A bounding-sphere centre this close to the Earth's centre (fraction of the polar radius)
/// points nowhere useful; Cesium then aims the occlusion point at the tile centre instead
/// (`EllipsoidalOccluder.computeHorizonCullingPointFromRectangle`, CesiumJS PR #761).
const DEGENERATE_DIRECTION: f64 = 0.1;

/// Encodes `mesh` as a quantized-mesh-1.0 tile covering `tile`, with the extensions `opts`
/// asks for.
///
/// The mesh contract: grid coordinates with x = column ∈ [0, cols − 1] (east), y = row ∈
/// [0, rows − 1] (south, row 0 on the north edge), z = height in metres above the WGS84
/// ellipsoid; triangles counter-clockwise seen from above with north up (then they are
/// counter-clockwise in (u, v) too, as the format requires). Vertices are renumbered in order
/// of first use, which the high-water-mark index code needs; unused vertices go last. Edge
/// lists hold every vertex on x = 0 (west), y = rows − 1 (south), x = cols − 1 (east) and
/// y = 0 (north), sorted south → north and west → east.
pub fn encode(mesh: &TerrainMesh, tile: &TileGeo, opts: &QmOptions) -> Result<Vec<u8>, QmError> {
    encode_with_normals(mesh, tile, opts, None)
}

/// [`encode`] with the vertex normals given (ECEF, one per vertex of `mesh`, in its order),
/// e.g. [`grid_normals`](super::grid_normals) for a stitched tile, instead of the
/// area-weighted normals of the mesh's own triangles.
pub fn encode_with_normals(
    mesh: &TerrainMesh,
    tile: &TileGeo,
    opts: &QmOptions,
    normals: Option<&[DVec3]>,
) -> Result<Vec<u8>, QmError> {
    // Check everything from outside first: nothing below can then fail.
    check_mesh(mesh)?;
    if let Some(given) = normals {
        if given.len() != mesh.positions.len() || given.iter().any(|v| !v.is_finite()) {
            return Err(QmError::InvalidMesh(format!(
                "{} normals, finite, for {} vertices",
                given.len(),
                mesh.positions.len()
            )));
        }
    }
    check_tile(tile)?;
    check_water_mask(opts.watermask.as_ref())?;
    let metadata = opts
        .metadata
        .as_ref()
        .map(serde_json::to_vec)
        .transpose()
        .map_err(|e| parameter("metadata", "serialisable JSON", e.to_string()))?;

    // Renumber vertices by first use: the index code can only introduce vertex `highest`.
    let (mut order, triangles) = first_use_order(mesh);
    if order.len() == MAX_VERTICES_16_BIT {
        order.push(cesium_pad(mesh, &order));
    }

    // Quantise against the tile bounds and the mesh's own (f32) height range.
    let (min_h, max_h) = f32_height_range(mesh);
    let q = Quantized::new(mesh, tile, &order, min_h, max_h);

    // Reconstruct what the client will draw, in ECEF, for the header and the normals.
    let ecef = q.ecef(tile, min_h, max_h);

    // Header: centre, heights, bounding sphere, horizon occlusion point.
    let header = header(tile, &ecef, min_h, max_h);

    // Edge lists, in the order CesiumJS sorts them to (so it never has to).
    let edges = edge_lists(mesh, &order, &q);

    // Count the bytes, then fill a buffer of exactly that size.
    let n = order.len();
    let wide = n > MAX_VERTICES_16_BIT;
    let index_bytes = if wide { 4 } else { 2 };
    let vertex_end = HEADER_BYTES + 4 + 6 * n;
    // vertex_end = 92 + 6n is even, so the remainder is 0 or 2 and `index_bytes + …` would
    // pad the same: an equivalent mutant.
    let padding = (index_bytes - vertex_end % index_bytes) % index_bytes;
    let edge_count: usize = edges.iter().map(Vec::len).sum();
    let normals_len = if opts.octvertexnormals { 5 + 2 * n } else { 0 };
    let water_len = match &opts.watermask {
        None => 0,
        Some(WaterMask::Uniform(_)) => 5 + 1,
        Some(WaterMask::Grid(g)) => 5 + g.len(),
    };
    let metadata_len = metadata.as_ref().map_or(0, |m| 5 + 4 + m.len());
    let total = vertex_end
        + padding
        + 4
        + 3 * triangles.len() * index_bytes
        + 4 * 4
        + edge_count * index_bytes
        + normals_len
        + water_len
        + metadata_len;
    let mut out = Vec::with_capacity(total);

    // Header and vertex data.
    put_header(&mut out, &header);
    put_u32(&mut out, len_u32(n)?);
    for values in [&q.u, &q.v, &q.h] {
        put_zigzag_deltas(&mut out, values);
    }

    // Index data: aligned to its own size, high-water-mark coded.
    out.resize(out.len() + padding, 0);
    put_u32(&mut out, len_u32(triangles.len())?);
    let mut highest = 0u32;
    for &index in triangles.iter().flatten() {
        debug_assert!(
            index <= highest,
            "first-use order guarantees index ≤ highest"
        );
        put_index(&mut out, highest - index, wide);
        if index == highest {
            highest += 1;
        }
    }

    // Edge lists: west, south, east, north.
    for list in &edges {
        put_u32(&mut out, len_u32(list.len())?);
        for &index in list {
            put_index(&mut out, index, wide);
        }
    }

    // Extensions, in id order.
    if opts.octvertexnormals {
        put_extension_header(&mut out, EXTENSION_OCT_NORMALS, 2 * n)?;
        match normals {
            Some(given) => {
                for &old in &order {
                    let n = given.get(old as usize).copied().unwrap_or(DVec3::Z);
                    out.extend_from_slice(&oct_encode(n.try_normalize().unwrap_or(DVec3::Z)));
                }
            }
            None => {
                for normal in vertex_normals(&ecef, &triangles) {
                    out.extend_from_slice(&oct_encode(normal));
                }
            }
        }
    }
    match &opts.watermask {
        None => {}
        Some(WaterMask::Uniform(value)) => {
            put_extension_header(&mut out, EXTENSION_WATER_MASK, 1)?;
            out.push(*value);
        }
        Some(WaterMask::Grid(grid)) => {
            put_extension_header(&mut out, EXTENSION_WATER_MASK, grid.len())?;
            out.extend_from_slice(grid);
        }
    }
    if let Some(json) = &metadata {
        put_extension_header(&mut out, EXTENSION_METADATA, 4 + json.len())?;
        put_u32(&mut out, len_u32(json.len())?);
        out.extend_from_slice(json);
    }
    debug_assert_eq!(out.len(), total, "counted and written sizes agree");
    Ok(out)
}

/// Quantised vertices in the new (first-use) order.
struct Quantized {
    u: Vec<u16>,
    v: Vec<u16>,
    h: Vec<u16>,
}

impl Quantized {
    fn new(mesh: &TerrainMesh, tile: &TileGeo, order: &[u32], min_h: f32, max_h: f32) -> Self {
        let max = f64::from(QUANTIZED_MAX);
        let (cols1, rows1) = ((mesh.cols - 1) as f64, (mesh.rows - 1) as f64);
        let (lo, range) = (f64::from(min_h), f64::from(max_h) - f64::from(min_h));
        let quantize = |t: f64| (t * max).round().clamp(0.0, max) as u16;
        let mut q = Self {
            u: Vec::with_capacity(order.len()),
            v: Vec::with_capacity(order.len()),
            h: Vec::with_capacity(order.len()),
        };
        for &old in order {
            let [x, y, z] = mesh.positions[old as usize];
            q.u.push(quantize(x / cols1));
            // v is linear in latitude: direct for geodetic rows, through the projection for
            // mercator rows.
            q.v.push(match tile.rows {
                RowSpacing::Latitude => quantize((rows1 - y) / rows1),
                RowSpacing::MercatorY => {
                    let lat = tile.latitude_at(y / rows1);
                    quantize((lat - tile.south) / (tile.north - tile.south))
                }
            });
            // A flat tile (range 0) quantises every height to 0 (so would the NaN of 0 / 0,
            // through the clamp and the cast: `>` and `>=` here are equivalent mutants).
            q.h.push(if range > 0.0 {
                quantize((z - lo) / range)
            } else {
                0
            });
        }
        q
    }

    /// ECEF positions of the quantised vertices, as a client reconstructs them.
    fn ecef(&self, tile: &TileGeo, min_h: f32, max_h: f32) -> Vec<DVec3> {
        let max = f64::from(QUANTIZED_MAX);
        let (lo, hi) = (f64::from(min_h), f64::from(max_h));
        (0..self.u.len())
            .map(|i| {
                let lon = tile.west + f64::from(self.u[i]) / max * (tile.east - tile.west);
                let lat = tile.south + f64::from(self.v[i]) / max * (tile.north - tile.south);
                let h = lo + f64::from(self.h[i]) / max * (hi - lo);
                Ellipsoid::WGS84.to_ecef(lon, lat, h)
            })
            .collect()
    }
}

struct Header {
    center: DVec3,
    min_h: f32,
    max_h: f32,
    sphere: BoundingSphere,
    horizon: DVec3,
}

fn header(tile: &TileGeo, ecef: &[DVec3], min_h: f32, max_h: f32) -> Header {
    let e = Ellipsoid::WGS84;
    // Centre: the tile's geographic centre at mid-height.
    let mid_h = (f64::from(min_h) + f64::from(max_h)) / 2.0;
    let center = e.to_ecef(
        (tile.west + tile.east) / 2.0,
        (tile.south + tile.north) / 2.0,
        mid_h,
    );
    // check_mesh guarantees vertices with finite coordinates.
    let sphere = BoundingSphere::from_points(ecef).unwrap_or(BoundingSphere {
        center,
        radius: 0.0,
    });
    // Aim the occlusion point at the sphere's centre, or the tile's when that is degenerate;
    // with no point at all (wider than a hemisphere), NaN: Cesium's test never culls it.
    // (`<=`, `==` and a far smaller bound are equivalent mutants: a centre within 0.1 b of
    // the Earth's needs a tile wider than a hemisphere, whose point is NaN either way.)
    let direction = if sphere.center.length() < DEGENERATE_DIRECTION * e.b {
        center
    } else {
        sphere.center
    };
    let horizon = horizon_occlusion_point(&e, direction, ecef).unwrap_or(DVec3::NAN);
    Header {
        center,
        min_h,
        max_h,
        sphere,
        horizon,
    }
}

/// The mesh's height range as f32, rounded outwards so every height quantises inside it.
fn f32_height_range(mesh: &TerrainMesh) -> (f32, f32) {
    let (lo, hi) = mesh.height_range().unwrap_or((0.0, 0.0));
    let mut lo32 = lo as f32;
    if f64::from(lo32) > lo {
        lo32 = lo32.next_down();
    }
    let mut hi32 = hi as f32;
    if f64::from(hi32) < hi {
        hi32 = hi32.next_up();
    }
    (lo32, hi32)
}

/// `order[new] = old` by first use in the triangle list (unused vertices last), and the
/// triangles renumbered.
fn first_use_order(mesh: &TerrainMesh) -> (Vec<u32>, Vec<[u32; 3]>) {
    const UNSEEN: u32 = u32::MAX;
    let n = mesh.positions.len();
    let mut new_of = vec![UNSEEN; n];
    let mut order = Vec::with_capacity(n);
    let mut next = 0u32;
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| {
            t.map(|old| {
                let slot = &mut new_of[old as usize];
                if *slot == UNSEEN {
                    *slot = next;
                    order.push(old);
                    next += 1;
                }
                *slot
            })
        })
        .collect();
    order.extend((0..n as u32).filter(|&old| new_of[old as usize] == UNSEEN));
    (order, triangles)
}

/// The vertex repeated, unused, after a tile's 65,536: CesiumJS cannot read a tile of exactly
/// that many (CesiumGS/cesium#5983, still in 24.0). Its terrain provider reads the spec's
/// 16-bit indices, then asks IndexDatatype for an array, which is 32-bit from 65,536 vertices
/// on, as a 16-bit index 65,535 would be WebGL's primitive restart: "RangeError: Invalid
/// typed array length" (a QA pass, on a N44W072 zoom-10 tile at a small threshold). With
/// one more vertex the tile has 32-bit indices, which every reader takes. An interior vertex
/// where there is one (the edge lists leave the copy out whichever it is).
fn cesium_pad(mesh: &TerrainMesh, order: &[u32]) -> u32 {
    let (last_col, last_row) = ((mesh.cols - 1) as f64, (mesh.rows - 1) as f64);
    let interior = |&old: &u32| {
        let [x, y, _] = mesh.positions[old as usize];
        x > 0.0 && x < last_col && y > 0.0 && y < last_row
    };
    order.iter().copied().find(interior).unwrap_or(order[0])
}

/// West, south, east, north lists of new indices: west/east sorted by v, south/north by u.
fn edge_lists(mesh: &TerrainMesh, order: &[u32], q: &Quantized) -> [Vec<u32>; 4] {
    let (last_col, last_row) = ((mesh.cols - 1) as f64, (mesh.rows - 1) as f64);
    let mut lists: [Vec<u32>; 4] = Default::default();
    // Not the copy `cesium_pad` may add after the mesh's own vertices.
    for (new, &old) in order.iter().enumerate().take(mesh.positions.len()) {
        let [x, y, _] = mesh.positions[old as usize];
        let new = new as u32;
        if x == 0.0 {
            lists[0].push(new);
        }
        if y == last_row {
            lists[1].push(new);
        }
        if x == last_col {
            lists[2].push(new);
        }
        if y == 0.0 {
            lists[3].push(new);
        }
    }
    let by_v = |i: &u32| q.v[*i as usize];
    let by_u = |i: &u32| q.u[*i as usize];
    lists[0].sort_by_key(by_v);
    lists[1].sort_by_key(by_u);
    lists[2].sort_by_key(by_v);
    lists[3].sort_by_key(by_u);
    lists
}

/// Area-weighted vertex normals in ECEF: the sum of each incident triangle's cross product
/// (twice its area along its normal), normalised; the ellipsoid normal where that vanishes.
fn vertex_normals(ecef: &[DVec3], triangles: &[[u32; 3]]) -> Vec<DVec3> {
    // Relative to the first vertex: keeps the cross products' operands small. (Adding the
    // origin instead of subtracting it cancels in the differences: an equivalent mutant.)
    let origin = ecef.first().copied().unwrap_or(DVec3::ZERO);
    let mut sums = vec![DVec3::ZERO; ecef.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| ecef[i as usize] - origin);
        let n = (b - a).cross(c - a);
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums.iter()
        .zip(ecef)
        .map(|(s, &p)| {
            s.try_normalize()
                .or_else(|| Ellipsoid::WGS84.surface_normal_at(p))
                .unwrap_or(DVec3::Z)
        })
        .collect()
}

fn check_mesh(mesh: &TerrainMesh) -> Result<(), QmError> {
    let bad = |msg: String| Err(QmError::InvalidMesh(msg));
    if mesh.rows < 2 || mesh.cols < 2 {
        return bad(format!(
            "a grid of {}×{} has no area (2×2 samples at least)",
            mesh.rows, mesh.cols
        ));
    }
    if mesh.triangles.is_empty() {
        return bad("no triangles".into());
    }
    let n = mesh.positions.len();
    if n > u32::MAX as usize {
        return bad(format!("{n} vertices do not fit u32 indices"));
    }
    let (last_col, last_row) = ((mesh.cols - 1) as f64, (mesh.rows - 1) as f64);
    for (i, &[x, y, z]) in mesh.positions.iter().enumerate() {
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return bad(format!("vertex {i} is not finite: ({x}, {y}, {z})"));
        }
        if !((0.0..=last_col).contains(&x) && (0.0..=last_row).contains(&y)) {
            return bad(format!(
                "vertex {i} at ({x}, {y}) is outside the {}×{} grid",
                mesh.rows, mesh.cols
            ));
        }
        if z.abs() > f64::from(f32::MAX) {
            return bad(format!("vertex {i}'s height {z} m does not fit an f32"));
        }
    }
    if let Some((t, tri)) = mesh
        .triangles
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&i| i as usize >= n))
    {
        return bad(format!("triangle {t} {tri:?} points past the {n} vertices"));
    }
    Ok(())
}

fn check_tile(tile: &TileGeo) -> Result<(), QmError> {
    let ok = [tile.west, tile.south, tile.east, tile.north]
        .iter()
        .all(|v| v.is_finite())
        && tile.west < tile.east
        && tile.south < tile.north
        && (-90.0..=90.0).contains(&tile.south)
        && (-90.0..=90.0).contains(&tile.north);
    if ok {
        Ok(())
    } else {
        Err(parameter(
            "tile bounds",
            "finite, west < east, −90 ≤ south < north ≤ 90 (degrees)",
            format!("{tile:?}"),
        ))
    }
}

fn check_water_mask(mask: Option<&WaterMask>) -> Result<(), QmError> {
    match mask {
        Some(WaterMask::Grid(g)) if g.len() != WATER_MASK_SIDE * WATER_MASK_SIDE => Err(parameter(
            "water mask grid",
            "256 × 256 = 65 536 bytes",
            g.len().to_string(),
        )),
        _ => Ok(()),
    }
}

fn parameter(name: &'static str, expected: &'static str, got: String) -> QmError {
    QmError::Parameter {
        name,
        expected,
        got,
    }
}

fn len_u32(n: usize) -> Result<u32, QmError> {
    u32::try_from(n).map_err(|_| QmError::InvalidMesh(format!("{n} elements exceed u32 counts")))
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f64s(out: &mut Vec<u8>, vs: &[f64]) {
    for v in vs {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

fn put_header(out: &mut Vec<u8>, h: &Header) {
    put_f64s(out, &h.center.to_array());
    out.extend_from_slice(&h.min_h.to_le_bytes());
    out.extend_from_slice(&h.max_h.to_le_bytes());
    put_f64s(out, &h.sphere.center.to_array());
    put_f64s(out, &[h.sphere.radius]);
    put_f64s(out, &h.horizon.to_array());
}

/// Each value minus the previous one, zig-zag mapped so small steps of either sign are
/// small numbers: 0, −1, 1, −2, … → 0, 1, 2, 3, ….
fn put_zigzag_deltas(out: &mut Vec<u8>, values: &[u16]) {
    let mut previous = 0i32;
    for &value in values {
        let delta = i32::from(value) - previous;
        previous = i32::from(value);
        // |delta| ≤ 32767, so the zig-zag code is at most 65534 (and `delta >> 31`, the sign
        // mask, equals `delta >> k` for any k from 15 up: those mutants are equivalent).
        let code = ((delta << 1) ^ (delta >> 31)) as u16;
        out.extend_from_slice(&code.to_le_bytes());
    }
}

fn put_index(out: &mut Vec<u8>, value: u32, wide: bool) {
    if wide {
        out.extend_from_slice(&value.to_le_bytes());
    } else {
        // Narrow indices are only chosen when every index is below 65 536.
        out.extend_from_slice(&(value as u16).to_le_bytes());
    }
}

fn put_extension_header(out: &mut Vec<u8>, id: u8, len: usize) -> Result<(), QmError> {
    out.push(id);
    put_u32(out, len_u32(len)?);
    Ok(())
}
