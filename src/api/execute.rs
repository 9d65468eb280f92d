//! `POST /processes/dmt-contour/execution`: JSON or multipart bodies in, a job queued,
//! and either its results (synchronous) or a statusInfo with `Location` (asynchronous).
//!
//! Invariant: every execution goes through the durable queue, synchronous ones too, so
//! its results are stored and fetchable from any node afterwards.

use std::time::{Duration, Instant};

use axum::body::Bytes;
use axum::extract::{FromRequest, Multipart, Path, Request, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::{Extension, Json};
use serde::Deserialize;
use serde_json::{Map, Value};

use super::AppState;
use super::auth::Principal;
use super::documents::{BaseUrl, PROCESS_ID, StatusInfo, job_href};
use super::jobs::results_for;
use super::problem::Problem;
use crate::jobs::{JobState, compress_json_inputs, now_ms};
use crate::process::ProcessInputs;

/// The OGC execute request body.
#[derive(Debug, Deserialize, utoipa::ToSchema)]
pub struct ExecuteRequest {
    pub inputs: ProcessInputs,
    /// Outputs the client wants, by id; every output is always produced, unknown ids are
    /// refused.
    #[serde(default)]
    #[schema(value_type = Option<Object>)]
    pub outputs: Option<Value>,
    /// `document` (default) or `raw`; the results document is returned either way.
    #[serde(default)]
    pub response: Option<String>,
}

/// The multipart form of an execution: one part per input.
#[derive(Debug, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
pub struct MultipartInputs {
    /// Wells JSON file.
    #[schema(value_type = Option<String>, format = Binary)]
    wells: Option<String>,
    /// Samples CSV file.
    #[schema(value_type = Option<String>, format = Binary)]
    samples_csv: Option<String>,
    /// Collar table CSV file.
    #[schema(value_type = Option<String>, format = Binary)]
    collars_csv: Option<String>,
    /// Survey table CSV file.
    #[schema(value_type = Option<String>, format = Binary)]
    surveys_csv: Option<String>,
    /// Interval table CSV file.
    #[schema(value_type = Option<String>, format = Binary)]
    intervals_csv: Option<String>,
    /// Thresholds: a number, a JSON array or comma-separated numbers.
    thresholds: String,
    variable: Option<String>,
    /// Inside codes: JSON array or comma-separated.
    inside: Option<String>,
    composite_length: Option<f64>,
    crs: Option<String>,
    unit: Option<String>,
    method: Option<String>,
    /// Lattice resolution of the curvature placement (4 to 12).
    lattice: Option<u32>,
    unknown: Option<String>,
    /// `sx,sy,sz` or a JSON array.
    anisotropy: Option<String>,
    /// Azimuth of the anisotropy's first axis, degrees.
    azimuth: Option<f64>,
    /// Dip of the anisotropy's second axis, degrees.
    dip: Option<f64>,
    min_volume: Option<f64>,
    /// Simplification tolerance (input units); 0 keeps every triangle.
    simplify: Option<f64>,
    /// Sweeps of the shape relaxation of IbC and CoI vertices (0 to 50; default 3).
    relax: Option<u32>,
    /// `kriging` (default for samples) or `linear`.
    interpolant: Option<String>,
    /// The model's ranges `major,semi,minor` or a JSON array.
    ranges: Option<String>,
    /// The model's orientation `dipdir,dip,pitch` (degrees) or a JSON array.
    orientation: Option<String>,
    sill: Option<f64>,
    nugget: Option<f64>,
    /// Order of the spheroidal covariance: 3, 5 or 7.
    spheroidal_order: Option<u8>,
    /// `none`, `log` or `normal-score`.
    transform: Option<String>,
    /// `distance` (default) or `indicator`: how 0/1 flags are modelled.
    flag_field: Option<String>,
    /// `rules` (default) or `cross-validation`: how the orientation and ranges not given
    /// are found.
    shape_from: Option<String>,
    /// `global` (default) or `varying`: whether the plane may turn where the ore's does.
    orientation_field: Option<String>,
    top_cut: Option<f64>,
    /// Finest infill step along the major axis.
    resolution: Option<f64>,
    max_samples: Option<u32>,
    max_samples_near: Option<u32>,
    max_per_hole: Option<u32>,
    /// Draw the drill-hole traces in the GLB: true (default) or false.
    well_traces: Option<bool>,
    /// Draw the samples in the GLB: true (default) or false.
    well_samples: Option<bool>,
    /// A JSON object of further inputs.
    inputs: Option<String>,
}

/// Runs the dmt-contour process.
#[utoipa::path(
    post,
    path = "/processes/{process_id}/execution",
    tag = "Processes",
    params(
        ("process_id" = String, Path, description = "Process id: dmt-contour"),
        ("Prefer" = Option<String>, Header, description = "`respond-async` queues the job and answers 201 at once"),
    ),
    request_body(
        description = "An OGC execute request `{\"inputs\": {...}}`, or multipart/form-data with one part per input (CSV files as file parts)",
        content(
            (ExecuteRequest = "application/json"),
            (MultipartInputs = "multipart/form-data"),
        ),
    ),
    responses(
        (status = 200, description = "Synchronous execution finished: the results document", body = Object),
        (status = 201, description = "Job queued (asynchronous); `Location` names it", body = StatusInfo,
            headers(("Location" = String, description = "URL of the job"))),
        (status = 400, description = "Malformed body", body = Problem, content_type = "application/problem+json"),
        (status = 401, description = "Missing or wrong API key", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such process", body = Problem, content_type = "application/problem+json"),
        (status = 413, description = "Body too large", body = Problem, content_type = "application/problem+json"),
        (status = 415, description = "Unsupported body media type", body = Problem, content_type = "application/problem+json"),
        (status = 422, description = "Invalid input, or too many samples; `field` names it", body = Problem, content_type = "application/problem+json"),
        (status = 429, description = "Queue full; retry after `Retry-After` seconds", body = Problem, content_type = "application/problem+json",
            headers(("Retry-After" = u64, description = "Seconds"))),
        (status = 500, description = "The job failed for an internal reason", body = Problem, content_type = "application/problem+json"),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ),
    security((), ("bearer" = [])),
)]
pub async fn execute(
    State(state): State<AppState>,
    Path(process_id): Path<String>,
    BaseUrl(base): BaseUrl,
    Extension(principal): Extension<Principal>,
    headers: HeaderMap,
    request: Request,
) -> Result<Response, Problem> {
    if process_id != PROCESS_ID {
        return Err(Problem::no_such_process(&process_id));
    }
    let content_type = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("application/json")
        .to_ascii_lowercase();
    let inputs = if content_type.starts_with("multipart/form-data") {
        let multipart = Multipart::from_request(request, &state)
            .await
            .map_err(|e| Problem::bad_request(e.body_text()))?;
        inputs_from_multipart(multipart, state.config.max_body_bytes).await?
    } else if content_type.starts_with("application/json") || content_type.ends_with("+json") {
        let body = Bytes::from_request(request, &state).await.map_err(|e| {
            if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
                Problem::too_large(state.config.max_body_bytes)
            } else {
                Problem::bad_request(e.body_text())
            }
        })?;
        // A large body is parsed on a blocking thread, not on the request threads.
        tokio::task::spawn_blocking(move || inputs_from_json(body))
            .await
            .map_err(|e| {
                tracing::error!(error = %e, "parsing the body ended abnormally");
                Problem::internal()
            })??
    } else {
        return Err(Problem::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "about:blank",
            format!("send application/json or multipart/form-data, not {content_type:?}"),
        ));
    };
    inputs
        .validate(state.config.max_points)
        .map_err(|e| Problem::invalid_input(&e.field, e.to_string()))?;
    let points = inputs.point_count();
    // Serialized straight into the compressor on a blocking thread, which drops the
    // parsed inputs: a large upload is never held parsed, serialized and compressed at once.
    let stored = tokio::task::spawn_blocking(move || compress_json_inputs(&inputs))
        .await
        .map_err(|e| {
            tracing::error!(error = %e, "compressing the inputs ended abnormally");
            Problem::internal()
        })?
        .map_err(|e| {
            tracing::error!(error = %e, "could not serialize inputs");
            Problem::internal()
        })?;
    let job = state
        .store
        .submit_compressed(
            &stored,
            principal.owner(),
            state.config.max_attempts,
            state.config.max_queued,
            now_ms(),
        )
        .await?;
    drop(stored);
    state.wake.notify_one();
    tracing::info!(job_id = %job.id, points, "job queued");
    let prefers_async = headers
        .get_all("prefer")
        .iter()
        .filter_map(|v| v.to_str().ok())
        .any(|v| v.to_ascii_lowercase().contains("respond-async"));
    if prefers_async || points > state.config.sync_max_points {
        return Ok(accepted(&job, prefers_async, &base));
    }
    // Synchronous: wait for a worker (here or on another node) to finish the job.
    let deadline = Instant::now() + state.config.sync_wait;
    let mut pause = Duration::from_millis(20);
    loop {
        let current = state
            .store
            .get(job.id)
            .await?
            .ok_or_else(|| Problem::no_such_job(&job.id.to_string()))?;
        match current.state {
            JobState::Successful => {
                let document = results_for(&state, &current).await?;
                let mut response = Json(document).into_response();
                let location = format!("{base}{}", job_href(&job.id));
                if let Ok(location) = HeaderValue::from_str(&location) {
                    response.headers_mut().insert(header::LOCATION, location);
                }
                return Ok(response);
            }
            JobState::Failed => return Err(Problem::job_failed(&current)),
            JobState::Dismissed => {
                return Err(Problem::not_found(format!(
                    "job {} was dismissed before it finished",
                    current.id
                )));
            }
            JobState::Accepted | JobState::Running => {}
        }
        if Instant::now() >= deadline {
            return Ok(accepted(&current, false, &base));
        }
        tokio::time::sleep(pause).await;
        pause = (pause * 2).min(Duration::from_millis(250));
    }
}

