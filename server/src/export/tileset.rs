//! A 3D Tiles 1.1 tileset (`tileset.json`) over exported glTF tiles, each in the ENU frame of
//! its own centre, for CesiumJS's `Cesium3DTileset` and the Cesium runtimes of game engines
//! and flight simulators: an HLOD tree that follows the tile pyramid (a tile's children are
//! the four of the next zoom under it, where the dataset has them), with `REPLACE`
//! refinement.
//!
//! Placement: a tile's `transform` takes its frame to its parent's (3D Tiles composes them
//! from the root down), so each is the parent frame's inverse times the tile's ENU → ECEF
//! matrix, worked in f64; the top tiles carry their ENU → ECEF matrix itself under a root
//! with none. glTF is y-up: the tiles' node rotation turns their z-up ENU vertices to y-up,
//! and the runtime's y-up → z-up turn gives them back, so the tile frames are z-up as 3D
//! Tiles has them.
//!
//! Bounds: a tile's `box` (in its frame) holds its own vertices and its descendants' boxes,
//! as 3D Tiles' spatial coherence asks, widened by the f32 rounding of the stored
//! vertices. Geometric error: the node's (metres; [`Node::error`]), raised to its
//! children's where theirs is larger, so errors never grow down the tree; 0 for a tile with
//! no children.
//!
//! Not done: one `tileset.json` holds the whole tree (some 0.5 kB a tile), where a
//! continent's pyramid would want external tilesets every few zooms.
//!
//! Reference: OGC 3D Tiles 1.1 (22-025r4), §5.5 (tile transforms, bounding volumes),
//! §5.8 (geometric error), §6.7 (glTF content).

use std::collections::HashMap;

use anyhow::{Context, Result};
use glam::{DMat4, DVec3};
use serde_json::{json, Value};
use zerotile_codec::container::TileId;
use zerotile_codec::mesh::Aabb;

/// One exported tile.
#[derive(Clone, Debug)]
pub struct Node {
    pub id: TileId,
    /// The tile's frame → ECEF (metres).
    pub frame: DMat4,
    /// The box of its vertices in its frame; empty when it wrote none.
    pub content: Aabb,
    /// Metres: how far the tile's surface may be from the data's.
    pub error: f64,
}

/// The tileset of `nodes` (distinct tiles), with each tile's content at `uri(id)`
/// (relative to tileset.json) and `version` as the `tilesetVersion` CesiumJS appends to
/// every request (`?v=`), so a CDN drops an earlier export's tiles. `root_error` is the root's
/// geometric error: above the top tiles', so a view that shows the data refines past the
/// root, which has no content of its own.
pub fn tileset(
    nodes: &[Node],
    uri: &dyn Fn(TileId) -> String,
    version: &str,
    root_error: f64,
) -> Result<Value> {
    let tree = Tree {
        nodes: nodes.iter().map(|n| (n.id, n)).collect(),
        boxes: HashMap::new(),
        errors: HashMap::new(),
        uri,
    };
    let tree = tree.bounded();
    // A tile below the top zoom with no parent would sit beside its grandparent, drawn over
    // it: the pyramid has no gaps, so this is a fault, not a case.
    let top = nodes.iter().map(|n| n.id.z).min().unwrap_or(0);
    if let Some(n) = nodes
        .iter()
        .find(|n| n.id.z > top && tree.parent(n.id).is_none())
    {
        anyhow::bail!("tile {} has no parent among the tiles exported", n.id);
    }
    // Top tiles: those with no parent among the nodes.
    let mut tops: Vec<&Node> = nodes
        .iter()
        .filter(|n| tree.parent(n.id).is_none() && tree.boxes.contains_key(&n.id))
        .collect();
    tops.sort_by_key(|n| (n.id.y, n.id.x));
    let mut top_tiles = Vec::new();
    let mut root_box = Aabb::default();
    for n in tops {
        let b = tree.boxes.get(&n.id).context("a top tile without bounds")?;
        root_box = union(root_box, moved_box(n.frame, *b));
        top_tiles.push(tree.emit(n, n.frame)?);
    }
    if root_box.is_empty() {
        anyhow::bail!("no tile with vertices to export");
    }
    Ok(json!({
        "asset": { "version": "1.1", "tilesetVersion": version },
        "geometricError": root_error,
        "root": {
            "boundingVolume": { "box": box_json(root_box) },
            "geometricError": root_error,
            "refine": "REPLACE",
            "children": top_tiles,
        },
    }))
}

/// The nodes by tile, and each one's bounds (its vertices and its descendants').
struct Tree<'a> {
    nodes: HashMap<TileId, &'a Node>,
    /// Never empty: a tile with none has no entry.
    boxes: HashMap<TileId, Aabb>,
    /// The geometric error each tile is written with, before a leaf's 0.
    errors: HashMap<TileId, f64>,
    uri: &'a dyn Fn(TileId) -> String,
}

