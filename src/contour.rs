//! The one pipeline: samples -> Delaunay -> DMT shells -> measures and summary.
//!
//! [`run`] is called by the CLI, by service workers and by tests alike.
//! Invariant: the summary's volumes and areas are those of exactly the triangles in
//! `ContourResult::shells`, which are what every exporter writes.

use glam::{DMat3, DVec3};
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
    /// `None` picks the default: the midpoint rule for 0/1 data, IbC for grades.
    pub method: Option<Method>,
    pub unknown: UnknownMode,
    /// Scale (and rotation) applied before tetrahedralizing and inverted on output.
    pub anisotropy: Option<Anisotropy>,
    /// A structured grid to contour instead of `samples` (which then only carries the
    /// unit and a fallback CRS): its cells are split into tetrahedra, no Delaunay.
    pub grid: Option<GridSource>,
    /// Bodies with a smaller volume are left out of the output (and counted in the
    /// shell's `filtered_bodies`); `None` keeps every body, folded ones included.
    pub min_volume: Option<f64>,
    /// Sweeps of the shape relaxation of IbC and CoI vertices (`dmt::relax`); 0 keeps the
    /// paper's positions. Other methods ignore it.
    pub relax: usize,
}

impl ContourRequest {
    /// A request with the defaults: method by data type, unknowns dropped, no
    /// anisotropy, no grid, every body kept.
    pub fn new(samples: SampleSet, thresholds: Vec<f64>) -> Self {
        ContourRequest {
            samples,
            thresholds,
            method: None,
            unknown: UnknownMode::Drop,
            anisotropy: None,
            grid: None,
            min_volume: None,
            relax: dmt::relax::DEFAULT_SWEEPS,
        }
    }
}

/// A grid input and the cube split that turns it into tetrahedra.
#[derive(Debug, Clone)]
pub struct GridSource {
    pub volume: crate::grid::GridVolume,
    pub split: crate::grid::CubeSplit,
}

/// An anisotropic frame: ore bodies are long and flat, so distances along the direction of
/// greatest continuity count less. Points are rotated into the frame whose first axis
/// points along `azimuth_deg` (clockwise from north) and whose second axis is tilted down by
/// `dip_deg` about the first, then scaled per axis; output is mapped back exactly.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Anisotropy {
    pub scale: DVec3,
    pub azimuth_deg: f64,
    pub dip_deg: f64,
}

impl Anisotropy {
    /// A pure per-axis scale of x, y, z (azimuth 90, dip 0: no rotation).
    pub fn scale(scale: DVec3) -> Self {
        Anisotropy {
            scale,
            azimuth_deg: 90.0,
            dip_deg: 0.0,
        }
    }

    /// The map from input (local) coordinates into the anisotropic frame.
    pub fn matrix(&self) -> DMat3 {
        let (a, d) = (self.azimuth_deg.to_radians(), self.dip_deg.to_radians());
        let x = DVec3::new(a.sin(), a.cos(), 0.0);
        let y0 = DVec3::new(-a.cos(), a.sin(), 0.0);
        let y = y0 * d.cos() - DVec3::Z * d.sin();
        let z = x.cross(y);
        DMat3::from_diagonal(self.scale) * DMat3::from_cols(x, y, z).transpose()
    }

