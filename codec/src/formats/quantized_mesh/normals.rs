//! Vertex normals from the height grid, for tiles meshed with their neighbours.
//!
//! Why not from the mesh's own triangles ([`encode`](super::encode) without these): a tile's
//! triangles stop at its edge, so an edge vertex's normal averages only the facets on its
//! side, and the tile across the edge gives the same vertex another normal. CesiumJS then
//! lights a seam along every tile border (the static-export screenshot showed them). The
//! gradient of the height grid, with the samples one past an edge read from the neighbour
//! that holds them, is the same on both sides of a border, and carries the relief of every
//! sample rather than of the mesh's facets.
//!
//! Each normal is the cross product of the central differences east–west and north–south
//! of the vertex's sample, in ECEF. Every sample the stencils read is the one value all tiles
//! holding it agree on: inside, the stitched height (the mean of the two decodes on an edge,
//! as [`stitched_heights`] gives); one past an edge, the neighbour's sample, or on the line of
//! a corner the mean of that neighbour's and the diagonal tile's decodes, since that sample
//! sits on their shared edge. So the four tiles at a corner give it one normal when each is
//! handed its diagonal neighbours ([`Diagonals`]); without them the corner's normal may differ
//! slightly between tiles. Past an edge without a neighbour the difference is one-sided.

use glam::DVec3;

use crate::geo::{Ellipsoid, TileGeo};
use crate::tile::{mean, stitched_heights, Neighbourhood, TileView};
use crate::zerotree::TerrainMesh;

/// The tiles across the centre's corners: north-west, north-east, south-west, south-east.
/// Only the samples next to a corner are read from them.
#[derive(Clone, Copy, Default)]
pub struct Diagonals<'a> {
    pub nw: Option<TileView<'a>>,
    pub ne: Option<TileView<'a>>,
    pub sw: Option<TileView<'a>>,
    pub se: Option<TileView<'a>>,
}

/// ECEF normals of `mesh`'s vertices (in the mesh's own order), for `encode_with_normals`.
/// `mesh` is in grid coordinates (x = column, y = row from the north edge) over
/// `n.center`'s grid, as `stitched_mesh` makes it; `tile` places that grid.
pub fn grid_normals(
    tile: &TileGeo,
    n: &Neighbourhood,
    diagonals: &Diagonals,
    mesh: &TerrainMesh,
) -> Vec<DVec3> {
    let heights = stitched_heights(n);
    let side = heights.rows();
    if side < 2 || heights.cols() != side {
        return vec![DVec3::Z; mesh.positions.len()];
    }
    let last = side - 1;
    let geo = GridGeo::new(tile, side);
    let d = diagonals;
    // The 3×3 block of tiles around the centre (rows north to south), the centre left out:
    // its own samples are the stitched ones.
    let block = [
        [d.nw, n.north, d.ne],
        [n.west, None, n.east],
        [d.sw, n.south, d.se],
    ];
    let l = last as isize;
    // Height at (row, col), one past each edge included where a neighbour holds it. Such a
    // sample is held by one neighbour, or on a corner's line by two (the neighbour and the
    // diagonal tile, on their shared edge): then the mean of both, as the stitch takes.
    let at = |r: isize, c: isize| -> Option<f64> {
        let inside = |k: isize| (0..=l).contains(&k);
        if inside(r) && inside(c) {
            return Some(*heights.get(r as usize, c as usize));
        }
        let mut held = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .filter_map(|(i, j)| {
                let (lr, lc) = (r - (i as isize - 1) * l, c - (j as isize - 1) * l);
                let v: TileView = block[i][j].filter(|_| inside(lr) && inside(lc))?;
                Some(*v.heights.get(lr as usize, lc as usize))
            });
        let first = held.next()?;
        Some(held.next().map_or(first, |second| mean(first, second)))
    };
    mesh.positions
        .iter()
        .map(|&[x, y, _]| {
            let (r, c) = (y.round() as isize, x.round() as isize);
            let Some(h) = at(r, c) else {
                return DVec3::Z;
            };
            // A row at a pole is one point: its east-west difference is only the heights'
            // scatter along the row, which would tip the normal sideways.
            if geo.at_pole(r) {
                return geo.up(r, c);
            }
            let here = geo.ecef(r, c, h);
            // A side without a sample falls back on the vertex itself (one-sided).
            let p = |dr: isize, dc: isize| {
                at(r + dr, c + dc).map_or(here, |h| geo.ecef(r + dr, c + dc, h))
            };
            let east = p(0, 1) - p(0, -1);
            let north = p(-1, 0) - p(1, 0);
            east.cross(north)
                .try_normalize()
                .unwrap_or_else(|| geo.up(r, c))
        })
        .collect()
}

/// Per row and column of the grid (one past each edge too), the trigonometry of its
/// latitude and longitude: an ECEF position is then a few products, not four sin/cos.
struct GridGeo {
    /// (cos φ, sin φ, N(φ)) for rows −1 ..= side.
    rows: Vec<(f64, f64, f64)>,
    /// (cos λ, sin λ) for columns −1 ..= side.
    cols: Vec<(f64, f64)>,
    e2: f64,
}

impl GridGeo {
    fn new(tile: &TileGeo, side: usize) -> Self {
        let e = Ellipsoid::WGS84;
        let e2 = e.e2();
        let steps = (side - 1) as f64;
        let rows = (-1..=side as isize)
            .map(|r| {
                let lat = tile.latitude_at(r as f64 / steps);
                let (s, c) = lat.to_radians().sin_cos();
                (c, s, e.a / (1.0 - e2 * s * s).sqrt())
            })
            .collect();
        let cols = (-1..=side as isize)
            .map(|c| {
                let lon = tile.west + c as f64 / steps * (tile.east - tile.west);
                let (s, co) = lon.to_radians().sin_cos();
                (co, s)
            })
            .collect();
        Self { rows, cols, e2 }
    }

    /// [`Ellipsoid::to_ecef`] of sample (r, c) at height `h`.
    fn ecef(&self, r: isize, c: isize, h: f64) -> DVec3 {
        let (cos_lat, sin_lat, n) = self.rows[(r + 1) as usize];
        let (cos_lon, sin_lon) = self.cols[(c + 1) as usize];
        DVec3::new(
            (n + h) * cos_lat * cos_lon,
            (n + h) * cos_lat * sin_lon,
            (n * (1.0 - self.e2) + h) * sin_lat,
        )
    }

    /// Whether row `r` lies on a pole (its samples are one point). The cosine is ~6e-17 at
    /// a pole and about the row spacing in radians one row off it (~1e-7 even at zoom 20):
    /// `<` or `<=` against 1e-9 alike.
    fn at_pole(&self, r: isize) -> bool {
        self.rows[(r + 1) as usize].0.abs() < 1e-9
    }

    /// The ellipsoid normal at sample (r, c).
    fn up(&self, r: isize, c: isize) -> DVec3 {
        let (cos_lat, sin_lat, _) = self.rows[(r + 1) as usize];
        let (cos_lon, sin_lon) = self.cols[(c + 1) as usize];
        DVec3::new(cos_lat * cos_lon, cos_lat * sin_lon, sin_lat)
    }
}
