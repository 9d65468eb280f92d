//! The JSON documents of OGC API - Processes Part 1 that the service answers with.
//!
//! Invariant: hrefs are absolute paths on this server (`/jobs/{id}/results/glb`), so a
//! document stays valid behind any host name or reverse proxy.

use std::collections::BTreeMap;
use std::time::{Duration, UNIX_EPOCH};

use serde::Serialize;
use utoipa::ToSchema;

use crate::jobs::{JobRecord, JobState, OutputInfo};

pub const PROCESS_ID: &str = "dmt-contour";
pub const OPENAPI_MEDIA_TYPE: &str = "application/vnd.oai.openapi+json;version=3.0";

/// A link (OGC API - Common).
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema)]
pub struct Link {
    pub href: String,
    pub rel: String,
    #[serde(rename = "type", skip_serializing_if = "Option::is_none")]
    pub media_type: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
}

impl Link {
    pub fn new(href: impl Into<String>, rel: &str, media_type: &str, title: &str) -> Self {
        Link {
            href: href.into(),
            rel: rel.to_string(),
            media_type: Some(media_type.to_string()),
            title: Some(title.to_string()),
        }
    }
}

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

/// A process in the list.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ProcessSummary {
    pub id: String,
    pub title: String,
    pub description: String,
    pub version: String,
    #[serde(rename = "jobControlOptions")]
    pub job_control_options: Vec<String>,
    #[serde(rename = "outputTransmission")]
    pub output_transmission: Vec<String>,
    pub links: Vec<Link>,
}

/// `GET /processes`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ProcessList {
    pub processes: Vec<ProcessSummary>,
    pub links: Vec<Link>,
}

/// One input of a process description.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct InputDescription {
    pub title: String,
    pub description: String,
    /// JSON Schema of the input's value.
    #[schema(value_type = Object)]
    pub schema: serde_json::Value,
    #[serde(rename = "minOccurs")]
    pub min_occurs: u32,
    #[serde(rename = "maxOccurs")]
    pub max_occurs: u32,
}

/// One output of a process description.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct OutputDescription {
    pub title: String,
    pub description: String,
    #[schema(value_type = Object)]
    pub schema: serde_json::Value,
}

/// `GET /processes/dmt-contour`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ProcessDescription {
    #[serde(flatten)]
    pub summary: ProcessSummary,
    pub inputs: BTreeMap<String, InputDescription>,
    pub outputs: BTreeMap<String, OutputDescription>,
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

