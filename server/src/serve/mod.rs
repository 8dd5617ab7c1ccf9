//! `zerotile serve`: the HTTP tile server.
//!
//! | module | concern |
//! |---|---|
//! | [`catalog`], [`dataset`], [`storage`], [`store_breaker`], [`reload`] | datasets of a folder or store URL, rescanned while serving, tiles read by range |
//! | [`threshold`], [`view_plane`] | T from `threshold`, `ratio`, a camera (eq. 4) or the zoom |
//! | [`pipeline`], [`tile_cache`] | decode (cached by bytes), stitch, off the async threads |
//! | [`render`] | quantized-mesh, PNG, ZTM1, OBJ/GLB/JSON bytes |
//! | [`negotiate`], [`revalidate`] | Accept, Accept-Encoding, If-None-Match, Range; ETags of descriptions and views |
//! | [`meshes`], [`mesh_reload`] | object meshes of `DATA/meshes`, uploaded or rescanned, and their LODs |
//! | [`routes`] | handlers; [`error`] the one JSON error edge; [`metrics`] Prometheus |
//! | [`routes::site`] | the viewer page at `/`, its embedded assets, `/openapi.json` |
//!
//! The routes are listed in docs/api.md.

pub mod built_once;
pub mod catalog;
pub mod codings;
pub mod dataset;
pub mod error;
pub mod frame;
pub mod listen;
pub mod mesh_reload;
pub mod meshes;
pub mod metrics;
pub mod negotiate;
pub mod pipeline;
pub mod plain_names;
pub mod preflight;
pub mod public_url;
pub mod reload;
pub mod render;
pub mod render_slots;
pub mod revalidate;
pub mod routes;
pub mod state;
pub mod storage;
pub mod store_breaker;
pub mod threshold;
pub mod tile_cache;
pub mod view_plane;

#[cfg(test)]
mod frame_tests;
#[cfg(test)]
mod geoid_tests;
#[cfg(test)]
mod mesh_reload_tests;
#[cfg(test)]
mod reload_tests;
#[cfg(test)]
mod site_tests;
#[cfg(test)]
mod tests;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result};
use axum::http::{header, Method, StatusCode};
use axum::routing::get;
use axum::Router;
use tower_http::cors::{AllowOrigin, Any, CorsLayer};
use tower_http::timeout::TimeoutLayer;
use tower_http::trace::TraceLayer;

pub use catalog::Catalog;
pub use state::{AppState, Config};

/// A request running longer than this is answered 503: a stuck decode must not hold a
/// client forever.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(30);

/// How long a browser may cache a CORS preflight's answer.
pub const CORS_MAX_AGE: Duration = Duration::from_secs(7200);

