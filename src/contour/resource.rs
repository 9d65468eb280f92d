//! The resource report of a run: per body and shell the tonnes, mean grade, metal and the
//! samples inside; the grade–tonnage curve; cross-validation when asked.
//!
//! Invariant: everything here is computed from one [`Classified`] (the tetrahedra and the
//! value of the field at each vertex, the piecewise-linear field the shells contour), so
//! the report holds for any way of building that field (the samples' own values, or a
//! model evaluated at the samples and infill points). Each body's figures are the
//! integrals over its marked region (`Body::region`), the support that the bodies are
//! balanced to (docs/dmt.md, *Volume balance*).

use serde::Serialize;

use super::{Classified, ContourError, Frame, ShellSummary, Source};
use crate::dmt::Shell;
use crate::dmt::mt::{NO_REGION, lower_point_touches, marked_regions, region_count};
use crate::report::{
    self, BodyResource, CutoffSweep, DensityField, GradeTonnageRow, GradeUnit, ReportUnits,
    Resource, SampleStats,
};
use crate::wells::SampleSet;

/// Where the density (t/m3) comes from.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum Density {
    /// No density: volumes and grades, no tonnes or metal.
    #[default]
    None,
    /// One density everywhere.
    Constant(f64),
    /// A column of the input read like the grade: one value per sample of the source
    /// (`None` where the column is empty), interpolated on the same mesh.
    Column {
        name: String,
        values: Vec<Option<f64>>,
    },
}

/// What the resource report asks for beyond the shells.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReportRequest {
    pub density: Density,
    /// The grade variable's unit (from its name, [`GradeUnit::from_variable`]).
    pub grade_unit: Option<GradeUnit>,
    /// The cut-offs of the grade–tonnage curve; `None`: a default sweep over the values.
    pub grade_tonnage: Option<CutoffSweep>,
    /// Hold out every K-th hole in turn and predict it (`None`: no cross-validation).
    pub cross_validate: Option<u32>,
}

/// How the density was found, for the summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DensitySummary {
    /// `none`, `constant` or `column`.
    pub source: &'static str,
    /// The constant, t/m3.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    /// The column's name.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub column: Option<String>,
    /// Samples with a grade but no density in the column: their vertices take
    /// `filled_with`.
    pub missing_samples: usize,
    /// The holes of those samples (at most `NAMED_HOLES` named).
    pub missing_holes: Vec<String>,
    /// The mean density of the samples that have one, given to the others, t/m3.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub filled_with: Option<f64>,
}

/// Holes named in a list of the summary; the count says how many there are.
pub const NAMED_HOLES: usize = 20;

/// The report beside the shells in the summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReportSummary {
    pub units: ReportUnits,
    pub density: DensitySummary,
    /// Everything at or above each cut-off, computed on the one tetrahedralization.
    pub grade_tonnage: Vec<GradeTonnageRow>,
    /// The held-out predictions, when asked.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cross_validation: Option<super::cross_validate::CrossValidation>,
}

/// The density at each mesh vertex, and how it was found.
fn vertex_density(
    data: &Classified,
    source: &Source,
    density: &Density,
) -> Result<(Option<Vec<f64>>, DensitySummary), ContourError> {
    let mut summary = DensitySummary {
        source: "none",
        value: None,
        column: None,
        missing_samples: 0,
        missing_holes: Vec::new(),
        filled_with: None,
    };
    let (name, values) = match density {
        Density::None => return Ok((None, summary)),
        Density::Constant(r) => {
            summary.source = "constant";
            summary.value = Some(*r);
            return Ok((Some(vec![*r; data.mesh.points.len()]), summary));
        }
        Density::Column { name, values } => (name, values),
    };
    summary.source = "column";
    summary.column = Some(name.clone());
    let Source::Samples(samples) = source else {
        return Err(ContourError::Density(format!(
            "column {name}: a grid has no sample columns; give a constant density"
        )));
    };
    let mut sum = vec![0.0; data.mesh.points.len()];
    let mut count = vec![0u32; data.mesh.points.len()];
    let mut missing_holes: Vec<u32> = Vec::new();
    for (k, i) in known_samples(samples).enumerate() {
        let Some(&v) = data.mesh.vertex_of_input.get(k) else {
            break;
        };
        match values.get(i).copied().flatten() {
            Some(r) => {
                sum[v as usize] += r;
                count[v as usize] += 1;
            }
            None => {
                summary.missing_samples += 1;
                let hole = samples.well_of[i];
                if !missing_holes.contains(&hole) {
                    missing_holes.push(hole);
                }
            }
        }
    }
    let (total, n) = sum
        .iter()
        .zip(&count)
        .fold((0.0, 0u32), |(s, n), (x, c)| (s + x, n + c));
    if n == 0 {
        return Err(ContourError::Density(format!(
            "column {name}: no sample with a grade has a density value"
        )));
    }
    let mean = total / f64::from(n);
    if summary.missing_samples > 0 || count.contains(&0) {
        summary.filled_with = Some(mean);
    }
    summary.missing_holes = missing_holes
        .iter()
        .take(NAMED_HOLES)
        .map(|&h| samples.wells[h as usize].id.clone())
        .collect();
    let per_vertex = sum
        .iter()
        .zip(&count)
        .map(|(s, &c)| if c > 0 { s / f64::from(c) } else { mean })
        .collect();
    Ok((Some(per_vertex), summary))
}

