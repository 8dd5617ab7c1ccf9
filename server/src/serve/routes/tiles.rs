//! `GET /v1/datasets/{name}/tiles/{z}/{x}/{y}.{format}`: one tile in any client format.
//!
//! Steps: parse the address and the format; choose the threshold; answer 304 when the
//! client's ETag matches; otherwise render off the async threads (decode, stitch, encode)
//! and add the cache, threshold and negotiation headers.

use std::borrow::Cow;
use std::collections::hash_map::DefaultHasher;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::io::Write;
use std::sync::atomic::Ordering::Relaxed;
use std::sync::Arc;

use axum::body::Body;
use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::header::{
    ACCEPT_RANGES, CACHE_CONTROL, CONTENT_ENCODING, CONTENT_RANGE, CONTENT_TYPE, ETAG, VARY,
};
use axum::http::{HeaderMap, HeaderValue, StatusCode};
use axum::response::Response;
use bytes::Bytes;
use flate2::write::GzEncoder;
use zerotile_codec::container::TileId;
use zerotile_codec::formats::quantized_mesh::{QmOptions, WaterMask};
use zerotile_codec::geo::Scheme;
use zerotile_codec::mesh::Format as MeshFormat;
use zerotile_codec::raster::Encoding;

use super::meta::dataset;
use crate::serve::codings::{self, Coding};
use crate::serve::dataset::Dataset;
use crate::serve::error::{echo, ApiError, ApiResult};
use crate::serve::frame::{self, Frame};
use crate::serve::negotiate::{self, Extensions, RangeAsk, QUANTIZED_MESH};
use crate::serve::pipeline;
use crate::serve::render;
use crate::serve::revalidate;
use crate::serve::state::AppState;
use crate::serve::threshold::{self, Depth};
use crate::serve::tile_cache::Encoded;

/// Media type of `.ezw` stream prefixes (not compressed again: they are arithmetic-coded).
pub const EZW_MEDIA: &str = "application/vnd.zerotile.ezw";
/// Media type of `.bin` (ZTM1) meshes.
pub const ZTM1_MEDIA: &str = "application/vnd.zerotile.ztm1";
/// Default and largest PNG side, pixels (MapLibre's raster-dem default is 512).
pub(crate) const PNG_DEFAULT_SIZE: u32 = 512;
pub(crate) const PNG_MAX_SIZE: u32 = 1024;
pub(crate) const PNG_MIN_SIZE: u32 = 16;

/// The formats a tile comes in, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TileFormat {
    Terrain,
    Png,
    Json,
    Bin,
    Obj,
    Glb,
    Ezw,
}

impl TileFormat {
    /// Every format: the extensions a tile address takes, and the docs' list.
    pub(crate) const ALL: [Self; 7] = [
        Self::Terrain,
        Self::Png,
        Self::Json,
        Self::Bin,
        Self::Obj,
        Self::Glb,
        Self::Ezw,
    ];

    fn from_extension(ext: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.extension() == ext)
    }

    fn extension(self) -> &'static str {
        match self {
            Self::Terrain => "terrain",
            Self::Png => "png",
            Self::Json => "json",
            Self::Bin => "bin",
            Self::Obj => "obj",
            Self::Glb => "glb",
            Self::Ezw => "ezw",
        }
    }

    pub(crate) fn media_type(self) -> &'static str {
        match self {
            Self::Terrain => QUANTIZED_MESH,
            Self::Png => "image/png",
            Self::Json => "application/json",
            Self::Bin => ZTM1_MEDIA,
            Self::Obj => "model/obj",
            Self::Glb => "model/gltf-binary",
            Self::Ezw => EZW_MEDIA,
        }
    }
}

/// The height encoding of a PNG tile ([`Variant::Png`]'s `terrarium`).
pub(crate) fn png_encoding(terrarium: bool) -> Encoding {
    if terrarium {
        Encoding::Terrarium
    } else {
        Encoding::TerrainRgb
    }
}

/// Format options that change the bytes (and so the ETag).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Variant {
    Terrain {
        ext: Extensions,
        coding: Coding,
    },
    Png {
        terrarium: bool,
        size: u32,
    },
    /// Meshes: compressed here (and cached so) in the coding of [`tile_coding`], written in
    /// `frame` (json and obj; bin carries its CRS, and always the scheme's).
    Mesh {
        coding: Coding,
        frame: Frame,
    },
    /// GLB: compact already, sent as it is.
    Glb {
        frame: Frame,
    },
    /// PNG and EZW bodies: compact already, sent as they are.
    Plain,
}

