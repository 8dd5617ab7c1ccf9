//! Decoded tiles kept between requests, bounded by bytes.
//!
//! A stitched mesh needs the tile and its four edge neighbours decoded to the same depth, so
//! one cold request decodes up to five tiles and its neighbours' requests find four of them
//! here. Keys are (dataset build, tile, depth); a re-ingested dataset has a new build id and
//! its old entries simply age out.

use std::sync::Arc;

use quick_cache::sync::Cache;
use quick_cache::Weighter;
use zerotile_codec::bintree::TileErrors;
use zerotile_codec::container::TileId;
use zerotile_codec::Grid;

use super::threshold::Depth;

/// Default cache size, bytes.
pub const DEFAULT_CACHE_BYTES: u64 = 256 << 20;

/// A tile decoded to one depth, with everything the formats need.
#[derive(Debug)]
pub struct DecodedTile {
    pub heights: Grid<f64>,
    /// The mesher's per-sample error tree over `heights`.
    pub errors: TileErrors,
    /// Exact source heights at the corners: NW, NE, SW, SE.
    pub corners: [f64; 4],
    /// The stream prefix this decode read: what `.ezw` sends.
    pub prefix: Vec<u8>,
}

impl DecodedTile {
    /// Heap bytes the tile holds: the cache's weight. The f64 heights, the error tree (one
    /// f32 a sample) and the prefix at its capacity, not its length (a prefix cut from a
    /// longer read keeps the whole allocation unless it is shrunk, as `pipeline::decode` does),
    /// plus the `Arc` around it.
    pub fn bytes(&self) -> u64 {
        let side = self.errors.side();
        let heights = self.heights.len() * std::mem::size_of::<f64>();
        let errors = side * side * std::mem::size_of::<f32>();
        let arc = std::mem::size_of::<Self>() + 2 * std::mem::size_of::<usize>();
        (heights + errors + self.prefix.capacity() + arc) as u64
    }
}

/// Cache key: dataset build, tile, decode depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Key {
    pub dataset: u64,
    pub tile: TileId,
    pub depth: Depth,
}

#[derive(Clone, Copy, Debug, Default)]
pub struct ByBytes;

impl Weighter<Key, Arc<DecodedTile>> for ByBytes {
    fn weight(&self, _key: &Key, val: &Arc<DecodedTile>) -> u64 {
        val.bytes().max(1)
    }
}

/// The bounded cache.
pub type TileCache = Cache<Key, Arc<DecodedTile>, ByBytes>;

/// Default size of the cache of encoded responses, bytes.
pub const DEFAULT_RESPONSE_CACHE_BYTES: u64 = 64 << 20;

/// An encoded tile body, ready to send again.
#[derive(Debug)]
pub struct Encoded {
    pub bytes: bytes::Bytes,
    pub triangles: Option<usize>,
}

impl Encoded {
    /// `body` at its length: see [`exact_bytes`].
    pub fn new(body: Vec<u8>, triangles: Option<usize>) -> Self {
        Self {
            bytes: exact_bytes(body),
            triangles,
        }
    }
}

/// `body` as `Bytes` holding no more than its length. `Bytes::from(Vec)` keeps the vector's
/// whole allocation, and an encoder's output vector grows by doubling (a gzip one starts at
/// half the raw size): cached as they were, the bodies held 1.7× the bytes the response
/// cache counted (100 MB in a 64 MiB cache under a load of distinct mesh tiles). The shrink
/// is a realloc in place (or a remap, for a large block), not a copy.
pub fn exact_bytes(body: Vec<u8>) -> bytes::Bytes {
    bytes::Bytes::from(body.into_boxed_slice())
}

#[derive(Clone, Copy, Debug, Default)]
pub struct EncodedBytes;

impl Weighter<u64, Arc<Encoded>> for EncodedBytes {
    fn weight(&self, _key: &u64, val: &Arc<Encoded>) -> u64 {
        val.bytes.len() as u64 + 64
    }
}

/// Encoded responses by their ETag hash: a warm tile skips meshing and encoding (PNG
/// encoding alone costs tens of milliseconds).
pub type ResponseCache = Cache<u64, Arc<Encoded>, EncodedBytes>;

/// A response cache holding about `bytes`.
pub fn new_response_cache(bytes: u64) -> ResponseCache {
    let items = (bytes / 50_000).clamp(16, 1 << 20) as usize;
    Cache::with_weighter(items, bytes.max(1), EncodedBytes)
}

/// Share of the decoded-tile cache kept for tiles asked for more than once; the rest takes
/// new tiles on probation. quick_cache's default, 0.97, left a 64 MiB cache's shard room for
/// one new 257² tile: once full, a tile decoded for a stitch was evicted by the next one
/// before the neighbour's request could use it, and a block of tiles fetched in order cost
/// 2.0 decodes a tile instead of 1.0 (`tests/load/block_decodes.py`, `--cache-mb 64`).
const HOT_SHARE: f64 = 0.8;

