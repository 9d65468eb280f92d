//! The model between the holes as the pipeline uses it: fit the field, evaluate it at the
//! samples and at infill points, tetrahedralize them together. DMT then runs unchanged on
//! the field's values at the mesh's vertices.
//!
//! Invariant: the levels contoured are the thresholds through the model's transform
//! (monotone), and a vertex is a sentinel exactly when it is an infill point beyond the
//! model's reach; every body that comes within a sentinel's tetrahedra is flagged truncated.

use serde::Serialize;

use super::{Classified, ContourError};
use crate::dmt::Shell;
use crate::field::{self, Field, FieldParams, ModelOptions, infill::InfillStats};
use crate::progress::{Progress, Stage};
use crate::wells::SampleSet;

/// What the summary records of the model: every parameter (so the run can be reproduced)
/// and what the refinement did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelSummary {
    #[serde(flatten)]
    pub params: FieldParams,
    /// The thresholds through the transform: the levels of the field contoured.
    pub levels: Vec<f64>,
    /// The value sentinels take (just below every level and every modelled sample value).
    pub outside_value: f64,
    /// Range units beyond which no surface lies (infill nodes within it are "inside").
    pub reach: f64,
    pub infill: InfillStats,
    pub kriging_blocks: usize,
    pub samples: usize,
    pub infill_points: usize,
}

/// A fitted, refined, tetrahedralized model.
pub(super) struct Modelled {
    pub data: Classified,
    pub field: Field,
    pub levels: Vec<f64>,
    pub summary: ModelSummary,
}

/// The known samples as the field takes them.
pub(super) fn known_samples(samples: &SampleSet, fill: Option<f64>) -> field::Samples {
    let mut out = field::Samples::default();
    for ((p, v), &h) in samples
        .points
        .iter()
        .zip(&samples.values)
        .zip(&samples.well_of)
    {
        if let Some(v) = v.or(fill) {
            out.points.push(*p);
            out.values.push(v);
            out.holes.push(h);
        }
    }
    out
}

/// Fits the model on `samples` (unknowns taken as `fill`, or left out when `None`) and
/// builds the mesh DMT contours at `thresholds`.
pub(super) fn model(
    samples: &SampleSet,
    fill: Option<f64>,
    thresholds: &[f64],
    options: &ModelOptions,
    progress: &dyn Progress,
) -> Result<Modelled, ContourError> {
    let known = known_samples(samples, fill);
    if known.values.is_empty() {
        return Err(ContourError::NoKnownSamples {
            unknown: samples.values.len(),
        });
    }
    progress.report(Stage::Fit, 0.0);
    let cancelled = || progress.is_cancelled();
    let field = Field::fit_cancellable(&known, thresholds, options, &cancelled)?;
    let at_samples = field
        .evaluate(&known.points, &cancelled)
        .ok_or(ContourError::Cancelled)?;
    progress.report(Stage::Fit, 1.0);
    let levels: Vec<f64> = thresholds
        .iter()
        .map(|&t| field.transform.apply(t))
        .collect();
    let outside = outside_value(&at_samples, &levels);
    let refinements = field.levels_for(options.resolution);
    progress.report(Stage::Refine, 0.0);
    let report = |f: f64| progress.report(Stage::Refine, f);
    let infill = field::infill::infill(&field, &levels, outside, refinements, &cancelled, &report)
        .ok_or(ContourError::Cancelled)?;
    let mut points = known.points.clone();
    points.extend_from_slice(&infill.points);
    let mut values = at_samples;
    values.extend_from_slice(&infill.values);
    progress.report(Stage::Tetrahedralize, 0.0);
    let data = super::tetrahedralize(&points, &values, progress)?;
    progress.report(Stage::Tetrahedralize, 1.0);
    let summary = ModelSummary {
        params: field.params.clone(),
        levels: levels.clone(),
        outside_value: outside,
        reach: field::infill::INSIDE_REACH,
        infill: infill.stats,
        kriging_blocks: field.blocks_solved(),
        samples: known.points.len(),
        infill_points: infill.points.len(),
    };
    Ok(Modelled {
        data,
        field,
        levels,
        summary,
    })
}

/// What sentinels take: just below every level and every modelled value at a sample — the
/// lowest value the data shows, so the field beyond the model's reach reads as background
/// in the resource report and in cross-validation, not as an invented negative grade.
fn outside_value(values: &[f64], levels: &[f64]) -> f64 {
    let (lo, hi) = values
        .iter()
        .chain(levels)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    lo - 1e-3 * (hi - lo).max(1e-9)
}

/// Flags the bodies that reach the model's extent as truncated.
pub(super) fn flag_truncated(shell: &mut Shell, field: &Field) {
    use rayon::prelude::*;
    for body in &mut shell.bodies {
        if !body.truncated && body.positions.par_iter().any(|p| field.beyond_reach(*p)) {
            body.truncated = true;
        }
    }
}

/// The volume of the finest infill cell: the default smallest body kept with a model.
pub(super) fn finest_cell_volume(stats: &InfillStats) -> f64 {
    stats.finest_step.iter().product()
}

/// The default simplification tolerance on a model's surfaces, as a share of its finest
/// infill step (the smallest of the three axes'): see docs/field.md, *Simplifying the
/// surfaces*.
pub const SIMPLIFY_SHARE: f64 = 0.25;

/// The default simplification tolerance of a model whose infill reached `stats`.
pub(super) fn default_simplify_tolerance(stats: &InfillStats) -> f64 {
    SIMPLIFY_SHARE
        * stats
            .finest_step
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
}

impl From<field::FieldError> for ContourError {
    fn from(e: field::FieldError) -> Self {
        match e {
            field::FieldError::Cancelled => ContourError::Cancelled,
            other => ContourError::Field(other.to_string()),
        }
    }
}