/// The service: every route, with CORS, compression, timeouts and metrics.
pub fn app(state: AppState) -> Router {
    let routes = Router::new()
        .route("/", get(routes::site::index))
        .route("/assets/{*file}", get(routes::site::asset))
        .route("/openapi.json", get(routes::site::openapi))
        .route("/healthz", get(routes::meta::healthz))
        .route("/metrics", get(routes::meta::metrics))
        .route("/v1/datasets", get(routes::meta::list))
        .route("/v1/datasets/{name}", get(routes::meta::describe))
        .route(
            "/v1/datasets/{name}/layer.json",
            get(routes::meta::layer_json),
        )
        .route(
            "/v1/datasets/{name}/tiles.json",
            get(routes::meta::tilejson),
        )
        .route("/v1/datasets/{name}/view", get(routes::view::view))
        .route(
            "/v1/datasets/{name}/tiles/{z}/{x}/{y}",
            get(routes::tiles::tile),
        )
        .route("/v1/meshes", get(routes::meshes::list))
        .route(
            "/v1/meshes/{name}",
            // The upload reads and limits its own body (`read_upload`).
            get(routes::meshes::describe).post(routes::meshes::upload),
        )
        .route("/v1/meshes/{name}/{method}", get(routes::meshes::lod))
        .fallback(error::not_found)
        .method_not_allowed_fallback(error::method_not_allowed);

    let origins: Vec<header::HeaderValue> = state
        .config
        .cors_origins
        .iter()
        .filter_map(|o| header::HeaderValue::from_str(o).ok())
        .collect();
    let cors = CorsLayer::new()
        // An unparsable configured origin is dropped, never widened to "any".
        .allow_origin(if state.config.cors_origins.is_empty() {
            AllowOrigin::any()
        } else {
            AllowOrigin::list(origins)
        })
        .allow_methods([Method::GET, Method::HEAD, Method::OPTIONS, Method::POST])
        .allow_headers(Any)
        // A browser may keep a preflight's answer this long (Chromium caps it at two hours)
        // instead of asking again before each upload or header-carrying request.
        .max_age(CORS_MAX_AGE)
        .expose_headers([
            header::ETAG,
            header::CONTENT_RANGE,
            header::ACCEPT_RANGES,
            header::HeaderName::from_static("x-threshold"),
            header::HeaderName::from_static("x-triangles"),
            header::HeaderName::from_static("x-view-ratio"),
            header::HeaderName::from_static("x-a-v"),
            header::HeaderName::from_static("x-a-t"),
            header::HeaderName::from_static("x-zoom"),
            header::HeaderName::from_static("x-vertices"),
            header::HeaderName::from_static("x-faces"),
            header::HeaderName::from_static("x-error"),
            header::HeaderName::from_static("x-max-level"),
            header::HeaderName::from_static("x-frame-origin"),
            // What a client is told to do next: when to retry a 503, which methods
            // a route answers (405), which coding an upload must use (415).
            header::RETRY_AFTER,
            header::ALLOW,
            header::ACCEPT_ENCODING,
        ]);
    routes
        .layer(axum::middleware::from_fn(plain_names::plain_names))
        .layer(axum::middleware::from_fn(codings::refuse_unacceptable))
        .layer(codings::app_layer())
        .layer(TimeoutLayer::with_status_code(
            StatusCode::SERVICE_UNAVAILABLE,
            REQUEST_TIMEOUT,
        ))
        .layer(axum::middleware::from_fn(error::json_errors))
        .layer(cors)
        .layer(axum::middleware::from_fn(preflight::route_methods))
        // Outside the layers that change the status (compression's 406, the timeout's 503)
        // and the CORS layer, which answers OPTIONS itself (those went uncounted).
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            metrics::track,
        ))
        // One span per request (method, URI, status, latency) at DEBUG: `RUST_LOG=debug`.
        // Failures too: a 500 has logged its cause at ERROR already (`ApiError::internal`),
        // and the default, an ERROR line per 5xx without its URI, turned every request shed
        // by an overload into one (the shed count is in /metrics).
        .layer(
            TraceLayer::new_for_http().on_failure(
                tower_http::trace::DefaultOnFailure::new().level(tracing::Level::DEBUG),
            ),
        )
        .with_state(state)
}

/// How to run the server.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    pub data: PathBuf,
    pub addr: SocketAddr,
    pub config: Config,
    /// When the datasets are rescanned.
    pub rescan: reload::Rescan,
}

