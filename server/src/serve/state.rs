//! What every handler shares: the datasets, the decoded-tile cache, the counters, and the
//! permits that bound CPU work.

use std::sync::Arc;

use anyhow::Context;
use arc_swap::ArcSwap;
use axum::http::StatusCode;
use zerotile_codec::formats::terrain_rgb::PngCompression;

use super::error::ApiError;

use super::catalog::Catalog;
use super::meshes::MeshCatalog;
use super::metrics::Metrics;
use super::render_slots::{RenderSlots, Ticket};
use super::tile_cache::{new_cache, new_response_cache, ResponseCache, TileCache};

/// Settings with their defaults.
#[derive(Clone, Debug)]
pub struct Config {
    /// Decoded-tile cache size, bytes.
    pub cache_bytes: u64,
    /// Encoded-response cache size, bytes.
    pub response_cache_bytes: u64,
    /// Tiles rendered at once (decode + mesh + encode on the blocking pool); requests past
    /// it wait, so a burst cannot start more CPU work than the machine has cores for.
    pub cpu_jobs: usize,
    /// Renders allowed to wait for a permit; past it requests are shed with 503 at once
    /// rather than queueing into the request timeout.
    pub cpu_queue: usize,
    /// Threads of the render pool, one pool for all renders: it runs the independent parts
    /// of a render side by side (a cold tile's five decodes, a view's tiles), so a lone
    /// request uses every core, and however many renders hand it work it runs this many.
    pub render_threads: usize,
    /// DEFLATE effort of terrain-RGB PNGs: rendered on request, `Fast` (a few ms for a 512²
    /// tile, where `Balanced` takes ~4× as long for ~30 % fewer bytes).
    pub png_compression: PngCompression,
    /// `Cache-Control: max-age` of tiles, seconds.
    pub tile_max_age: u32,
    /// Origins allowed by CORS; empty: any origin (tiles are public by default).
    pub cors_origins: Vec<String>,
    /// The URL clients reach the server at (checked, no trailing slash): TileJSON's tile
    /// URLs start with it. `None`: they follow each request's Host.
    pub public_url: Option<String>,
    /// Take the origin from `X-Forwarded-*` (only behind a proxy that sets them).
    pub trust_forwarded: bool,
    /// Refuse mesh uploads (403 `read_only`).
    pub read_only: bool,
    /// Faces the served meshes may hold together before uploads are refused (507).
    pub mesh_quota: u64,
}

impl Default for Config {
    fn default() -> Self {
        let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
        Self {
            cache_bytes: super::tile_cache::DEFAULT_CACHE_BYTES,
            response_cache_bytes: super::tile_cache::DEFAULT_RESPONSE_CACHE_BYTES,
            cpu_jobs: cores * 2,
            cpu_queue: cores * 64,
            render_threads: cores,
            png_compression: PngCompression::Fast,
            tile_max_age: 3600,
            cors_origins: Vec::new(),
            public_url: None,
            trust_forwarded: false,
            read_only: false,
            mesh_quota: super::meshes::DEFAULT_MESH_QUOTA,
        }
    }
}

/// Cloned into every handler and middleware: one `Arc`, so a clone or a drop is one atomic
/// operation on one counter, where seven separate handles cost seven on counters every core
/// touches (`drop_in_place<AppState>` was the top user-space symbol of a warm-tile profile).
#[derive(Clone)]
pub struct AppState(Arc<Shared>);

/// Uploads parsed and repaired at once. A 2M-face upload takes seconds of one core and a few
/// hundred MB; eight at once shared the cores until every one passed the request timeout
/// (503, none stored) with 3.4 GB held. One at a time, they finish in turn.
pub const UPLOAD_JOBS: usize = 1;
/// Uploads that may wait for [`UPLOAD_JOBS`], body read or arriving; more are a 503 before
/// their body is read. Bounds what uploads hold (each body up to 64 MiB) and keeps the last
/// in line (4 × ~5 s on a busy two-core machine) inside the request timeout.
pub const UPLOAD_QUEUE: usize = 3;

