//! JSON problem documents (RFC 9457, the shape OGC API exceptions use) for every error
//! the API answers.
//!
//! Invariant: every 4xx/5xx the service sends has a JSON body with `type`, `title`,
//! `status` and `detail`; a 500 never carries internal details (they are logged).

use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use utoipa::ToSchema;

use crate::jobs::JobStoreError;

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
            detail: detail.into(),
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

    pub fn unavailable(detail: impl Into<String>) -> Self {
        Problem::new(StatusCode::SERVICE_UNAVAILABLE, "about:blank", detail)
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
