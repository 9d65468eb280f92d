//! Operations endpoints (`/healthz`, `/readyz`, `/metrics`), bearer API keys and the
//! JSON answers for unknown routes and methods.
//!
//! Invariant: API keys are compared in constant time, and every configured key is
//! compared on every request, so timing tells nothing about which key nearly matched.

use std::fmt::Write as _;

use axum::Json;
use axum::extract::{Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use subtle::ConstantTimeEq;

use super::AppState;
use super::problem::Problem;
use crate::jobs::JobState;

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

/// The job database answers.
#[utoipa::path(get, path = "/readyz", tag = "Operations",
    responses(
        (status = 200, description = "Ready", body = Health),
        (status = 503, description = "The job database is not answering", body = Problem, content_type = "application/problem+json"),
    ))]
pub async fn readyz(State(state): State<AppState>) -> Result<Json<Health>, Problem> {
    state.store.ping().await?;
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
    state.metrics.render(&mut text);
    let mut response = text.into_response();
    response.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/plain; version=0.0.4; charset=utf-8"),
    );
    Ok(response)
}

/// `true` when `presented` equals one of `keys`, comparing all of them in constant time.
pub fn key_matches(keys: &[String], presented: &str) -> bool {
    keys.iter().fold(false, |found, key| {
        found | bool::from(key.as_bytes().ct_eq(presented.as_bytes()))
    })
}

/// Rejects requests without a valid `Authorization: Bearer KEY` when keys are set.
pub async fn require_api_key(
    State(state): State<AppState>,
    request: Request,
    next: Next,
) -> Response {
    let keys = &state.config.api_keys;
    if keys.is_empty() || request.method() == axum::http::Method::OPTIONS {
        return next.run(request).await;
    }
    let presented = request
        .headers()
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| {
            v.strip_prefix("Bearer ")
                .or_else(|| v.strip_prefix("bearer "))
        })
        .map(str::trim);
    match presented {
        Some(key) if key_matches(keys, key) => next.run(request).await,
        _ => {
            let mut response = Problem::new(
                StatusCode::UNAUTHORIZED,
                "about:blank",
                "send a valid API key as `Authorization: Bearer KEY`",
            )
            .into_response();
            response
                .headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
            response
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_match_exactly() {
        let keys = vec!["alpha".to_string(), "beta-key".to_string()];
        assert!(key_matches(&keys, "beta-key"));
        assert!(key_matches(&keys, "alpha"));
        assert!(!key_matches(&keys, "beta"));
        assert!(!key_matches(&keys, "alphaa"));
        assert!(!key_matches(&keys, ""));
        assert!(!key_matches(&[], "alpha"));
    }
}
