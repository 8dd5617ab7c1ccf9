//! Crack-free meshes across tile borders.
//!
//! Two neighbouring tiles share their edge samples (tiles are (2^n + 1)² for this reason),
//! but each is coded and decoded on its own, so their error trees, and hence their border
//! vertices and decoded border heights, differ. A tile decoded at some depth is therefore
//! meshed together with its four edge neighbours decoded at the same depth:
//!
//! - border vertices: the union of the border vertices each tile would have on its own.
//!   A plain bintree mesh is closed under ancestors and the ancestors of a border sample on
//!   the border are the same dyadic points seen from either side, so both tiles arrive at
//!   the same set. Near a corner, though, the ancestors of a vertex forced onto one edge lie
//!   on the other edge too, where the neighbour across that edge never forced it: every tile
//!   therefore also forces those few corner samples (`edge_spill`, a staircase of a dozen
//!   samples a corner; +0 to +70 triangles on a 257² tile), so that no forcing adds a border
//!   vertex the tile across does not have;
//! - border heights: the mean of the two decodes, computed as `(a + b) / 2`, which is
//!   bit-identical whichever tile computes it;
//! - corner heights: the exact source samples (stored with the tile), identical in all four
//!   tiles that share a corner.
//!
//! Both tiles then emit the same vertices with the same heights along their shared edge.
//! The triangles are chosen from the centre tile's own errors, so the mesh is within the
//! tolerance of its own decode plus the largest border change (see [`stitched_mesh`]).

use crate::bintree::{self, Forced, Hierarchy, TileErrors};
use crate::grid::Grid;
use crate::zerotree::{BorderVertices, TerrainMesh};

/// A decoded tile as the stitcher needs it: heights and their error tree.
#[derive(Clone, Copy)]
pub struct TileView<'a> {
    pub heights: &'a Grid<f64>,
    pub errors: &'a TileErrors,
}

/// A tile and whichever of its edge neighbours exist, all decoded at the same depth.
pub struct Neighbourhood<'a> {
    pub center: TileView<'a>,
    pub north: Option<TileView<'a>>,
    pub south: Option<TileView<'a>>,
    pub west: Option<TileView<'a>>,
    pub east: Option<TileView<'a>>,
    /// Exact heights at the corners: north-west, north-east, south-west, south-east.
    pub corners: Option<[f64; 4]>,
}

/// Why a neighbourhood cannot be stitched.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum StitchError {
    #[error("{side} tile is {got_rows}×{got_cols}, the hierarchy is for {side_len}²")]
    Shape {
        side: &'static str,
        side_len: usize,
        got_rows: usize,
        got_cols: usize,
    },
}

/// Meshes the centre tile so that its border matches each neighbour's stitched mesh at the
/// same `tolerance`. Every triangle is within `tolerance` of the centre's own decoded heights
/// before the border heights move; the move is at most half the two decodes' difference on
/// an edge, and the corner's own decode error at a corner, so against the source the mesh
/// is within `tolerance + 2 × (largest decode error of the five tiles)`.
pub fn stitched_mesh(
    hierarchy: &Hierarchy,
    n: &Neighbourhood,
    tolerance: f64,
) -> Result<TerrainMesh, StitchError> {
    let side = hierarchy.side();
    let sides = [
        ("centre", Some(n.center)),
        ("north", n.north),
        ("south", n.south),
        ("west", n.west),
        ("east", n.east),
    ];
    for (name, view) in sides {
        if let Some(v) = view {
            let (r, c) = (v.heights.rows(), v.heights.cols());
            if r != side || c != side || v.errors.side() != side {
                return Err(StitchError::Shape {
                    side: name,
                    side_len: side,
                    got_rows: r,
                    got_cols: c,
                });
            }
        }
    }
    let last = side - 1;
    let at = |r: usize, c: usize| r * side + c;

    // Border vertices each neighbour has on the shared edge, forced into ours.
    let theirs = |view: Option<TileView>| {
        view.map(|v| bintree::border_vertices(hierarchy, v.errors, tolerance))
    };
    let mut forced = Vec::new();
    if let Some(b) = theirs(n.north) {
        forced.extend(flags(&b.south).map(|c| at(0, c)));
    }
    if let Some(b) = theirs(n.south) {
        forced.extend(flags(&b.north).map(|c| at(last, c)));
    }
    if let Some(b) = theirs(n.west) {
        forced.extend(flags(&b.east).map(|r| at(r, 0)));
    }
    if let Some(b) = theirs(n.east) {
        forced.extend(flags(&b.west).map(|r| at(r, last)));
    }
    // And what any forcing could spill onto an edge, so that both tiles of each edge hold it.
    forced.extend(hierarchy.edge_spill().iter().map(|&s| s as usize));
    let forced = Forced::new(hierarchy, forced);

    let heights = stitched_heights(n);
    Ok(bintree::extract(
        hierarchy,
        n.center.errors,
        &heights,
        tolerance,
        Some(&forced),
    ))
}

