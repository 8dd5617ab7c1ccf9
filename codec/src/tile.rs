//! Crack-free meshes across tile borders.
//!
//! Two neighbouring tiles share their edge samples (tiles are (2^n + 1)² for this reason),
//! but each is coded and decoded on its own, so their zerotrees, and hence their border
//! vertices and decoded border heights, differ. A tile decoded at threshold T is therefore
//! meshed together with its four edge neighbours decoded at the same T:
//!
//! - border vertices: the union of both tiles' border vertex sets, inserted by the mesher
//!   without T-junctions;
//! - border heights: the mean of the two decodes, computed as `(a + b) / 2`, which is
//!   bit-identical whichever tile computes it;
//! - corner heights: the exact source samples (stored with the tile), identical in all four
//!   tiles that share a corner.
//!
//! Both tiles then emit the same vertices with the same heights along their shared edge.

use crate::grid::Grid;
use crate::zerotree::{self, BorderVertices, SplitMap, TerrainMesh};

/// A decoded tile as the stitcher needs it.
#[derive(Clone, Copy)]
pub struct TileView<'a> {
    pub heights: &'a Grid<f64>,
    pub split: &'a SplitMap,
}

/// A tile and whichever of its edge neighbours exist, all decoded at the same threshold.
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
    #[error("{side} neighbour is {got_rows}×{got_cols}, the tile is {rows}×{cols}")]
    Shape {
        side: &'static str,
        rows: usize,
        cols: usize,
        got_rows: usize,
        got_cols: usize,
    },
}

/// Meshes the centre tile so that its border matches each neighbour's stitched mesh.
pub fn stitched_mesh(n: &Neighbourhood) -> Result<TerrainMesh, StitchError> {
    let c = n.center;
    let (rows, cols) = (c.heights.rows(), c.heights.cols());
    for (side, nb) in [
        ("north", n.north),
        ("south", n.south),
        ("west", n.west),
        ("east", n.east),
    ] {
        if let Some(nb) = nb {
            if nb.heights.rows() != rows || nb.heights.cols() != cols {
                return Err(StitchError::Shape {
                    side,
                    rows,
                    cols,
                    got_rows: nb.heights.rows(),
                    got_cols: nb.heights.cols(),
                });
            }
        }
    }

    // Border vertices: ours plus what each neighbour has on the shared edge.
    let own = c.split.border_vertices();
    let mut extra = own.clone();
    let empty = |len| vec![false; len];
    let from = |nb: Option<TileView>, pick: fn(BorderVertices) -> Vec<bool>, len| {
        nb.map_or_else(|| empty(len), |t| pick(t.split.border_vertices()))
    };
    let theirs = BorderVertices {
        north: from(n.north, |b| b.south, cols),
        south: from(n.south, |b| b.north, cols),
        west: from(n.west, |b| b.east, rows),
        east: from(n.east, |b| b.west, rows),
    };
    extra = extra.union(&theirs);

    // Border heights: the symmetric mean with each neighbour; corners exact.
    let mut heights = c.heights.clone();
    let last_r = rows - 1;
    let last_c = cols - 1;
    if let Some(nb) = n.north {
        for j in 0..cols {
            let v = mean(*c.heights.get(0, j), *nb.heights.get(last_r, j));
            *heights.get_mut(0, j) = v;
        }
    }
    if let Some(nb) = n.south {
        for j in 0..cols {
            let v = mean(*c.heights.get(last_r, j), *nb.heights.get(0, j));
            *heights.get_mut(last_r, j) = v;
        }
    }
    if let Some(nb) = n.west {
        for i in 0..rows {
            let v = mean(*c.heights.get(i, 0), *nb.heights.get(i, last_c));
            *heights.get_mut(i, 0) = v;
        }
    }
    if let Some(nb) = n.east {
        for i in 0..rows {
            let v = mean(*c.heights.get(i, last_c), *nb.heights.get(i, 0));
            *heights.get_mut(i, last_c) = v;
        }
    }
    if let Some([nw, ne, sw, se]) = n.corners {
        *heights.get_mut(0, 0) = nw;
        *heights.get_mut(0, last_c) = ne;
        *heights.get_mut(last_r, 0) = sw;
        *heights.get_mut(last_r, last_c) = se;
    }
    Ok(zerotree::triangulate(c.split, &heights, Some(&extra)))
}

