//! Read-side OGC handlers: landing page, conformance, process list and description,
//! job list, status, dismissal, results and raw outputs.
//!
//! Invariant: results are served only for successful jobs; anything else answers a
//! JSON problem (`result-not-ready` while queued or running).

use std::ops::Range;
use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::extract::{Path, RawQuery, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::{Extension, Json};
use futures_util::Stream;
use uuid::Uuid;

use super::AppState;
use super::auth::Principal;
use super::documents::{
    BaseUrl, ConformanceDeclaration, JobList, LandingPage, Link, OPENAPI_MEDIA_TYPE, PROCESS_ID,
    ProcessDescription, ProcessList, StatusInfo, conformance as conformance_doc,
    process_description, process_summary, results_document,
};
use super::problem::Problem;
use crate::jobs::{
    Dismissal, JobQuery, JobRecord, JobState, JobStore, JobStoreError, ListPosition, now_ms,
};

/// Landing page with links to the API description, conformance and processes.
#[utoipa::path(get, path = "/", tag = "Capabilities",
    responses((status = 200, description = "Landing page", body = LandingPage)))]
pub async fn landing_page(BaseUrl(base): BaseUrl) -> Json<LandingPage> {
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
const DEFAULT_LIST_LIMIT: i64 = 50;

/// What `GET /jobs` was asked for.
#[derive(Debug, Clone, PartialEq)]
struct ListRequest {
    limit: i64,
    after: Option<ListPosition>,
    states: Vec<JobState>,
    /// `false` when a `processID` other than dmt-contour was asked for (nothing matches).
    process_matches: bool,
    /// The query's filters again, for the `next` link.
    filters: Vec<String>,
}

fn list_request(query: Option<&str>) -> Result<ListRequest, Problem> {
    let mut request = ListRequest {
        limit: DEFAULT_LIST_LIMIT,
        after: None,
        states: Vec::new(),
        process_matches: true,
        filters: Vec::new(),
    };
    for pair in query.unwrap_or("").split('&').filter(|p| !p.is_empty()) {
        let (name, value) = pair.split_once('=').unwrap_or((pair, ""));
        match name {
            "limit" => {
                request.limit = value
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
            "status" => {
                for name in value.split(',').filter(|n| !n.is_empty()) {
                    let state = JobState::ALL
                        .into_iter()
                        .find(|s| s.as_str() == name && *s != JobState::Dismissed)
                        .ok_or_else(|| {
                            Problem::bad_request(format!(
                                "status must be accepted, running, successful or failed, not {name:?}"
                            ))
                            .with_field("status")
                        })?;
                    request.states.push(state);
                }
                request.filters.push(format!("status={value}"));
            }
            "processID" | "processId" => {
                request.process_matches &= value.split(',').any(|p| p == PROCESS_ID);
                request.filters.push(format!("processID={value}"));
            }
            "after" => {
                request.after = Some(parse_position(value).ok_or_else(|| {
                    Problem::bad_request(format!(
                        "after must be a cursor from a `next` link, not {value:?}"
                    ))
                    .with_field("after")
                })?);
            }
            _ => {}
        }
    }
    Ok(request)
}

/// A page's cursor: the last job's creation time and id.
fn position_text(job: &JobRecord) -> String {
    format!("{}_{}", job.created_ms, job.id)
}

fn parse_position(text: &str) -> Option<ListPosition> {
    let (created, id) = text.split_once('_')?;
    Some(ListPosition {
        created_ms: created.parse().ok()?,
        id: Uuid::parse_str(id).ok()?,
    })
}

/// The caller's jobs (every job for an admin key or without keys), newest first, a page at
/// a time: a full page links the `next` one.
#[utoipa::path(get, path = "/jobs", tag = "Jobs",
    params(
        ("limit" = Option<i64>, Query, minimum = 1, maximum = 1000, description = "Most jobs to list (default 50)"),
        ("status" = Option<String>, Query, description = "Only jobs in these states (comma-separated: accepted, running, successful, failed)"),
        ("processID" = Option<String>, Query, description = "Only jobs of these processes (comma-separated)"),
        ("after" = Option<String>, Query, description = "The cursor of a `next` link"),
    ),
    responses(
        (status = 200, description = "Job list", body = JobList),
        (status = 400, description = "Bad limit, status or cursor", body = Problem, content_type = "application/problem+json"),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])))]
pub async fn list_jobs(
    State(state): State<AppState>,
    Extension(principal): Extension<Principal>,
    RawQuery(query): RawQuery,
) -> Result<Json<JobList>, Problem> {
    let request = list_request(query.as_deref())?;
    let jobs = if request.process_matches {
        state
            .store
            .list_jobs(&JobQuery {
                limit: request.limit,
                after: request.after,
                states: request.states.clone(),
                owner: principal.listing_owner(),
            })
            .await?
    } else {
        Vec::new()
    };
    let mut query = vec![format!("limit={}", request.limit)];
    query.extend(request.filters.iter().cloned());
    let mut links = vec![Link::new(
        format!("/jobs?{}", query.join("&")),
        "self",
        "application/json",
        "this document",
    )];
    if let Some(last) = jobs.last().filter(|_| jobs.len() as i64 == request.limit) {
        query.push(format!("after={}", position_text(last)));
        links.push(Link::new(
            format!("/jobs?{}", query.join("&")),
            "next",
            "application/json",
            "the next page",
        ));
    }
    Ok(Json(JobList {
        jobs: jobs.iter().map(StatusInfo::from_record).collect(),
        links,
    }))
}