/// Binds, opens the datasets, prints the URL and serves until SIGTERM or Ctrl-C, then lets
/// in-flight requests finish.
pub fn run(opts: ServeOptions) -> Result<()> {
    init_tracing();
    // Bound first: a port in use is refused at once, not after every dataset has been
    // opened (from an object store, that can take a while). Connections made meanwhile wait
    // in the backlog.
    let listener =
        std::net::TcpListener::bind(opts.addr).with_context(|| format!("binding {}", opts.addr))?;
    listener
        .set_nonblocking(true)
        .context("making the listener non-blocking")?;
    // The runtime and the SIGHUP handler before the datasets are opened (from a store that
    // can take a while): a SIGHUP sent to a replica still starting, as deployment.md has
    // operators do after an ingest, would otherwise end it (the signal's default action).
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let hangups = {
        let _in_runtime = rt.enter();
        reload::hangups()
    };
    open_file_room();
    let data = opts.data.to_string_lossy().into_owned();
    let (origin, meshes) = if storage::is_url(&data) {
        // Object meshes are served from local folders only.
        (
            reload::Origin::url(&data)?,
            meshes::MeshCatalog::empty(opts.config.response_cache_bytes),
        )
    } else {
        (
            reload::Origin::Dir(opts.data.clone()),
            meshes::MeshCatalog::open(&opts.data, opts.config.response_cache_bytes),
        )
    };
    let every = opts.rescan.period(&origin);
    let catalog = origin.open()?;
    let meshes = meshes.with_quota(opts.config.mesh_quota);
    let meshes = if opts.config.read_only {
        meshes.read_only()
    } else {
        meshes
    };
    let n = catalog.len();
    if catalog.is_empty() && meshes.list().is_empty() {
        tracing::warn!(
            "no datasets or meshes in {} (build a dataset with `zerotile ingest`: {})",
            opts.data.display(),
            match every {
                Some(every) => format!("it is served within {} s", every.as_secs_f64()),
                None => "SIGHUP has it served".to_owned(),
            }
        );
    }
    let state = AppState::new(catalog, opts.config)?.with_meshes(meshes);
    let served = rt.block_on(async move {
        let listener = tokio::net::TcpListener::from_std(listener)
            .with_context(|| format!("listening on {}", opts.addr))?;
        let local = listener.local_addr()?;
        println!(
            "zerotile: serving {n} dataset(s) from {} on http://{local}/",
            opts.data.display()
        );
        use std::io::Write;
        let _ = std::io::stdout().flush();
        tokio::spawn(reload::watch(state.clone(), origin, every, hangups));
        anyhow::Ok(listen::serve(listener, app(state), shutdown_signal()).await)
    });
    // Not waiting on blocking work still under way (a rescan's listing of a store that does
    // not answer, a render past its request): the drain deadline is the stop's.
    rt.shutdown_timeout(Duration::from_secs(1));
    if served? {
        tracing::info!("shut down cleanly");
    }
    Ok(())
}

/// Descriptors kept for connections, the listing of the data folder and the like, whatever
/// the datasets take.
const SPARE_DESCRIPTORS: u64 = 256;

/// Raises the soft open-file limit to the hard one (a soft 1,024 is common, where the hard
/// one is far higher) and caps the datasets kept open to what it leaves beside
/// [`SPARE_DESCRIPTORS`].
fn open_file_room() {
    let limit = match rlimit::increase_nofile_limit(u64::MAX) {
        Ok(limit) => limit,
        Err(e) => {
            tracing::warn!("cannot read the open-file limit: {e}");
            return;
        }
    };
    let most =
        usize::try_from(limit.saturating_sub(SPARE_DESCRIPTORS).max(16)).unwrap_or(usize::MAX);
    catalog::MAX_DATASETS.store(most, std::sync::atomic::Ordering::Relaxed);
    tracing::debug!("open-file limit {limit}: at most {most} datasets open");
}

fn init_tracing() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    // Colour only on a terminal: logs captured to files stay greppable.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
}

/// Resolves on Ctrl-C or SIGTERM.
async fn shutdown_signal() {
    let ctrl_c = async {
        if let Err(e) = tokio::signal::ctrl_c().await {
            tracing::error!("cannot listen for Ctrl-C: {e}");
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(e) => {
                tracing::error!("cannot listen for SIGTERM: {e}");
                std::future::pending::<()>().await;
            }
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {},
        () = term => {},
    }
    tracing::info!("shutdown signal received: draining in-flight requests");
}