/// Lets at most `max_large_uploads` executions with a large body (by `Content-Length`,
/// or of unknown length) be read at once; another answers 429 with `Retry-After` at once
/// rather than holding its body in memory too.
pub async fn limit_large_uploads(
    State(state): State<AppState>,
    request: Request,
    next: Next,
) -> Response {
    let length = request
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<usize>().ok());
    if length.is_some_and(|l| l <= state.config.large_body_bytes) {
        return next.run(request).await;
    }
    if length.is_some_and(|l| l > state.config.max_body_bytes) {
        return Problem::too_large(state.config.max_body_bytes).into_response();
    }
    let Ok(_permit) = state.uploads.clone().try_acquire_owned() else {
        let mut problem = Problem::new(
            StatusCode::TOO_MANY_REQUESTS,
            "about:blank",
            format!(
                "{} large uploads are being read, this server's limit; retry later",
                state.config.max_large_uploads
            ),
        );
        problem.retry_after_s = Some(UPLOAD_RETRY_AFTER_S);
        return problem.into_response();
    };
    next.run(request).await
}

/// Seconds a client refused for too many concurrent large uploads is told to wait.
const UPLOAD_RETRY_AFTER_S: u64 = 2;

fn accepted(job: &crate::jobs::JobRecord, preference_applied: bool, base: &str) -> Response {
    let mut response = (StatusCode::CREATED, Json(StatusInfo::from_record(job))).into_response();
    let location = format!("{base}{}", job_href(&job.id));
    let headers = response.headers_mut();
    if let Ok(location) = HeaderValue::from_str(&location) {
        headers.insert(header::LOCATION, location);
    }
    if preference_applied {
        headers.insert(
            "preference-applied",
            HeaderValue::from_static("respond-async"),
        );
    }
    response
}