impl Variant {
    fn coding(self) -> Coding {
        match self {
            Self::Terrain { coding, .. } | Self::Mesh { coding, .. } => coding,
            Self::Png { .. } | Self::Glb { .. } | Self::Plain => Coding::Identity,
        }
    }

    fn frame(self) -> Frame {
        match self {
            Self::Mesh { frame, .. } | Self::Glb { frame } => frame,
            _ => Frame::Scheme,
        }
    }
}

/// The coding a mesh or quantized-mesh tile is compressed in once, when rendered (and
/// cached so): gzip when the client takes it, whatever weight it gives it, else what the
/// compression layer would send (br, or none). The layer sent br itself before, on every
/// request, under the uncompressed body's tag.
fn tile_coding(headers: &HeaderMap) -> Coding {
    if negotiate::accepts_gzip(headers) {
        Coding::Gzip
    } else {
        codings::of_layer(headers)
    }
}

pub async fn tile(
    State(state): State<AppState>,
    path: Result<Path<(String, String, String, String)>, PathRejection>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    uri: axum::http::Uri,
    headers: HeaderMap,
) -> ApiResult<Response> {
    // Address and format.
    let Path((name, z, x, y_ext)) = path?;
    let Query(query) = query?;
    let d = dataset(&state, &name)?;
    // As sent, not percent-decoded: `%33` would name tile 3 under a second URL, as `03` would.
    let sent: Vec<&str> = uri.path().rsplitn(4, '/').take(3).collect();
    if sent != [y_ext.as_str(), x.as_str(), z.as_str()] {
        return Err(ApiError::bad_request(
            "bad_tile_address",
            format!(
                "a tile address is plain z/x/y.ext, not percent-encoded: got {}",
                echo(uri.path())
            ),
        ));
    }
    let (id, format) = parse_address(&d, &z, &x, &y_ext)?;

    // A missing root tile of a world scheme is served flat: Cesium needs every root.
    let exists = d.has_tile(id);
    let flat_root = !exists && format == TileFormat::Terrain && id.z == 0 && in_tiling(&d, id);
    if !exists && !flat_root {
        return Err(ApiError::not_found(
            "tile_not_found",
            format!("{name} has no tile {id}; see /v1/datasets/{name} for what exists"),
        ));
    }

    // Threshold and format options, all checked before any work.
    let t = threshold::from_query(&d, id.z, &query)?;
    let variant = variant(&d, format, &query, &headers)?;

    // Conditional requests.
    let etag_key = etag_hash(&d, id, t.t, format, variant);
    // A stream prefix is never re-encoded, so its tag is strong: `If-Range` can name it.
    let etag = if format == TileFormat::Ezw {
        format!("\"{etag_key:016x}\"")
    } else {
        format!("W/\"{etag_key:016x}\"")
    };
    let mut base = cache_headers(&state, &etag, t.t, format, variant)?;
    if variant.frame() == Frame::Enu {
        let enu = frame::at_tile(&d, id).map_err(ApiError::internal)?;
        base.insert("x-frame-origin", frame::origin_header(&enu)?);
    }
    // If-Match before If-None-Match and Range (RFC 9110 §13.2.2), before any render.
    revalidate::if_match(&headers, Some(&etag))?;
    if negotiate::not_modified(&headers, &etag) {
        let mut res = Response::new(Body::empty());
        *res.status_mut() = StatusCode::NOT_MODIFIED;
        res.headers_mut().extend(base);
        return Ok(res);
    }

    // Encoded before (same ETag), or render off the async threads, a bounded number at a
    // time.
    let rendered = match state.responses.get(&etag_key) {
        Some(hit) => {
            state.metrics.response_cache_hits.fetch_add(1, Relaxed);
            hit
        }
        None => {
            let ticket = state.admit_render()?;
            let job_state = state.clone();
            let job_d = d.clone();
            let cancel = pipeline::Cancel::default();
            let _cancel_on_drop = cancel.on_drop();
            let fresh = tokio::task::spawn_blocking(move || {
                ticket.run(|| {
                    let r = render_tile(
                        &job_state, &job_d, id, t.t, format, variant, flat_root, &cancel,
                    );
                    pipeline::count_cancelled(&job_state, r)
                })
            })
            .await
            .map_err(ApiError::internal)?
            .map_err(ApiError::render)?;
            let fresh = Arc::new(fresh);
            state.responses.insert(etag_key, fresh.clone());
            fresh
        }
    };

    // Headers, then the body (a byte range of it for `.ezw`).
    let mut res_headers = base;
    let content_type = match variant {
        Variant::Terrain { ext, .. } if ext != Extensions::default() => {
            format!("{QUANTIZED_MESH};extensions={}", ext.names())
        }
        _ => format.media_type().to_string(),
    };
    res_headers.insert(CONTENT_TYPE, header(&content_type)?);
    if let Some(n) = rendered.triangles {
        res_headers.insert("x-triangles", header(&n.to_string())?);
    }
    if let Some(coding) = variant.coding().content_encoding() {
        res_headers.insert(CONTENT_ENCODING, HeaderValue::from_static(coding));
    }
    let (status, body) = if format == TileFormat::Ezw {
        match ranged(&headers, &etag, &rendered.bytes, &mut res_headers)? {
            Some(part) => part,
            None => {
                let len = rendered.bytes.len();
                let mut e = axum::response::IntoResponse::into_response(ApiError::new(
                    StatusCode::RANGE_NOT_SATISFIABLE,
                    "range_not_satisfiable",
                    format!("the stream prefix is {len} bytes"),
                ));
                e.headers_mut()
                    .insert(CONTENT_RANGE, header(&format!("bytes */{len}"))?);
                return Ok(e);
            }
        }
    } else {
        (StatusCode::OK, rendered.bytes.clone())
    };
    let mut res = Response::new(Body::from(body));
    *res.status_mut() = status;
    res.headers_mut().extend(res_headers);
    Ok(res)
}

