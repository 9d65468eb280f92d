//! JSON problem documents (RFC 9457, the shape OGC API exceptions use) for every error
//! the API answers.
//!
//! Invariant: every 4xx/5xx the service sends has a JSON body with `type`, `title`,
//! `status` and `detail`; a 500 never carries internal details (they are logged).

use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use utoipa::ToSchema;

use crate::jobs::{FailureKind, JobRecord, JobStoreError, cap_message};

const OGC: &str = "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/";

/// An error answer.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema)]
pub struct Problem {
    /// A URI naming the kind of error (OGC exception types where one exists).
    #[serde(rename = "type")]
    pub kind: String,
    pub title: String,
    pub status: u16,
    pub detail: String,
    /// The request field at fault, when there is one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    /// Seconds to wait before retrying (429 answers).
    #[serde(skip)]
    pub retry_after_s: Option<u64>,
}

impl Problem {
    pub fn new(status: StatusCode, kind: &str, detail: impl Into<String>) -> Self {
        Problem {
            kind: kind.to_string(),
            title: status.canonical_reason().unwrap_or("Error").to_string(),
            status: status.as_u16(),
            detail: cap_message(&detail.into()),
            field: None,
            retry_after_s: None,
        }
    }

    pub fn with_field(mut self, field: &str) -> Self {
        self.field = Some(field.to_string());
        self
    }

    pub fn bad_request(detail: impl Into<String>) -> Self {
        Problem::new(StatusCode::BAD_REQUEST, "about:blank", detail)
    }

    pub fn invalid_input(field: &str, detail: impl Into<String>) -> Self {
        Problem::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            &format!("{OGC}invalid-parameter-value"),
            detail,
        )
        .with_field(field)
    }

    pub fn no_such_job(id: &str) -> Self {
        Problem::new(
            StatusCode::NOT_FOUND,
            &format!("{OGC}no-such-job"),
            format!("there is no job {id:?}"),
        )
    }

    pub fn no_such_process(id: &str) -> Self {
        Problem::new(
            StatusCode::NOT_FOUND,
            &format!("{OGC}no-such-process"),
            format!("there is no process {id:?}; the only process is dmt-contour"),
        )
    }

    pub fn result_not_ready(detail: impl Into<String>) -> Self {
        Problem::new(
            StatusCode::NOT_FOUND,
            &format!("{OGC}result-not-ready"),
            detail,
        )
    }

    pub fn not_found(detail: impl Into<String>) -> Self {
        Problem::new(StatusCode::NOT_FOUND, "about:blank", detail)
    }

    pub fn too_large(limit_bytes: usize) -> Self {
        Problem::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "about:blank",
            format!("the request body exceeds this server's limit of {limit_bytes} bytes"),
        )
        .with_field("body")
    }

    pub fn internal() -> Self {
        Problem::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            "about:blank",
            "internal error; it has been logged",
        )
    }

    /// The answer for a job that failed: the one mapping from failure kind to status
    /// (`failure_status`). A failure the user can fix says why and names the input where
    /// known; an internal one says only that it happened and which job it was (the cause
    /// is in the worker's log under that job id).
    pub fn job_failed(job: &JobRecord) -> Self {
        let kind = job.failure.unwrap_or(FailureKind::Internal);
        let status = failure_status(kind);
        match kind {
            FailureKind::Input | FailureKind::Timeout => {
                let mut problem = Problem::new(
                    status,
                    &format!("{OGC}invalid-parameter-value"),
                    format!("job {} failed: {}", job.id, job.message),
                );
                problem.field = job.failure_field.clone();
                problem
            }
            FailureKind::LeaseExpired | FailureKind::Internal => Problem::new(
                status,
                "about:blank",
                format!(
                    "job {} failed with an internal error; it has been logged under this job id",
                    job.id
                ),
            ),
        }
    }

    pub fn unavailable(detail: impl Into<String>) -> Self {
        Problem::new(StatusCode::SERVICE_UNAVAILABLE, "about:blank", detail)
    }
}

