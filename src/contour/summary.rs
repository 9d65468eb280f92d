//! The summary JSON of a contouring run (design.md's contract): per shell and body, the
//! measures in input units, with counts and warnings.
//!
//! Invariant: every figure here is computed from the bodies' output triangles (the f32
//! positions every exporter writes), never from an intermediate surface.

use glam::DVec3;
use serde::Serialize;

use super::{ReportSummary, UnknownMode};
use crate::dmt::{Quality, Shell, ShellCounts};
use crate::report::BodyResource;

/// Per-body figures of the summary JSON (design.md contract), in input units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodySummary {
    pub volume: f64,
    pub area: f64,
    pub closed: bool,
    pub truncated: bool,
    /// The DMT surface folded over itself (negative volume), so this body is the
    /// marching-tetrahedra surface of the same marked material.
    pub mt_fallback: bool,
    /// `[[min x, min y, min z], [max x, max y, max z]]` in input coordinates (origin added).
    pub bbox: [[f64; 3]; 2],
    /// Tonnes, mean grade, metal and the samples inside (the resource report; units in
    /// `Summary::report.units`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resource: Option<BodyResource>,
}

/// Per-threshold figures of the summary JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShellSummary {
    pub threshold: f64,
    pub volume: f64,
    pub area: f64,
    pub bodies: Vec<BodySummary>,
    /// Surface counts (DMT/MT duality holds for `surface_*`).
    pub counts: ShellCounts,
    /// Triangle quality of the written triangles.
    pub quality: Quality,
    /// Bodies left out by the request's `min_volume`, and their summed volume.
    pub filtered_bodies: usize,
    pub filtered_volume: f64,
    /// With `--unknown bounds`: the volumes with every "don't know" sample taken as
    /// outside (pessimistic) and as inside (optimistic).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub volume_range: Option<VolumeRange>,
    /// The shell's resource: the sums over its bodies (units in `Summary::report.units`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resource: Option<BodyResource>,
    /// The simplification's tolerance and what the bodies held before it (absent when the
    /// shell was not simplified).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub simplified: Option<Simplification>,
}

/// What a shell's simplification did: the largest distance allowed between a removed
/// vertex and the surface kept (input units), the largest distance a body's vertices were
/// then moved along their normals to give it back its volume, and the counts before it
/// (after it: `quality.vertices` and `quality.triangles`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Simplification {
    pub tolerance: f64,
    pub largest_offset: f64,
    pub vertices_before: usize,
    pub triangles_before: usize,
}

/// The volume range that brackets the answer when some samples are "don't know".
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VolumeRange {
    pub pessimistic: f64,
    pub optimistic: f64,
    pub pessimistic_bodies: Vec<BodySummary>,
    pub optimistic_bodies: Vec<BodySummary>,
}

/// The summary JSON (design.md contract); extra fields may be added, none removed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub method: String,
    /// `kriging` (the model between the holes) or `linear` (the samples' own
    /// interpolation, the paper's method; every grid).
    pub interpolant: String,
    /// Every parameter of the model, as fitted or given, and what its refinement did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<super::ModelSummary>,
    /// The smallest body kept (the request's, or with a model the finest infill cell's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_volume: Option<f64>,
    /// Sweeps of the shape relaxation applied (0 when none: the paper's positions, or a
    /// method other than IbC and CoI).
    pub relax_sweeps: usize,
    pub origin: [f64; 3],
    pub crs: Option<String>,
    pub unit: String,
    /// How "don't know" samples were handled.
    pub unknown: UnknownMode,
    /// `true` when every known value is 0 or 1.
    pub binary: bool,
    pub counts: serde_json::Map<String, serde_json::Value>,
    pub shells: Vec<ShellSummary>,
    /// Units, density, the grade–tonnage curve and cross-validation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<ReportSummary>,
    /// What reading the input doubted or dropped.
    pub warnings: Vec<String>,
}

pub(super) fn body_summary(body: &crate::dmt::Body, origin: DVec3) -> BodySummary {
    let [lo, hi] = body.bbox;
    BodySummary {
        volume: body.volume,
        area: body.area,
        closed: body.closed,
        truncated: body.truncated,
        mt_fallback: body.mt_fallback,
        bbox: [(lo + origin).to_array(), (hi + origin).to_array()],
        resource: None,
    }
}

pub(super) fn shell_summary(
    shell: &Shell,
    filtered_bodies: usize,
    filtered_volume: f64,
    origin: DVec3,
) -> ShellSummary {
    ShellSummary {
        threshold: shell.threshold,
        volume: shell.bodies.iter().map(|b| b.volume).sum(),
        area: shell.bodies.iter().map(|b| b.area).sum(),
        bodies: shell
            .bodies
            .iter()
            .map(|b| body_summary(b, origin))
            .collect(),
        counts: shell.counts,
        quality: shell.quality,
        filtered_bodies,
        filtered_volume,
        volume_range: None,
        resource: None,
        simplified: None,
    }
}