/// Parses an execute request, unwrapping OGC qualified values (`{"value": ...}`).
fn inputs_from_json(body: impl AsRef<[u8]>) -> Result<ProcessInputs, Problem> {
    let mut document: Value = serde_json::from_slice(body.as_ref())
        .map_err(|e| Problem::bad_request(format!("the body is not valid JSON: {e}")))?;
    // The body's bytes are not needed once parsed: a large upload is freed here.
    drop(body);
    let Some(object) = document.as_object_mut() else {
        return Err(Problem::bad_request(
            "the body must be a JSON object {\"inputs\": {...}}",
        ));
    };
    let Some(inputs) = object.get_mut("inputs") else {
        return Err(Problem::invalid_input(
            "inputs",
            "the body has no \"inputs\" object",
        ));
    };
    if let Some(inputs) = inputs.as_object_mut() {
        unwrap_qualified_values(inputs);
    }
    // Deserialized from the document by value, so the CSV texts move into the request
    // rather than being copied; the one value an error may quote is kept aside.
    let thresholds = inputs.get("thresholds").cloned();
    let request: ExecuteRequest = serde_path_to_error::deserialize(document).map_err(|e| {
        let field = field_at_fault(&e);
        let sent = thresholds.as_ref().filter(|_| field == "thresholds");
        let reason = plain_reason(&e.inner().to_string(), sent);
        Problem::invalid_input(&field, format!("{field}: {reason}"))
    })?;
    if let Some(response) = &request.response
        && response != "document"
        && response != "raw"
    {
        return Err(Problem::invalid_input(
            "response",
            "must be \"document\" or \"raw\"",
        ));
    }
    if let Some(outputs) = &request.outputs {
        let Some(outputs) = outputs.as_object() else {
            return Err(Problem::invalid_input(
                "outputs",
                "must be an object keyed by output id",
            ));
        };
        if let Some(unknown) = outputs.keys().find(|id| !OUTPUT_IDS.contains(&id.as_str())) {
            return Err(Problem::invalid_input(
                "outputs",
                format!(
                    "unknown output {unknown:?}: expected one of {}",
                    OUTPUT_IDS.join(", ")
                ),
            ));
        }
    }
    Ok(request.inputs)
}