/// The centre's heights as its stitched mesh carries them: each border sample the
/// symmetric mean with the neighbour across it (the same bits from either tile), corners
/// the exact ones. Shapes are the caller's to check (`stitched_mesh` does).
pub fn stitched_heights(n: &Neighbourhood) -> Grid<f64> {
    let mut heights = n.center.heights.clone();
    let own = n.center.heights;
    let side = own.rows();
    let Some(last) = side.checked_sub(1) else {
        return heights;
    };
    if let Some(nb) = n.north {
        for c in 0..side {
            *heights.get_mut(0, c) = mean(*own.get(0, c), *nb.heights.get(last, c));
        }
    }
    if let Some(nb) = n.south {
        for c in 0..side {
            *heights.get_mut(last, c) = mean(*own.get(last, c), *nb.heights.get(0, c));
        }
    }
    if let Some(nb) = n.west {
        for r in 0..side {
            *heights.get_mut(r, 0) = mean(*own.get(r, 0), *nb.heights.get(r, last));
        }
    }
    if let Some(nb) = n.east {
        for r in 0..side {
            *heights.get_mut(r, last) = mean(*own.get(r, last), *nb.heights.get(r, 0));
        }
    }
    if let Some([nw, ne, sw, se]) = n.corners {
        *heights.get_mut(0, 0) = nw;
        *heights.get_mut(0, last) = ne;
        *heights.get_mut(last, 0) = sw;
        *heights.get_mut(last, last) = se;
    }
    heights
}

fn flags(v: &[bool]) -> impl Iterator<Item = usize> + '_ {
    v.iter().enumerate().filter(|(_, &f)| f).map(|(k, _)| k)
}

/// The mean of two border samples, the same bits whichever tile computes it.
#[inline]
pub(crate) fn mean(a: f64, b: f64) -> f64 {
    (a + b) / 2.0
}