impl<'a> Tree<'a> {
    /// The four tiles of the next zoom under `id` that are among the nodes, in row order.
    fn children(&self, id: TileId) -> Vec<&'a Node> {
        let Some(z) = id.z.checked_add(1) else {
            return Vec::new();
        };
        let (x, y) = (id.x.saturating_mul(2), id.y.saturating_mul(2));
        [(0, 0), (1, 0), (0, 1), (1, 1)]
            .into_iter()
            .filter_map(|(dx, dy)| {
                let child = TileId {
                    z,
                    x: x.saturating_add(dx),
                    y: y.saturating_add(dy),
                };
                self.nodes.get(&child).copied()
            })
            .collect()
    }

    fn parent(&self, id: TileId) -> Option<&'a Node> {
        let z = id.z.checked_sub(1)?;
        let up = TileId {
            z,
            x: id.x / 2,
            y: id.y / 2,
        };
        self.nodes.get(&up).copied()
    }

    /// Bounds every tile, from the deepest zoom up: a tile's box holds its children's,
    /// moved into its frame, and its error is at least theirs. A tile with neither vertices
    /// nor bounded children has no box, and is left out.
    fn bounded(mut self) -> Self {
        let mut order: Vec<&Node> = self.nodes.values().copied().collect();
        order.sort_by_key(|n| std::cmp::Reverse(n.id.z));
        for n in order {
            let to_local = n.frame.inverse();
            let mut b = widen(n.content);
            let mut error = n.error;
            for c in self.children(n.id) {
                if let Some(&cb) = self.boxes.get(&c.id) {
                    b = union(b, moved_box(to_local * c.frame, cb));
                    error = error.max(self.errors.get(&c.id).copied().unwrap_or(0.0));
                }
            }
            self.errors.insert(n.id, error);
            if !b.is_empty() {
                self.boxes.insert(n.id, b);
            }
        }
        self
    }

    /// Tile `n` and its subtree, placed by `transform` (its frame → its parent's).
    fn emit(&self, n: &Node, transform: DMat4) -> Result<Value> {
        let b = self.boxes.get(&n.id).context("a tile without bounds")?;
        let to_local = n.frame.inverse();
        let kids = self
            .children(n.id)
            .into_iter()
            .filter(|c| self.boxes.contains_key(&c.id))
            .map(|c| self.emit(c, to_local * c.frame))
            .collect::<Result<Vec<_>>>()?;
        let mut t = serde_json::Map::new();
        t.insert("boundingVolume".into(), json!({ "box": box_json(*b) }));
        let error = match kids.is_empty() {
            true => 0.0,
            false => self.errors.get(&n.id).copied().unwrap_or(n.error),
        };
        t.insert("geometricError".into(), json!(error));
        t.insert(
            "transform".into(),
            json!(transform.to_cols_array().to_vec()),
        );
        if !n.content.is_empty() {
            t.insert("content".into(), json!({ "uri": (self.uri)(n.id) }));
        }
        if !kids.is_empty() {
            t.insert("children".into(), Value::Array(kids));
        }
        Ok(Value::Object(t))
    }
}

/// A box widened by what storing its vertices as f32 may move them (half a unit in the
/// last place of its largest coordinate, twice over) and a millimetre, so a flat tile's box
/// keeps some thickness: CesiumJS normalises a box's half-axes.
/// An empty box stays empty.
fn widen(b: Aabb) -> Aabb {
    if b.is_empty() {
        return b;
    }
    let largest = b.min.abs().max(b.max.abs()).max_element();
    let pad = DVec3::splat(largest * f64::from(f32::EPSILON) + 1e-3);
    Aabb {
        min: b.min - pad,
        max: b.max + pad,
    }
}

/// The box holding both (either may be empty).
fn union(a: Aabb, b: Aabb) -> Aabb {
    Aabb {
        min: a.min.min(b.min),
        max: a.max.max(b.max),
    }
}

/// The box, in another frame by the rigid `m`, bounded there by its eight corners.
fn moved_box(m: DMat4, b: Aabb) -> Aabb {
    let corners = (0..8).map(|k| {
        let pick = |bit: i32, lo: f64, hi: f64| if k & bit == 0 { lo } else { hi };
        let corner = DVec3::new(
            pick(1, b.min.x, b.max.x),
            pick(2, b.min.y, b.max.y),
            pick(4, b.min.z, b.max.z),
        );
        m.transform_point3(corner)
    });
    corners.fold(Aabb::default(), Aabb::grow)
}

/// 3D Tiles' `box`: the centre, then the three half-axes.
fn box_json(Aabb { min: lo, max: hi }: Aabb) -> Vec<f64> {
    let c = (lo + hi) / 2.0;
    let h = (hi - lo) / 2.0;
    vec![c.x, c.y, c.z, h.x, 0.0, 0.0, 0.0, h.y, 0.0, 0.0, 0.0, h.z]
}
