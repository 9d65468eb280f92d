//! The one pipeline: a source of values -> tetrahedra -> DMT shells -> measures and summary.
//!
//! [`run`] is called by the CLI, by service workers and by tests alike.
//! Invariant: the summary's volumes and areas are those of exactly the triangles in
//! `ContourResult::shells`, which are what every exporter writes.

mod cross_validate;
mod request;
mod resource;
mod summary;

use glam::{DMat3, DVec3};

use crate::dmt::{self, DmtError, Method, Placement, Shell, Triangulation, measure};
use crate::progress::{Part, Progress, Stage};
use crate::tet::{TetError, TetMesh};
use crate::wells::{ReadReport, SampleSet};

pub use cross_validate::{CrossValidation, GradeScore, HoleScore, ThresholdScore};
pub use request::{
    Anisotropy, ContourOptions, ContourRequest, GridSource, MAX_THRESHOLDS, OptionError, Source,
    Thresholds, UnknownMode, default_method, is_binary,
};
pub use resource::{Density, DensitySummary, ReportRequest, ReportSummary, load_density_column};
pub use summary::{BodySummary, ShellSummary, Summary, VolumeRange};

/// The outcome of [`run`].
#[derive(Debug, Clone)]
pub struct ContourResult {
    pub summary: Summary,
    /// Shells in the order of the request's thresholds; positions are local (origin
    /// subtracted), in input units.
    pub shells: Vec<Shell>,
    /// The samples as read, for exporters that draw wells (none for a grid).
    pub samples: SampleSet,
}