/// `scheme://host` of this server as the client reached it (`X-Forwarded-Proto` and
/// `X-Forwarded-Host` from a reverse proxy win over `Host`); empty when unknown, which
/// leaves links as absolute paths.
pub fn base_url(headers: &axum::http::HeaderMap) -> String {
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
    let Some(host) = header("x-forwarded-host").or_else(|| header("host")) else {
        return String::new();
    };
    let scheme = match header("x-forwarded-proto") {
        Some("https") => "https",
        _ => "http",
    };
    format!("{scheme}://{host}")
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

pub fn process_summary() -> ProcessSummary {
    ProcessSummary {
        id: PROCESS_ID.to_string(),
        title: "Closed ore bodies from wells (Dual Marching Tetrahedra)".to_string(),
        description: "Tetrahedralizes the samples of wells or drill holes (exact 3D Delaunay) \
             and extracts one closed, oriented surface per threshold with Dual Marching \
             Tetrahedra; returns a summary (volumes, areas, bodies) and a glTF model."
            .to_string(),
        version: env!("CARGO_PKG_VERSION").to_string(),
        job_control_options: vec![
            "sync-execute".to_string(),
            "async-execute".to_string(),
            "dismiss".to_string(),
        ],
        output_transmission: vec!["value".to_string(), "reference".to_string()],
        links: vec![
            Link::new(
                format!("/processes/{PROCESS_ID}"),
                "self",
                "application/json",
                "process description",
            ),
            Link::new(
                format!("/processes/{PROCESS_ID}/execution"),
                "http://www.opengis.net/def/rel/ogc/1.0/execute",
                "application/json",
                "execute",
            ),
        ],
    }
}

fn input(title: &str, description: &str, schema: serde_json::Value) -> InputDescription {
    InputDescription {
        title: title.to_string(),
        description: description.to_string(),
        schema,
        min_occurs: 0,
        max_occurs: 1,
    }
}

pub fn process_description() -> ProcessDescription {
    use serde_json::json;
    let csv =
        |what: &str| json!({"type": "string", "contentMediaType": "text/csv", "description": what});
    let mut inputs = BTreeMap::new();
    inputs.insert(
        "wells".to_string(),
        input(
            "Wells JSON",
            "{\"crs\"?, \"wells\": [{\"id\", \"x\", \"y\", \"z\"?, \"samples\": [{\"depth\" | \"z\", \"value\": number | null}]}]}; depth is measured down a vertical hole from the collar z.",
            json!({"type": "object", "required": ["wells"], "properties": {
                "crs": {"type": "string"},
                "wells": {"type": "array", "items": {"type": "object"}}}}),
        ),
    );
    inputs.insert(
        "samples_csv".to_string(),
        input(
            "Samples CSV",
            "CSV text with a header row: well,x,y,z,value (aliases hole_id/bhid, easting, northing, elevation/rl). Empty, NA or ? values are \"don't know\".",
            csv("well,x,y,z,value"),
        ),
    );
    inputs.insert(
        "collars_csv".to_string(),
        input(
            "Collar table",
            "CSV text: hole_id,x,y,z.",
            csv("hole_id,x,y,z"),
        ),
    );
    inputs.insert(
        "surveys_csv".to_string(),
        input(
            "Survey table",
            "CSV text: hole_id,depth,azimuth,dip; desurveyed by minimum curvature. Without it holes are vertical.",
            csv("hole_id,depth,azimuth,dip"),
        ),
    );
    inputs.insert(
        "intervals_csv".to_string(),
        input(
            "Interval table",
            "CSV text: hole_id,from,to,<variables...>.",
            csv("hole_id,from,to,<variables...>"),
        ),
    );
    inputs.insert(
        "variable".to_string(),
        input(
            "Variable",
            "Interval column holding the value to contour.",
            json!({"type": "string"}),
        ),
    );
    inputs.insert(
        "inside".to_string(),
        input(
            "Inside codes",
            "Categorical codes of the variable that count as inside (value 1); others are 0.",
            json!({"type": "array", "items": {"type": "string"}}),
        ),
    );
    inputs.insert(
        "composite_length".to_string(),
        input(
            "Composite length",
            "Composite intervals to this length (input units); default: interval midpoints.",
            json!({"type": "number", "exclusiveMinimum": 0}),
        ),
    );
    let mut thresholds = input(
        "Thresholds",
        "One closed shell per threshold; a sample is inside when value >= threshold.",
        json!({"oneOf": [{"type": "number"}, {"type": "array", "items": {"type": "number"}, "minItems": 1, "maxItems": 64}]}),
    );
    thresholds.min_occurs = 1;
    inputs.insert("thresholds".to_string(), thresholds);
    inputs.insert(
        "method".to_string(),
        input(
            "Vertex placement",
            "distance, curvature, ibc, coi, midpoint (Dual Marching Tetrahedra) or mt (marching tetrahedra). Default: curvature for 0/1 data, ibc for grades.",
            json!({"type": "string", "enum": ["distance", "curvature", "ibc", "coi", "midpoint", "mt"]}),
        ),
    );
    inputs.insert(
        "unknown".to_string(),
        input(
            "Don't-know samples",
            "drop: leave them out (default); bounds: also build pessimistic and optimistic bodies.",
            json!({"type": "string", "enum": ["drop", "bounds"], "default": "drop"}),
        ),
    );
    inputs.insert(
        "anisotropy".to_string(),
        input(
            "Anisotropy",
            "Per-axis scale [sx, sy, sz] applied before tetrahedralizing and inverted on output.",
            json!({"type": "array", "items": {"type": "number", "exclusiveMinimum": 0}, "minItems": 3, "maxItems": 3}),
        ),
    );
    inputs.insert(
        "min_volume".to_string(),
        input(
            "Minimum body volume",
            "Bodies smaller than this (input units cubed) are left out.",
            json!({"type": "number", "minimum": 0}),
        ),
    );
    inputs.insert(
        "relax".to_string(),
        input(
            "Shape relaxation sweeps",
            "IbC and CoI vertices slide within their tetrahedron's marching-tetrahedra polygon to cut slivers (triangles under 10 degrees); 0 keeps the paper's positions.",
            json!({"type": "integer", "minimum": 0, "maximum": crate::dmt::relax::MAX_SWEEPS, "default": crate::dmt::relax::DEFAULT_SWEEPS}),
        ),
    );
    for (name, title, what) in [
        (
            "well_traces",
            "Drill-hole traces",
            "the drill-hole traces (line primitives)",
        ),
        ("well_samples", "Samples", "the samples (point primitives)"),
    ] {
        inputs.insert(
            name.to_string(),
            input(
                title,
                &format!("Draw {what} in their own node of the GLB (default true)."),
                json!({"type": "boolean", "default": true}),
            ),
        );
    }
    inputs.insert(
        "crs".to_string(),
        input(
            "CRS",
            "Coordinate reference system to report when the input carries none, e.g. EPSG:32633.",
            json!({"type": "string"}),
        ),
    );
    inputs.insert(
        "unit".to_string(),
        input(
            "Length unit",
            "Horizontal length unit of the input.",
            json!({"type": "string", "enum": ["m", "ft"]}),
        ),
    );
    let mut outputs = BTreeMap::new();
    let output = |title: &str, description: &str, media_type: &str| OutputDescription {
        title: title.to_string(),
        description: description.to_string(),
        schema: if media_type == "application/json" && title == "Summary" {
            json!({"type": "object", "contentMediaType": media_type})
        } else {
            json!({"type": "string", "contentEncoding": "binary", "contentMediaType": media_type})
        },
    };
    outputs.insert(
        "summary".to_string(),
        output(
            "Summary",
            "Method, origin, CRS, counts, and per threshold the volume, area and bodies.",
            "application/json",
        ),
    );
    outputs.insert(
        "glb".to_string(),
        output(
            "glTF model",
            "glTF 2.0 binary, Y-up relative to the origin; one mesh per body.",
            "model/gltf-binary",
        ),
    );
    outputs.insert(
        "tileset".to_string(),
        output(
            "3D Tiles tileset",
            "3D Tiles tileset whose root content is the glb output.",
            "application/json",
        ),
    );
    outputs.insert(
        "geojson".to_string(),
        output(
            "Level plans",
            "GeoJSON level plans of the bodies.",
            "application/geo+json",
        ),
    );
    outputs.insert(
        "obj".to_string(),
        output("OBJ model", "Wavefront OBJ of the bodies.", "model/obj"),
    );
    outputs.insert(
        "vtu".to_string(),
        output(
            "VTU mesh",
            "VTK unstructured grid of the bodies.",
            "application/xml",
        ),
    );
    ProcessDescription {
        summary: process_summary(),
        inputs,
        outputs,
    }
}
