//! The JSON documents of OGC API - Processes Part 1 that the service answers with.
//!
//! Invariant: hrefs are absolute paths on this server (`/jobs/{id}/results/glb`), so a
//! document stays valid behind any host name or reverse proxy.

use std::net::{IpAddr, SocketAddr};
use std::time::{Duration, UNIX_EPOCH};

use axum::extract::{ConnectInfo, FromRequestParts};
use axum::http::HeaderMap;
use axum::http::request::Parts;

use serde::Serialize;
use utoipa::ToSchema;

use super::{ApiConfig, AppState};
use crate::jobs::{JobRecord, JobState, OutputInfo};
pub use crate::process::{
    InputDescription, Link, OutputDescription, PROCESS_ID, ProcessDescription, ProcessSummary,
    process_description, process_summary,
};

pub const OPENAPI_MEDIA_TYPE: &str = "application/vnd.oai.openapi+json;version=3.0";

/// `GET /`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct LandingPage {
    pub title: String,
    pub description: String,
    pub links: Vec<Link>,
}

/// `GET /conformance`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ConformanceDeclaration {
    #[serde(rename = "conformsTo")]
    pub conforms_to: Vec<String>,
}

/// `GET /processes`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ProcessList {
    pub processes: Vec<ProcessSummary>,
    pub links: Vec<Link>,
}

/// OGC statusInfo: where a job is.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct StatusInfo {
    #[serde(rename = "jobID")]
    pub job_id: String,
    #[serde(rename = "processID")]
    pub process_id: String,
    #[serde(rename = "type")]
    pub kind: String,
    pub status: JobState,
    pub message: String,
    /// 0..=100.
    #[schema(minimum = 0, maximum = 100)]
    pub progress: u8,
    /// RFC 3339.
    pub created: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub started: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub finished: Option<String>,
    pub updated: String,
    pub links: Vec<Link>,
}

/// `GET /jobs`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct JobList {
    pub jobs: Vec<StatusInfo>,
    pub links: Vec<Link>,
}

/// A link to one output in the results document.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct OutputLink {
    pub href: String,
    #[serde(rename = "type")]
    pub media_type: String,
}

fn rfc3339(ms: i64) -> String {
    let time = UNIX_EPOCH + Duration::from_millis(ms.max(0) as u64);
    humantime::format_rfc3339_millis(time).to_string()
}

/// `scheme://host` of this server as the client reached it: the configured public URL;
/// else `Host`, or `X-Forwarded-Host` and `X-Forwarded-Proto` when the request comes from
/// a configured trusted proxy (from anyone else they are ignored); empty when unknown,
/// which leaves links as absolute paths.
pub fn base_url(config: &ApiConfig, headers: &HeaderMap, peer: Option<IpAddr>) -> String {
    if let Some(public) = &config.public_url {
        return public.trim_end_matches('/').to_string();
    }
    let header = |name: &str| {
        headers
            .get(name)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.split(',').next())
            .map(str::trim)
            .filter(|v| {
                !v.is_empty()
                    && v.chars()
                        .all(|c| c.is_ascii_alphanumeric() || "-.:[]_".contains(c))
            })
    };
    let trusted = peer.is_some_and(|peer| config.trusted_proxies.contains(&peer));
    let forwarded = |name: &str| if trusted { header(name) } else { None };
    let Some(host) = forwarded("x-forwarded-host").or_else(|| header("host")) else {
        return String::new();
    };
    let scheme = match forwarded("x-forwarded-proto") {
        Some("https") => "https",
        _ => "http",
    };
    format!("{scheme}://{host}")
}

/// The base of a request's absolute links ([`base_url`] with the peer's address).
pub struct BaseUrl(pub String);

impl FromRequestParts<AppState> for BaseUrl {
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(
        parts: &mut Parts,
        state: &AppState,
    ) -> Result<Self, Self::Rejection> {
        let peer = parts
            .extensions
            .get::<ConnectInfo<SocketAddr>>()
            .map(|info| info.0.ip());
        Ok(BaseUrl(base_url(&state.config, &parts.headers, peer)))
    }
}

pub fn job_href(id: &uuid::Uuid) -> String {
    format!("/jobs/{id}")
}

impl StatusInfo {
    pub fn from_record(job: &JobRecord) -> Self {
        let href = job_href(&job.id);
        let mut links = vec![Link::new(
            href.clone(),
            "self",
            "application/json",
            "this job's status",
        )];
        if job.state == JobState::Successful {
            links.push(Link::new(
                format!("{href}/results"),
                "http://www.opengis.net/def/rel/ogc/1.0/results",
                "application/json",
                "this job's results",
            ));
            links.push(Link::new(
                format!("/viewer?job={}", job.id),
                "alternate",
                "text/html",
                "this job's bodies in the 3D viewer",
            ));
        }
        StatusInfo {
            job_id: job.id.to_string(),
            process_id: PROCESS_ID.to_string(),
            kind: "process".to_string(),
            status: job.state,
            message: job.message.clone(),
            progress: job.progress,
            created: rfc3339(job.created_ms),
            started: job.started_ms.map(rfc3339),
            finished: job.finished_ms.map(rfc3339),
            updated: rfc3339(job.updated_ms),
            links,
        }
    }
}

/// The results document: the summary inline, the other outputs by reference.
pub fn results_document(
    job_id: &uuid::Uuid,
    summary: Option<serde_json::Value>,
    outputs: &[OutputInfo],
) -> serde_json::Map<String, serde_json::Value> {
    let mut document = serde_json::Map::new();
    if let Some(summary) = summary {
        document.insert("summary".to_string(), summary);
    }
    for output in outputs.iter().filter(|o| o.id != "summary") {
        let link = OutputLink {
            href: format!("/jobs/{job_id}/results/{}", output.id),
            media_type: output.media_type.clone(),
        };
        document.insert(
            output.id.clone(),
            serde_json::to_value(link).unwrap_or_default(),
        );
    }
    document
}

pub fn conformance() -> ConformanceDeclaration {
    let base = "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/";
    ConformanceDeclaration {
        conforms_to: [
            "core",
            "ogc-process-description",
            "json",
            "oas30",
            "job-list",
            "dismiss",
        ]
        .iter()
        .map(|c| format!("{base}{c}"))
        .chain(std::iter::once(
            "http://www.opengis.net/spec/ogcapi-common-1/1.0/conf/core".to_string(),
        ))
        .collect(),
    }
}
