//! Object-mesh routes: the meshes of `DATA/meshes` and their LODs.
//!
//! - `GET /v1/meshes`, `GET /v1/meshes/{name}`
//! - `GET /v1/meshes/{name}/{method}` with `method` one of `original`, `curvature`
//!   (`error=E` or `level=1..3`), `silhouette` (`level=K` and/or `eye=x,y,z&target=x,y,z`),
//!   `qem` (`faces=N`, `ratio=R` or `error=E`), `octree` (`level=K`, and for region-of-
//!   interest browsing `roi=x0,y0,x1,y1` in NDC with `eye`, `target`, `fov`, `aspect`), and
//!   `format=obj|ply|glb|json`; headers `X-Vertices`, `X-Faces`, `X-Error`, and for the
//!   methods with levels (curvature by level, silhouette, octree) `X-Max-Level`.
//! - `POST /v1/meshes/{name}`: an OBJ, PLY or STL body (≤ 64 MiB), validated, stored.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::header::{
    ACCEPT_ENCODING, CONTENT_ENCODING, CONTENT_LENGTH, CONTENT_TYPE, IF_MATCH, IF_NONE_MATCH,
    LOCATION, RETRY_AFTER,
};
use axum::http::{HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use glam::DVec3;
use http_body_util::BodyExt;
use serde_json::{json, Value};
use zerotile_codec::mesh::curvature::{self, CurvatureOptions};
use zerotile_codec::mesh::io::{self, Format};
use zerotile_codec::mesh::octree::{Roi, View as OctreeView};
use zerotile_codec::mesh::silhouette::View;
use zerotile_codec::mesh::{qem, QemOptions, TriMesh};

use crate::serve::built_once::BuildError;
use crate::serve::codings;
use crate::serve::error::{echo, ApiError, ApiResult};
use crate::serve::meshes::{
    MeshAnswer, MeshEntry, Put, Refuses, Structure, UploadError, MAX_UPLOAD_BYTES,
};
use crate::serve::negotiate;
use crate::serve::revalidate::{self, REVALIDATE};
use crate::serve::state::AppState;
use crate::serve::threshold::{aspect, integer, number, vec3};

/// The LOD methods, as path segments.
pub const METHODS: [&str; 5] = ["original", "curvature", "silhouette", "qem", "octree"];

pub async fn list(
    State(state): State<AppState>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    no_parameters(&query?, "the mesh list", "")?;
    let meshes: Vec<Value> = state.meshes.list().iter().map(|e| summary(e)).collect();
    let skipped = super::meta::skipped_json(&state.meshes.skipped());
    revalidate::json(
        &headers,
        &json!({ "meshes": meshes, "skipped": skipped }),
        REVALIDATE,
    )
}

pub async fn describe(
    State(state): State<AppState>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    let Path(name) = path?;
    let query = query?;
    let e = entry(&state, &name)?;
    // `?format=glb` here would otherwise answer this JSON with a 200 to a client that
    // asked for a model.
    no_parameters(
        &query,
        "the mesh description",
        format_args!("; the mesh itself is /v1/meshes/{name}/original?format=obj|ply|glb|json"),
    )?;
    revalidate::json(&headers, &description(&e), REVALIDATE)
}

/// `GET /v1/meshes/{name}`'s JSON: the summary, the methods and the formats.
fn description(e: &MeshEntry) -> Value {
    let mut v = summary(e);
    let base = format!("/v1/meshes/{}", e.name);
    let methods = json!({
        "original": format!("{base}/original"),
        "curvature": { "url": format!("{base}/curvature"), "params": "error=E | level=1..3 (ε 0.15, 0.20, 0.25; default 1)" },
        "silhouette": { "url": format!("{base}/silhouette"), "params": "level=0..7 and/or eye=x,y,z&target=x,y,z" },
        "qem": { "url": format!("{base}/qem"), "params": "faces=N | ratio=R | error=E (fraction of the diagonal)" },
        "octree": { "url": format!("{base}/octree"), "params": "level=K (default 2, or the deepest level if shallower) [&roi=x0,y0,x1,y1 (NDC, -1..1) &eye=x,y,z&target=x,y,z[&fov=DEG][&aspect=W/H]]" },
    });
    if let Some(o) = v.as_object_mut() {
        o.insert("methods".into(), methods);
        o.insert("formats".into(), json!(["obj", "ply", "glb", "json"]));
    }
    v
}

fn summary(e: &MeshEntry) -> Value {
    let b = e.mesh.bounding_box();
    json!({
        "name": e.name,
        "vertices": e.mesh.vertex_count(),
        "faces": e.mesh.face_count(),
        "faces_dropped": e.faces_dropped,
        "bbox": [b.min.to_array(), b.max.to_array()],
        "diagonal": b.diagonal(),
        "url": format!("/v1/meshes/{}", e.name),
    })
}

fn entry(state: &AppState, name: &str) -> ApiResult<Arc<MeshEntry>> {
    state.meshes.get(name).ok_or_else(|| {
        ApiError::not_found(
            "mesh_not_found",
            format!("no mesh {}; GET /v1/meshes lists them", echo(name)),
        )
    })
}

/// A browsing camera: eye, target, vertical fov (degrees), aspect, and the NDC rectangle.
type Browse = ([f64; 3], [f64; 3], f64, f64, [f64; 4]);

/// What to compute, checked and canonical (so equal asks share a cache entry).
#[derive(Clone, Debug, PartialEq)]
enum Ask {
    Original,
    Curvature(f64),
    /// Level K of the nested sequence cut at the paper's ε: one continuing decimation, so a
    /// coarser level's vertices are a subset of a finer one's (a client can switch LODs
    /// without popping vertices back).
    CurvatureLevel(usize),
    Silhouette {
        level: Option<u8>,
        view: Option<View>,
    },
    QemFaces(usize),
    QemError(f64),
    Octree {
        /// `None`: not asked, [`OCTREE_DEFAULT_LEVEL`] or the deepest level, the shallower.
        level: Option<u32>,
        roi: Option<Browse>,
    },
}

impl Ask {
    /// The mesh's LOD structure this ask reads, if any.
    fn structure(&self) -> Option<Structure> {
        match self {
            Self::CurvatureLevel(_) => Some(Structure::CurvatureLevels),
            Self::Silhouette { .. } => Some(Structure::ViewSphere),
            Self::Octree { .. } => Some(Structure::Octree),
            Self::Original | Self::Curvature(_) | Self::QemFaces(_) | Self::QemError(_) => None,
        }
    }
}

/// Seconds a client is told to wait for a LOD structure under way: they take seconds to a
/// minute, and each ask while one is built is answered at once.
pub const BUILDING_RETRY_SECONDS: u32 = 5;

/// 503 for an ask whose structure another request is building: waiting for it here would
/// hold a render slot for up to a minute, and a client's retries would fill the slots.
fn building(e: &MeshEntry, s: Structure, since: std::time::Duration) -> ApiError {
    ApiError::new(
        StatusCode::SERVICE_UNAVAILABLE,
        "building",
        format!(
            "the {} of mesh {:?} ({} faces) have been building for {} s; retry in a few seconds",
            s.name(),
            e.name,
            e.mesh.face_count(),
            since.as_secs()
        ),
    )
    .with_header(RETRY_AFTER, HeaderValue::from(BUILDING_RETRY_SECONDS))
}

/// The octree level served when `level` is not given.
const OCTREE_DEFAULT_LEVEL: u32 = 2;

/// The query parameters each LOD method takes besides `format` (assets/openapi.json lists
/// every one; `site_tests` checks).
pub(crate) const TAKES: [(&str, &[&str]); 5] = [
    ("original", &[]),
    ("curvature", &["error", "level"]),
    ("silhouette", &["level", "eye", "target"]),
    ("qem", &["faces", "ratio", "error"]),
    (
        "octree",
        &["level", "roi", "eye", "target", "fov", "aspect"],
    ),
];

fn parse_ask(method: &str, q: &HashMap<String, String>, mesh: &TriMesh) -> ApiResult<Ask> {
    let get = |k: &str| q.get(k).map(String::as_str);
    // Called once the method is known (an unknown one is a 404, not a 400).
    let only = || -> ApiResult<()> {
        let allowed = TAKES
            .iter()
            .find(|(m, _)| *m == method)
            .map_or(&[][..], |(_, a)| *a);
        match q
            .keys()
            .find(|k| k.as_str() != "format" && !allowed.contains(&k.as_str()))
        {
            Some(k) => Err(ApiError::bad_request(
                "bad_query",
                format!(
                    "{method} does not take {}; it takes {allowed:?} and format",
                    echo(k)
                ),
            )),
            None => Ok(()),
        }
    };
    match method {
        "original" => {
            only()?;
            Ok(Ask::Original)
        }
        "curvature" => {
            only()?;
            match (get("error"), get("level")) {
                (Some(e), None) => Ok(Ask::Curvature(number("error", e, 0.0, 10.0)?)),
                (None, l) => {
                    let k = integer("level", l.unwrap_or("1"), 1.0, 3.0)?;
                    Ok(Ask::CurvatureLevel(k as usize))
                }
                _ => Err(ApiError::bad_request(
                    "bad_query",
                    "give error=E or level=K, not both",
                )),
            }
        }
        "silhouette" => {
            only()?;
            let level = get("level")
                .map(|l| integer("level", l, 0.0, 7.0))
                .transpose()?
                .map(|l| l as u8);
            let view = match (get("eye"), get("target")) {
                (Some(e), Some(t)) => Some(View {
                    eye: vec3("eye", e)?,
                    target: vec3("target", t)?,
                }),
                (None, None) => None,
                _ => {
                    return Err(ApiError::bad_request(
                        "bad_query",
                        "give eye and target together",
                    ))
                }
            };
            if level.is_none() && view.is_none() {
                return Err(ApiError::bad_request(
                    "bad_query",
                    "silhouette needs level=K, or eye=x,y,z&target=x,y,z (or both)",
                ));
            }
            Ok(Ask::Silhouette { level, view })
        }
        "qem" => {
            only()?;
            let n = mesh.face_count() as f64;
            match (get("faces"), get("ratio"), get("error")) {
                (Some(f), None, None) => {
                    Ok(Ask::QemFaces(integer("faces", f, 1.0, n.max(1.0))? as usize))
                }
                (None, Some(r), None) => {
                    let r = number("ratio", r, 0.0, 1.0)?;
                    Ok(Ask::QemFaces(((r * n).round() as usize).max(1)))
                }
                (None, None, Some(e)) => Ok(Ask::QemError(number("error", e, 0.0, 1.0)?)),
                _ => Err(ApiError::bad_request(
                    "bad_query",
                    "give one of faces=N, ratio=R, error=E",
                )),
            }
        }
        "octree" => {
            only()?;
            let level = get("level")
                .map(|l| integer("level", l, 0.0, 32.0))
                .transpose()?
                .map(|l| l as u32);
            let browsing = ["roi", "eye", "target"]
                .into_iter()
                .any(|k| get(k).is_some());
            // Without the rest of the camera, fov or aspect would be dropped without a word
            // and the client would take the plain level for a browse.
            if let Some(k) = ["fov", "aspect"].into_iter().find(|k| get(k).is_some()) {
                if !browsing {
                    return Err(ApiError::bad_request(
                        "bad_query",
                        format!(
                            "{k} shapes a browse, which needs roi, eye and target too; \
                             without them the answer is the plain level"
                        ),
                    ));
                }
            }
            let roi = match (get("roi"), get("eye"), get("target")) {
                (None, None, None) => None,
                (Some(r), Some(e), Some(t)) => {
                    let parts: Vec<&str> = r.split(',').collect();
                    if parts.len() != 4 {
                        return Err(ApiError::bad_request(
                            "bad_vector",
                            format!("roi must be x0,y0,x1,y1 in [-1, 1], got {}", echo(r)),
                        ));
                    }
                    let mut rect = [0.0; 4];
                    for (slot, p) in rect.iter_mut().zip(&parts) {
                        *slot = number("roi", p, -1.0, 1.0)?;
                    }
                    // Narrower than the terrain view's (0, 179] and [0.001, 1000] (documented
                    // in docs/api.md): browsing divides by tan(fov / 2), which the terrain's
                    // lower bound (the smallest positive f64) rounds to zero.
                    let fov = number("fov", get("fov").unwrap_or("45"), 1.0, 170.0)?;
                    let aspect = get("aspect").map_or(Ok(1.0), |s| aspect(s, 0.05, 20.0))?;
                    Some((
                        vec3("eye", e)?.to_array(),
                        vec3("target", t)?.to_array(),
                        fov,
                        aspect,
                        rect,
                    ))
                }
                _ => {
                    return Err(ApiError::bad_request(
                        "bad_query",
                        "browsing needs roi, eye and target together",
                    ))
                }
            };
            Ok(Ask::Octree { level, roi })
        }
        other => Err(ApiError::not_found(
            "unknown_method",
            format!("no LOD method {}; use one of {METHODS:?}", echo(other)),
        )),
    }
}

/// The answer's format and media type; JSON unless `format` names another.
fn parse_format(q: &HashMap<String, String>) -> ApiResult<(Format, &'static str)> {
    match q.get("format").map(String::as_str).unwrap_or("json") {
        "obj" => Ok((Format::Obj, "model/obj")),
        "ply" => Ok((Format::Ply, "application/ply")),
        "glb" => Ok((Format::Glb, "model/gltf-binary")),
        "json" => Ok((Format::Json, "application/json")),
        other => Err(ApiError::bad_request(
            "bad_format",
            format!("format must be obj, ply, glb or json, got {}", echo(other)),
        )),
    }
}

/// What an ask computes: the mesh, the method's error figure (`X-Error`), and for the
/// level-indexed methods the deepest level this mesh has (`X-Max-Level`), so a client's
/// level control can fit a small mesh instead of asking for levels it does not have.
struct Computed {
    mesh: TriMesh,
    error: f64,
    max_level: Option<u32>,
}

impl Computed {
    fn new(mesh: TriMesh, error: f64) -> Self {
        Self {
            mesh,
            error,
            max_level: None,
        }
    }

    fn with_max_level(mut self, max_level: u32) -> Self {
        self.max_level = Some(max_level);
        self
    }
}

/// Runs an ask.
fn compute(e: &MeshEntry, ask: &Ask) -> Result<Computed, ApiError> {
    let bad = |m: String| ApiError::bad_request("bad_mesh_query", m);
    let unbuilt = |s: Structure| {
        move |x: BuildError| match x {
            BuildError::Failed(m) => bad(m),
            BuildError::Building(since) => building(e, s, since),
        }
    };
    match ask {
        Ask::Original => Ok(Computed::new(e.mesh.clone(), 0.0)),
        Ask::Curvature(eps) => {
            let m = curvature::to_error(&e.mesh, *eps, &CurvatureOptions::default())
                .map_err(|x| bad(x.to_string()))?;
            // The rung the mesh was cut at, not the ask: 0.26 and 0.2999 are one mesh.
            Ok(Computed::new(m, curvature::bound_of(*eps)))
        }
        Ask::CurvatureLevel(k) => {
            let levels = e
                .curvature_levels()
                .map_err(unbuilt(Structure::CurvatureLevels))?;
            let level = k
                .checked_sub(1)
                .and_then(|i| levels.get(i))
                .ok_or_else(|| bad(format!("no level {k}")))?;
            Ok(Computed::new(level.mesh.clone(), level.error)
                .with_max_level(u32::try_from(levels.len()).unwrap_or(u32::MAX)))
        }
        Ask::Silhouette { level, view } => {
            let vs = e.view_sphere().map_err(unbuilt(Structure::ViewSphere))?;
            let deepest = u32::from(vs.max_level());
            let answer = match view {
                Some(v) => {
                    let (m, drawn) = vs.view(v, *level).map_err(|x| bad(x.to_string()))?;
                    Computed::new(m, f64::from(drawn.level))
                }
                None => {
                    let level = level.unwrap_or(vs.max_level());
                    Computed::new(
                        vs.level(level).map_err(|x| bad(x.to_string()))?,
                        f64::from(level),
                    )
                }
            };
            Ok(answer.with_max_level(deepest))
        }
        Ask::QemFaces(n) => {
            let (m, r) = qem::simplify(&e.mesh, &QemOptions::to_faces(*n))
                .map_err(|x| bad(x.to_string()))?;
            Ok(Computed::new(m, r.max_error))
        }
        Ask::Octree { level, roi } => {
            let lod = e.octree().map_err(unbuilt(Structure::Octree))?;
            // A small mesh's octree can stop above the default level: the default is a
            // starting point, not an ask, so it gives way to the deepest level there is.
            let level = &level.unwrap_or_else(|| OCTREE_DEFAULT_LEVEL.min(lod.max_level()));
            let m = match roi {
                None => lod.level(*level).map_err(|x| bad(x.to_string()))?,
                Some((eye, target, fov, aspect, r)) => {
                    let view = OctreeView::looking_at(
                        DVec3::from_array(*eye),
                        DVec3::from_array(*target),
                        *fov,
                        *aspect,
                    );
                    let roi = Roi {
                        x0: r[0],
                        y0: r[1],
                        x1: r[2],
                        y1: r[3],
                    };
                    lod.browse(*level, &view, &roi)
                        .map_err(|x| bad(x.to_string()))?
                        .cut
                        .mesh
                }
            };
            Ok(Computed::new(m, f64::from(*level)).with_max_level(lod.max_level()))
        }
        Ask::QemError(err) => {
            let (m, r) = qem::simplify(&e.mesh, &QemOptions::to_error(*err))
                .map_err(|x| bad(x.to_string()))?;
            Ok(Computed::new(m, r.max_error))
        }
    }
}

pub async fn lod(
    State(state): State<AppState>,
    path: Result<Path<(String, String)>, PathRejection>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    let Path((name, method)) = path?;
    let Query(q) = query?;
    let e = entry(&state, &name)?;
    let ask = parse_ask(&method, &q, &e.mesh)?;
    let (format, content_type) = parse_format(&q)?;

    let mut h = std::collections::hash_map::DefaultHasher::new();
    (
        e.name.as_str(),
        e.content,
        format!("{ask:?}"),
        format.name(),
    )
        .hash(&mut h);
    let key = h.finish();
    let etag = revalidate::weak_tag('m', key, codings::of_answer(&headers, content_type));
    // Revalidated on every use (an upload replaces the mesh at this URL); the tag comes from
    // the ask, before any mesh work.
    let held = match revalidate::Held::check(&headers, &etag, REVALIDATE)? {
        Ok(held) => held,
        Err(not_modified) => return Ok(not_modified),
    };

    let answer = match state.meshes.answers.get(&key) {
        Some(hit) => hit,
        None => {
            // Saves a render slot; the build's claim (in compute) is what decides.
            if let Some(s) = ask.structure() {
                if let Some(since) = e.building_for(s) {
                    return Err(building(&e, s, since));
                }
            }
            let ticket = state.admit_render()?;
            let job = e.clone();
            let keep = state.clone();
            // The answer is cached by the job itself: a client that leaves (or the request
            // timeout, on a large mesh) does not throw the work away, and its retry is a hit.
            tokio::task::spawn_blocking(move || -> ApiResult<Arc<MeshAnswer>> {
                ticket.run(|| {
                    let c = compute(&job, &ask)?;
                    let bytes = io::write_bytes(&c.mesh, format).map_err(ApiError::internal)?;
                    let fresh = Arc::new(MeshAnswer {
                        bytes: crate::serve::tile_cache::exact_bytes(bytes),
                        vertices: c.mesh.vertex_count(),
                        faces: c.mesh.face_count(),
                        error: c.error,
                        max_level: c.max_level,
                    });
                    keep.meshes.answers.insert(key, fresh.clone());
                    Ok(fresh)
                })
            })
            .await
            .map_err(ApiError::internal)??
        }
    };
    if let Some(not_modified) = held.release()? {
        return Ok(not_modified);
    }

    let mut res = Response::new(Body::from(answer.bytes.clone()));
    let h = res.headers_mut();
    h.insert(CONTENT_TYPE, HeaderValue::from_static(content_type));
    revalidate::validators(h, &etag, REVALIDATE)?;
    h.insert("x-vertices", value(&answer.vertices.to_string())?);
    h.insert("x-faces", value(&answer.faces.to_string())?);
    h.insert("x-error", value(&answer.error.to_string())?);
    if let Some(k) = answer.max_level {
        h.insert("x-max-level", value(&k.to_string())?);
    }
    Ok(res)
}

/// How long an upload's body may take to arrive: less than the request timeout, so a
/// client that stalls or declares more than it sends gets its own 408 rather than the
/// timeout's 503, which says "the server failed, retry".
pub const UPLOAD_READ_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(20);

/// The next frame of a body (its data, `None` for trailers), `None` at its end.
async fn next_frame(body: &mut Body) -> Option<Result<Option<Bytes>, axum::Error>> {
    body.frame()
        .await
        .map(|frame| frame.map(|f| f.into_data().ok()))
}

/// Reads and drops what is left of a refused body, for at most [`UPLOAD_READ_TIMEOUT`], after
/// the answer has gone: hyper closes a connection whose request body nobody reads, and a
/// client still sending would get a broken pipe instead of the answer.
pub(crate) fn drain(mut body: Body) {
    tokio::spawn(async move {
        let _ = tokio::time::timeout(UPLOAD_READ_TIMEOUT, async {
            while let Some(Ok(_)) = next_frame(&mut body).await {}
        })
        .await;
    });
}

/// An upload body, read here rather than by an extractor: a `Content-Length` over
/// [`MAX_UPLOAD_BYTES`] is refused before a byte is read (the body-limit layer only counts
/// what arrives, so a short body under a huge declared length waited for the timeout); a
/// body that stops arriving or ends short is the client's fault (408, 400), not a 503.
pub async fn read_upload(
    headers: &HeaderMap,
    mut body: Body,
    deadline: std::time::Duration,
) -> ApiResult<Bytes> {
    let too_large = |what: String| {
        ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "too_large",
            format!("{what}; an upload may be at most {MAX_UPLOAD_BYTES} bytes (64 MiB)"),
        )
    };
    // hyper has already refused a Content-Length that is not a number.
    let declared: Option<u64> = headers
        .get(CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|s| s.trim().parse().ok());
    if let Some(n) = declared.filter(|&n| n > MAX_UPLOAD_BYTES as u64) {
        drain(body);
        return Err(too_large(format!("the body declares {n} bytes")));
    }
    let of = || declared.map_or("unknown".to_string(), |n| n.to_string());
    let mut got = bytes::BytesMut::new();
    let read = async {
        while let Some(frame) = next_frame(&mut body).await {
            let frame = frame.map_err(|e| {
                ApiError::bad_request(
                    "incomplete_body",
                    format!(
                        "the body broke off after {} of {} bytes: {e}",
                        got.len(),
                        of()
                    ),
                )
            })?;
            if let Some(data) = frame {
                if got.len() + data.len() > MAX_UPLOAD_BYTES {
                    return Err(too_large("the body is larger".to_string()));
                }
                got.extend_from_slice(&data);
            }
        }
        Ok(())
    };
    let outcome = tokio::time::timeout(deadline, read).await;
    match outcome {
        Ok(Ok(())) => Ok(got.freeze()),
        Ok(Err(e)) => {
            if e.status == StatusCode::PAYLOAD_TOO_LARGE {
                drain(body);
            }
            Err(e)
        }
        Err(_) => Err(ApiError::new(
            StatusCode::REQUEST_TIMEOUT,
            "timeout",
            format!(
                "the body did not arrive within {} s ({} of {} bytes received)",
                deadline.as_secs_f64(),
                got.len(),
                of()
            ),
        )),
    }
}