/// The mean of two border samples, the same bits whichever tile computes it.
#[inline]
fn mean(a: f64, b: f64) -> f64 {
    (a + b) / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ezw::{self, DecodeLimit, EncodeParams};
    use crate::fixtures::n44w072;
    use crate::wavelet::Wavelet;
    use crate::zerotree::Complexity;

    struct Decoded {
        heights: Grid<f64>,
        split: SplitMap,
    }

    /// 2×2 neighbouring 257² tiles of N44W072 sharing edges, decoded at threshold `t`.
    fn tiles(t: f64, wavelet: Wavelet) -> (Vec<Decoded>, Vec<[f64; 4]>) {
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
            let split = Complexity::new(&d.layout, &d.coefficients).leaves(t);
            out.push(Decoded {
                heights: d.heights,
                split,
            });
        }
        (out, corners)
    }

    fn view(d: &Decoded) -> TileView<'_> {
        TileView {
            heights: &d.heights,
            split: &d.split,
        }
    }

    fn mesh_of(t: &[Decoded], corners: &[[f64; 4]], k: usize) -> TerrainMesh {
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
        stitched_mesh(&n).unwrap()
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
        for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
            for t in [0.5, 2.0, 8.0, 32.0] {
                let (tiles, corners) = tiles(t, wavelet);
                let meshes: Vec<TerrainMesh> =
                    (0..4).map(|k| mesh_of(&tiles, &corners, k)).collect();
                let east = |p: &[f64; 3]| (p[0] == 256.0).then_some(p[1]);
                let west = |p: &[f64; 3]| (p[0] == 0.0).then_some(p[1]);
                let south = |p: &[f64; 3]| (p[1] == 256.0).then_some(p[0]);
                let north = |p: &[f64; 3]| (p[1] == 0.0).then_some(p[0]);
                for (a, b, sa, sb) in [
                    (
                        0,
                        1,
                        &east as &dyn Fn(&[f64; 3]) -> Option<f64>,
                        &west as &dyn Fn(&[f64; 3]) -> Option<f64>,
                    ),
                    (2, 3, &east, &west),
                    (0, 2, &south, &north),
                    (1, 3, &south, &north),
                ] {
                    let ea = edge(&meshes[a], sa);
                    let eb = edge(&meshes[b], sb);
                    assert!(ea.len() >= 2);
                    assert_eq!(
                        ea, eb,
                        "{wavelet:?} T={t}: tiles {a} and {b} disagree on their shared edge"
                    );
                }
            }
        }
    }

    #[test]
    fn stitched_tiles_are_watertight_inside() {
        let (tiles, corners) = tiles(4.0, Wavelet::Cdf97);
        for k in 0..4 {
            let m = mesh_of(&tiles, &corners, k);
            let mut edges = std::collections::HashMap::new();
            let mut area = 0.0;
            for t in &m.triangles {
                // Upward (counter-clockwise, north up) triangles only: the areas add up.
                area += m.signed_area2(*t) / 2.0;
                for e in 0..3 {
                    let (a, b) = (t[e], t[(e + 1) % 3]);
                    *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                }
            }
            assert!((area - 256.0 * 256.0).abs() < 1e-6, "tile {k}: area {area}");
            for ((a, b), n) in edges {
                let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
                let same_line = |a: f64, b: f64| a == b && (a == 0.0 || a == 256.0);
                let border_edge = same_line(pa[0], pb[0]) || same_line(pa[1], pb[1]);
                assert_eq!(
                    n,
                    if border_edge { 1 } else { 2 },
                    "tile {k}: edge {pa:?}-{pb:?} used {n} times"
                );
            }
        }
    }

    #[test]
    fn mismatched_neighbour_is_an_error() {
        let (tiles, _) = tiles(8.0, Wavelet::Cdf97);
        let small = Grid::<f64>::zeros(3, 3);
        let n = Neighbourhood {
            center: view(&tiles[0]),
            north: Some(TileView {
                heights: &small,
                split: &tiles[1].split,
            }),
            south: None,
            west: None,
            east: None,
            corners: None,
        };
        assert!(matches!(
            stitched_mesh(&n),
            Err(StitchError::Shape { side: "north", .. })
        ));
    }
}
