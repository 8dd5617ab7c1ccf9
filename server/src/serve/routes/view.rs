//! `GET /v1/datasets/{name}/view?eye=…&target=…&fov=…[&aspect=…][&format=json|glb|obj]`:
//! the mesh of the terrain inside a camera's view plane at T_i of eq. 4.
//!
//! Steps: the view plane and T_i from the camera; the deepest zoom whose tiles over the
//! footprint number at most [`MAX_VIEW_TILES`]; each of those tiles meshed at T_i stitched
//! to its neighbours (so the pieces join without cracks); the triangles whose centroid lies
//! in the footprint kept, shared edge vertices welded; one mesh out.

use std::collections::HashMap;
use std::hash::{DefaultHasher, Hash, Hasher};

use axum::body::Body;
use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::header::CONTENT_TYPE;
use axum::http::{HeaderMap, HeaderValue};
use axum::response::Response;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use zerotile_codec::container::TileId;
use zerotile_codec::geo::{lonlat_to_mercator, Bounds, EnuFrame, Scheme};
use zerotile_codec::mesh::{io, Aabb, Format, TriMesh};

use super::meta::dataset;
use crate::serve::codings;
use crate::serve::dataset::Dataset;
use crate::serve::error::{echo, ApiError, ApiResult};
use crate::serve::frame::{self, Frame};
use crate::serve::revalidate::{self, REVALIDATE};
use crate::serve::state::AppState;
use crate::serve::threshold::{self, eq4, view_plane, ViewPlane};
use crate::serve::{pipeline, render};

/// Most tiles one view request meshes: the zoom is chosen so the footprint fits.
pub const MAX_VIEW_TILES: u64 = 16;

pub async fn view(
    State(state): State<AppState>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    // Camera, threshold and format, checked before any work.
    let Path(name) = path?;
    let Query(q) = query?;
    let d = dataset(&state, &name)?;
    // The camera sets a view's threshold (eq. 4): a second source is refused, as on tiles.
    threshold::one_source(&q)?;
    let plane = view_plane(&d, &q)?;
    let t = eq4(&d, plane.ratio);
    let format = match q.get("format").map(String::as_str) {
        None | Some("json") => Format::Json,
        Some("glb") => Format::Glb,
        Some("obj") => Format::Obj,
        Some(other) => {
            return Err(ApiError::bad_request(
                "bad_format",
                format!("format must be json, glb or obj, got {}", echo(other)),
            ))
        }
    };
    // Metres about the target, or the scheme's coordinates.
    let frame = Frame::from_query(&q, d.tiling.scheme(), true, format.name())?;
    let enu = (frame == Frame::Enu).then(|| frame::at_lonlat(plane.target));
    let (zoom, tiles) = tiles_in_view(&d, &plane)?;
    let media = match format {
        Format::Json => "application/json",
        Format::Glb => "model/gltf-binary",
        _ => "model/obj",
    };
    // The plane and T decide the mesh, so a camera that has not moved revalidates without
    // meshing its tiles again.
    let coding = codings::of_answer(&headers, media);
    let etag = revalidate::weak_tag('v', view_key(&d, &plane, t, format, frame), coding);
    let held = match revalidate::Held::check(&headers, &etag, REVALIDATE)? {
        Ok(held) => held,
        Err(not_modified) => return with_origin(not_modified, enu.as_ref()),
    };

    // Mesh off the async threads.
    let ticket = state.admit_render()?;
    let job_state = state.clone();
    let job_d = d.clone();
    let job_plane = plane.clone();
    let job_enu = enu;
    let cancel = pipeline::Cancel::default();
    let _cancel_on_drop = cancel.on_drop();
    let mesh = tokio::task::spawn_blocking(move || {
        ticket.run(|| {
            let r = view_mesh(&job_state, &job_d, &tiles, t, &job_plane, &cancel);
            let mut mesh = pipeline::count_cancelled(&job_state, r)?;
            // Here, off the async threads: the geoid's first use in a place evaluates its
            // lattice's nodes, about a millisecond each. An empty mesh (a 404 below) has no
            // box to fetch them for.
            if let Some(enu) = job_enu.as_ref().filter(|_| !mesh.faces.is_empty()) {
                to_enu(&job_d, &mut mesh, enu);
            }
            Ok(mesh)
        })
    })
    .await
    .map_err(ApiError::internal)?
    .map_err(ApiError::render)?;
    if mesh.faces.is_empty() {
        return Err(ApiError::not_found(
            "empty_view",
            "the view plane covers no terrain of this dataset",
        ));
    }
    if let Some(not_modified) = held.release()? {
        return with_origin(not_modified, enu.as_ref());
    }

    // The body: JSON with the figures, or a mesh file with them in headers.
    let triangles = mesh.faces.len();
    let bytes = match format {
        Format::Json => {
            let body = ViewBody {
                a_t: plane.a_t,
                a_v: plane.a_v,
                footprint: &plane.footprint,
                mesh: MeshBody {
                    indices: mesh.faces.iter().flatten().copied().collect(),
                    positions: mesh.positions.iter().flat_map(|p| p.to_array()).collect(),
                },
                origin: enu.as_ref().map(EnuFrame::origin),
                ratio: plane.ratio,
                threshold: t,
                triangles,
                zoom,
            };
            serde_json::to_vec(&body).map_err(ApiError::internal)?
        }
        _ => io::write_z_up_bytes(&mesh, format).map_err(ApiError::internal)?,
    };
    let mut res = Response::new(Body::from(bytes));
    let h = res.headers_mut();
    h.insert(CONTENT_TYPE, HeaderValue::from_static(media));
    revalidate::validators(h, &etag, REVALIDATE)?;
    for (k, v) in [
        ("x-threshold", t),
        ("x-view-ratio", plane.ratio),
        ("x-a-v", plane.a_v),
        ("x-a-t", plane.a_t),
    ] {
        h.insert(k, header(&threshold::short(v))?);
    }
    h.insert("x-triangles", header(&triangles.to_string())?);
    h.insert("x-zoom", header(&zoom.to_string())?);
    if let Some(enu) = &enu {
        h.insert("x-frame-origin", frame::origin_header(enu)?);
    }
    Ok(res)
}

