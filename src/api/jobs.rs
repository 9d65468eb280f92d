//! Read-side OGC handlers: landing page, conformance, process list and description,
//! job list, status, dismissal, results and raw outputs.
//!
//! Invariant: results are served only for successful jobs; anything else answers a
//! JSON problem (`result-not-ready` while queued or running).

use axum::Json;
use axum::extract::{Path, RawQuery, State};
use axum::http::{HeaderMap, HeaderValue, header};
use axum::response::{IntoResponse, Response};
use uuid::Uuid;

use super::AppState;
use super::documents::{
    ConformanceDeclaration, JobList, LandingPage, Link, OPENAPI_MEDIA_TYPE, PROCESS_ID,
    ProcessDescription, ProcessList, StatusInfo, base_url, conformance as conformance_doc,
    process_description, process_summary, results_document,
};
use super::problem::Problem;
use crate::jobs::{Dismissal, JobRecord, JobState, now_ms};

/// Landing page with links to the API description, conformance and processes.
#[utoipa::path(get, path = "/", tag = "Capabilities",
    responses((status = 200, description = "Landing page", body = LandingPage)))]
pub async fn landing_page(headers: HeaderMap) -> Json<LandingPage> {
    let base = base_url(&headers);
    let mut page = LandingPage {
        title: "wellmesh".to_string(),
        description: "Closed ore-body surfaces from wells and drill holes (OGC API - Processes)"
            .to_string(),
        links: vec![
            Link::new("/", "self", "application/json", "this document"),
            Link::new(
                "/api",
                "service-desc",
                OPENAPI_MEDIA_TYPE,
                "the API definition",
            ),
            Link::new(
                "/api/docs/",
                "service-doc",
                "text/html",
                "the API documentation",
            ),
            Link::new(
                "/conformance",
                "http://www.opengis.net/def/rel/ogc/1.0/conformance",
                "application/json",
                "conformance classes",
            ),
            Link::new(
                "/processes",
                "http://www.opengis.net/def/rel/ogc/1.0/processes",
                "application/json",
                "processes",
            ),
            Link::new(
                "/jobs",
                "http://www.opengis.net/def/rel/ogc/1.0/job-list",
                "application/json",
                "jobs",
            ),
            Link::new("/viewer", "alternate", "text/html", "3D viewer"),
        ],
    };
    // OGC clients follow these links as they are: make them absolute.
    for link in &mut page.links {
        link.href = format!("{base}{}", link.href);
    }
    Json(page)
}

/// Conformance classes implemented.
#[utoipa::path(get, path = "/conformance", tag = "Capabilities",
    responses((status = 200, description = "Conformance declaration", body = ConformanceDeclaration)))]
pub async fn conformance() -> Json<ConformanceDeclaration> {
    Json(conformance_doc())
}

/// The processes offered (one: dmt-contour).
#[utoipa::path(get, path = "/processes", tag = "Processes",
    responses((status = 200, description = "Process list", body = ProcessList)))]
pub async fn list_processes() -> Json<ProcessList> {
    Json(ProcessList {
        processes: vec![process_summary()],
        links: vec![Link::new(
            "/processes",
            "self",
            "application/json",
            "this document",
        )],
    })
}

/// Describes a process: every input and output.
#[utoipa::path(get, path = "/processes/{process_id}", tag = "Processes",
    params(("process_id" = String, Path, description = "Process id: dmt-contour")),
    responses(
        (status = 200, description = "Process description", body = ProcessDescription),
        (status = 404, description = "No such process", body = Problem, content_type = "application/problem+json"),
    ))]
pub async fn describe_process(
    Path(process_id): Path<String>,
) -> Result<Json<ProcessDescription>, Problem> {
    if process_id != PROCESS_ID {
        return Err(Problem::no_such_process(&process_id));
    }
    Ok(Json(process_description()))
}

const MAX_LIST_LIMIT: i64 = 1000;

/// The newest jobs, newest first.
#[utoipa::path(get, path = "/jobs", tag = "Jobs",
    params(("limit" = Option<i64>, Query, minimum = 1, maximum = 1000, description = "Most jobs to list (default 50)")),
    responses(
        (status = 200, description = "Job list", body = JobList),
        (status = 400, description = "Bad limit", body = Problem, content_type = "application/problem+json"),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])))]
pub async fn list_jobs(
    State(state): State<AppState>,
    RawQuery(query): RawQuery,
) -> Result<Json<JobList>, Problem> {
    let mut limit = 50;
    for pair in query.as_deref().unwrap_or("").split('&') {
        if let Some(value) = pair.strip_prefix("limit=") {
            limit = value
                .parse::<i64>()
                .ok()
                .filter(|l| (1..=MAX_LIST_LIMIT).contains(l))
                .ok_or_else(|| {
                    Problem::bad_request(format!(
                        "limit must be an integer from 1 to {MAX_LIST_LIMIT}, not {value:?}"
                    ))
                    .with_field("limit")
                })?;
        }
    }
    let jobs = state.store.list(limit).await?;
    Ok(Json(JobList {
        jobs: jobs
            .iter()
            .filter(|job| job.state != JobState::Dismissed)
            .map(StatusInfo::from_record)
            .collect(),
        links: vec![Link::new(
            format!("/jobs?limit={limit}"),
            "self",
            "application/json",
            "this document",
        )],
    }))
}