/// The headers every answer for this tile carries, 304 included: validator, freshness,
/// threshold, and what the body varies with.
fn cache_headers(
    state: &AppState,
    etag: &str,
    t: f64,
    format: TileFormat,
    variant: Variant,
) -> ApiResult<HeaderMap> {
    let mut h = HeaderMap::new();
    h.insert(ETAG, header(etag)?);
    let cache = format!("public, max-age={}", state.config.tile_max_age);
    h.insert(CACHE_CONTROL, header(&cache)?);
    h.insert("x-threshold", header(&threshold::short(t))?);
    match variant {
        Variant::Terrain { .. } => {
            h.insert(VARY, HeaderValue::from_static("Accept, Accept-Encoding"));
        }
        Variant::Mesh { .. } => {
            h.insert(VARY, HeaderValue::from_static("Accept-Encoding"));
        }
        Variant::Png { .. } | Variant::Glb { .. } | Variant::Plain => {}
    }
    if format == TileFormat::Ezw {
        h.insert(ACCEPT_RANGES, HeaderValue::from_static("bytes"));
    }
    Ok(h)
}

/// The body or the byte range `Range` asks for (206 with `Content-Range`); `None` when the
/// range lies past the end. An `If-Range` that does not name `etag` gets the whole body.
fn ranged(
    headers: &HeaderMap,
    etag: &str,
    body: &Bytes,
    res_headers: &mut HeaderMap,
) -> ApiResult<Option<(StatusCode, Bytes)>> {
    let len = body.len() as u64;
    if !negotiate::if_range_allows(headers, etag) {
        return Ok(Some((StatusCode::OK, body.clone())));
    }
    Ok(match negotiate::range(headers, len) {
        RangeAsk::Full => Some((StatusCode::OK, body.clone())),
        RangeAsk::Part { start, end } => {
            res_headers.insert(
                CONTENT_RANGE,
                header(&format!("bytes {start}-{end}/{len}"))?,
            );
            Some((
                StatusCode::PARTIAL_CONTENT,
                body.slice(start as usize..=end as usize),
            ))
        }
        RangeAsk::Unsatisfiable => None,
    })
}

/// `z`, `x` and `y.ext` from the path, checked against the dataset's tiling.
fn parse_address(d: &Dataset, z: &str, x: &str, y_ext: &str) -> ApiResult<(TileId, TileFormat)> {
    let (y, ext) = y_ext.rsplit_once('.').ok_or_else(|| {
        ApiError::not_found(
            "unknown_format",
            "tile paths end in .terrain, .png, .json, .bin, .obj, .glb or .ezw",
        )
    })?;
    let format = TileFormat::from_extension(ext).ok_or_else(|| {
        ApiError::not_found(
            "unknown_format",
            format!(
                "unknown tile format {}: use terrain, png, json, bin, obj, glb or ezw",
                echo(ext)
            ),
        )
    })?;
    let bad = |what: &str, s: &str, max: u32| {
        ApiError::bad_request(
            "bad_tile_address",
            format!("{what} must be an integer from 0 to {max}, got {}", echo(s)),
        )
    };
    // Plain decimal only: `+3` or `03` would name tile 3 under a second URL, a second cache
    // entry for every cache on the way.
    let canonical =
        |s: &str| s == "0" || (s.bytes().all(|b| b.is_ascii_digit()) && !s.starts_with('0'));
    let parse = |what: &str, s: &str, max: u32| -> ApiResult<u32> {
        s.parse::<u32>()
            .ok()
            .filter(|&v| canonical(s) && v <= max)
            .ok_or_else(|| bad(what, s, max))
    };
    let z = parse("z", z, u8::MAX.into())? as u8;
    let x = parse("x", x, u32::MAX)?;
    let y = parse("y", y, u32::MAX)?;
    let id = TileId { z, x, y };
    let m = d.metadata();
    if z < m.min_zoom || z > m.max_zoom {
        return Err(ApiError::not_found(
            "tile_not_found",
            format!(
                "zoom {z} is outside {}..={} of {}",
                m.min_zoom, m.max_zoom, d.name
            ),
        ));
    }
    if format == TileFormat::Terrain && matches!(d.tiling.scheme(), Scheme::Local { .. }) {
        return Err(ApiError::not_found(
            "not_georeferenced",
            format!(
                "{} is a local grid without georeference: quantized-mesh needs a geodetic or \
                 mercator dataset; use .json, .bin, .obj, .glb or .png",
                d.name
            ),
        ));
    }
    Ok((id, format))
}

