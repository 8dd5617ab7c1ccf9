//! Tile work, off the async threads: read a record, decode it to a depth (cached), and mesh
//! it stitched to its neighbours. Blocking functions; the routes call them through
//! `spawn_blocking`.

use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
use std::sync::Arc;

use anyhow::{Context, Result};
use zerotile_codec::bintree::TileErrors;
use zerotile_codec::container::TileId;
use zerotile_codec::ezw;
use zerotile_codec::formats::quantized_mesh::Diagonals;
use zerotile_codec::geo::Scheme;
use zerotile_codec::tile::{stitched_mesh, Neighbourhood, TileView};
use zerotile_codec::zerotree::TerrainMesh;

use super::dataset::Dataset;
use super::state::AppState;
use super::threshold::{mesh_tolerance, Depth};
use super::tile_cache::{DecodedTile, Key};

/// Set once nobody waits for a render any more (the client went away, or the request timed
/// out): the render stops at its next stage instead of decoding tiles no one will read.
#[derive(Clone, Debug, Default)]
pub struct Cancel(Arc<AtomicBool>);

/// The error a cancelled render stops with.
#[derive(Debug, thiserror::Error)]
#[error("the request was cancelled")]
pub struct Cancelled;

impl Cancel {
    /// A guard for the request's future: dropping the future (hyper does when the client
    /// disconnects) cancels the render it started.
    #[must_use]
    pub fn on_drop(&self) -> CancelOnDrop {
        CancelOnDrop(self.clone())
    }

    pub fn is_cancelled(&self) -> bool {
        self.0.load(Relaxed)
    }

    /// A stage boundary: stop here if cancelled.
    pub fn check(&self) -> Result<()> {
        if self.is_cancelled() {
            Err(Cancelled.into())
        } else {
            Ok(())
        }
    }
}

/// Cancels its [`Cancel`] when dropped.
#[derive(Debug)]
pub struct CancelOnDrop(Cancel);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0 .0.store(true, Relaxed);
    }
}

/// Counts `r` in the metrics if it ended by cancellation, and passes it on.
pub fn count_cancelled<T>(state: &AppState, r: Result<T>) -> Result<T> {
    if r.as_ref().is_err_and(|e| e.is::<Cancelled>()) {
        state.metrics.renders_cancelled.fetch_add(1, Relaxed);
    }
    r
}

/// Where `id` decoded to `depth` is cached.
fn key(d: &Dataset, id: TileId, depth: Depth) -> Key {
    Key {
        dataset: d.version,
        tile: id,
        depth,
    }
}

/// `id` decoded to `depth`, from the cache or decoded now.
pub fn decoded(
    state: &AppState,
    d: &Dataset,
    id: TileId,
    depth: Depth,
    cancel: &Cancel,
) -> Result<Arc<DecodedTile>> {
    let key = key(d, id, depth);
    if let Some(hit) = state.cache.get(&key) {
        state.metrics.cache_hits.fetch_add(1, Relaxed);
        return Ok(hit);
    }
    state.metrics.cache_misses.fetch_add(1, Relaxed);
    // Concurrent misses on one key wait for a single decode.
    state.cache.get_or_insert_with(&key, || {
        cancel.check()?;
        let tile = decode(d, id, depth)?;
        state.metrics.tiles_decoded.fetch_add(1, Relaxed);
        Ok(Arc::new(tile))
    })
}