fn parse_job_id(id: &str) -> Result<Uuid, Problem> {
    Uuid::parse_str(id).map_err(|_| Problem::no_such_job(id))
}

async fn load_job(state: &AppState, id: &str) -> Result<JobRecord, Problem> {
    let uuid = parse_job_id(id)?;
    // A dismissed job is gone for clients; the row stays so its worker is fenced out.
    state
        .store
        .get(uuid)
        .await?
        .filter(|job| job.state != JobState::Dismissed)
        .ok_or_else(|| Problem::no_such_job(id))
}

/// A job's status, progress and links.
#[utoipa::path(get, path = "/jobs/{job_id}", tag = "Jobs",
    params(("job_id" = String, Path, description = "Job id")),
    responses(
        (status = 200, description = "statusInfo", body = StatusInfo),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such job", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])))]
pub async fn get_job(
    State(state): State<AppState>,
    Path(job_id): Path<String>,
) -> Result<Json<StatusInfo>, Problem> {
    let job = load_job(&state, &job_id).await?;
    Ok(Json(StatusInfo::from_record(&job)))
}

/// Dismisses a job: a queued job never runs, a running one is cancelled, a finished
/// one's results are deleted. Afterwards the job answers 404.
#[utoipa::path(delete, path = "/jobs/{job_id}", tag = "Jobs",
    params(("job_id" = String, Path, description = "Job id")),
    responses(
        (status = 200, description = "statusInfo of the dismissed job", body = StatusInfo),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such job", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])))]
pub async fn dismiss_job(
    State(state): State<AppState>,
    Path(job_id): Path<String>,
) -> Result<Json<StatusInfo>, Problem> {
    let uuid = load_job(&state, &job_id).await?.id;
    match state.store.request_dismissal(uuid, now_ms()).await? {
        Dismissal::Dismissed(job) => {
            tracing::info!(job_id = %job.id, "job dismissed");
            Ok(Json(StatusInfo::from_record(&job)))
        }
        Dismissal::NotFound => Err(Problem::no_such_job(&job_id)),
    }
}

fn not_ready(job: &JobRecord) -> Problem {
    match job.state {
        JobState::Failed => {
            Problem::result_not_ready(format!("job {} failed: {}", job.id, job.message))
        }
        JobState::Dismissed => Problem::result_not_ready(format!("job {} was dismissed", job.id)),
        _ => Problem::result_not_ready(format!(
            "job {} is {} ({}% {}); poll /jobs/{} until it is successful",
            job.id,
            job.state.as_str(),
            job.progress,
            job.message,
            job.id
        )),
    }
}

/// The results document of a successful job.
pub async fn results_for(
    state: &AppState,
    job: &JobRecord,
) -> Result<serde_json::Map<String, serde_json::Value>, Problem> {
    let outputs = state.store.outputs(job.id).await?;
    let summary = match state.store.output(job.id, "summary").await? {
        Some(summary) => Some(serde_json::from_slice(&summary.bytes).map_err(|e| {
            tracing::error!(job_id = %job.id, error = %e, "stored summary is not JSON");
            Problem::internal()
        })?),
        None => None,
    };
    Ok(results_document(&job.id, summary, &outputs))
}

/// Results: the summary inline, links to the GLB and the other outputs.
#[utoipa::path(get, path = "/jobs/{job_id}/results", tag = "Jobs",
    params(("job_id" = String, Path, description = "Job id")),
    responses(
        (status = 200, description = "Results document: `summary` inline; `glb`, `tileset`, `geojson`, `obj`, `vtu` as {href, type}", body = Object),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such job, or result-not-ready", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])))]
pub async fn get_results(
    State(state): State<AppState>,
    Path(job_id): Path<String>,
) -> Result<Json<serde_json::Map<String, serde_json::Value>>, Problem> {
    let job = load_job(&state, &job_id).await?;
    if job.state != JobState::Successful {
        return Err(not_ready(&job));
    }
    Ok(Json(results_for(&state, &job).await?))
}

/// One output's bytes with its media type (`glb`, `summary`, `tileset`, ...).
#[utoipa::path(get, path = "/jobs/{job_id}/results/{output_id}", tag = "Jobs",
    params(
        ("job_id" = String, Path, description = "Job id"),
        ("output_id" = String, Path, description = "glb, summary, tileset, geojson, obj or vtu"),
    ),
    responses(
        (status = 200, description = "The output's bytes", content(
            ("model/gltf-binary"), ("application/json"), ("application/geo+json"),
            ("model/obj"), ("application/xml"))),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such job or output, or result-not-ready", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])))]
pub async fn get_output(
    State(state): State<AppState>,
    Path((job_id, output_id)): Path<(String, String)>,
) -> Result<Response, Problem> {
    let job = load_job(&state, &job_id).await?;
    if job.state != JobState::Successful {
        return Err(not_ready(&job));
    }
    let output = state
        .store
        .output(job.id, &output_id)
        .await?
        .ok_or_else(|| Problem::not_found(format!("job {job_id} has no output {output_id:?}")))?;
    let mut response = output.bytes.into_response();
    let headers = response.headers_mut();
    if let Ok(media_type) = HeaderValue::from_str(&output.media_type) {
        headers.insert(header::CONTENT_TYPE, media_type);
    }
    if let Ok(disposition) =
        HeaderValue::from_str(&format!("inline; filename=\"{}\"", output.file_name))
    {
        headers.insert(header::CONTENT_DISPOSITION, disposition);
    }
    Ok(response)
}