/// What a view's bytes depend on: the server (its mesher, its tile cap), the dataset's build,
/// the plane (whose footprint picks the zoom and tiles), T and the format. Derived values,
/// not the query's text, so `fov=60` and `fov=60.0` share a tag.
fn view_key(d: &Dataset, plane: &ViewPlane, t: f64, format: Format, frame: Frame) -> u64 {
    let mut h = DefaultHasher::new();
    (revalidate::RENDERER, MAX_VIEW_TILES).hash(&mut h);
    d.version.hash(&mut h);
    for v in plane.footprint.iter().flatten().chain(&plane.target) {
        v.to_bits().hash(&mut h);
    }
    for v in [plane.ratio, plane.a_v, plane.a_t, t] {
        v.to_bits().hash(&mut h);
    }
    (format.name(), frame).hash(&mut h);
    h.finish()
}

/// The JSON answer, serialised straight from the mesh (a `serde_json::Value` tree would box
/// every coordinate first); fields in name order, as the `json!` object it replaced wrote
/// them, so the bytes did not change.
#[derive(Serialize)]
struct ViewBody<'a> {
    a_t: f64,
    a_v: f64,
    footprint: &'a [[f64; 2]],
    mesh: MeshBody,
    /// `[lon°, lat°, height m]` of the ENU frame's origin (`frame=enu` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    origin: Option<[f64; 3]>,
    ratio: f64,
    threshold: f64,
    triangles: usize,
    zoom: u8,
}

/// Flat arrays: x, y, z per vertex; three indices per triangle.
#[derive(Serialize)]
struct MeshBody {
    indices: Vec<u32>,
    positions: Vec<f64>,
}

/// A 304 with the 200's `X-Frame-Origin`, as a tile's has: the validator headers a cache
/// updates its copy from (RFC 9110 §15.4.5) include what places the mesh.
fn with_origin(mut res: Response, enu: Option<&EnuFrame>) -> ApiResult<Response> {
    if let Some(enu) = enu {
        res.headers_mut()
            .insert("x-frame-origin", frame::origin_header(enu)?);
    }
    Ok(res)
}

fn header(s: &str) -> ApiResult<HeaderValue> {
    HeaderValue::from_str(s).map_err(ApiError::internal)
}