fn in_tiling(d: &Dataset, id: TileId) -> bool {
    d.tiling
        .tiles_per_axis(id.z)
        .is_ok_and(|(nx, ny)| id.x < nx && id.y < ny)
}

fn variant(
    d: &Dataset,
    format: TileFormat,
    q: &HashMap<String, String>,
    headers: &HeaderMap,
) -> ApiResult<Variant> {
    let takes_frame = matches!(format, TileFormat::Json | TileFormat::Obj | TileFormat::Glb);
    let frame = Frame::from_query(q, d.tiling.scheme(), takes_frame, format.extension())?;
    Ok(match format {
        TileFormat::Terrain => Variant::Terrain {
            ext: negotiate::terrain_extensions(headers, q.get("extensions").map(String::as_str))?,
            coding: tile_coding(headers),
        },
        TileFormat::Png => Variant::Png {
            terrarium: png_terrarium(q)?,
            size: png_size(q)?,
        },
        TileFormat::Json | TileFormat::Bin | TileFormat::Obj => Variant::Mesh {
            coding: tile_coding(headers),
            frame,
        },
        TileFormat::Glb => Variant::Glb { frame },
        TileFormat::Ezw => Variant::Plain,
    })
}

/// Weak ETag over everything that decides the bytes: the dataset build, the tile, the
/// threshold, the format and its options, the content coding among them. Weak, since a
/// change of the compression libraries may change compressed bytes.
fn etag_hash(d: &Dataset, id: TileId, t: f64, format: TileFormat, variant: Variant) -> u64 {
    let mut h = DefaultHasher::new();
    d.version.hash(&mut h);
    id.hash(&mut h);
    if format == TileFormat::Ezw {
        // A prefix's bytes are the dataset's stream cut at a depth: its strong tag names the
        // depth, so a server whose rule from T to depth differs never reuses it for other
        // bytes (and two T of one depth share the bytes and the tag).
        Depth::for_threshold(t).hash(&mut h);
    } else {
        t.to_bits().hash(&mut h);
        revalidate::RENDERER.hash(&mut h);
    }
    format.hash(&mut h);
    variant.hash(&mut h);
    h.finish()
}

fn header(s: &str) -> ApiResult<HeaderValue> {
    HeaderValue::from_str(s).map_err(ApiError::internal)
}