/// `id` read and decoded to `depth`, with its error tree: what the cache keeps.
pub fn decode(d: &Dataset, id: TileId, depth: Depth) -> Result<DecodedTile> {
    let rec = d.read_tile(id)?;
    let dec = ezw::decode_heights(&rec.stream, depth.limit(), ezw::DEFAULT_MAX_SAMPLES)
        .with_context(|| format!("decoding tile {id} of {}", d.name))?;
    let side = d.hierarchy.side();
    if dec.heights.rows() != side || dec.heights.cols() != side {
        anyhow::bail!(
            "tile {id} of {} decodes to {}×{}, the dataset says {side}²",
            d.name,
            dec.heights.rows(),
            dec.heights.cols()
        );
    }
    let errors = TileErrors::exact_above(&d.hierarchy, &dec.heights, depth.mesh_floor());
    // The prefix alone is kept: a coarse depth reads a fraction of the record.
    let mut prefix = rec.stream;
    prefix.truncate(dec.bytes_used);
    prefix.shrink_to_fit();
    Ok(DecodedTile {
        heights: dec.heights,
        errors,
        corners: rec.corners,
        prefix,
    })
}

fn view(t: &DecodedTile) -> TileView<'_> {
    TileView {
        heights: &t.heights,
        errors: &t.errors,
    }
}

/// The rows north and south of `id` and the columns west and east of it, where the tiling
/// has them (whether a tile is there is the caller's question).
fn steps(d: &Dataset, id: TileId) -> [Option<u32>; 4] {
    // Row 0 of a tile is its north edge; geodetic tile rows count from the south.
    let (north_y, south_y) = match d.tiling.scheme() {
        Scheme::Geodetic => (id.y.checked_add(1), id.y.checked_sub(1)),
        Scheme::Mercator | Scheme::Local { .. } => (id.y.checked_sub(1), id.y.checked_add(1)),
    };
    // The world schemes go round: across the antimeridian the first column's west
    // neighbour is the last column (both zoom-0 geodetic roots always exist, and a crack
    // between them showed on every globe).
    let columns = match d.tiling.scheme() {
        Scheme::Geodetic | Scheme::Mercator => d.tiling.tiles_per_axis(id.z).ok().map(|(n, _)| n),
        Scheme::Local { .. } => None,
    };
    let west_x = id.x.checked_sub(1).or(columns.map(|n| n - 1));
    let east_x = match columns {
        Some(n) if id.x + 1 >= n => Some(0),
        _ => id.x.checked_add(1),
    };
    [north_y, south_y, west_x, east_x]
}

/// The tile at column `x`, row `y` of `id`'s zoom, if both exist and the dataset holds it.
fn existing(d: &Dataset, z: u8, x: Option<u32>, y: Option<u32>) -> Option<TileId> {
    let t = TileId { z, x: x?, y: y? };
    d.has_tile(t).then_some(t)
}

/// Edge neighbours that exist: north, south, west, east.
pub fn neighbours(d: &Dataset, id: TileId) -> [Option<TileId>; 4] {
    let [north, south, west, east] = steps(d, id);
    let at = |x, y| existing(d, id.z, x, y);
    [
        at(Some(id.x), north),
        at(Some(id.x), south),
        at(west, Some(id.y)),
        at(east, Some(id.y)),
    ]
}

/// Corner neighbours that exist: north-west, north-east, south-west, south-east.
pub fn diagonal_neighbours(d: &Dataset, id: TileId) -> [Option<TileId>; 4] {
    let [north, south, west, east] = steps(d, id);
    let at = |x, y| existing(d, id.z, x, y);
    [
        at(west, north),
        at(east, north),
        at(west, south),
        at(east, south),
    ]
}