/// The status a failed job answers with: 422 when the inputs were at fault (they could
/// not be read or contoured, or asked for more than the per-job time limit allows), 500
/// when the service was (a broken invariant, a panic, an export that failed, workers that
/// kept dying).
pub fn failure_status(kind: FailureKind) -> StatusCode {
    match kind {
        FailureKind::Input | FailureKind::Timeout => StatusCode::UNPROCESSABLE_ENTITY,
        FailureKind::LeaseExpired | FailureKind::Internal => StatusCode::INTERNAL_SERVER_ERROR,
    }
}

impl From<JobStoreError> for Problem {
    fn from(err: JobStoreError) -> Self {
        match err {
            JobStoreError::QueueFull { queued } => {
                let mut problem = Problem::new(
                    StatusCode::TOO_MANY_REQUESTS,
                    "about:blank",
                    format!("{queued} jobs are waiting, this server's limit; retry later"),
                );
                problem.retry_after_s = Some(10);
                problem
            }
            other => {
                tracing::error!(error = %other, "job store error");
                Problem::unavailable("the job database is not answering; retry later")
            }
        }
    }
}

impl IntoResponse for Problem {
    fn into_response(self) -> Response {
        let status = StatusCode::from_u16(self.status).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
        let body = serde_json::to_vec(&self).unwrap_or_default();
        let mut response = (status, body).into_response();
        let headers = response.headers_mut();
        headers.insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/problem+json"),
        );
        if let Some(seconds) = self.retry_after_s {
            headers.insert(header::RETRY_AFTER, HeaderValue::from(seconds));
        }
        response
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::JobState;

    fn failed(kind: Option<FailureKind>, field: Option<&str>, message: &str) -> JobRecord {
        JobRecord {
            id: uuid::Uuid::from_u128(7),
            state: JobState::Failed,
            message: message.to_string(),
            progress: 40,
            attempt: 1,
            max_attempts: 3,
            failure: kind,
            failure_field: field.map(str::to_string),
            owner: None,
            created_ms: 0,
            started_ms: Some(1),
            finished_ms: Some(2),
            updated_ms: 2,
        }
    }

    #[test]
    fn every_failure_kind_has_one_status() {
        let table = [
            (FailureKind::Input, 422),
            (FailureKind::Timeout, 422),
            (FailureKind::LeaseExpired, 500),
            (FailureKind::Internal, 500),
        ];
        for (kind, status) in table {
            assert_eq!(failure_status(kind).as_u16(), status, "{kind:?}");
            let problem = Problem::job_failed(&failed(Some(kind), None, "m"));
            assert_eq!(problem.status, status, "{kind:?}");
        }
    }

    #[test]
    fn an_input_failure_says_why_and_names_the_field() {
        let job = failed(
            Some(FailureKind::Input),
            Some("samples_csv"),
            "samples_csv, line 3: x is not a number",
        );
        let problem = Problem::job_failed(&job);
        assert_eq!(problem.field.as_deref(), Some("samples_csv"));
        assert!(problem.detail.contains("line 3: x is not a number"));
        assert!(problem.detail.contains(&job.id.to_string()));
    }

    #[test]
    fn an_internal_failure_names_the_job_and_nothing_else() {
        for kind in [
            Some(FailureKind::Internal),
            Some(FailureKind::LeaseExpired),
            None,
        ] {
            let job = failed(
                kind,
                Some("wells"),
                "exporting the results: index 7 out of range",
            );
            let problem = Problem::job_failed(&job);
            assert_eq!(problem.status, 500);
            assert!(problem.detail.contains(&job.id.to_string()));
            assert!(!problem.detail.contains("index 7"), "{}", problem.detail);
            assert_eq!(problem.field, None);
        }
    }

    #[test]
    fn a_long_detail_is_cut() {
        let problem = Problem::bad_request("x".repeat(50 * 1024 * 1024));
        assert!(problem.detail.len() <= crate::jobs::MAX_MESSAGE_BYTES);
        assert!(problem.detail.ends_with("more bytes)"));
    }
}