/// Indices of the samples with a known value, in the order they were tetrahedralized
/// (`mesh.vertex_of_input[k]` is the vertex of the k-th).
pub(super) fn known_samples(samples: &SampleSet) -> impl Iterator<Item = usize> + '_ {
    samples
        .values
        .iter()
        .enumerate()
        .filter_map(|(i, v)| v.map(|_| i))
}

/// Mesh volumes to m3: the input's length unit cubed over the anisotropic frame's
/// determinant (the tetrahedra are built in the frame).
pub(super) fn volume_factor(unit: &str, frame: &Frame) -> f64 {
    let metres = match crate::wells::Unit::parse(unit) {
        Some(u) => u.factor_to(crate::wells::Unit::Metre),
        None => 1.0,
    };
    metres.powi(3) / frame.forward.determinant().abs()
}

/// The figures of one shell: per body (in the shell's order) and in total.
fn shell_resources(
    data: &Classified,
    samples: Option<&SampleSet>,
    density: DensityField,
    has_density: bool,
    unit: GradeUnit,
    factor: f64,
    shell: &Shell,
) -> (Vec<BodyResource>, BodyResource) {
    let threshold = shell.threshold;
    // The marking the extraction used: samples exactly at the threshold with none above
    // around them are lowered (they enclose no volume).
    let lowered = lower_point_touches(&data.mesh, &data.values, threshold);
    let values = lowered.as_ref().map_or(&data.values[..], |(v, _)| &v[..]);
    let marked: Vec<bool> = values.iter().map(|&v| v >= threshold).collect();
    let regions = marked_regions(&data.mesh, &marked);
    let len = region_count(&regions);
    let moments =
        report::integrate::region_moments(&data.mesh, values, density, threshold, &regions, len);
    let mut stats = vec![SampleStats::default(); len];
    if let Some(samples) = samples {
        for (k, i) in known_samples(samples).enumerate() {
            let Some(&v) = data.mesh.vertex_of_input.get(k) else {
                break;
            };
            let r = regions[v as usize];
            if let (Some(value), true) = (samples.values[i], r != NO_REGION) {
                stats[r as usize].add(value);
            }
        }
    }
    let mut total_moments = report::Moments::default();
    let mut total_stats = SampleStats::default();
    let bodies = shell
        .bodies
        .iter()
        .map(|body| {
            let r = body.region as usize;
            let (m, s) = match (moments.get(r), stats.get(r)) {
                (Some(m), Some(s)) => (m.scaled(factor), *s),
                _ => (report::Moments::default(), SampleStats::default()),
            };
            total_moments = add(total_moments, m);
            total_stats.merge(&s);
            BodyResource {
                resource: Resource::from_moments(m, has_density, unit),
                samples: s,
            }
        })
        .collect();
    let total = BodyResource {
        resource: Resource::from_moments(total_moments, has_density, unit),
        samples: total_stats,
    };
    (bodies, total)
}

fn add(a: report::Moments, b: report::Moments) -> report::Moments {
    report::Moments {
        volume: a.volume + b.volume,
        grade: a.grade + b.grade,
        mass: a.mass + b.mass,
        metal: a.metal + b.metal,
    }
}