/// Decodes of `ids` at `depth`. Two or more not in the cache (a cold tile needs up to five)
/// are decoded side by side on the render pool: one after another they would leave the
/// other cores idle while a lone client waits, and under load the pool's threads are busy
/// anyway, so this costs no throughput. One or none is done here: a hop to the pool and back
/// would cost more than it could overlap (a block of tiles fetched in order needs about one
/// new decode a tile). The decodes must not use rayon themselves: a task waiting on the
/// cache for a key another task is decoding never steals work while it waits, so it is
/// never handed a task that waits on itself.
fn decoded_all<const N: usize>(
    state: &AppState,
    d: &Dataset,
    ids: [Option<TileId>; N],
    depth: Depth,
    cancel: &Cancel,
) -> [Option<Result<Arc<DecodedTile>>>; N] {
    let misses = ids
        .iter()
        .flatten()
        .filter(|&&id| !state.cache.contains_key(&key(d, id, depth)))
        .count();
    if misses < 2 {
        return ids.map(|id| id.map(|id| decoded(state, d, id, depth, cancel)));
    }
    let mut out: [Option<Result<Arc<DecodedTile>>>; N] = std::array::from_fn(|_| None);
    state.pool.install(|| {
        rayon::scope(|s| {
            for (slot, id) in out.iter_mut().zip(ids) {
                if let Some(id) = id {
                    s.spawn(move |_| *slot = Some(decoded(state, d, id, depth, cancel)));
                }
            }
        });
    });
    out
}

/// The neighbours' decodes `id` is meshed with. One that cannot be read (a corrupt record)
/// is left out: it costs this tile its match there, not the tile itself. One the store did
/// not give, or whose file is being written over, fails the tile: that failure passes, and
/// a tile meshed without its neighbour would carry cracks along that edge under the tile's
/// ETag and an hour's freshness.
fn usable<const N: usize>(
    d: &Dataset,
    id: TileId,
    ids: [Option<TileId>; N],
    decodes: [Option<Result<Arc<DecodedTile>>>; N],
) -> Result<[Option<Arc<DecodedTile>>; N]> {
    let mut out: [Option<Arc<DecodedTile>>; N] = std::array::from_fn(|_| None);
    for ((slot, n), decode) in out.iter_mut().zip(ids).zip(decodes) {
        let (Some(n), Some(decode)) = (n, decode) else {
            continue;
        };
        match decode {
            Ok(t) => *slot = Some(t),
            Err(e) if e.is::<Cancelled>() || super::storage::passing(&e) => return Err(e),
            Err(e) => tracing::warn!("meshing {id} of {} without neighbour {n}: {e:#}", d.name),
        }
    }
    Ok(out)
}

/// A tile meshed against its neighbours, with the decodes it was meshed from.
pub struct Stitched {
    id: TileId,
    pub center: Arc<DecodedTile>,
    /// North, south, west, east, where they exist and read.
    around: [Option<Arc<DecodedTile>>; 4],
    /// North-west, north-east, south-west, south-east, once [`Stitched::add_diagonals`] ran.
    diagonals: [Option<Arc<DecodedTile>>; 4],
    depth: Depth,
    pub mesh: TerrainMesh,
}

impl Stitched {
    /// The decodes as the stitcher saw them (for normals that agree across borders).
    pub fn neighbourhood(&self) -> Neighbourhood<'_> {
        let [north, south, west, east] = &self.around;
        Neighbourhood {
            center: view(&self.center),
            north: north.as_deref().map(view),
            south: south.as_deref().map(view),
            west: west.as_deref().map(view),
            east: east.as_deref().map(view),
            corners: Some(self.center.corners),
        }
    }

    /// Decodes the corner neighbours too: the vertex normals read one sample of each, so
    /// the four tiles at a corner give it one normal. The mesh does not need them.
    pub fn add_diagonals(&mut self, state: &AppState, d: &Dataset, cancel: &Cancel) -> Result<()> {
        let ids = diagonal_neighbours(d, self.id);
        let decodes = decoded_all(state, d, ids, self.depth, cancel);
        self.diagonals = usable(d, self.id, ids, decodes)?;
        Ok(())
    }

    /// The corner neighbours as the normals read them (none before `add_diagonals`).
    pub fn diagonals(&self) -> Diagonals<'_> {
        let [nw, ne, sw, se] = &self.diagonals;
        Diagonals {
            nw: nw.as_deref().map(view),
            ne: ne.as_deref().map(view),
            sw: sw.as_deref().map(view),
            se: se.as_deref().map(view),
        }
    }
}

