//! The HTTP service: OGC API - Processes Part 1 over the job store, with its OpenAPI
//! document, operations endpoints and the static 3D viewer.
//!
//! Invariant: handlers never compute geometry; they validate, queue and read the store,
//! so any API node serves any job whichever worker ran it.

mod documents;
mod execute;
mod jobs;
mod openapi;
mod ops;
mod problem;
mod viewer;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::{HeaderName, Method, header};
use axum::routing::{get, post};
use tokio::sync::Notify;
use tower_http::compression::CompressionLayer;
use tower_http::cors::{Any, CorsLayer};
use tower_http::trace::TraceLayer;
use utoipa::OpenApi;
use utoipa_swagger_ui::SwaggerUi;

use crate::jobs::{JobMetrics, JobStore};

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
    /// Bearer keys; empty: no authentication.
    pub api_keys: Vec<String>,
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
            viewer_dir: PathBuf::from("viewer"),
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
}

/// The whole HTTP application.
pub fn router(state: AppState) -> Router {
    let protected = Router::new()
        .route("/processes/{process_id}/execution", post(execute::execute))
        .route("/jobs", get(jobs::list_jobs))
        .route(
            "/jobs/{job_id}",
            get(jobs::get_job).delete(jobs::dismiss_job),
        )
        .route("/jobs/{job_id}/results", get(jobs::get_results))
        .route("/jobs/{job_id}/results/{output_id}", get(jobs::get_output))
        .route_layer(axum::middleware::from_fn_with_state(
            state.clone(),
            ops::require_api_key,
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
        .route("/metrics", get(ops::metrics))
        .route("/viewer", get(viewer::index))
        .route("/viewer/", get(viewer::index))
        .route("/viewer/{*path}", get(viewer::file))
        .merge(protected)
        .merge(SwaggerUi::new("/api/docs").url("/api", ApiDoc::openapi()))
        .fallback(ops::not_found)
        .method_not_allowed_fallback(ops::method_not_allowed)
        .layer(DefaultBodyLimit::max(state.config.max_body_bytes))
        .layer(CompressionLayer::new())
        .layer(cors)
        .layer(TraceLayer::new_for_http())
        .with_state(state)
}