    fn is_valid(&self) -> bool {
        self.scale.is_finite()
            && self.scale.min_element() > 0.0
            && self.azimuth_deg.is_finite()
            && self.dip_deg.is_finite()
    }
}

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
    #[error(
        "anisotropy: scale factors must be positive finite numbers and angles finite, got {0:?}"
    )]
    BadAnisotropy(Anisotropy),
    #[error("grid: {0}")]
    Grid(#[from] crate::grid::GridError),
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

/// The method used when the request names none: the distance placement for 0/1 data, IbC
/// for grades. (The paper's curvature placement, selectable, roughens surfaces on the long
/// thin tetrahedra of drilling data: see docs/dmt.md for the measurements.)
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
    inverse: Option<DMat3>,
    min_volume: Option<f64>,
    relax: usize,
    progress: &dyn Progress,
) -> Result<(Shell, Filtered), ContourError> {
    let mut shell = match method {
        Method::Dmt(placement) => dmt::extract_shell_relaxed(
            &data.mesh,
            &data.values,
            threshold,
            placement,
            Triangulation::default(),
            relax,
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
            let q = inverse.map_or(*p, |m| m * *p);
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
    if let Some(min_volume) = min_volume {
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

/// What a `min_volume` filter left out of one shell.
#[derive(Debug, Clone, Copy, Default)]
struct Filtered {
    bodies: usize,
    volume: f64,
}

fn body_summary(body: &crate::dmt::Body, origin: DVec3) -> BodySummary {
    let [lo, hi] = body.bbox;
    BodySummary {
        volume: body.volume,
        area: body.area,
        closed: body.closed,
        truncated: body.truncated,
        mt_fallback: body.mt_fallback,
        bbox: [(lo + origin).to_array(), (hi + origin).to_array()],
    }
}

fn shell_summary(shell: &Shell, filtered: Filtered, origin: DVec3) -> ShellSummary {
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
        filtered_bodies: filtered.bodies,
        filtered_volume: filtered.volume,
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
    let binary = match &request.grid {
        Some(g) => g.volume.values.iter().all(|&v| v == 0.0 || v == 1.0),
        None => is_binary(&samples.values),
    };
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
    let (forward, inverse) = match request.anisotropy {
        Some(a) if !a.is_valid() => return Err(ContourError::BadAnisotropy(a)),
        Some(a) => (a.matrix(), Some(a.matrix().inverse())),
        None => (DMat3::IDENTITY, None),
    };
    let method = request.method.unwrap_or_else(|| default_method(binary));

    progress.report("tetrahedralize", 0.0);
    let (data, unknown) = match &request.grid {
        Some(grid) => {
            let mut mesh = crate::grid::tetrahedralize(&grid.volume, grid.split)?;
            if inverse.is_some() {
                for p in &mut mesh.points {
                    *p = forward * *p;
                }
            }
            let unknown = grid.volume.blanked.iter().filter(|&&b| b).count();
            let values = grid.volume.values.clone();
            (Classified { mesh, values }, unknown)
        }
        None => {
            // The paper's rule: "don't know" samples are removed before tetrahedralizing.
            let (points, values): (Vec<DVec3>, Vec<f64>) = samples
                .points
                .iter()
                .zip(&samples.values)
                .filter_map(|(p, v)| v.map(|v| (forward * *p, v)))
                .unzip();
            let unknown = samples.values.len() - values.len();
            if values.is_empty() {
                return Err(ContourError::NoKnownSamples { unknown });
            }
            (tetrahedralize(&points, &values, progress)?, unknown)
        }
    };
    progress.report("tetrahedralize", 1.0);

    let mut shells = Vec::with_capacity(thresholds.len());
    for &threshold in &thresholds {
        if progress.is_cancelled() {
            return Err(ContourError::Cancelled);
        }
        let min_volume = request.min_volume;
        shells.push(shell(
            &data,
            threshold,
            method,
            inverse,
            min_volume,
            request.relax,
            progress,
        )?);
    }
    let (shells, filtered): (Vec<Shell>, Vec<Filtered>) = shells.into_iter().unzip();
    let (origin, crs, mut warnings) = match &request.grid {
        Some(g) => (
            g.volume.origin,
            g.volume.crs.clone().or_else(|| samples.crs.clone()),
            g.volume.warnings.clone(),
        ),
        None => (
            samples.origin,
            samples.crs.clone(),
            samples.report.warnings.clone(),
        ),
    };
    let mut shell_summaries: Vec<ShellSummary> = shells
        .iter()
        .zip(&filtered)
        .map(|(s, &f)| shell_summary(s, f, origin))
        .collect();
    // Material that only touches the threshold at samples is not a body; say where.
    for s in shells.iter().filter(|s| s.point_touches > 0) {
        warnings.push(format!(
            "threshold {}: {} places where samples are exactly at the threshold and none \
             around them above it enclose no volume and are not bodies",
            s.threshold, s.point_touches
        ));
    }
    // Folded DMT surfaces are reported, never dropped silently: the bodies rebuilt by
    // marching tetrahedra and any body still of negative volume.
    for s in &shell_summaries {
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

    // Don't-know bounds: every sample tetrahedralized, unknowns taken as "no" then "yes".
    if request.unknown == UnknownMode::Bounds && unknown > 0 && request.grid.is_none() {
        let all_points: Vec<DVec3> = samples.points.iter().map(|p| forward * *p).collect();
        let (lo, hi) = data
            .values
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
        let min_volume = request.min_volume;
        for (summary, &threshold) in shell_summaries.iter_mut().zip(&thresholds) {
            let (low, _) = shell(
                &pessimistic,
                threshold,
                method,
                inverse,
                min_volume,
                request.relax,
                progress,
            )?;
            let (high, _) = shell(
                &optimistic,
                threshold,
                method,
                inverse,
                min_volume,
                request.relax,
                progress,
            )?;
            let volume = |s: &Shell| s.bodies.iter().map(|b| b.volume).sum::<f64>();
            let bodies = |s: &Shell| s.bodies.iter().map(|b| body_summary(b, origin)).collect();
            summary.volume_range = Some(VolumeRange {
                pessimistic: volume(&low),
                optimistic: volume(&high),
                pessimistic_bodies: bodies(&low),
                optimistic_bodies: bodies(&high),
            });
        }
    }

    let mut counts = serde_json::Map::new();
    let mut count = |k: &str, v: usize| {
        counts.insert(k.to_string(), serde_json::Value::from(v));
    };
    match &request.grid {
        Some(g) => count("grid_points", g.volume.points.len()),
        None => {
            count("samples", samples.points.len());
            count("wells", samples.wells.len());
        }
    }
    count("unknown_dropped", unknown);
    count("points", data.mesh.points.len());
    count("duplicates_merged", data.mesh.duplicates_merged);
    count("tets", data.mesh.tet_count());
    let active = shells.iter().map(|s| s.counts.active_tets).max();
    count("active_tets", active.unwrap_or(0));
    count("bodies", shells.iter().map(|s| s.bodies.len()).sum());
    let summary = Summary {
        method: method.name().to_string(),
        relax_sweeps: match method {
            Method::Dmt(Placement::Ibc | Placement::Coi) => request.relax,
            _ => 0,
        },
        origin: origin.to_array(),
        crs,
        unit: samples.unit.clone(),
        unknown: request.unknown,
        binary,
        counts,
        shells: shell_summaries,
        warnings,
    };
    progress.report("done", 1.0);
    Ok(ContourResult {
        summary,
        shells,
        samples: samples.clone(),
    })
}