/// `POST /v1/meshes/{name}`: the body is the mesh.
pub async fn upload(
    State(state): State<AppState>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    headers: HeaderMap,
    body: Body,
) -> ApiResult<Response> {
    // A server that keeps no uploads says so before it reads one (up to 64 MiB).
    let target = upload_target(path, query, &headers).and_then(|t| {
        state
            .meshes
            .takes_uploads()
            .map(|()| t)
            .map_err(upload_error)
    });
    // The preconditions before the body is read too, against the mesh's description (RFC
    // 9110 §13.1.1–2): If-Match `*` uploads only over a mesh that exists (a tag never passes,
    // the description's being weak), If-None-Match `*` only where none does, and its tag
    // refuses an upload over the description it names. Without them no description is made.
    let put = if headers.contains_key(IF_MATCH) {
        Put::Replace
    } else if negotiate::none_match_lists_star(&headers) {
        Put::Create
    } else {
        Put::Any
    };
    let target = target.and_then(|t| {
        if !headers.contains_key(IF_MATCH) && !headers.contains_key(IF_NONE_MATCH) {
            return Ok(t);
        }
        let (tag, tags) = match state.meshes.get(&t.0) {
            Some(e) => {
                let (tag, every) = revalidate::tags(&headers, &description(&e))?;
                (Some(tag), Some(every))
            }
            None => (None, None),
        };
        revalidate::if_match(&headers, tag.as_deref())?;
        // Judged again under the catalog's lock, `*` by `put`, a tag by `refuses`.
        revalidate::if_none_match_on_write(&headers, tags.as_deref())?;
        Ok(t)
    });
    // Admitted before the body is read, so the uploads in hand bound the bodies held too.
    let admitted = target.and_then(|t| state.admit_upload().map(|ticket| (t, ticket)));
    let ((name, label), ticket) = match admitted {
        Ok(t) => t,
        Err(e) => {
            drain(body);
            return Err(e);
        }
    };
    let body = read_upload(&headers, body, UPLOAD_READ_TIMEOUT).await?;
    if body.is_empty() {
        return Err(ApiError::bad_request(
            "empty_body",
            "the body must hold the mesh",
        ));
    }
    let format = label.format(&body);
    let job_state = state.clone();
    // If-None-Match's tags against the mesh served when the catalog stores this one.
    let refuses = (put != Put::Create && headers.contains_key(IF_NONE_MATCH)).then(|| {
        let headers = headers.clone();
        Box::new(move |e: &MeshEntry| {
            revalidate::tags(&headers, &description(e)).is_ok_and(|(_, every)| {
                revalidate::if_none_match_on_write(&headers, Some(&every)).is_err()
            })
        }) as Refuses
    });
    let (entry, replaced) = tokio::task::spawn_blocking(move || {
        // The catalog judges the preconditions again, under its lock: the mesh may have
        // come or gone while the body was read.
        ticket.run(|| {
            job_state
                .meshes
                .upload_unless(&name, &body, format, put, refuses)
        })
    })
    .await
    .map_err(ApiError::internal)?
    .map_err(upload_error)?;
    // RFC 9110 §15.3.2: a 201 names what it made. The mesh lives at the URL posted to, so the
    // reference is its last segment (relative: right behind a proxy's prefix too). A mesh
    // replaced was not created: 200.
    let mut res = (
        if replaced {
            StatusCode::OK
        } else {
            StatusCode::CREATED
        },
        Json(summary(&entry)),
    )
        .into_response();
    if !replaced {
        let location = HeaderValue::from_str(&entry.name).map_err(ApiError::internal)?;
        res.headers_mut().insert(LOCATION, location);
    }
    Ok(res)
}

