//! The HTTP service: OGC API - Processes Part 1 over the job store, with its OpenAPI
//! document, operations endpoints and the static 3D viewer.
//!
//! Invariant: handlers never compute geometry; they validate, queue and read the store,
//! so any API node serves any job whichever worker ran it.

mod auth;
mod documents;
mod execute;
mod jobs;
mod openapi;
mod ops;
mod problem;
mod viewer;

use std::net::IpAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::{HeaderName, Method, header};
use axum::routing::{get, post};
use tokio::sync::{Notify, Semaphore};
use tower_http::compression::CompressionLayer;
use tower_http::cors::{Any, CorsLayer};
use tower_http::timeout::RequestBodyTimeoutLayer;
use tower_http::trace::TraceLayer;
use utoipa::OpenApi;
use utoipa_swagger_ui::SwaggerUi;

use crate::jobs::{JobMetrics, JobStore};

pub use auth::{ApiKey, Principal, parse_key_file};
pub use documents::{PROCESS_ID, StatusInfo};
pub use openapi::{ApiDoc, openapi_json};
pub use problem::Problem;

/// Limits and switches of the HTTP side.
#[derive(Debug, Clone, PartialEq)]
pub struct ApiConfig {
    /// Largest accepted request body (413 beyond).
    pub max_body_bytes: usize,
    /// Largest accepted number of samples per source (422 beyond).
    pub max_points: usize,
    /// Requests with at most this many samples run synchronously unless the client
    /// prefers `respond-async`.
    pub sync_max_points: usize,
    /// How long a synchronous request waits before it answers 201 and goes async.
    pub sync_wait: Duration,
    /// Most jobs waiting in the queue (429 beyond); `None`: no limit.
    pub max_queued: Option<i64>,
    /// Times a job may be started before lost leases fail it.
    pub max_attempts: i64,
    /// Bearer keys; empty: no authentication (and jobs have no owner).
    pub api_keys: Vec<ApiKey>,
    /// Routes open without a key even when keys are set.
    pub open_routes: OpenRoutes,
    /// The base of every absolute link (`https://host/prefix`); `None`: from the request's
    /// `Host` (or, from a trusted proxy, its `X-Forwarded-Host` and `-Proto`).
    pub public_url: Option<String>,
    /// Addresses whose `X-Forwarded-*` headers are believed.
    pub trusted_proxies: Vec<IpAddr>,
    /// A request body that has not all arrived by then is refused (408).
    pub body_read_timeout: Duration,
    /// Executions with a body over `large_body_bytes` read at once, at most; more answer
    /// 429 with `Retry-After` rather than hold more memory.
    pub max_large_uploads: usize,
    pub large_body_bytes: usize,
    /// Directory of the browser viewer (`viewer/index.html`, `viewer/node_modules`).
    pub viewer_dir: PathBuf,
}

impl Default for ApiConfig {
    fn default() -> Self {
        ApiConfig {
            max_body_bytes: 64 * 1024 * 1024,
            max_points: 2_000_000,
            sync_max_points: 20_000,
            sync_wait: Duration::from_secs(60),
            max_queued: Some(100),
            max_attempts: 3,
            api_keys: Vec::new(),
            open_routes: OpenRoutes::default(),
            public_url: None,
            trusted_proxies: Vec::new(),
            body_read_timeout: Duration::from_secs(60),
            max_large_uploads: 4,
            large_body_bytes: 1024 * 1024,
            viewer_dir: PathBuf::from("viewer"),
        }
    }
}

/// Which of the routes that hold no job data stay open without a key when keys are set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OpenRoutes {
    /// `/metrics`.
    pub metrics: bool,
    /// `/viewer/**`.
    pub viewer: bool,
    /// `/api` and `/api/docs/**`.
    pub docs: bool,
}

impl Default for OpenRoutes {
    fn default() -> Self {
        OpenRoutes {
            metrics: true,
            viewer: true,
            docs: true,
        }
    }
}

/// What every handler shares.
#[derive(Clone)]
pub struct AppState {
    pub store: Arc<dyn JobStore>,
    pub config: Arc<ApiConfig>,
    /// Notified after each submit so local workers start at once.
    pub wake: Arc<Notify>,
    pub metrics: Arc<JobMetrics>,
    /// One permit per large upload being read (`ApiConfig::max_large_uploads`).
    pub uploads: Arc<Semaphore>,
}

impl AppState {
    /// The state of an application over `store` with `config`.
    pub fn new(store: Arc<dyn JobStore>, config: ApiConfig) -> Self {
        AppState {
            store,
            uploads: Arc::new(Semaphore::new(config.max_large_uploads.max(1))),
            config: Arc::new(config),
            wake: Arc::new(Notify::new()),
            metrics: Arc::new(JobMetrics::default()),
        }
    }
}

/// The whole HTTP application.
pub fn router(state: AppState) -> Router {
    let open = state.config.open_routes;
    let mut protected = Router::new()
        .route(
            "/processes/{process_id}/execution",
            post(execute::execute).layer(axum::middleware::from_fn_with_state(
                state.clone(),
                execute::limit_large_uploads,
            )),
        )
        .route("/jobs", get(jobs::list_jobs))
        .route(
            "/jobs/{job_id}",
            get(jobs::get_job).delete(jobs::dismiss_job),
        )
        .route("/jobs/{job_id}/results", get(jobs::get_results))
        .route("/jobs/{job_id}/results/{output_id}", get(jobs::get_output));
    let mut public = Router::new();
    let metrics = Router::new().route("/metrics", get(ops::metrics));
    let viewer = Router::new()
        .route("/viewer", get(viewer::index))
        .route("/viewer/", get(viewer::index))
        .route("/viewer/{*path}", get(viewer::file));
    let docs = Router::new().merge(SwaggerUi::new("/api/docs").url("/api", ApiDoc::openapi()));
    for (router, is_open) in [
        (metrics, open.metrics),
        (viewer, open.viewer),
        (docs, open.docs),
    ] {
        if is_open {
            public = public.merge(router);
        } else {
            protected = protected.merge(router);
        }
    }
    let protected = protected.route_layer(axum::middleware::from_fn_with_state(
        state.clone(),
        auth::require_api_key,
    ));
    let cors = CorsLayer::new()
        .allow_origin(Any)
        .allow_methods([Method::GET, Method::POST, Method::DELETE, Method::OPTIONS])
        .allow_headers([
            header::AUTHORIZATION,
            header::CONTENT_TYPE,
            HeaderName::from_static("prefer"),
        ])
        .expose_headers([
            header::LOCATION,
            header::RETRY_AFTER,
            HeaderName::from_static("preference-applied"),
        ]);
    Router::new()
        .route("/", get(jobs::landing_page))
        .route("/conformance", get(jobs::conformance))
        .route("/processes", get(jobs::list_processes))
        .route("/processes/{process_id}", get(jobs::describe_process))
        .route("/healthz", get(ops::healthz))
        .route("/readyz", get(ops::readyz))
        .merge(public)
        .merge(protected)
        .fallback(ops::not_found)
        .method_not_allowed_fallback(ops::method_not_allowed)
        .layer(DefaultBodyLimit::max(state.config.max_body_bytes))
        .layer(RequestBodyTimeoutLayer::new(state.config.body_read_timeout))
        .layer(CompressionLayer::new())
        .layer(cors)
        .layer(TraceLayer::new_for_http())
        .with_state(state)
}
