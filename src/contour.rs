//! The one pipeline: samples -> Delaunay -> DMT shells -> measures and summary.
//!
//! [`run`] is called by the CLI, by service workers and by tests alike.
//! Invariant: the summary's volumes and areas are those of exactly the triangles in
//! `ContourResult::shells`, which are what every exporter writes.

use glam::DVec3;
use serde::Serialize;

use crate::dmt::{Method, Shell};
use crate::wells::SampleSet;

/// What to do with "don't know" samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum UnknownMode {
    /// The paper's rule: drop them before tetrahedralizing.
    #[default]
    Drop,
    /// Also build the pessimistic (unknown = no) and optimistic (unknown = yes) bodies.
    Bounds,
}

/// A contouring job.
#[derive(Debug, Clone)]
pub struct ContourRequest {
    pub samples: SampleSet,
    /// One shell per threshold; a sample is inside when `value >= threshold`.
    pub thresholds: Vec<f64>,
    /// `None` picks the default: curvature for 0/1 data, IbC for grades.
    pub method: Option<Method>,
    pub unknown: UnknownMode,
    /// Per-axis scale applied before tetrahedralizing and inverted on output.
    pub anisotropy: Option<DVec3>,
    /// Bodies with a smaller volume are left out of the output.
    pub min_volume: f64,
}

/// Per-body figures of the summary JSON (design.md contract), in input units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodySummary {
    pub volume: f64,
    pub area: f64,
    pub closed: bool,
    pub truncated: bool,
    /// `[[min x, min y, min z], [max x, max y, max z]]` in input coordinates (origin added).
    pub bbox: [[f64; 3]; 2],
}

/// Per-threshold figures of the summary JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShellSummary {
    pub threshold: f64,
    pub volume: f64,
    pub area: f64,
    pub bodies: Vec<BodySummary>,
}

/// The summary JSON (design.md contract); extra fields may be added, none removed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub method: String,
    pub origin: [f64; 3],
    pub crs: Option<String>,
    pub unit: String,
    pub counts: serde_json::Map<String, serde_json::Value>,
    pub shells: Vec<ShellSummary>,
}

/// The outcome of [`run`].
#[derive(Debug, Clone)]
pub struct ContourResult {
    pub summary: Summary,
    /// Shells in the order of the request's thresholds; positions are local (origin
    /// subtracted), in input units.
    pub shells: Vec<Shell>,
    /// The samples as read, for exporters that draw wells.
    pub samples: SampleSet,
}

/// Why a contouring job failed.
#[derive(Debug, thiserror::Error)]
pub enum ContourError {
    #[error("no thresholds given")]
    NoThresholds,
    #[error("threshold {0} is not a finite number")]
    BadThreshold(f64),
    #[error("cancelled")]
    Cancelled,
    #[error("{0}")]
    Input(String),
}

/// Runs the whole pipeline on one request. Called on a CPU thread (never on an async
/// runtime's threads); reports stages to `progress` and stops when it is cancelled.
pub fn run(
    request: &ContourRequest,
    progress: &dyn crate::progress::Progress,
) -> Result<ContourResult, ContourError> {
    let _ = (request, progress);
    todo!("contour::run is being built on main")
}