/// The client's mesh is a 422 with what was wrong with it; a server that cannot store it is
/// not the client's fault (500, the detail logged, since it names the server's paths).
fn upload_error(e: UploadError) -> ApiError {
    match e {
        UploadError::Invalid(_) => ApiError::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_mesh",
            e.to_string(),
        ),
        UploadError::NoFolder => ApiError::new(
            StatusCode::FORBIDDEN,
            "read_only",
            "this server serves its data from an object store and keeps no uploads; \
             upload to a server of a data folder",
        ),
        UploadError::ReadOnly => ApiError::new(
            StatusCode::FORBIDDEN,
            "read_only",
            "this server was started with --read-only and takes no uploads",
        ),
        UploadError::Quota { .. } => ApiError::new(
            StatusCode::INSUFFICIENT_STORAGE,
            "mesh_quota",
            e.to_string(),
        ),
        UploadError::Gone | UploadError::Exists | UploadError::Matched => ApiError::new(
            StatusCode::PRECONDITION_FAILED,
            "precondition_failed",
            format!(
                "{e} (any more: a rescan or another upload changed that while the body was read)"
            ),
        ),
        UploadError::Store(_) => ApiError::internal(e),
    }
}

/// Refuses any query parameter (400 `bad_query`) on a route that takes none: the object-mesh
/// routes name a parameter they would ignore, as no map client adds its own there. `what`
/// starts the message and `hint` ends it (formatted only for the refusal).
fn no_parameters(
    query: &Query<HashMap<String, String>>,
    what: &str,
    hint: impl std::fmt::Display,
) -> ApiResult<()> {
    match query.keys().next() {
        None => Ok(()),
        Some(k) => Err(ApiError::bad_request(
            "bad_query",
            format!("{what} takes no parameters, got {}{hint}", echo(k)),
        )),
    }
}