/// A cache holding about `bytes` of decoded tiles.
pub fn new_cache(bytes: u64) -> TileCache {
    // 257² tiles weigh about 0.8 MB: size the item estimate from that.
    let items = (bytes / 800_000).clamp(16, 1 << 20) as usize;
    let options = quick_cache::OptionsBuilder::new()
        .estimated_items_capacity(items)
        .weight_capacity(bytes.max(1))
        .hot_allocation(HOT_SHARE)
        .build()
        .unwrap_or_else(|_| unreachable!("both capacities are set"));
    Cache::with_options(options, ByBytes, Default::default(), Default::default())
}

#[cfg(test)]
mod tests {
    use super::*;
    use zerotile_codec::bintree::Hierarchy;

    fn tile(side: usize) -> Arc<DecodedTile> {
        let heights = Grid::new(side, side, vec![0.0; side * side]).unwrap();
        let errors = TileErrors::new(&Hierarchy::new(side).unwrap(), &heights);
        Arc::new(DecodedTile {
            heights,
            errors,
            corners: [0.0; 4],
            prefix: vec![0; 1000],
        })
    }

    /// The decoded-tile cache keeps to its byte budget, counting each tile's heights (8
    /// bytes a sample) and error tree (4 bytes a sample): filling it far past the budget
    /// leaves it holding no more than the budget's worth.
    #[test]
    fn the_tile_cache_holds_no_more_than_its_byte_budget() {
        let one = tile(65);
        assert!(one.bytes() >= 65 * 65 * 12 + 1000, "{}", one.bytes());
        let budget = 20 * one.bytes();
        let cache = new_cache(budget);
        for i in 0..200 {
            let key = Key {
                dataset: 1,
                tile: TileId { z: 10, x: i, y: 0 },
                depth: Depth::All,
            };
            cache.insert(key, tile(65));
        }
        let held = cache.len() as u64;
        assert!(held >= 1, "empty");
        assert!(
            held * 65 * 65 * 12 <= budget,
            "{held} tiles in {budget} bytes"
        );
    }

    /// A full cache keeps a tile just decoded while a stitch decodes its four neighbours and
    /// the next request comes for it: with quick_cache's default hot share the probation
    /// room held about one tile, and each new tile pushed the last one out.
    #[test]
    fn a_full_cache_keeps_a_new_tile_through_a_stitch() {
        let one = tile(257);
        let cache = new_cache(64 << 20);
        let key = |x: u32| Key {
            dataset: 1,
            tile: TileId { z: 10, x, y: 0 },
            depth: Depth::All,
        };
        // Full, with tiles each asked for twice (the ones a frequency policy keeps).
        for x in 0..200 {
            cache.insert(key(x), Arc::clone(&one));
            let _ = cache.get(&key(x));
        }
        assert!(cache.len() < 200, "not full: {}", cache.len());
        for round in 0..10 {
            let first = 1000 + 10 * round;
            for x in first..first + 5 {
                cache.insert(key(x), Arc::clone(&one));
            }
            assert!(cache.get(&key(first)).is_some(), "round {round}");
        }
    }

    /// The response cache counts each body's bytes: 100 KB bodies fill a 1 MB cache with
    /// about ten, not the hundred it was offered.
    #[test]
    fn the_response_cache_holds_no_more_than_its_byte_budget() {
        let budget = 1 << 20;
        let cache = new_response_cache(budget);
        for key in 0..100 {
            let body = Encoded {
                bytes: bytes::Bytes::from(vec![0u8; 100_000]),
                triangles: None,
            };
            cache.insert(key, Arc::new(body));
        }
        let held = cache.len() as u64;
        assert!(held >= 1, "empty");
        assert!(held * 100_000 <= budget, "{held} bodies in {budget} bytes");
    }

    /// A body is kept at its length, whatever its vector's capacity: an encoder's output
    /// grows by doubling, and `Bytes::from(Vec)` kept the spare half too, so the response
    /// cache held 1.7× its budget. Counted by the allocations that stay behind.
    #[test]
    fn an_encoded_body_weighs_what_it_holds() {
        let mut kept = None;
        let info = allocation_counter::measure(|| {
            let mut body = Vec::with_capacity(200_000);
            body.extend((0..100_001u32).map(|i| i as u8));
            kept = Some(Arc::new(Encoded::new(body, None)));
        });
        let kept = kept.unwrap();
        let weight = EncodedBytes.weight(&0, &kept) as f64;
        let held = info.bytes_current as f64;
        assert!(held >= 100_001.0, "{held}");
        assert!(
            (weight - held).abs() <= 0.01 * held,
            "weight {weight}, held {held}"
        );
    }
}