/// The cut-offs of the curve: those asked for, or the default sweep over the vertex
/// values (none for 0/1 data, whose only cut-off is the shell).
fn cutoffs(request: &ReportRequest, values: &[f64], binary: bool) -> Vec<f64> {
    if let Some(sweep) = request.grade_tonnage {
        return sweep.cutoffs();
    }
    if binary {
        return Vec::new();
    }
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    CutoffSweep::default_for(lo, hi)
        .map(|s| s.cutoffs())
        .unwrap_or_default()
}

/// Everything the run needs to write the report into the summary.
pub(super) struct ReportInput<'a> {
    pub data: &'a Classified,
    pub source: &'a Source,
    pub request: &'a ReportRequest,
    pub frame: &'a Frame,
    pub unit: &'a str,
    pub binary: bool,
}

/// Fills each shell's and body's resource and returns the report (without
/// cross-validation, which [`super::cross_validate`] adds).
pub(super) fn report(
    input: &ReportInput,
    shells: &[Shell],
    summaries: &mut [ShellSummary],
) -> Result<ReportSummary, ContourError> {
    let unit = input.request.grade_unit.unwrap_or(GradeUnit::AsGiven);
    let (per_vertex, density_summary) =
        vertex_density(input.data, input.source, &input.request.density)?;
    let has_density = per_vertex.is_some();
    let density = match &per_vertex {
        Some(values) => DensityField::PerVertex(values),
        None => DensityField::Constant(1.0),
    };
    let factor = volume_factor(input.unit, input.frame);
    let samples = match input.source {
        Source::Samples(s) => Some(s),
        Source::Grid(_) => None,
    };
    for (shell, summary) in shells.iter().zip(summaries.iter_mut()) {
        let (bodies, total) = shell_resources(
            input.data,
            samples,
            density,
            has_density,
            unit,
            factor,
            shell,
        );
        for (b, r) in summary.bodies.iter_mut().zip(bodies) {
            b.resource = Some(r);
        }
        summary.resource = Some(total);
    }
    // The default sweep spans the data's values: the samples' (a model's mesh also holds
    // infill values and the sentinels' value below every level), or the grid's.
    let known: Vec<f64> = match input.source {
        Source::Samples(s) => s.values.iter().flatten().copied().collect(),
        Source::Grid(_) => input.data.values.clone(),
    };
    let cutoffs = cutoffs(input.request, &known, input.binary);
    let grade_tonnage = report::grade_tonnage(
        &input.data.mesh,
        &input.data.values,
        density,
        has_density,
        factor,
        unit,
        &cutoffs,
    );
    Ok(ReportSummary {
        units: ReportUnits::new(unit),
        density: density_summary,
        grade_tonnage,
        cross_validation: None,
    })
}

/// Reads the density column the request names (if any) from `input`: the same tables read
/// again with the column as the variable, so each sample gets the density of the same
/// intervals (composited the same way) as its grade. Empty cells stay `None` and are
/// counted in the report.
pub fn load_density_column(
    request: &mut super::ContourRequest,
    input: &crate::wells::Input,
) -> Result<(), ContourError> {
    let Density::Column { name, values } = &mut request.report.density else {
        return Ok(());
    };
    let Source::Samples(samples) = &request.source else {
        return Err(ContourError::Density(format!(
            "column {name}: a grid has no sample columns; give a constant density"
        )));
    };
    if input.wells_json.is_some() {
        return Err(ContourError::Density(format!(
            "column {name}: a wells JSON carries one value per sample; a density column needs \
             drill-hole tables, a samples CSV or LAS curves"
        )));
    }
    let mut column_input = input.clone();
    column_input.variable = Some(name.clone());
    column_input.inside_codes.clear();
    let read = column_input
        .load()
        .map_err(|e| ContourError::Density(format!("column {name}: {e}")))?;
    if read.points != samples.points {
        return Err(ContourError::Density(format!(
            "column {name}: its samples ({}) are not at the grade's ({}); it must be a column \
             of the same interval table",
            read.points.len(),
            samples.points.len()
        )));
    }
    if let Some(bad) = read
        .values
        .iter()
        .flatten()
        .find(|r| r.is_nan() || **r <= 0.0)
    {
        return Err(ContourError::Density(format!(
            "column {name}: {bad} is not a positive density (t/m3)"
        )));
    }
    *values = read.values;
    Ok(())
}