/// What an upload's Content-Type says of its format.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Label {
    /// A mesh type: read as that format.
    Format(Format),
    /// None, empty or `application/octet-stream`: sniffed.
    Sniff,
    /// `text/plain`, how many clients label any text file: sniffed, and OBJ (the one text
    /// format with no mark of its own) when nothing is recognised. A JSON mesh so labelled
    /// was read as OBJ and refused as "no faces".
    Text,
}

impl Label {
    /// The format to read `body` as (`None`: sniff it).
    fn format(self, body: &[u8]) -> Option<Format> {
        match self {
            Label::Format(f) => Some(f),
            Label::Sniff => None,
            Label::Text => Some(Format::sniff(body).unwrap_or(Format::Obj)),
        }
    }
}

/// The name and format of an upload, checked before its body is read.
fn upload_target(
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    headers: &HeaderMap,
) -> ApiResult<(String, Label)> {
    let Path(name) = path?;
    // A parameter an upload would ignore (`?format=ply` say) is the client's mistake.
    no_parameters(&query?, "an upload", "; its Content-Type names the format")?;
    crate::ingest::check_name_of("mesh", &name)
        .map_err(|e| ApiError::bad_request("bad_name", e.to_string()))?;
    // Nothing decodes a compressed body: it reached the mesh parsers as it came and was
    // refused as an unreadable mesh (422 "OBJ: read error"), which sent the client looking at
    // its file instead of at the header. RFC 9110 §15.5.16: a coding not supported is a 415.
    // Every Content-Encoding line and list item counts: `identity` then `gzip` on two lines
    // is a gzipped body. Such a 415 names the codings accepted in Accept-Encoding, which
    // tells it from a 415 for the Content-Type (which must not carry it: RFC 9110 §12.5.3).
    if let Some(coding) = headers
        .get_all(CONTENT_ENCODING)
        .iter()
        .flat_map(|v| v.to_str().unwrap_or("?").split(','))
        .map(str::trim)
        .find(|c| !c.is_empty() && !c.eq_ignore_ascii_case("identity"))
    {
        return Err(ApiError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "unsupported_media_type",
            format!(
                "an upload is read as sent, and Content-Encoding {} is not decoded; send the \
                 mesh uncompressed (it may be up to 64 MiB)",
                echo(coding)
            ),
        )
        .with_header(ACCEPT_ENCODING, HeaderValue::from_static("identity")));
    }
    // RFC 9110 §5.3: Content-Type is one field line. Two (a proxy's and the client's, say)
    // name no one format; the first was taken silently.
    let mut types = headers.get_all(CONTENT_TYPE).iter();
    if let (Some(first), Some(second)) = (types.next(), types.next()) {
        let shown = |v: &HeaderValue| echo(&String::from_utf8_lossy(v.as_bytes()));
        return Err(ApiError::bad_request(
            "bad_header",
            format!(
                "two Content-Type lines ({} and {}): an upload names its format in one",
                shown(first),
                shown(second)
            ),
        ));
    }
    let ct = headers
        .get(CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .map(|s| {
            s.split(';')
                .next()
                .unwrap_or("")
                .trim()
                .to_ascii_lowercase()
        });
    let label = match ct.as_deref() {
        Some("model/obj") => Label::Format(Format::Obj),
        Some("text/plain") => Label::Text,
        Some("application/ply" | "model/ply" | "application/x-ply") => Label::Format(Format::Ply),
        Some("model/stl" | "application/sla" | "application/vnd.ms-pki.stl") => {
            Label::Format(Format::Stl)
        }
        // What `?format=json` answers: {"positions": [...], "indices": [...]}.
        Some("application/json") => Label::Format(Format::Json),
        // An empty header (`curl -H 'Content-Type;'` sends one) says as little as none.
        None | Some("" | "application/octet-stream") => Label::Sniff,
        Some(other) => {
            // What `curl --data-binary @mesh.obj` sends unless told otherwise: say how.
            let hint = if other == "application/x-www-form-urlencoded" {
                " (curl's -d/--data-binary default: add -H 'Content-Type: model/obj', or \
                 application/octet-stream to have the format sniffed)"
            } else {
                ""
            };
            return Err(ApiError::new(
                StatusCode::UNSUPPORTED_MEDIA_TYPE,
                "unsupported_media_type",
                format!(
                    "{} is not a mesh{hint}; send model/obj, application/ply, model/stl, \
                     application/json or application/octet-stream (sniffed)",
                    echo(other)
                ),
            ));
        }
    };
    Ok((name, label))
}

fn value(s: &str) -> ApiResult<HeaderValue> {
    HeaderValue::from_str(s).map_err(ApiError::internal)
}