/// The deepest zoom whose tiles over the footprint (clipped to the data) are few enough,
/// and those of its tiles the dataset holds.
fn tiles_in_view(d: &Dataset, plane: &ViewPlane) -> ApiResult<(u8, Vec<TileId>)> {
    let m = d.metadata();
    let (xs, ys): (Vec<f64>, Vec<f64>) = plane.footprint.iter().map(|p| (p[0], p[1])).unzip();
    let lo = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // The footprint's box cut to the data: to each part of it either side of the
    // antimeridian when it crosses (west past east), so a footprint wider than the data
    // counts only the tiles over the data, and one away from it is empty. The box itself
    // is cut at the antimeridian too when the footprint runs past it.
    let local = matches!(d.tiling.scheme(), Scheme::Local { .. });
    let spans = if local {
        vec![(lo(&xs), hi(&xs))]
    } else {
        on_globe(lo(&xs), hi(&xs))
    };
    let (y0, y1) = (lo(&ys), hi(&ys));
    let boxes: Vec<Bounds> = Bounds::from(m.bounds)
        .split_at_antimeridian()
        .iter()
        .flat_map(|part| {
            spans.iter().map(move |&(x0, x1)| Bounds {
                min_x: x0.max(part.min_x.min(part.max_x)),
                max_x: x1.min(part.min_x.max(part.max_x)),
                min_y: y0.max(part.min_y.min(part.max_y)),
                max_y: y1.min(part.min_y.max(part.max_y)),
            })
        })
        .filter(|b| b.min_x <= b.max_x && b.min_y <= b.max_y)
        .collect();
    let empty = || {
        ApiError::not_found(
            "empty_view",
            "the view plane covers no terrain of this dataset",
        )
    };
    if boxes.is_empty() {
        return Err(empty());
    }
    for z in (m.min_zoom..=m.max_zoom).rev() {
        let ranges: Vec<_> = boxes
            .iter()
            .filter_map(|b| d.tiling.tile_range(z, b).ok().flatten())
            .collect();
        if ranges.is_empty() {
            continue;
        }
        let shallowest = z == m.min_zoom;
        // Boxes can meet in one tile (mercator's single root, a footprint's two spans in one
        // tile column): counted once. Past the cap times the boxes, none can bring it under.
        let count: u64 = ranges.iter().map(|r| r.count()).sum();
        if !shallowest && count > MAX_VIEW_TILES * ranges.len() as u64 {
            continue;
        }
        let mut tiles: Vec<TileId> = ranges
            .iter()
            .flat_map(|r| r.tiles())
            .map(|t| TileId {
                z: t.z,
                x: t.x,
                y: t.y,
            })
            .collect();
        if ranges.len() > 1 {
            tiles.sort_by_key(|t| (t.y, t.x));
            tiles.dedup();
        }
        if !shallowest && tiles.len() as u64 > MAX_VIEW_TILES {
            continue;
        }
        tiles.retain(|&id| d.has_tile(id));
        return Ok((z, tiles));
    }
    Err(empty())
}

/// A footprint box's longitudes `lo..hi` (which run on round the target, one turn at most)
/// on the globe: one span, or two when it runs past ±180°.
fn on_globe(lo: f64, hi: f64) -> Vec<(f64, f64)> {
    if hi - lo >= 360.0 {
        vec![(-180.0, 180.0)]
    } else if hi > 180.0 {
        vec![(lo, 180.0), (-180.0, hi - 360.0)]
    } else if lo < -180.0 {
        vec![(lo + 360.0, 180.0), (-180.0, hi)]
    } else {
        vec![(lo, hi)]
    }
}

/// The view's mesh in `enu`, the geoid's undulation over the mesh's own box.
fn to_enu(d: &Dataset, mesh: &mut TriMesh, enu: &EnuFrame) {
    let b = Aabb::from_points(&mesh.positions);
    let scheme = d.tiling.scheme();
    let geoid = frame::geoid(
        d,
        frame::degrees(scheme, [b.min.x, b.min.y, b.max.x, b.max.y]),
    );
    frame::to_enu(mesh, scheme, enu, geoid.as_ref());
}

