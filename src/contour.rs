//! The one pipeline: samples -> Delaunay -> DMT shells -> measures and summary.
//!
//! [`run`] is called by the CLI, by service workers and by tests alike.
//! Invariant: the summary's volumes and areas are those of exactly the triangles in
//! `ContourResult::shells`, which are what every exporter writes.

use glam::DVec3;
use serde::Serialize;

use crate::dmt::{
    self, DmtError, Method, Placement, Quality, Shell, ShellCounts, Triangulation, measure,
};
use crate::progress::Progress;
use crate::tet::{TetError, TetMesh};
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
    /// Surface counts (DMT/MT duality holds for `surface_*`).
    pub counts: ShellCounts,
    /// Triangle quality of the written triangles.
    pub quality: Quality,
    /// With `--unknown bounds`: the volumes with every "don't know" sample taken as
    /// outside (pessimistic) and as inside (optimistic).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub volume_range: Option<VolumeRange>,
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
    pub origin: [f64; 3],
    pub crs: Option<String>,
    pub unit: String,
    /// How "don't know" samples were handled.
    pub unknown: UnknownMode,
    /// `true` when every known value is 0 or 1.
    pub binary: bool,
    pub counts: serde_json::Map<String, serde_json::Value>,
    pub shells: Vec<ShellSummary>,
    /// What reading the input doubted or dropped.
    pub warnings: Vec<String>,
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
    #[error("no thresholds given: pass at least one (0/1 data defaults to 0.5)")]
    NoThresholds,
    #[error("threshold {0} is not a finite number")]
    BadThreshold(f64),
    #[error("anisotropy: each scale factor must be a positive finite number, got {0}")]
    BadAnisotropy(DVec3),
    #[error("no samples with a known value (all {unknown} are \"don't know\")")]
    NoKnownSamples { unknown: usize },
    #[error("tetrahedralization: {0}")]
    Tet(#[from] TetError),
    #[error("contouring: {0}")]
    Dmt(#[from] DmtError),
    #[error("cancelled")]
    Cancelled,
}

/// `true` when every known value is 0 or 1 (binary "copper above trace" data).
pub fn is_binary(values: &[Option<f64>]) -> bool {
    let mut any = false;
    for v in values.iter().flatten() {
        any = true;
        if *v != 0.0 && *v != 1.0 {
            return false;
        }
    }
    any
}

/// The method used when the request names none: curvature for 0/1 data, IbC for grades.
pub fn default_method(binary: bool) -> Method {
    if binary {
        Method::Dmt(Placement::Curvature {
            lattice: crate::dmt::DEFAULT_CURVATURE_LATTICE,
        })
    } else {
        Method::Dmt(Placement::Ibc)
    }
}

/// One tetrahedralized point set with a value per mesh vertex.
struct Classified {
    mesh: TetMesh,
    values: Vec<f64>,
}

/// Tetrahedralizes `points` (already scaled) and averages the values of merged duplicates.
fn tetrahedralize(
    points: &[DVec3],
    values: &[f64],
    progress: &dyn Progress,
) -> Result<Classified, ContourError> {
    let mesh = crate::tet::delaunay(points, progress)?;
    let mut sum = vec![0.0; mesh.points.len()];
    let mut count = vec![0u32; mesh.points.len()];
    for (i, &v) in mesh.vertex_of_input.iter().enumerate() {
        sum[v as usize] += values[i];
        count[v as usize] += 1;
    }
    let values = sum
        .iter()
        .zip(&count)
        .map(|(s, &c)| s / f64::from(c.max(1)))
        .collect();
    Ok(Classified { mesh, values })
}

/// Extracts one shell and brings it back from the anisotropic frame, with measures
/// recomputed from the output triangles.
fn shell(
    data: &Classified,
    threshold: f64,
    method: Method,
    scale: DVec3,
    min_volume: f64,
    progress: &dyn Progress,
) -> Result<Shell, ContourError> {
    let mut shell = match method {
        Method::Dmt(placement) => dmt::extract_shell(
            &data.mesh,
            &data.values,
            threshold,
            placement,
            Triangulation::default(),
            progress,
        )?,
        Method::MarchingTetrahedra => {
            dmt::marching_tetrahedra_shell(&data.mesh, &data.values, threshold, progress)?
        }
    };
    if scale != DVec3::ONE {
        for body in &mut shell.bodies {
            for p in &mut body.positions {
                *p /= scale;
            }
            body.volume = measure::volume(&body.positions, &body.triangles);
            body.area = measure::area(&body.positions, &body.triangles);
            body.bbox = measure::bbox(&body.positions);
        }
        shell.quality = measure::quality(
            shell
                .bodies
                .iter()
                .map(|b| (b.positions.as_slice(), b.triangles.as_slice())),
        );
    }
    shell.bodies.retain(|b| b.volume >= min_volume);
    Ok(shell)
}

fn body_summary(body: &crate::dmt::Body, origin: DVec3) -> BodySummary {
    let [lo, hi] = body.bbox;
    BodySummary {
        volume: body.volume,
        area: body.area,
        closed: body.closed,
        truncated: body.truncated,
        bbox: [(lo + origin).to_array(), (hi + origin).to_array()],
    }
}

fn shell_summary(shell: &Shell, origin: DVec3) -> ShellSummary {
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
        volume_range: None,
    }
}

