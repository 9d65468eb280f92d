//! The one pipeline: a source of values -> tetrahedra -> DMT shells -> measures and summary.
//!
//! [`run`] is called by the CLI, by service workers and by tests alike.
//! Invariant: the summary's volumes and areas are those of exactly the triangles in
//! `ContourResult::shells`, which are what every exporter writes.

mod cross_validate;
mod model;
mod request;
mod resource;
mod summary;

use glam::{DMat3, DVec3};

use crate::dmt::{self, DmtError, Method, Placement, Shell, Triangulation, measure};
use crate::progress::{Part, Progress, Stage};
use crate::tet::{TetError, TetMesh};
use crate::wells::{ReadReport, SampleSet};

pub use cross_validate::{CrossValidation, GradeScore, HoleScore, ThresholdScore};
pub use model::ModelSummary;
pub use request::{
    Anisotropy, ContourOptions, ContourRequest, GridSource, Interpolant, MAX_THRESHOLDS,
    OptionError, Simplify, Source, Thresholds, UnknownMode, default_method, is_binary,
};
pub use resource::{Density, DensitySummary, ReportRequest, ReportSummary, load_density_column};
pub use summary::{BodySummary, ShellSummary, Simplification, Summary, VolumeRange};

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
    #[error("model between the holes: {0}")]
    Field(String),
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
pub(crate) struct Classified {
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

/// The tetrahedra of a grid and their values, and the number of blanked points.
fn classify_grid(
    grid: &GridSource,
    frame: &Frame,
    progress: &dyn Progress,
) -> Result<Prepared, ContourError> {
    progress.report(Stage::Tetrahedralize, 0.0);
    let mut mesh = crate::grid::tetrahedralize(&grid.volume, grid.split)?;
    if frame.inverse.is_some() {
        for p in &mut mesh.points {
            *p = frame.forward * *p;
        }
    }
    let unknown = grid.volume.blanked.iter().filter(|&&b| b).count();
    let values = grid.volume.values.clone();
    progress.report(Stage::Tetrahedralize, 1.0);
    Ok(Prepared {
        data: Classified { mesh, values },
        levels: Vec::new(),
        model: None,
        unknown,
    })
}

/// How each shell is extracted and what is kept of it.
#[derive(Debug, Clone, Copy)]
struct Extraction {
    method: Method,
    relax: usize,
    min_volume: Option<f64>,
    /// The floor is the model's default (one finest infill cell), not the request's: it
    /// never takes more than [`SPECK_SHARE`] of the shell's largest body.
    default_floor: bool,
    frame: Frame,
    /// The simplification's tolerance (input units), `None` for none.
    simplify: Option<f64>,
}

/// A default floor is at most this share of the shell's largest body: on sparse drilling
/// (kilometre ranges) one infill cell can outweigh every body there is.
const SPECK_SHARE: f64 = 0.01;

/// What a `min_volume` filter left out of one shell, and what the simplification took.
#[derive(Debug, Clone, Copy, Default)]
struct Filtered {
    bodies: usize,
    volume: f64,
    simplified: Option<Simplification>,
}

/// Extracts one shell, brings it back from the anisotropic frame, flags the bodies at the
/// model's extent (`reach`), leaves out those under the volume floor, simplifies the rest
/// and takes their measures and quality from the output triangles.
fn shell(
    data: &Classified,
    threshold: f64,
    how: &Extraction,
    reach: Option<&crate::field::Field>,
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
    }
    if let Some(field) = reach {
        model::flag_truncated(&mut shell, field);
    }
    measure_bodies(&mut shell);
    let mut filtered = Filtered::default();
    if let Some(mut min_volume) = how.min_volume {
        if how.default_floor {
            let largest = shell.bodies.iter().map(|b| b.volume).fold(0.0, f64::max);
            min_volume = min_volume.min(SPECK_SHARE * largest);
        }
        shell.bodies.retain(|b| {
            let keep = b.volume >= min_volume;
            if !keep {
                filtered.bodies += 1;
                filtered.volume += b.volume;
            }
            keep
        });
    }
    // Simplified after the filter: which bodies are kept is decided on the surfaces as
    // extracted, and no time goes into bodies left out.
    if let Some(tolerance) = how.simplify {
        filtered.simplified = Some(simplify_bodies(&mut shell, tolerance, progress)?);
        measure_bodies(&mut shell);
    }
    shell.quality = measure::quality(
        shell
            .bodies
            .iter()
            .map(|b| (b.positions.as_slice(), b.triangles.as_slice())),
    );
    Ok((shell, filtered))
}

/// Takes every body's volume, area and bounds from its triangles.
fn measure_bodies(shell: &mut Shell) {
    for body in &mut shell.bodies {
        body.volume = measure::volume(&body.positions, &body.triangles);
        body.area = measure::area(&body.positions, &body.triangles);
        body.bbox = measure::bbox(&body.positions);
    }
}