const OUTPUT_IDS: [&str; 6] = ["summary", "glb", "tileset", "geojson", "obj", "vtu"];

fn unwrap_qualified_values(inputs: &mut Map<String, Value>) {
    for (name, value) in inputs.iter_mut() {
        let qualified = value.as_object().is_some_and(|o| {
            o.contains_key("value") && !(name == "wells" && o.contains_key("wells"))
        });
        if qualified && let Some(inner) = value.get_mut("value").map(Value::take) {
            *value = inner;
        }
    }
}

/// The input a deserialization error is about: the unknown or missing field serde
/// names in backticks, else the path where it failed (without the `inputs.` prefix).
fn field_at_fault(error: &serde_path_to_error::Error<serde_json::Error>) -> String {
    let message = error.inner().to_string();
    if (message.starts_with("unknown field") || message.starts_with("missing field"))
        && let Some(named) = message.split('`').nth(1).filter(|f| !f.is_empty())
    {
        return named.to_string();
    }
    let path = error.path().to_string();
    let path = path.strip_prefix("inputs.").unwrap_or(&path);
    match path.split(['.', '[']).next() {
        Some(field) if !field.is_empty() && field != "?" => field.to_string(),
        _ => "inputs".to_string(),
    }
}

/// serde's reason in the client's terms: no Rust type names (`u32`, `struct
/// ProcessInputs`, `untagged enum Thresholds`), and the value sent where serde's message
/// does not quote it.
fn plain_reason(reason: &str, sent: Option<&Value>) -> String {
    if reason.contains("did not match any variant of untagged enum Thresholds") {
        let mut shown = sent.map_or_else(String::new, Value::to_string);
        if shown.len() > 80 {
            shown.truncate(shown.floor_char_boundary(80));
            shown.push_str("...");
        }
        return format!("expected a number or an array of numbers, got {shown}");
    }
    reason
        .replace(
            "expected struct ProcessInputs",
            "expected an object of inputs",
        )
        .replace(
            "expected struct ExecuteRequest",
            "expected an object {\"inputs\": {...}}",
        )
        .replace("expected u32", "expected a whole number")
        .replace("expected f64", "expected a number")
}

const TEXT_FIELDS: [&str; 15] = [
    "interpolant",
    "transform",
    "flag_field",
    "shape_from",
    "orientation_field",
    "samples_csv",
    "collars_csv",
    "surveys_csv",
    "intervals_csv",
    "variable",
    "crs",
    "unit",
    "method",
    "unknown",
    "response",
];