/// What [`AppState`] shares; its fields read through it (`state.cache`).
#[derive(Clone)]
pub struct Shared {
    /// The datasets, swapped whole by a rescan ([`super::reload`]): read it through
    /// [`AppState::catalog`].
    datasets: Arc<ArcSwap<Catalog>>,
    pub cache: Arc<TileCache>,
    pub responses: Arc<ResponseCache>,
    pub metrics: Arc<Metrics>,
    /// Admission and CPU slots for renders.
    pub renders: Arc<RenderSlots>,
    /// Admission and slots for mesh uploads ([`UPLOAD_JOBS`], [`UPLOAD_QUEUE`]).
    pub uploads: Arc<RenderSlots>,
    /// The threads renders decode and mesh on ([`Config::render_threads`]).
    pub pool: Arc<rayon::ThreadPool>,
    pub config: Arc<Config>,
    /// Object meshes and their LODs.
    pub meshes: Arc<MeshCatalog>,
}

impl std::ops::Deref for AppState {
    type Target = Shared;

    fn deref(&self) -> &Shared {
        &self.0
    }
}

impl AppState {
    /// Fails only when the render pool's threads cannot be started.
    pub fn new(catalog: Catalog, config: Config) -> anyhow::Result<Self> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(config.render_threads.max(1))
            .thread_name(|i| format!("zerotile-render-{i}"))
            .build()
            .context("starting the render threads")?;
        Ok(Self(Arc::new(Shared {
            datasets: Arc::new(ArcSwap::from_pointee(catalog)),
            cache: Arc::new(new_cache(config.cache_bytes)),
            responses: Arc::new(new_response_cache(config.response_cache_bytes)),
            metrics: Arc::new(Metrics::default()),
            renders: Arc::new(RenderSlots::new(config.cpu_jobs, config.cpu_queue)),
            uploads: Arc::new(RenderSlots::new(UPLOAD_JOBS, UPLOAD_QUEUE)),
            pool: Arc::new(pool),
            meshes: Arc::new(MeshCatalog::empty(config.response_cache_bytes / 4)),
            config: Arc::new(config),
        })))
    }

    /// The datasets as they are now: a request keeps the one catalog it read, whatever a
    /// rescan swaps in meanwhile.
    pub fn catalog(&self) -> arc_swap::Guard<Arc<Catalog>> {
        self.datasets.load()
    }

    /// [`Self::catalog`] to keep past a short borrow (a rescan compares against it).
    pub fn catalog_now(&self) -> Arc<Catalog> {
        self.datasets.load_full()
    }

    /// Serves `catalog` from now on.
    pub fn replace_catalog(&self, catalog: Catalog) {
        self.datasets.store(Arc::new(catalog));
    }

    /// Serves `meshes` too.
    #[must_use]
    pub fn with_meshes(mut self, meshes: MeshCatalog) -> Self {
        Arc::make_mut(&mut self.0).meshes = Arc::new(meshes);
        self
    }
}

impl AppState {
    /// A ticket to run one render (see [`RenderSlots`]), or 503 + Retry-After when
    /// `cpu_jobs + cpu_queue` renders are already in: a burst cannot pile up work nobody
    /// will wait for.
    pub fn admit_render(&self) -> Result<Ticket, ApiError> {
        self.renders.admit().ok_or_else(|| {
            ApiError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "overloaded",
                "too many tiles are being rendered; retry shortly",
            )
        })
    }

    /// A ticket to read and store one mesh upload, or 503 + Retry-After when
    /// [`UPLOAD_JOBS`] + [`UPLOAD_QUEUE`] uploads are already in.
    pub fn admit_upload(&self) -> Result<Ticket, ApiError> {
        self.uploads.admit().ok_or_else(|| {
            ApiError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "overloaded",
                format!(
                    "{} mesh uploads are being read or stored, as many as this server takes at \
                     once; retry shortly",
                    UPLOAD_JOBS + UPLOAD_QUEUE
                ),
            )
        })
    }
}