/// Simplifies every body of `shell` within `tolerance` (in parallel), keeping each closed,
/// oriented and of its volume (`dmt::simplify`); returns what was done.
fn simplify_bodies(
    shell: &mut Shell,
    tolerance: f64,
    progress: &dyn Progress,
) -> Result<Simplification, ContourError> {
    use rayon::prelude::*;
    let mut done = Simplification {
        tolerance,
        largest_offset: 0.0,
        vertices_before: shell.bodies.iter().map(|b| b.positions.len()).sum(),
        triangles_before: shell.bodies.iter().map(|b| b.triangles.len()).sum(),
    };
    let limits = dmt::simplify::Limits::new(tolerance);
    let cancelled = || progress.is_cancelled();
    let offsets: Option<Vec<f64>> = shell
        .bodies
        .par_iter_mut()
        .map(|body| {
            let out =
                dmt::simplify::simplify(&body.positions, &body.triangles, &limits, &cancelled)?;
            body.positions = out.positions;
            body.triangles = out.triangles;
            Some(out.offset)
        })
        .collect();
    let offsets = offsets.ok_or(ContourError::Cancelled)?;
    done.largest_offset = offsets.iter().map(|o| o.abs()).fold(0.0, f64::max);
    Ok(done)
}

/// One shell per threshold, in order, reporting each as its part of the contour stage.
fn prepared_shells(
    prepared: &Prepared,
    thresholds: &[f64],
    how: &Extraction,
    progress: &dyn Progress,
) -> Result<(Vec<Shell>, Vec<Filtered>), ContourError> {
    let mut shells = Vec::with_capacity(thresholds.len());
    let mut filtered = Vec::with_capacity(thresholds.len());
    for index in 0..thresholds.len() {
        if progress.is_cancelled() {
            return Err(ContourError::Cancelled);
        }
        let part = Part {
            inner: progress,
            index,
            count: thresholds.len(),
        };
        let (s, f) = prepared.shell(index, thresholds, how, &part)?;
        shells.push(s);
        filtered.push(f);
    }
    Ok((shells, filtered))
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

/// Don't-know bounds: unknowns taken as "no" then "yes" (every sample tetrahedralized, or
/// the model refitted on them); each shell summary gets the two volumes and their bodies.
fn add_unknown_bounds(
    samples: &SampleSet,
    request: &ContourRequest,
    thresholds: &[f64],
    how: &Extraction,
    summaries: &mut [ShellSummary],
    progress: &dyn Progress,
) -> Result<(), ContourError> {
    progress.report(Stage::Bounds, 0.0);
    let (lo, hi) = samples
        .values
        .iter()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let max_threshold = thresholds.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min_threshold = thresholds.iter().copied().fold(f64::INFINITY, f64::min);
    // 0/1 data keeps its classes (a model of an indicator stays one); grades go past
    // every threshold.
    let binary = is_binary(&samples.values);
    let (no, yes) = if binary {
        (0.0, 1.0)
    } else {
        (lo.min(min_threshold) - 1.0, hi.max(max_threshold) + 1.0)
    };
    let cancellable = Cancellable(progress);
    let low = prepare(samples, Some(no), request, thresholds, how, &cancellable)?;
    let high = prepare(samples, Some(yes), request, thresholds, how, &cancellable)?;
    let origin = samples.origin;
    let count = summaries.len();
    for (index, summary) in summaries.iter_mut().enumerate() {
        if progress.is_cancelled() {
            return Err(ContourError::Cancelled);
        }
        let (low, _) = low.shell(index, thresholds, how, &cancellable)?;
        let (high, _) = high.shell(index, thresholds, how, &cancellable)?;
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

/// The field every shell contours, the levels it is contoured at (the thresholds, or
/// their transforms under a model) and the model, if there is one.
struct Prepared {
    data: Classified,
    levels: Vec<f64>,
    model: Option<(crate::field::Field, ModelSummary)>,
    unknown: usize,
}

impl Prepared {
    /// The shell of threshold `index`, at the threshold given.
    fn shell(
        &self,
        index: usize,
        thresholds: &[f64],
        how: &Extraction,
        progress: &dyn Progress,
    ) -> Result<(Shell, Filtered), ContourError> {
        let reach = self.model.as_ref().map(|(field, _)| field);
        let (mut shell, filtered) = shell(&self.data, self.levels[index], how, reach, progress)?;
        shell.threshold = thresholds[index];
        Ok((shell, filtered))
    }
}

/// Puts a model's field values back on the scale of the grades (the inverse of its
/// transform; sentinels included), for the resource report and cross-validation. The
/// transform is monotone, so every vertex stays on the same side of every threshold.
fn raw_scale(prepared: &mut Prepared) {
    let Prepared { data, model, .. } = prepared;
    if let Some((field, _)) = model
        && !matches!(field.transform, crate::field::Transform::None)
    {
        for v in &mut data.values {
            *v = field.transform.invert(*v);
        }
    }
}

/// Samples (with unknowns as `fill`, or dropped) under the request's interpolant: the
/// linear mesh of the samples, or the model's.
fn prepare(
    samples: &SampleSet,
    fill: Option<f64>,
    request: &ContourRequest,
    thresholds: &[f64],
    how: &Extraction,
    progress: &dyn Progress,
) -> Result<Prepared, ContourError> {
    let unknown = if fill.is_some() {
        0
    } else {
        samples.values.iter().filter(|v| v.is_none()).count()
    };
    match &request.interpolant {
        Interpolant::Kriging(options) => {
            let m = model::model(samples, fill, thresholds, options, progress)?;
            Ok(Prepared {
                data: m.data,
                levels: m.levels,
                model: Some((m.field, m.summary)),
                unknown,
            })
        }
        Interpolant::Linear => {
            let (points, values): (Vec<DVec3>, Vec<f64>) = samples
                .points
                .iter()
                .zip(&samples.values)
                .filter_map(|(p, v)| v.or(fill).map(|v| (how.frame.forward * *p, v)))
                .unzip();
            if values.is_empty() {
                return Err(ContourError::NoKnownSamples { unknown });
            }
            progress.report(Stage::Tetrahedralize, 0.0);
            let data = tetrahedralize(&points, &values, progress)?;
            progress.report(Stage::Tetrahedralize, 1.0);
            Ok(Prepared {
                data,
                levels: thresholds.to_vec(),
                model: None,
                unknown,
            })
        }
    }
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
    let mut how = Extraction {
        method,
        relax: request.relax,
        min_volume: request.min_volume,
        default_floor: false,
        frame: Frame::new(request.anisotropy),
        simplify: match request.simplify {
            Simplify::Tolerance(t) => Some(t),
            Simplify::Default | Simplify::Off => None,
        },
    };
    let samples = result_samples(&request.source);
    let origin = samples.origin;

    let mut prepared = match &request.source {
        Source::Grid(grid) => classify_grid(grid, &how.frame, progress)?,
        Source::Samples(s) => prepare(s, None, request, &thresholds, &how, progress)?,
    };
    if prepared.levels.is_empty() {
        prepared.levels = thresholds.clone();
    }
    // With a model, specks smaller than one finest infill cell are not resolved: they are
    // left out unless the request sets its own floor.
    if how.min_volume.is_none()
        && let Some((_, m)) = &prepared.model
    {
        how.min_volume = Some(model::finest_cell_volume(&m.infill));
        how.default_floor = true;
    }
    // A model's surfaces carry the finest infill step everywhere: by default they are
    // simplified within a share of it.
    if request.simplify == Simplify::Default
        && let Some((_, m)) = &prepared.model
    {
        how.simplify = Some(model::default_simplify_tolerance(&m.infill));
    }
    let (shells, filtered) = prepared_shells(&prepared, &thresholds, &how, progress)?;
    // The report integrates grades: back from the model's transform, once the shells are cut.
    raw_scale(&mut prepared);
    let unknown = prepared.unknown;
    let data = &prepared.data;

    let mut shell_summaries: Vec<ShellSummary> = shells
        .iter()
        .zip(&filtered)
        .map(|(s, f)| {
            let mut summary = summary::shell_summary(s, f.bodies, f.volume, origin);
            summary.simplified = f.simplified;
            summary
        })
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
        add_unknown_bounds(
            s,
            request,
            &thresholds,
            &how,
            &mut shell_summaries,
            progress,
        )?;
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
        data,
        source: &request.source,
        request: &request.report,
        frame: &how.frame,
        unit: &samples.unit,
        binary,
    };
    let mut report = resource::report(&report_input, &shells, &mut shell_summaries)?;
    if let Some(folds) = request.report.cross_validate {
        // Each fold is fitted as the run was: the same interpolant, the same options.
        let fit = |training: &SampleSet, p: &dyn Progress| -> Result<Classified, ContourError> {
            let mut fitted = prepare(training, None, request, &thresholds, &how, p)?;
            raw_scale(&mut fitted);
            Ok(fitted.data)
        };
        report.cross_validation = Some(cross_validate::cross_validate(
            &request.source,
            folds,
            &thresholds,
            &how.frame,
            &fit,
            progress,
        )?);
    }
    let summary = Summary {
        method: method.name().to_string(),
        interpolant: request.interpolant.name().to_string(),
        model: prepared.model.as_ref().map(|(_, m)| m.clone()),
        min_volume: how.min_volume,
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
