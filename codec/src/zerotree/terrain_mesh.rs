//! The triangle mesh of one tile at one threshold.

/// Vertices on grid samples and triangles between them.
///
/// Coordinates are the grid's: `x` = column (east), `y` = row (south), `z` = height in height
/// units. Triangles wind counter-clockwise seen from above with north up, i.e. clockwise in
/// (column, row) coordinates; formats that want another frame convert.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TerrainMesh {
    /// Grid size the mesh covers.
    pub rows: usize,
    pub cols: usize,
    pub positions: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl TerrainMesh {
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Twice the signed area of triangle `t` seen from above with north up (x east, y north):
    /// positive for the winding this type promises.
    pub fn signed_area2(&self, t: [u32; 3]) -> f64 {
        let p = |k: usize| self.positions[t[k] as usize];
        let (a, b, c) = (p(0), p(1), p(2));
        // North up: y_north = −row.
        (b[0] - a[0]) * (a[1] - c[1]) - (c[0] - a[0]) * (a[1] - b[1])
    }

    /// Smallest and largest height, `None` for an empty mesh.
    pub fn height_range(&self) -> Option<(f64, f64)> {
        self.positions
            .iter()
            .map(|p| p[2])
            .fold(None, |acc, z| match acc {
                None => Some((z, z)),
                Some((lo, hi)) => Some((lo.min(z), hi.max(z))),
            })
    }
}

#[cfg(test)]
/// Checks the mesh is a proper triangulation of the grid rectangle: every triangle upward
/// and non-degenerate, areas summing to the rectangle, every interior edge shared by exactly
/// two triangles (no crack, no T-junction: a T-junction leaves a long edge used once beside
/// two short ones), border edges used once, and no vertex left unused.
pub(crate) fn assert_watertight(m: &TerrainMesh, what: &str) {
    let (w, h) = ((m.cols - 1) as f64, (m.rows - 1) as f64);
    let mut area = 0.0;
    let mut edges: std::collections::HashMap<(u32, u32), i32> = std::collections::HashMap::new();
    let mut used = vec![false; m.positions.len()];
    for &t in &m.triangles {
        let a2 = m.signed_area2(t);
        assert!(
            a2 > 0.0,
            "{what}: triangle {t:?} is degenerate or downward ({a2})"
        );
        area += a2 / 2.0;
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            used[a as usize] = true;
        }
    }
    assert!(
        (area - w * h).abs() < 1e-6,
        "{what}: area {area}, grid {}",
        w * h
    );
    assert!(used.iter().all(|&u| u), "{what}: unused vertex");
    for ((a, b), n) in edges {
        let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
        let on = |v: f64, lim: f64| v == 0.0 || v == lim;
        let border = (pa[0] == pb[0] && on(pa[0], w)) || (pa[1] == pb[1] && on(pa[1], h));
        assert_eq!(
            n,
            if border { 1 } else { 2 },
            "{what}: edge {pa:?}–{pb:?} used {n}×"
        );
    }
}
