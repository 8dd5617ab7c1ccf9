//! The leaf cells of one threshold, and the vertices they put on the grid's border.

/// One leaf: the 2^level × 2^level square whose top-left sample is (`row`, `col`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Leaf {
    pub row: u32,
    pub col: u32,
    pub level: u8,
}

impl Leaf {
    /// Side in samples minus one (cells of level m span 2^m sample steps).
    #[inline]
    pub fn size(&self) -> usize {
        1 << self.level
    }
}

/// The leaves of a quadtree over a `rows × cols` grid, in Z order: they tile the grid.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SplitMap {
    rows: usize,
    cols: usize,
    leaves: Vec<Leaf>,
}

impl SplitMap {
    pub fn new(rows: usize, cols: usize, leaves: Vec<Leaf>) -> Self {
        Self { rows, cols, leaves }
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn cols(&self) -> usize {
        self.cols
    }

    pub fn leaves(&self) -> &[Leaf] {
        &self.leaves
    }

    /// Which samples of each border edge are leaf corners: what a neighbouring tile must also
    /// put on the shared edge for the two meshes to meet without T-junctions.
    pub fn border_vertices(&self) -> BorderVertices {
        let mut b = BorderVertices::empty(self.rows, self.cols);
        let (last_r, last_c) = (self.rows.saturating_sub(1), self.cols.saturating_sub(1));
        for l in &self.leaves {
            let (r0, c0) = (l.row as usize, l.col as usize);
            let (r1, c1) = (r0 + l.size(), c0 + l.size());
            if r0 == 0 {
                b.north[c0] = true;
                b.north[c1] = true;
            }
            if r1 == last_r {
                b.south[c0] = true;
                b.south[c1] = true;
            }
            if c0 == 0 {
                b.west[r0] = true;
                b.west[r1] = true;
            }
            if c1 == last_c {
                b.east[r0] = true;
                b.east[r1] = true;
            }
        }
        b
    }
}

/// Vertex flags along the four border edges of a grid: `north`/`south` by column (west to
/// east), `west`/`east` by row (north to south).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BorderVertices {
    pub north: Vec<bool>,
    pub south: Vec<bool>,
    pub west: Vec<bool>,
    pub east: Vec<bool>,
}

impl BorderVertices {
    /// No vertex anywhere on a `rows × cols` grid's border.
    pub fn empty(rows: usize, cols: usize) -> Self {
        Self {
            north: vec![false; cols],
            south: vec![false; cols],
            west: vec![false; rows],
            east: vec![false; rows],
        }
    }

    /// Flags set in either (edges of different lengths keep `self`'s length).
    pub fn union(&self, other: &Self) -> Self {
        let or = |a: &[bool], b: &[bool]| -> Vec<bool> {
            a.iter()
                .enumerate()
                .map(|(k, &x)| x || b.get(k).copied().unwrap_or(false))
                .collect()
        };
        Self {
            north: or(&self.north, &other.north),
            south: or(&self.south, &other.south),
            west: or(&self.west, &other.west),
            east: or(&self.east, &other.east),
        }
    }
}