/// Runs the whole pipeline on one request. Called on a CPU thread (never on an async
/// runtime's threads); reports stages to `progress` and stops when it is cancelled.
pub fn run(
    request: &ContourRequest,
    progress: &dyn Progress,
) -> Result<ContourResult, ContourError> {
    let samples = &request.samples;
    let binary = is_binary(&samples.values);
    let thresholds: Vec<f64> = if request.thresholds.is_empty() && binary {
        vec![0.5]
    } else {
        request.thresholds.clone()
    };
    if thresholds.is_empty() {
        return Err(ContourError::NoThresholds);
    }
    if let Some(&t) = thresholds.iter().find(|t| !t.is_finite()) {
        return Err(ContourError::BadThreshold(t));
    }
    let scale = request.anisotropy.unwrap_or(DVec3::ONE);
    if !(scale.is_finite() && scale.min_element() > 0.0) {
        return Err(ContourError::BadAnisotropy(scale));
    }
    let method = request.method.unwrap_or_else(|| default_method(binary));

    // The paper's rule: "don't know" samples are removed before tetrahedralizing.
    let (points, values): (Vec<DVec3>, Vec<f64>) = samples
        .points
        .iter()
        .zip(&samples.values)
        .filter_map(|(p, v)| v.map(|v| (*p * scale, v)))
        .unzip();
    let unknown = samples.values.len() - values.len();
    if values.is_empty() {
        return Err(ContourError::NoKnownSamples { unknown });
    }
    progress.report("tetrahedralize", 0.0);
    let data = tetrahedralize(&points, &values, progress)?;
    progress.report("tetrahedralize", 1.0);

    let mut shells = Vec::with_capacity(thresholds.len());
    for &threshold in &thresholds {
        if progress.is_cancelled() {
            return Err(ContourError::Cancelled);
        }
        shells.push(shell(
            &data,
            threshold,
            method,
            scale,
            request.min_volume,
            progress,
        )?);
    }
    let origin = samples.origin;
    let mut shell_summaries: Vec<ShellSummary> =
        shells.iter().map(|s| shell_summary(s, origin)).collect();

    // Don't-know bounds: every sample tetrahedralized, unknowns taken as "no" then "yes".
    if request.unknown == UnknownMode::Bounds && unknown > 0 {
        let all_points: Vec<DVec3> = samples.points.iter().map(|p| *p * scale).collect();
        let (lo, hi) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
        let max_threshold = thresholds.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let min_threshold = thresholds.iter().cloned().fold(f64::INFINITY, f64::min);
        let no = lo.min(min_threshold) - 1.0;
        let yes = hi.max(max_threshold) + 1.0;
        let with =
            |fill: f64| -> Vec<f64> { samples.values.iter().map(|v| v.unwrap_or(fill)).collect() };
        let pessimistic = tetrahedralize(&all_points, &with(no), progress)?;
        let optimistic = tetrahedralize(&all_points, &with(yes), progress)?;
        for (summary, &threshold) in shell_summaries.iter_mut().zip(&thresholds) {
            let low = shell(
                &pessimistic,
                threshold,
                method,
                scale,
                request.min_volume,
                progress,
            )?;
            let high = shell(
                &optimistic,
                threshold,
                method,
                scale,
                request.min_volume,
                progress,
            )?;
            let volume = |s: &Shell| s.bodies.iter().map(|b| b.volume).sum::<f64>();
            summary.volume_range = Some(VolumeRange {
                pessimistic: volume(&low),
                optimistic: volume(&high),
                pessimistic_bodies: low.bodies.iter().map(|b| body_summary(b, origin)).collect(),
                optimistic_bodies: high
                    .bodies
                    .iter()
                    .map(|b| body_summary(b, origin))
                    .collect(),
            });
        }
    }

    let mut counts = serde_json::Map::new();
    let mut count = |k: &str, v: usize| {
        counts.insert(k.to_string(), serde_json::Value::from(v));
    };
    count("samples", samples.points.len());
    count("wells", samples.wells.len());
    count("unknown_dropped", unknown);
    count("points", data.mesh.points.len());
    count("duplicates_merged", data.mesh.duplicates_merged);
    count("tets", data.mesh.tets.len());
    count(
        "active_tets",
        shells
            .iter()
            .map(|s| s.counts.active_tets)
            .max()
            .unwrap_or(0),
    );
    count("bodies", shells.iter().map(|s| s.bodies.len()).sum());
    let summary = Summary {
        method: method.name().to_string(),
        origin: origin.to_array(),
        crs: samples.crs.clone(),
        unit: samples.unit.clone(),
        unknown: request.unknown,
        binary,
        counts,
        shells: shell_summaries,
        warnings: samples.report.warnings.clone(),
    };
    progress.report("done", 1.0);
    Ok(ContourResult {
        summary,
        shells,
        samples: samples.clone(),
    })
}