/// One part per input: CSV tables as files or text, `wells` as a JSON file, numbers and
/// lists as JSON or comma-separated text, or a whole `inputs` JSON object.
async fn inputs_from_multipart(
    mut multipart: Multipart,
    max_body_bytes: usize,
) -> Result<ProcessInputs, Problem> {
    let mut inputs = Map::new();
    let mut inside = Vec::new();
    loop {
        let field = match multipart.next_field().await {
            Ok(Some(field)) => field,
            Ok(None) => break,
            Err(e) if e.status() == StatusCode::PAYLOAD_TOO_LARGE => {
                return Err(Problem::too_large(max_body_bytes));
            }
            Err(e) => return Err(Problem::bad_request(e.body_text())),
        };
        let name = field.name().unwrap_or_default().to_string();
        let text = match field.text().await {
            Ok(text) => text,
            Err(e) if e.status() == StatusCode::PAYLOAD_TOO_LARGE => {
                return Err(Problem::too_large(max_body_bytes));
            }
            Err(e) => {
                return Err(Problem::invalid_input(
                    &name,
                    format!("part {name:?} is not UTF-8 text: {}", e.body_text()),
                ));
            }
        };
        match name.as_str() {
            "inputs" => {
                let Value::Object(object) = serde_json::from_str(&text).map_err(|e| {
                    Problem::invalid_input("inputs", format!("not a JSON object: {e}"))
                })?
                else {
                    return Err(Problem::invalid_input("inputs", "not a JSON object"));
                };
                inputs.extend(object);
            }
            "wells" => {
                let value: Value = serde_json::from_str(&text)
                    .map_err(|e| Problem::invalid_input("wells", format!("not JSON: {e}")))?;
                inputs.insert(name, value);
            }
            "thresholds" | "anisotropy" | "ranges" | "orientation" => {
                inputs.insert(name.clone(), number_list(&name, &text)?);
            }
            "min_volume" | "composite_length" | "azimuth" | "dip" | "sill" | "nugget"
            | "top_cut" | "resolution" | "simplify" => {
                let value: f64 = text.trim().parse().map_err(|_| {
                    Problem::invalid_input(&name, format!("{:?} is not a number", text.trim()))
                })?;
                inputs.insert(name, Value::from(value));
            }
            "relax" | "lattice" | "spheroidal_order" | "max_samples" | "max_samples_near"
            | "max_per_hole" => {
                let value: u32 = text.trim().parse().map_err(|_| {
                    Problem::invalid_input(
                        &name,
                        format!("{:?} is not a whole number >= 0", text.trim()),
                    )
                })?;
                inputs.insert(name, Value::from(value));
            }
            "well_traces" | "well_samples" => {
                let value: bool = text.trim().parse().map_err(|_| {
                    Problem::invalid_input(&name, format!("{:?} is not true or false", text.trim()))
                })?;
                inputs.insert(name, Value::from(value));
            }
            "inside" => match serde_json::from_str::<Vec<String>>(&text) {
                Ok(codes) => inside.extend(codes),
                Err(_) => inside.extend(
                    text.split(',')
                        .map(|c| c.trim().to_string())
                        .filter(|c| !c.is_empty()),
                ),
            },
            _ if TEXT_FIELDS.contains(&name.as_str()) => {
                if name != "response" {
                    inputs.insert(name, Value::String(text));
                }
            }
            _ => {
                return Err(Problem::invalid_input(
                    &name,
                    format!("unknown part {name:?}"),
                ));
            }
        }
    }
    if !inside.is_empty() {
        inputs.insert("inside".to_string(), Value::from(inside));
    }
    serde_path_to_error::deserialize(Value::Object(inputs)).map_err(|e| {
        let field = field_at_fault(&e);
        Problem::invalid_input(&field, format!("{field}: {}", e.inner()))
    })
}

fn number_list(field: &str, text: &str) -> Result<Value, Problem> {
    if let Ok(value) = serde_json::from_str::<Value>(text)
        && (value.is_number() || value.is_array())
    {
        return Ok(value);
    }
    let numbers: Result<Vec<f64>, _> = text
        .split(',')
        .map(|n| n.trim())
        .filter(|n| !n.is_empty())
        .map(str::parse::<f64>)
        .collect();
    numbers.map(Value::from).map_err(|_| {
        Problem::invalid_input(
            field,
            format!("{text:?} is not a number or a comma-separated list of numbers"),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qualified_values_are_unwrapped_but_wells_objects_are_not() {
        let body = br#"{"inputs": {"thresholds": {"value": [0.5]}, "samples_csv": {"value": "well,x,y,z,value\n"},
                        "wells": {"wells": [], "value": 1}}}"#;
        let inputs = inputs_from_json(body).unwrap();
        assert_eq!(
            inputs.thresholds,
            crate::process::Thresholds::Many(vec![0.5])
        );
        assert_eq!(inputs.samples_csv.as_deref(), Some("well,x,y,z,value\n"));
        assert!(inputs.wells.unwrap().get("wells").is_some());
    }

    #[test]
    fn unknown_inputs_are_named() {
        let err =
            inputs_from_json(br#"{"inputs": {"thresholds": [1], "treshold": 2}}"#).unwrap_err();
        assert_eq!(err.status, 422);
        assert_eq!(err.field.as_deref(), Some("treshold"));
    }

    #[test]
    fn comma_separated_numbers_are_read() {
        assert_eq!(
            number_list("t", "0.5, 1").unwrap(),
            serde_json::json!([0.5, 1.0])
        );
        assert_eq!(number_list("t", "[2]").unwrap(), serde_json::json!([2]));
        assert_eq!(
            number_list("t", "x").unwrap_err().field.as_deref(),
            Some("t")
        );
    }
}