/// The border vertices of a plain mesh, as [`BorderVertices`] (for callers that cache them).
pub fn border_vertices(h: &Hierarchy, errors: &TileErrors, tolerance: f64) -> BorderVertices {
    bintree::border_vertices(h, errors, tolerance)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ezw::{self, DecodeLimit, EncodeParams};
    use crate::fixtures::n44w072;
    use crate::wavelet::Wavelet;
    use crate::zerotree::terrain_mesh::assert_watertight;
    use crate::zerotree::{mesh_error, TerrainMesh};

    struct Decoded {
        heights: Grid<f64>,
        errors: TileErrors,
    }

    /// 2×2 neighbouring 257² tiles of N44W072 sharing edges, decoded at threshold `t`.
    fn tiles(h: &Hierarchy, t: f64, wavelet: Wavelet) -> (Vec<Decoded>, Vec<[f64; 4]>, Grid<f64>) {
        let dem = n44w072();
        let mut out = Vec::new();
        let mut corners = Vec::new();
        for (r, c) in [(300, 400), (300, 656), (556, 400), (556, 656)] {
            let g = dem.crop(r, c, 257, 257).unwrap();
            corners.push([
                *g.get(0, 0),
                *g.get(0, 256),
                *g.get(256, 0),
                *g.get(256, 256),
            ]);
            let enc = ezw::encode(&g, &EncodeParams::new(wavelet, 1.0)).unwrap();
            let d = ezw::decode(
                &enc.bytes,
                DecodeLimit::Threshold(t),
                ezw::DEFAULT_MAX_SAMPLES,
            )
            .unwrap();
            let errors = TileErrors::new(h, &d.heights);
            out.push(Decoded {
                heights: d.heights,
                errors,
            });
        }
        (out, corners, dem)
    }

    fn view(d: &Decoded) -> TileView<'_> {
        TileView {
            heights: &d.heights,
            errors: &d.errors,
        }
    }

    fn mesh_of(
        h: &Hierarchy,
        t: &[Decoded],
        corners: &[[f64; 4]],
        k: usize,
        tol: f64,
    ) -> TerrainMesh {
        // Layout: 0 = NW, 1 = NE, 2 = SW, 3 = SE.
        let nb = |i: Option<usize>| i.map(|i| view(&t[i]));
        let (north, south, west, east) = match k {
            0 => (None, Some(2), None, Some(1)),
            1 => (None, Some(3), Some(0), None),
            2 => (Some(0), None, None, Some(3)),
            _ => (Some(1), None, Some(2), None),
        };
        let n = Neighbourhood {
            center: view(&t[k]),
            north: nb(north),
            south: nb(south),
            west: nb(west),
            east: nb(east),
            corners: Some(corners[k]),
        };
        stitched_mesh(h, &n, tol).unwrap()
    }

    /// Vertices on one side of a mesh: (position along the edge, height), sorted.
    fn edge(m: &TerrainMesh, on: impl Fn(&[f64; 3]) -> Option<f64>) -> Vec<(f64, f64)> {
        let mut v: Vec<(f64, f64)> = m
            .positions
            .iter()
            .filter_map(|p| on(p).map(|s| (s, p[2])))
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    }

    #[test]
    fn neighbouring_real_tiles_share_identical_edge_vertices() {
        let h = Hierarchy::new(257).unwrap();
        type Side = dyn Fn(&[f64; 3]) -> Option<f64>;
        let east: &Side = &|p| (p[0] == 256.0).then_some(p[1]);
        let west: &Side = &|p| (p[0] == 0.0).then_some(p[1]);
        let south: &Side = &|p| (p[1] == 256.0).then_some(p[0]);
        let north: &Side = &|p| (p[1] == 0.0).then_some(p[0]);
        for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
            for t in [0.5, 4.0, 32.0] {
                let (tiles, corners, _) = tiles(&h, t, wavelet);
                for tol in [1.0, 4.0, 16.0, 64.0] {
                    let meshes: Vec<TerrainMesh> = (0..4)
                        .map(|k| mesh_of(&h, &tiles, &corners, k, tol))
                        .collect();
                    for (a, b, sa, sb) in [
                        (0, 1, east, west),
                        (2, 3, east, west),
                        (0, 2, south, north),
                        (1, 3, south, north),
                    ] {
                        let (ea, eb) = (edge(&meshes[a], sa), edge(&meshes[b], sb));
                        assert!(ea.len() >= 2);
                        assert_eq!(
                            ea, eb,
                            "{wavelet:?} T={t} tol={tol}: tiles {a} and {b} disagree on their edge"
                        );
                    }
                }
            }
        }
    }

    /// Every shared edge of a 4×4 block, each tile meshed with all the neighbours it has
    /// there. A border vertex forced in from one neighbour pulls in its ancestors, and near a
    /// corner those lie on the tile's other edges: the 2×2 block above cannot show that, as
    /// its tiles never have neighbours on two sides of one corner.
    #[test]
    fn every_edge_of_a_block_matches_whatever_the_tiles_around_it_force() {
        let side = 129;
        let h = Hierarchy::new(side).unwrap();
        let last = (side - 1) as f64;
        let dem = n44w072();
        let mut checked = 0;
        for t in [0.5, 4.0] {
            let mut corners = Vec::new();
            let tiles: Vec<Decoded> = (0..16)
                .map(|k| {
                    let g = dem
                        .crop(
                            100 + (k / 4) * (side - 1),
                            100 + (k % 4) * (side - 1),
                            side,
                            side,
                        )
                        .unwrap();
                    let l = side - 1;
                    corners.push([*g.get(0, 0), *g.get(0, l), *g.get(l, 0), *g.get(l, l)]);
                    let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
                    let d = ezw::decode(
                        &enc.bytes,
                        DecodeLimit::Threshold(t),
                        ezw::DEFAULT_MAX_SAMPLES,
                    )
                    .unwrap();
                    let errors = TileErrors::new(&h, &d.heights);
                    Decoded {
                        heights: d.heights,
                        errors,
                    }
                })
                .collect();
            for tol in [2.0, 8.0, 24.0, 50.0, 100.0, 200.0] {
                let meshes: Vec<TerrainMesh> = (0..16)
                    .map(|k| {
                        let (r, c) = (k / 4, k % 4);
                        let at =
                            |r: usize, c: usize| (r < 4 && c < 4).then(|| view(&tiles[r * 4 + c]));
                        let n = Neighbourhood {
                            center: view(&tiles[k]),
                            north: r.checked_sub(1).and_then(|r| at(r, c)),
                            south: at(r + 1, c),
                            west: c.checked_sub(1).and_then(|c| at(r, c)),
                            east: at(r, c + 1),
                            corners: Some(corners[k]),
                        };
                        stitched_mesh(&h, &n, tol).unwrap()
                    })
                    .collect();
                for k in 0..16 {
                    let (r, c) = (k / 4, k % 4);
                    if c < 3 {
                        let a = edge(&meshes[k], |p| (p[0] == last).then_some(p[1]));
                        let b = edge(&meshes[k + 1], |p| (p[0] == 0.0).then_some(p[1]));
                        assert_eq!(
                            a, b,
                            "T={t} tol={tol}: tile ({r},{c}) and its east neighbour"
                        );
                        checked += 1;
                    }
                    if r < 3 {
                        let a = edge(&meshes[k], |p| (p[1] == last).then_some(p[0]));
                        let b = edge(&meshes[k + 4], |p| (p[1] == 0.0).then_some(p[0]));
                        assert_eq!(
                            a, b,
                            "T={t} tol={tol}: tile ({r},{c}) and its south neighbour"
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert_eq!(checked, 2 * 6 * 24);
    }

    #[test]
    fn stitched_tiles_are_watertight_and_within_the_stated_bound() {
        let h = Hierarchy::new(257).unwrap();
        let (tiles, corners, dem) = tiles(&h, 1.0, Wavelet::Cdf97);
        let origins = [(300, 400), (300, 656), (556, 400), (556, 656)];
        for k in 0..4 {
            let m = mesh_of(&h, &tiles, &corners, k, 8.0);
            assert_watertight(&m, &format!("tile {k}"));
            let (r, c) = origins[k];
            let source = dem.crop(r, c, 257, 257).unwrap();
            let decode_error = (0..4)
                .map(|i| {
                    let (r, c) = origins[i];
                    let s = dem.crop(r, c, 257, 257).unwrap();
                    s.data()
                        .iter()
                        .zip(tiles[i].heights.data())
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0, f64::max)
                })
                .fold(0.0, f64::max);
            let e = mesh_error(&m, &source);
            assert!(
                e.max_abs <= 8.0 + 2.0 * decode_error,
                "tile {k}: {e:?}, decode {decode_error}"
            );
        }
    }

    #[test]
    fn mismatched_neighbour_is_an_error() {
        let h = Hierarchy::new(257).unwrap();
        let (tiles, _, _) = tiles(&h, 8.0, Wavelet::Cdf97);
        let small = Grid::<f64>::zeros(3, 3);
        let n = Neighbourhood {
            center: view(&tiles[0]),
            north: Some(TileView {
                heights: &small,
                errors: &tiles[1].errors,
            }),
            south: None,
            west: None,
            east: None,
            corners: None,
        };
        assert!(matches!(
            stitched_mesh(&h, &n, 4.0),
            Err(StitchError::Shape { side: "north", .. })
        ));
    }
}
