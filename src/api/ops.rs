//! Operations endpoints (`/healthz`, `/readyz`, `/metrics`) and the JSON answers for
//! unknown routes and methods.
//!
//! Invariant: `/healthz` touches nothing but the process; `/readyz` answers within
//! [`READY_TIMEOUT`] whatever the database does.

use std::fmt::Write as _;

use axum::Json;
use axum::extract::{Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;

use super::AppState;
use super::problem::Problem;
use crate::jobs::{JobState, StorageUse};

/// `{"status": "ok"}`.
#[derive(Debug, Serialize, utoipa::ToSchema)]
pub struct Health {
    pub status: String,
}

/// The process is up.
#[utoipa::path(get, path = "/healthz", tag = "Operations",
    responses((status = 200, description = "Alive", body = Health)))]
pub async fn healthz() -> Json<Health> {
    Json(Health {
        status: "ok".to_string(),
    })
}

/// Longest `/readyz` waits for the database.
pub const READY_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(2);

/// The job database answers.
#[utoipa::path(get, path = "/readyz", tag = "Operations",
    responses(
        (status = 200, description = "Ready", body = Health),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ))]
pub async fn readyz(State(state): State<AppState>) -> Result<Json<Health>, Problem> {
    match tokio::time::timeout(READY_TIMEOUT, state.store.ping()).await {
        Ok(answer) => answer?,
        Err(_) => {
            return Err(Problem::unavailable(format!(
                "the job database did not answer within {} s",
                READY_TIMEOUT.as_secs()
            )));
        }
    }
    Ok(Json(Health {
        status: "ready".to_string(),
    }))
}

/// Prometheus text exposition: jobs by state, queue depth, job outcomes and durations.
#[utoipa::path(get, path = "/metrics", tag = "Operations",
    responses(
        (status = 200, description = "Prometheus metrics", body = String, content_type = "text/plain"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ))]
pub async fn metrics(State(state): State<AppState>) -> Result<Response, Problem> {
    let counts = state.store.count_by_state().await?;
    let count = |wanted: JobState| {
        counts
            .iter()
            .find(|(state, _)| *state == wanted)
            .map_or(0, |(_, n)| *n)
    };
    let mut text = String::new();
    let _ = writeln!(text, "# HELP wellmesh_jobs Jobs in the store, by state.");
    let _ = writeln!(text, "# TYPE wellmesh_jobs gauge");
    for job_state in JobState::ALL {
        let _ = writeln!(
            text,
            "wellmesh_jobs{{state=\"{}\"}} {}",
            job_state.as_str(),
            count(job_state)
        );
    }
    let _ = writeln!(
        text,
        "# HELP wellmesh_queue_depth Jobs waiting for a worker."
    );
    let _ = writeln!(text, "# TYPE wellmesh_queue_depth gauge");
    let _ = writeln!(text, "wellmesh_queue_depth {}", count(JobState::Accepted));
    let storage = state.store.storage().await?;
    render_storage(&mut text, &storage);
    state.metrics.render(&mut text);
    let mut response = text.into_response();
    response.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/plain; version=0.0.4; charset=utf-8"),
    );
    Ok(response)
}

pub async fn not_found(request: Request) -> Problem {
    Problem::not_found(format!("no resource at {}", request.uri().path()))
}

pub async fn method_not_allowed(request: Request) -> Problem {
    Problem::new(
        StatusCode::METHOD_NOT_ALLOWED,
        "about:blank",
        format!(
            "{} is not allowed on {}",
            request.method(),
            request.uri().path()
        ),
    )
}

/// The store's disk use: totals, per job (mean and largest) and the file's size.
fn render_storage(text: &mut String, storage: &StorageUse) {
    let _ = writeln!(
        text,
        "# HELP wellmesh_store_bytes Bytes the job store holds, by part (inputs compressed)."
    );
    let _ = writeln!(text, "# TYPE wellmesh_store_bytes gauge");
    let _ = writeln!(
        text,
        "wellmesh_store_bytes{{part=\"inputs\"}} {}",
        storage.input_bytes
    );
    let _ = writeln!(
        text,
        "wellmesh_store_bytes{{part=\"outputs\"}} {}",
        storage.output_bytes
    );
    let _ = writeln!(
        text,
        "# HELP wellmesh_store_jobs Jobs stored, in every state."
    );
    let _ = writeln!(text, "# TYPE wellmesh_store_jobs gauge");
    let _ = writeln!(text, "wellmesh_store_jobs {}", storage.jobs);
    let mean = if storage.jobs > 0 {
        (storage.input_bytes + storage.output_bytes) as f64 / storage.jobs as f64
    } else {
        0.0
    };
    let _ = writeln!(
        text,
        "# HELP wellmesh_store_job_bytes Bytes stored per job (inputs and outputs): mean and largest."
    );
    let _ = writeln!(text, "# TYPE wellmesh_store_job_bytes gauge");
    let _ = writeln!(text, "wellmesh_store_job_bytes{{stat=\"mean\"}} {mean:.0}");
    let _ = writeln!(
        text,
        "wellmesh_store_job_bytes{{stat=\"max\"}} {}",
        storage.largest_job_bytes
    );
    if let Some(bytes) = storage.file_bytes {
        let _ = writeln!(
            text,
            "# HELP wellmesh_store_file_bytes Size of the SQLite database file."
        );
        let _ = writeln!(text, "# TYPE wellmesh_store_file_bytes gauge");
        let _ = writeln!(text, "wellmesh_store_file_bytes {bytes}");
    }
}