/// The tile's mesh at threshold `t`, crack-free against its neighbours' meshes at the same
/// `t`, and the decodes it was made from.
pub fn stitched(
    state: &AppState,
    d: &Dataset,
    id: TileId,
    t: f64,
    cancel: &Cancel,
) -> Result<Stitched> {
    // The tile and each neighbour at one depth: the stitch needs them decoded alike.
    let depth = Depth::for_threshold(t);
    let [north, south, west, east] = neighbours(d, id);
    let [center, decodes @ ..] = decoded_all(
        state,
        d,
        [Some(id), north, south, west, east],
        depth,
        cancel,
    );
    // Always there (it was asked for); decoded here if it ever were not.
    let center = center.unwrap_or_else(|| decoded(state, d, id, depth, cancel))?;
    let around = usable(d, id, [north, south, west, east], decodes)?;
    let mut out = Stitched {
        id,
        center,
        around,
        diagonals: Default::default(),
        depth,
        mesh: TerrainMesh::default(),
    };
    cancel.check()?;
    out.mesh = stitched_mesh(&d.hierarchy, &out.neighbourhood(), mesh_tolerance(t))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::serve::tile_cache::{ByBytes, Key};
    use quick_cache::Weighter;
    use zerotile_codec::container::Writer;
    use zerotile_codec::ezw::EncodeParams;
    use zerotile_codec::raster::{read_heightmap, ReadOptions};
    use zerotile_codec::wavelet::Wavelet;

    const ROOT: TileId = TileId { z: 0, x: 0, y: 0 };

    /// A one-tile local dataset of real terrain: a 257² window of the SRTM tile N44W072
    /// (3″, 1201², big-endian i16) over the Presidential Range, 1 m steps.
    fn srtm_dataset() -> Dataset {
        let hgt = crate::fixtures::shared_data("dem/N44W072.hgt");
        let g = read_heightmap(hgt, &ReadOptions::default())
            .unwrap()
            .crop(750, 700, 257, 257)
            .unwrap()
            .heights;
        let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
        let corners = [(0, 0), (0, 256), (256, 0), (256, 256)].map(|(r, c)| *g.get(r, c));
        let mut w = Writer::new();
        w.add(ROOT, corners, &enc.bytes);
        let m = crate::fixtures::local_257(enc.bytes.len() as u64);
        let path = crate::fixtures::scratch("decoded-weight").join("t.ztd");
        std::fs::write(&path, w.finish(&m).unwrap()).unwrap();
        Dataset::open(&path).unwrap()
    }

    /// The decoded-tile cache weighs what a decode really keeps, counted independently:
    /// the bytes allocated on this thread by the decode and not freed (heights, error tree,
    /// stream prefix, the `Arc`). A coarse depth reads a fraction of the record, whose
    /// whole allocation the prefix kept (and the weight did not count) before it was shrunk.
    #[test]
    fn a_decoded_tile_weighs_what_it_holds() {
        let d = srtm_dataset();
        // Whatever the reader sets up once is not the tile's.
        decode(&d, ROOT, Depth::All).unwrap();
        for t in [0.0, 8.0, 64.0, 512.0] {
            let depth = Depth::for_threshold(t);
            let mut kept = None;
            let info = allocation_counter::measure(|| {
                kept = Some(Arc::new(decode(&d, ROOT, depth).unwrap()));
            });
            let kept = kept.unwrap();
            let key = Key {
                dataset: d.version,
                tile: ROOT,
                depth,
            };
            let weight = ByBytes.weight(&key, &kept) as f64;
            let held = info.bytes_current as f64;
            assert_eq!(kept.prefix.capacity(), kept.prefix.len(), "T {t}");
            assert!(held > 257.0 * 257.0 * 12.0, "T {t}: {held} bytes held");
            assert!(
                (weight - held).abs() <= 0.02 * held,
                "T {t}: weight {weight}, held {held} (prefix {} of {})",
                kept.prefix.len(),
                kept.prefix.capacity()
            );
        }
    }
}