/// Decode, mesh and encode one tile (blocking).
#[allow(
    clippy::too_many_arguments,
    reason = "the tile's identity, its rendering and the cancel token; both callers pass them straight through"
)]
pub(crate) fn render_tile(
    state: &AppState,
    d: &Dataset,
    id: TileId,
    t: f64,
    format: TileFormat,
    variant: Variant,
    flat_root: bool,
    cancel: &pipeline::Cancel,
) -> anyhow::Result<Encoded> {
    // A missing world root is served flat, with no decode behind it.
    let stitched = || -> anyhow::Result<Option<pipeline::Stitched>> {
        Ok(if flat_root {
            None
        } else {
            Some(pipeline::stitched(state, d, id, t, cancel)?)
        })
    };
    let flat = || render::flat_mesh(d.hierarchy.side(), d.metadata().fill);
    let mesh_of = || -> anyhow::Result<_> { Ok(stitched()?.map_or_else(flat, |s| s.mesh)) };
    let (bytes, triangles) = match (format, variant) {
        (TileFormat::Terrain, Variant::Terrain { ext, .. }) => {
            // The decodes stay beside the mesh: its normals are read from them, and from
            // the corner neighbours' (decoded only for normals).
            let mut s = stitched()?;
            if let Some(s) = s.as_mut().filter(|_| ext.octvertexnormals) {
                s.add_diagonals(state, d, cancel)?;
            }
            let mesh = s
                .as_ref()
                .map_or_else(|| Cow::Owned(flat()), |s| Cow::Borrowed(&s.mesh));
            let opts = QmOptions {
                octvertexnormals: ext.octvertexnormals,
                watermask: ext.watermask.then_some(WaterMask::Uniform(0)),
                metadata: if ext.metadata {
                    Some(render::child_availability(d, id)?)
                } else {
                    None
                },
            };
            let around = s.as_ref().map(|s| (s.neighbourhood(), s.diagonals()));
            (
                render::quantized_mesh(d, id, &mesh, &opts, around)?,
                Some(mesh.triangle_count()),
            )
        }
        (TileFormat::Png, Variant::Png { terrarium, size }) => {
            let dec = pipeline::decoded(state, d, id, Depth::for_threshold(t), cancel)?;
            let enc = png_encoding(terrarium);
            let png = render::png(&dec.heights, enc, size, state.config.png_compression)?;
            (png, None)
        }
        (TileFormat::Ezw, _) => {
            let dec = pipeline::decoded(state, d, id, Depth::for_threshold(t), cancel)?;
            (dec.prefix.clone(), None)
        }
        (TileFormat::Bin, _) => {
            let mesh = mesh_of()?;
            (render::mesh_bin(d, id, &mesh)?, Some(mesh.triangle_count()))
        }
        (
            TileFormat::Json | TileFormat::Obj | TileFormat::Glb,
            Variant::Mesh { frame, .. } | Variant::Glb { frame },
        ) => {
            let mesh = mesh_of()?;
            let f = match format {
                TileFormat::Json => MeshFormat::Json,
                TileFormat::Obj => MeshFormat::Obj,
                _ => MeshFormat::Glb,
            };
            let enu = match frame {
                Frame::Scheme => None,
                Frame::Enu => Some(frame::at_tile(d, id)?),
            };
            (
                render::mesh_file(d, id, &mesh, f, enu.as_ref())?,
                Some(mesh.triangle_count()),
            )
        }
        (f, v) => anyhow::bail!("format {f:?} with options {v:?}"),
    };
    // Compressed once here, the cached body is sent as it is (the compression layer skips
    // bodies with a Content-Encoding).
    let bytes = match variant.coding() {
        Coding::Identity => bytes,
        Coding::Gzip => gzip_bytes(&bytes)?,
        Coding::Br => brotli_bytes(&bytes)?,
    };
    Ok(Encoded::new(bytes, triangles))
}

/// Brotli's quality for tiles: the compression layer's (and nginx's) for bodies made on
/// the fly, as a cold tile waits for it; 11, the library's default, takes tens of times
/// longer.
const BROTLI_QUALITY: i32 = 4;

fn brotli_bytes(raw: &[u8]) -> std::io::Result<Vec<u8>> {
    let params = brotli::enc::BrotliEncoderParams {
        quality: BROTLI_QUALITY,
        ..Default::default()
    };
    let mut out = Vec::with_capacity(raw.len() / 2);
    brotli::BrotliCompress(&mut &raw[..], &mut out, &params)?;
    Ok(out)
}

fn gzip_bytes(raw: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut enc = GzEncoder::new(
        Vec::with_capacity(raw.len() / 2),
        flate2::Compression::default(),
    );
    enc.write_all(raw)?;
    enc.finish()
}

/// `?encoding=` of a PNG tile (and of the TileJSON that lists them): Terrarium or not.
pub(crate) fn png_terrarium(q: &HashMap<String, String>) -> ApiResult<bool> {
    match q.get("encoding").map(String::as_str) {
        None | Some("mapbox") | Some("terrain-rgb") => Ok(false),
        Some("terrarium") => Ok(true),
        Some(other) => Err(ApiError::bad_request(
            "bad_encoding",
            format!(
                "encoding must be terrain-rgb (the default; also called mapbox) or terrarium, \
                 got {}",
                echo(other)
            ),
        )),
    }
}

/// `?size=` of a PNG tile, pixels a side.
pub(crate) fn png_size(q: &HashMap<String, String>) -> ApiResult<u32> {
    Ok(match q.get("size") {
        Some(s) => {
            threshold::integer("size", s, f64::from(PNG_MIN_SIZE), f64::from(PNG_MAX_SIZE))? as u32
        }
        None => PNG_DEFAULT_SIZE,
    })
}