fn parse_job_id(id: &str) -> Result<Uuid, Problem> {
    Uuid::parse_str(id).map_err(|_| Problem::no_such_job(id))
}

async fn load_job(state: &AppState, principal: &Principal, id: &str) -> Result<JobRecord, Problem> {
    let uuid = parse_job_id(id)?;
    // A dismissed job is gone for clients; the row stays so its worker is fenced out.
    // Another principal's job does not exist for this one (404, not 403: nothing leaks).
    state
        .store
        .get(uuid)
        .await?
        .filter(|job| job.state != JobState::Dismissed && principal.may_see(job))
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
    Extension(principal): Extension<Principal>,
    Path(job_id): Path<String>,
) -> Result<Json<StatusInfo>, Problem> {
    let job = load_job(&state, &principal, &job_id).await?;
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
    Extension(principal): Extension<Principal>,
    Path(job_id): Path<String>,
) -> Result<Json<StatusInfo>, Problem> {
    let uuid = load_job(&state, &principal, &job_id).await?.id;
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
        (status = 200, description = "Results document: `summary` inline; `glb`, `tileset`, `geojson`, `obj`, `vtu`, `report` (grade–tonnage CSV), `chart` (its SVG) as {href, type}", body = Object),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such job, or result-not-ready", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])))]
pub async fn get_results(
    State(state): State<AppState>,
    Extension(principal): Extension<Principal>,
    Path(job_id): Path<String>,
) -> Result<Json<serde_json::Map<String, serde_json::Value>>, Problem> {
    let job = load_job(&state, &principal, &job_id).await?;
    if job.state != JobState::Successful {
        return Err(not_ready(&job));
    }
    Ok(Json(results_for(&state, &job).await?))
}

/// One output's bytes with its media type (`glb`, `summary`, `tileset`, ...).
#[utoipa::path(get, path = "/jobs/{job_id}/results/{output_id}", tag = "Jobs",
    params(
        ("job_id" = String, Path, description = "Job id"),
        ("output_id" = String, Path, description = "glb, summary, tileset, geojson, obj, vtu, report or chart"),
    ),
    responses(
        (status = 206, description = "Part of the output's bytes (`Range: bytes=...`; `Content-Range` says which)"),
        (status = 416, description = "The range starts past the output's end", body = Problem, content_type = "application/problem+json"),
        (status = 200, description = "The output's bytes", content(
            ("model/gltf-binary"), ("application/json"), ("application/geo+json"),
            ("model/obj"), ("application/xml"), ("text/csv"), ("image/svg+xml"))),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such job or output, or result-not-ready", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])))]
pub async fn get_output(
    State(state): State<AppState>,
    Extension(principal): Extension<Principal>,
    Path((job_id, output_id)): Path<(String, String)>,
    request_headers: HeaderMap,
) -> Result<Response, Problem> {
    let job = load_job(&state, &principal, &job_id).await?;
    if job.state != JobState::Successful {
        return Err(not_ready(&job));
    }
    let output = state
        .store
        .output_info(job.id, &output_id)
        .await?
        .ok_or_else(|| Problem::not_found(format!("job {job_id} has no output {output_id:?}")))?;
    let total = u64::try_from(output.size_bytes).unwrap_or(0);
    let range = request_headers
        .get(header::RANGE)
        .and_then(|v| v.to_str().ok())
        .map(|v| byte_range(v, total));
    let (status, start, end) = match range {
        None | Some(ByteRange::Ignored) => (StatusCode::OK, 0, total),
        Some(ByteRange::Part(first, last)) => (StatusCode::PARTIAL_CONTENT, first, last + 1),
        Some(ByteRange::Unsatisfiable) => {
            let mut response = Problem::new(
                StatusCode::RANGE_NOT_SATISFIABLE,
                "about:blank",
                format!("the output has {total} bytes"),
            )
            .into_response();
            if let Ok(value) = HeaderValue::from_str(&format!("bytes */{total}")) {
                response.headers_mut().insert(header::CONTENT_RANGE, value);
            }
            return Ok(response);
        }
    };
    let body = Body::from_stream(output_stream(
        state.store.clone(),
        job.id,
        output.id.clone(),
        start..end,
    ));
    let mut response = (status, body).into_response();
    let headers = response.headers_mut();
    headers.insert(header::CONTENT_LENGTH, HeaderValue::from(end - start));
    if status == StatusCode::PARTIAL_CONTENT
        && let Ok(value) = HeaderValue::from_str(&format!("bytes {start}-{}/{total}", end - 1))
    {
        headers.insert(header::CONTENT_RANGE, value);
    }
    headers.insert(header::ACCEPT_RANGES, HeaderValue::from_static("bytes"));
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

/// The bytes `range` of a stored output, read from the store one part at a time as the
/// client takes them: a download holds one part (at most `OUTPUT_PART_BYTES`) in memory,
/// whatever the output's size. An output deleted meanwhile (dismissed, swept) ends the
/// stream with an error, so the client sees a cut body, never a wrong one.
fn output_stream(
    store: Arc<dyn JobStore>,
    job_id: Uuid,
    output_id: String,
    range: Range<u64>,
) -> impl Stream<Item = Result<Bytes, JobStoreError>> + Send + 'static {
    futures_util::stream::try_unfold(range.start, move |offset| {
        let store = store.clone();
        let output_id = output_id.clone();
        let end = range.end;
        async move {
            if offset >= end {
                return Ok(None);
            }
            let mut part = store
                .output_part(job_id, &output_id, offset)
                .await?
                .filter(|part| !part.is_empty())
                .ok_or_else(|| {
                    JobStoreError::Corrupt(format!(
                        "output {output_id} of job {job_id} ended at byte {offset} of {end}"
                    ))
                })?;
            part.truncate(usize::try_from(end - offset).unwrap_or(usize::MAX));
            let next = offset + part.len() as u64;
            Ok(Some((Bytes::from(part), next)))
        }
    })
}

/// What a `Range` header asks of an output of `total` bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ByteRange {
    /// Bytes `start..=end`.
    Part(u64, u64),
    /// Starts past the end: 416.
    Unsatisfiable,
    /// Not one byte range (several ranges, other units, malformed): the whole output.
    Ignored,
}

/// Reads `bytes=a-b`, `bytes=a-` and `bytes=-n` (RFC 9110); anything else is ignored,
/// which the RFC allows.
fn byte_range(value: &str, total: u64) -> ByteRange {
    let Some(spec) = value.trim().strip_prefix("bytes=") else {
        return ByteRange::Ignored;
    };
    if spec.contains(',') {
        return ByteRange::Ignored;
    }
    let Some((first, last)) = spec.split_once('-') else {
        return ByteRange::Ignored;
    };
    let (first, last) = (first.trim(), last.trim());
    let parse = |n: &str| n.parse::<u64>().ok();
    let (start, end) = match (first.is_empty(), last.is_empty()) {
        (true, false) => match parse(last) {
            Some(0) => return ByteRange::Unsatisfiable,
            Some(n) => (total.saturating_sub(n), total.saturating_sub(1)),
            None => return ByteRange::Ignored,
        },
        (false, true) => match parse(first) {
            Some(start) => (start, total.saturating_sub(1)),
            None => return ByteRange::Ignored,
        },
        (false, false) => match (parse(first), parse(last)) {
            (Some(start), Some(end)) if start <= end => (start, end.min(total.saturating_sub(1))),
            _ => return ByteRange::Ignored,
        },
        (true, true) => return ByteRange::Ignored,
    };
    if start >= total {
        ByteRange::Unsatisfiable
    } else {
        ByteRange::Part(start, end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_ranges_follow_rfc_9110() {
        assert_eq!(byte_range("bytes=0-99", 1000), ByteRange::Part(0, 99));
        assert_eq!(byte_range("bytes=900-", 1000), ByteRange::Part(900, 999));
        assert_eq!(byte_range("bytes=-100", 1000), ByteRange::Part(900, 999));
        assert_eq!(
            byte_range("bytes=990-2000", 1000),
            ByteRange::Part(990, 999)
        );
        assert_eq!(byte_range("bytes=1000-", 1000), ByteRange::Unsatisfiable);
        assert_eq!(byte_range("bytes=0-1,5-6", 1000), ByteRange::Ignored);
        assert_eq!(byte_range("items=0-1", 1000), ByteRange::Ignored);
        assert_eq!(byte_range("bytes=5-1", 1000), ByteRange::Ignored);
    }

    #[test]
    fn a_listing_query_reads_limit_filters_and_cursor() {
        let id = Uuid::from_u128(5);
        let request = list_request(Some(&format!(
            "limit=2&status=failed,running&after=77_{id}"
        )))
        .unwrap();
        assert_eq!(request.limit, 2);
        assert_eq!(request.states, vec![JobState::Failed, JobState::Running]);
        assert_eq!(request.after, Some(ListPosition { created_ms: 77, id }));
        assert!(request.process_matches);
        assert!(
            !list_request(Some("processID=other"))
                .unwrap()
                .process_matches
        );
        for bad in [
            "limit=0",
            "limit=1001",
            "status=dismissed",
            "status=done",
            "after=x",
        ] {
            assert_eq!(list_request(Some(bad)).unwrap_err().status, 400, "{bad}");
        }
    }
}