/// The stitched meshes of `tiles` at `t`, cut to the footprint and welded into one. Across
/// the antimeridian the tiles past it are moved a turn round (360° or the mercator world's
/// width) to the footprint's side, so the mesh is one piece, as the footprint is.
fn view_mesh(
    state: &AppState,
    d: &Dataset,
    tiles: &[TileId],
    t: f64,
    plane: &ViewPlane,
    cancel: &pipeline::Cancel,
) -> anyhow::Result<TriMesh> {
    // The footprint in the mesh's coordinates (see `render::tri_mesh`).
    let to_mesh = |[x, y]: [f64; 2]| match d.tiling.scheme() {
        Scheme::Local { .. } => [x, -y],
        Scheme::Geodetic => [x, y],
        Scheme::Mercator => lonlat_to_mercator([x, y]),
    };
    let polygon: Vec<[f64; 2]> = plane.footprint.iter().copied().map(to_mesh).collect();
    // A turn of longitude in the mesh's x; none on a local grid.
    let turn = match d.tiling.scheme() {
        Scheme::Local { .. } => None,
        _ => Some(to_mesh([180.0, 0.0])[0] - to_mesh([-180.0, 0.0])[0]),
    };
    // Faces are tried a turn round only when the footprint runs past the seam.
    let shifts: Vec<f64> = match turn {
        Some(w) if polygon.iter().any(|p| p[0].abs() > w / 2.0) => vec![0.0, w, -w],
        _ => vec![0.0],
    };
    // A footprint smaller or thinner than a triangle holds no centroid: the triangles under
    // the target stand in for it then, rather than an empty view over the data. (Not the
    // polygon's vertex mean: a grazing view's sliver runs far past the data, and so can it.)
    let target = to_mesh(plane.target);
    let middle = if inside(&polygon, target) {
        target
    } else {
        polygon
            .iter()
            .fold([0.0, 0.0], |a, p| [a[0] + p[0], a[1] + p[1]])
            .map(|v| v / polygon.len().max(1) as f64)
    };
    let mut positions: Vec<DVec3> = Vec::new();
    let mut faces = Vec::new();
    let mut under_middle = Vec::new();
    let mut welded: HashMap<[u64; 2], u32> = HashMap::new();
    // Each tile a task on the render pool (up to 16 tiles and their neighbours, decoded
    // and meshed independently); the cut and the weld below then read them in tile order,
    // so the mesh is the same whichever task finished first.
    let meshes = state.pool.install(|| {
        tiles
            .par_iter()
            .map(|&id| {
                let mesh = pipeline::stitched(state, d, id, t, cancel)?.mesh;
                render::tri_mesh(d, id, &mesh)
            })
            .collect::<anyhow::Result<Vec<_>>>()
    })?;
    for (&id, tile) in tiles.iter().zip(&meshes) {
        for f in &tile.faces {
            let Some(p) = at3(&tile.positions, *f) else {
                anyhow::bail!("tile {id} mesh has a face past its vertices");
            };
            let c = (p[0] + p[1] + p[2]) / 3.0;
            let moved = |s: f64| p.map(|q| DVec3::new(q.x + s, q.y, q.z));
            if let Some(&s) = shifts.iter().find(|&&s| inside(&polygon, [c.x + s, c.y])) {
                faces.push(moved(s));
            } else if faces.is_empty() {
                // `middle` may lie past the seam too.
                if let Some(&s) = shifts.iter().find(|&&s| covers(&moved(s), middle)) {
                    under_middle.push(moved(s));
                }
            }
        }
    }
    if faces.is_empty() {
        faces = under_middle;
    }
    // Stitched edges are bit-identical in x and y: weld on the bits.
    let faces = faces
        .into_iter()
        .map(|p| {
            let mut out = [0u32; 3];
            for (slot, q) in out.iter_mut().zip(p) {
                let key = [q.x.to_bits(), q.y.to_bits()];
                *slot = *welded.entry(key).or_insert_with(|| {
                    positions.push(q);
                    (positions.len() - 1) as u32
                });
            }
            out
        })
        .collect();
    Ok(TriMesh::new(positions, faces))
}

/// Whether triangle `p` (x, y) holds point `m`, edges included, whichever its winding.
fn covers(p: &[DVec3; 3], m: [f64; 2]) -> bool {
    let side = |a: DVec3, b: DVec3| (b.x - a.x) * (m[1] - a.y) - (b.y - a.y) * (m[0] - a.x);
    let s = [side(p[0], p[1]), side(p[1], p[2]), side(p[2], p[0])];
    s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0)
}

/// The three corners of `f`, if they exist.
fn at3(positions: &[DVec3], f: [u32; 3]) -> Option<[DVec3; 3]> {
    let p = |i: u32| positions.get(i as usize).copied();
    Some([p(f[0])?, p(f[1])?, p(f[2])?])
}

/// Point in polygon (even-odd rule).
fn inside(poly: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut odd = false;
    // Each vertex with the one before it (the last before the first).
    let before = poly.last().into_iter().chain(poly);
    for (&a, &b) in poly.iter().zip(before) {
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                odd = !odd;
            }
        }
    }
    odd
}

#[cfg(test)]
mod tests {
    use super::{covers, inside, on_globe};
    use glam::DVec3;

    #[test]
    fn a_box_past_the_seam_is_cut_into_the_spans_either_side() {
        assert_eq!(on_globe(10.0, 20.0), [(10.0, 20.0)]);
        assert_eq!(on_globe(170.0, 190.0), [(170.0, 180.0), (-180.0, -170.0)]);
        assert_eq!(on_globe(-190.0, -170.0), [(170.0, 180.0), (-180.0, -170.0)]);
        // A whole turn (a view of a pole): the globe once, not one column twice.
        assert_eq!(on_globe(-170.0, 190.0), [(-180.0, 180.0)]);
    }

    #[test]
    fn covers_takes_either_winding_and_the_edges() {
        let ccw = [
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 5.0),
            DVec3::new(0.0, 2.0, 1.0),
        ];
        let cw = [ccw[0], ccw[2], ccw[1]];
        for t in [ccw, cw] {
            assert!(covers(&t, [0.5, 0.5]));
            assert!(covers(&t, [1.0, 0.0]));
            assert!(!covers(&t, [1.5, 1.5]));
        }
    }

    #[test]
    fn inside_follows_the_even_odd_rule() {
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert!(inside(&square, [0.5, 0.5]));
        assert!(!inside(&square, [1.5, 0.5]));
        assert!(!inside(&square, [0.5, -0.1]));
    }
}