/// Why a contouring job failed.
#[derive(Debug, thiserror::Error)]
pub enum ContourError {
    #[error("no thresholds given: pass at least one (0/1 data defaults to 0.5)")]
    NoThresholds,
    #[error("grid: {0}")]
    Grid(#[from] crate::grid::GridError),
    #[error("no samples with a known value (all {unknown} are \"don't know\")")]
    NoKnownSamples { unknown: usize },
    #[error("tetrahedralization: {0}")]
    Tet(#[from] TetError),
    #[error("contouring: {0}")]
    Dmt(#[from] DmtError),
    #[error("density: {0}")]
    Density(String),
    #[error("cross-validation: {0}")]
    CrossValidation(String),
    #[error("cancelled")]
    Cancelled,
}

/// The map into the anisotropic frame in which the tetrahedra are built, and back.
#[derive(Debug, Clone, Copy)]
struct Frame {
    forward: DMat3,
    /// `None` when the frame is the input's own (no anisotropy).
    inverse: Option<DMat3>,
}

impl Frame {
    fn new(anisotropy: Option<Anisotropy>) -> Self {
        match anisotropy {
            Some(a) => Frame {
                forward: a.matrix(),
                inverse: Some(a.matrix().inverse()),
            },
            None => Frame {
                forward: DMat3::IDENTITY,
                inverse: None,
            },
        }
    }
}

/// One tetrahedralized point set with a value per mesh vertex: the piecewise-linear field
/// that the shells contour and the resource report integrates. When built from samples,
/// `mesh.vertex_of_input[k]` is the vertex of the k-th sample with a known value (further
/// vertices, if any, carry the field between the samples).
struct Classified {
    mesh: TetMesh,
    values: Vec<f64>,
}

/// Tetrahedralizes `points` (already in the frame) and averages the values of merged
/// duplicates.
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

/// The tetrahedra and their values for the request's source, and the number of "don't
/// know" samples (or blanked grid points) left out.
fn classify(
    source: &Source,
    frame: &Frame,
    progress: &dyn Progress,
) -> Result<(Classified, usize), ContourError> {
    progress.report(Stage::Tetrahedralize, 0.0);
    let classified = match source {
        Source::Grid(grid) => {
            let mut mesh = crate::grid::tetrahedralize(&grid.volume, grid.split)?;
            if frame.inverse.is_some() {
                for p in &mut mesh.points {
                    *p = frame.forward * *p;
                }
            }
            let unknown = grid.volume.blanked.iter().filter(|&&b| b).count();
            let values = grid.volume.values.clone();
            (Classified { mesh, values }, unknown)
        }
        Source::Samples(samples) => {
            // The paper's rule: "don't know" samples are removed before tetrahedralizing.
            let (points, values): (Vec<DVec3>, Vec<f64>) = samples
                .points
                .iter()
                .zip(&samples.values)
                .filter_map(|(p, v)| v.map(|v| (frame.forward * *p, v)))
                .unzip();
            let unknown = samples.values.len() - values.len();
            if values.is_empty() {
                return Err(ContourError::NoKnownSamples { unknown });
            }
            (tetrahedralize(&points, &values, progress)?, unknown)
        }
    };
    progress.report(Stage::Tetrahedralize, 1.0);
    Ok(classified)
}

/// How each shell is extracted and what is kept of it.
#[derive(Debug, Clone, Copy)]
struct Extraction {
    method: Method,
    relax: usize,
    min_volume: Option<f64>,
    frame: Frame,
}

/// What a `min_volume` filter left out of one shell.
#[derive(Debug, Clone, Copy, Default)]
struct Filtered {
    bodies: usize,
    volume: f64,
}

/// Extracts one shell and brings it back from the anisotropic frame, with measures
/// recomputed from the output triangles.
fn shell(
    data: &Classified,
    threshold: f64,
    how: &Extraction,
    progress: &dyn Progress,
) -> Result<(Shell, Filtered), ContourError> {
    let mut shell = match how.method {
        Method::Dmt(placement) => dmt::extract_shell_relaxed(
            &data.mesh,
            &data.values,
            threshold,
            placement,
            Triangulation::default(),
            how.relax,
            progress,
        )?,
        Method::MarchingTetrahedra => {
            dmt::mt::shell(&data.mesh, &data.values, threshold, progress)?
        }
    };
    // Output positions are what the GLB stores: f32 relative to the origin. Measures are
    // taken from exactly those, so any reader of the GLB finds the summary's figures.
    for body in &mut shell.bodies {
        for p in &mut body.positions {
            let q = how.frame.inverse.map_or(*p, |m| m * *p);
            *p = q.as_vec3().as_dvec3();
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
    let mut filtered = Filtered::default();
    if let Some(min_volume) = how.min_volume {
        shell.bodies.retain(|b| {
            let keep = b.volume >= min_volume;
            if !keep {
                filtered.bodies += 1;
                filtered.volume += b.volume;
            }
            keep
        });
    }
    Ok((shell, filtered))
}

/// One shell per threshold, in order, reporting each as its part of the contour stage.
fn shells(
    data: &Classified,
    thresholds: &[f64],
    how: &Extraction,
    progress: &dyn Progress,
) -> Result<Vec<(Shell, Filtered)>, ContourError> {
    let mut out = Vec::with_capacity(thresholds.len());
    for (index, &threshold) in thresholds.iter().enumerate() {
        if progress.is_cancelled() {
            return Err(ContourError::Cancelled);
        }
        let part = Part {
            inner: progress,
            index,
            count: thresholds.len(),
        };
        out.push(shell(data, threshold, how, &part)?);
    }
    Ok(out)
}

/// What the summary says about the shells besides their measures: places that touch a
/// threshold without enclosing volume, bodies rebuilt by marching tetrahedra, folded ones.
fn shell_warnings(shells: &[Shell], summaries: &[ShellSummary]) -> Vec<String> {
    let mut warnings = Vec::new();
    for s in shells.iter().filter(|s| s.point_touches > 0) {
        warnings.push(format!(
            "threshold {}: {} places where samples are exactly at the threshold and none \
             around them above it enclose no volume and are not bodies",
            s.threshold, s.point_touches
        ));
    }
    // Folded DMT surfaces are reported, never dropped silently: the bodies rebuilt by
    // marching tetrahedra and any body still of negative volume.
    for s in summaries {
        let listed = |keep: &dyn Fn(&BodySummary) -> bool| -> Vec<usize> {
            s.bodies
                .iter()
                .enumerate()
                .filter(|(_, b)| keep(b))
                .map(|(i, _)| i)
                .collect()
        };
        let rebuilt = listed(&|b| b.mt_fallback);
        if !rebuilt.is_empty() {
            warnings.push(format!(
                "threshold {}: the DMT surface of {} of {} bodies folded over itself (long, \
                 flat tetrahedra between holes); bodies {:?} are the marching-tetrahedra \
                 surface of the same material (mt_fallback)",
                s.threshold,
                rebuilt.len(),
                s.bodies.len(),
                rebuilt
            ));
        }
        let folded = listed(&|b| b.volume < 0.0);
        if !folded.is_empty() {
            warnings.push(format!(
                "threshold {}: {} of {} bodies have a negative volume (their surface folds over \
                 itself; bodies {:?}); compare with --method mt",
                s.threshold,
                folded.len(),
                s.bodies.len(),
                folded
            ));
        }
    }
    warnings
}

/// Don't-know bounds: every sample tetrahedralized, unknowns taken as "no" then "yes"; each
/// shell summary gets the two volumes and their bodies.
fn add_unknown_bounds(
    samples: &SampleSet,
    known: &Classified,
    thresholds: &[f64],
    how: &Extraction,
    summaries: &mut [ShellSummary],
    progress: &dyn Progress,
) -> Result<(), ContourError> {
    progress.report(Stage::Bounds, 0.0);
    let all_points: Vec<DVec3> = samples
        .points
        .iter()
        .map(|p| how.frame.forward * *p)
        .collect();
    let (lo, hi) = known
        .values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let max_threshold = thresholds.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min_threshold = thresholds.iter().copied().fold(f64::INFINITY, f64::min);
    let no = lo.min(min_threshold) - 1.0;
    let yes = hi.max(max_threshold) + 1.0;
    let with =
        |fill: f64| -> Vec<f64> { samples.values.iter().map(|v| v.unwrap_or(fill)).collect() };
    let cancellable = Cancellable(progress);
    let pessimistic = tetrahedralize(&all_points, &with(no), &cancellable)?;
    let optimistic = tetrahedralize(&all_points, &with(yes), &cancellable)?;
    let origin = samples.origin;
    let count = summaries.len();
    for (index, (summary, &threshold)) in summaries.iter_mut().zip(thresholds).enumerate() {
        if progress.is_cancelled() {
            return Err(ContourError::Cancelled);
        }
        let (low, _) = shell(&pessimistic, threshold, how, &cancellable)?;
        let (high, _) = shell(&optimistic, threshold, how, &cancellable)?;
        let volume = |s: &Shell| s.bodies.iter().map(|b| b.volume).sum::<f64>();
        let bodies = |s: &Shell| {
            s.bodies
                .iter()
                .map(|b| summary::body_summary(b, origin))
                .collect()
        };
        summary.volume_range = Some(VolumeRange {
            pessimistic: volume(&low),
            optimistic: volume(&high),
            pessimistic_bodies: bodies(&low),
            optimistic_bodies: bodies(&high),
        });
        progress.report(Stage::Bounds, (index + 1) as f64 / count as f64);
    }
    Ok(())
}

/// A progress that passes cancellation through but no reports (sub-steps whose own stages
/// would move the percent backwards).
struct Cancellable<'a>(&'a dyn Progress);

impl Progress for Cancellable<'_> {
    fn report(&self, _stage: Stage, _fraction: f64) {}

    fn is_cancelled(&self) -> bool {
        self.0.is_cancelled()
    }
}

/// The samples as the result carries them: the request's own, or for a grid an empty set
/// with the grid's origin, CRS and unit.
fn result_samples(source: &Source) -> SampleSet {
    match source {
        Source::Samples(samples) => samples.clone(),
        Source::Grid(grid) => SampleSet {
            origin: grid.volume.origin,
            crs: grid.volume.crs.clone().or_else(|| grid.crs.clone()),
            unit: grid
                .volume
                .unit
                .clone()
                .unwrap_or_else(|| grid.unit.clone()),
            wells: vec![],
            points: vec![],
            values: vec![],
            well_of: vec![],
            report: ReadReport::default(),
        },
    }
}

/// Runs the whole pipeline on one request. Called on a CPU thread (never on an async
/// runtime's threads); reports stages to `progress` and stops when it is cancelled.
pub fn run(
    request: &ContourRequest,
    progress: &dyn Progress,
) -> Result<ContourResult, ContourError> {
    let binary = request.source.is_binary();
    let thresholds = request
        .thresholds
        .or_default(binary)
        .ok_or(ContourError::NoThresholds)?;
    let method = request.resolved_method(binary);
    let how = Extraction {
        method,
        relax: request.relax,
        min_volume: request.min_volume,
        frame: Frame::new(request.anisotropy),
    };
    let samples = result_samples(&request.source);
    let origin = samples.origin;

    let (data, unknown) = classify(&request.source, &how.frame, progress)?;
    let (shells, filtered): (Vec<Shell>, Vec<Filtered>) =
        shells(&data, &thresholds, &how, progress)?
            .into_iter()
            .unzip();

    let mut shell_summaries: Vec<ShellSummary> = shells
        .iter()
        .zip(&filtered)
        .map(|(s, f)| summary::shell_summary(s, f.bodies, f.volume, origin))
        .collect();
    let mut warnings = match &request.source {
        Source::Grid(g) => g.volume.warnings.clone(),
        Source::Samples(s) => s.report.warnings.clone(),
    };
    warnings.extend(shell_warnings(&shells, &shell_summaries));
    if let Source::Samples(s) = &request.source
        && request.unknown == UnknownMode::Bounds
        && unknown > 0
    {
        add_unknown_bounds(s, &data, &thresholds, &how, &mut shell_summaries, progress)?;
    }

    let mut counts = serde_json::Map::new();
    let mut count = |k: &str, v: usize| {
        counts.insert(k.to_string(), serde_json::Value::from(v));
    };
    match &request.source {
        Source::Grid(g) => count("grid_points", g.volume.points.len()),
        Source::Samples(s) => {
            count("samples", s.points.len());
            count("wells", s.wells.len());
        }
    }
    count("unknown_dropped", unknown);
    count("points", data.mesh.points.len());
    count("duplicates_merged", data.mesh.duplicates_merged);
    count("tets", data.mesh.tet_count());
    let active = shells.iter().map(|s| s.counts.active_tets).max();
    count("active_tets", active.unwrap_or(0));
    count("bodies", shells.iter().map(|s| s.bodies.len()).sum());
    let report_input = resource::ReportInput {
        data: &data,
        source: &request.source,
        request: &request.report,
        frame: &how.frame,
        unit: &samples.unit,
        binary,
    };
    let mut report = resource::report(&report_input, &shells, &mut shell_summaries)?;
    if let Some(folds) = request.report.cross_validate {
        report.cross_validation = Some(cross_validate::cross_validate(
            &request.source,
            folds,
            &thresholds,
            &how.frame,
            progress,
        )?);
    }
    let summary = Summary {
        method: method.name().to_string(),
        relax_sweeps: match method {
            Method::Dmt(Placement::Ibc | Placement::Coi) => request.relax,
            _ => 0,
        },
        origin: origin.to_array(),
        crs: samples.crs.clone(),
        unit: samples.unit.clone(),
        unknown: request.unknown,
        binary,
        counts,
        shells: shell_summaries,
        report: Some(report),
        warnings,
    };
    Ok(ContourResult {
        summary,
        shells,
        samples,
    })
}
