//! The execute inputs of the `dmt-contour` process, checked at the door.
//!
//! Invariant: a [`ProcessInputs`] that passed [`ProcessInputs::validate`] names exactly
//! one kind of well source, at least one finite threshold, a known method and unknown
//! mode, and a positive finite anisotropy; errors name the input field at fault.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::contour::{ContourOptions, ContourRequest, OptionError, Source};
use crate::wells::{Input, InputFile, SampleSet};

/// Inputs of `POST /processes/dmt-contour/execution` (the `inputs` object).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ProcessInputs {
    /// Wells JSON: `{"crs"?, "wells": [{"id", "x", "y", "z"?, "samples": [{"depth" | "z",
    /// "value": number | null}]}]}`; depth is measured down a vertical hole from the collar z.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Object>)]
    pub wells: Option<serde_json::Value>,
    /// Samples CSV text with a header row: `well,x,y,z,value` (aliases `hole_id`/`bhid`,
    /// `easting`, `northing`, `elevation`/`rl`). Empty, `NA` or `?` values are "don't know".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(content_media_type = "text/csv")]
    pub samples_csv: Option<String>,
    /// Drill-hole collar table as CSV text (`hole_id,x,y,z`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(content_media_type = "text/csv")]
    pub collars_csv: Option<String>,
    /// Drill-hole survey table as CSV text (`hole_id,depth,azimuth,dip`), desurveyed by
    /// minimum curvature; without it holes are vertical.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(content_media_type = "text/csv")]
    pub surveys_csv: Option<String>,
    /// Drill-hole interval table as CSV text (`hole_id,from,to,<variables...>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(content_media_type = "text/csv")]
    pub intervals_csv: Option<String>,
    /// Interval column holding the value to contour.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variable: Option<String>,
    /// Categorical codes of `variable` that count as inside (value 1).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inside: Vec<String>,
    /// Composite intervals to this length (input units), length-weighted; default: one
    /// sample at each interval's midpoint.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub composite_length: Option<f64>,
    /// CRS to report when the input carries none (e.g. `EPSG:32633`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crs: Option<String>,
    /// Horizontal length unit, `m` or `ft`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// One shell per threshold; a sample is inside when `value >= threshold` (a number, or
    /// an array of 1 to 64 numbers).
    #[schema(inline)]
    pub thresholds: Thresholds,
    /// Vertex placement: `distance`, `curvature`, `ibc`, `coi`, `midpoint` or `mt`.
    /// Default: curvature for 0/1 data, IbC for grades.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// Lattice resolution N of the curvature placement (candidates (aP+bQ+cR+dS)/N), 4 to
    /// 12; default 7.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 4, maximum = 12)]
    pub lattice: Option<u32>,
    /// "Don't know" samples: `drop` (default) or `bounds`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unknown: Option<String>,
    /// Per-axis scale `[sx, sy, sz]` applied before tetrahedralizing (in the frame turned
    /// by `azimuth` and `dip`), inverted on output.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(min_items = 3, max_items = 3)]
    pub anisotropy: Option<[f64; 3]>,
    /// Azimuth (degrees clockwise from north) of the anisotropy's first axis; default 90.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub azimuth: Option<f64>,
    /// Dip (degrees) of the anisotropy's second axis, tilted down about the first; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dip: Option<f64>,
    /// Bodies with a smaller volume (input units cubed) are left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_volume: Option<f64>,
    /// Simplification tolerance (input units): removed vertices stay within it of the
    /// surface kept, bodies stay closed. 0 keeps every triangle; default: a model's surfaces
    /// within a quarter of its finest infill step, the linear interpolant's and grids' not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 0)]
    pub simplify: Option<f64>,
    /// Sweeps of the shape relaxation of IbC and CoI vertices (0 to 50; default 3; 0 keeps
    /// the paper's positions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relax: Option<u32>,
    /// Density in t/m3: the report gives tonnes and contained metal with it (volumes and
    /// mean grades without). Not with `density_column`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(exclusive_minimum = 0.0)]
    pub density: Option<f64>,
    /// Interval column holding the density (t/m3), read and interpolated like `variable`;
    /// samples without a value are counted and named in the report.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density_column: Option<String>,
    /// Cut-offs of the grade–tonnage curve as `FROM:TO:STEP` (e.g. `1:10:0.5`); default
    /// about 20 round cut-offs over the values' range. The curve is in the summary and the
    /// `report` (CSV) and `chart` (SVG) results.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(pattern = r"^[^:]+:[^:]+:[^:]+$")]
    pub grade_tonnage: Option<String>,
    /// Cross-validate with K folds: hold out every K-th hole in turn (whole holes, sorted by
    /// id), rebuild without it and predict its samples; the scores are in the summary.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 2)]
    pub cross_validate: Option<u32>,
    /// Values between the samples: `kriging` (default for samples: a model between the
    /// holes, evaluated where the surface is, then contoured by DMT) or `linear` (DMT on the
    /// samples' own tetrahedra, the paper's method; what `anisotropy` selects).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interpolant: Option<String>,
    /// The model's ranges `[major, semi-major, minor]` (input units); default from the
    /// intercepts at the lowest threshold.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(min_items = 3, max_items = 3)]
    pub ranges: Option<[f64; 3]>,
    /// The ore's orientation `[dip direction, dip, pitch]` in degrees; default from the
    /// principal axes of the intercepts. Ranges not given are measured along its axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(min_items = 3, max_items = 3)]
    pub orientation: Option<[f64; 3]>,
    /// The covariance's sill; default the variance of the (transformed) values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sill: Option<f64>,
    /// The nugget; default the down-hole variogram at lag zero, at most half the sill.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nugget: Option<f64>,
    /// Order of the spheroidal covariance: 3, 5 or 7 (default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spheroidal_order: Option<u8>,
    /// Transform before the fit: `none` (default), `log` or `normal-score`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<String>,
    /// How 0/1 flags are modelled: `distance` (default; the signed distance to the contacts
    /// down each hole, contoured at zero) or `indicator` (the kriged 0s and 1s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flag_field: Option<String>,
    /// How the orientation and ranges not given are found: `rules` (default) or
    /// `cross-validation` (planes and scaled ranges chosen by leave-holes-out
    /// cross-validation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape_from: Option<String>,
    /// `global` (default; one plane everywhere) or `varying` (the variogram map drawn
    /// around anchors over the ore turns each kriging block's plane where the ore's turns).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation_field: Option<String>,
    /// Values above this are capped to it before the fit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub top_cut: Option<f64>,
    /// Finest infill step along the major axis (input units); default 1/32 of the range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<f64>,
    /// Most samples in one kriging block (4 to 512; default 96).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_samples: Option<u32>,
    /// Most samples in a block whose nearest `max_samples` straddle a threshold, where the
    /// surface is (4 to 512; default 192; at or below `max_samples` turns it off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_samples_near: Option<u32>,
    /// Most samples of one hole in one kriging block (default 12).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_per_hole: Option<u32>,
    /// Draw the drill-hole traces (line primitives) in the GLB; default true.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub well_traces: Option<bool>,
    /// Draw the samples (point primitives) in the GLB; default true.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub well_samples: Option<bool>,
}

/// One threshold or several.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(untagged)]
pub enum Thresholds {
    One(f64),
    Many(Vec<f64>),
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds::Many(Vec::new())
    }
}

impl Thresholds {
    pub fn values(&self) -> Vec<f64> {
        match self {
            Thresholds::One(t) => vec![*t],
            Thresholds::Many(ts) => ts.clone(),
        }
    }
}

/// An input the service refuses, naming the field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct InputError {
    pub field: String,
    pub reason: String,
}

impl From<OptionError> for InputError {
    fn from(e: OptionError) -> Self {
        InputError {
            field: e.field.to_string(),
            reason: e.reason,
        }
    }
}

impl InputError {
    pub fn new(field: &str, reason: impl Into<String>) -> Self {
        InputError {
            field: field.to_string(),
            reason: reason.into(),
        }
    }
}

impl ProcessInputs {
    /// Checks everything that can be checked without reading the wells, and counts the
    /// sample rows per source against `max_points`.
    pub fn validate(&self, max_points: usize) -> Result<(), InputError> {
        let has_tables = self.collars_csv.is_some()
            || self.surveys_csv.is_some()
            || self.intervals_csv.is_some();
        let sources = [self.wells.is_some(), self.samples_csv.is_some(), has_tables]
            .into_iter()
            .filter(|&given| given)
            .count();
        if sources == 0 {
            return Err(InputError::new(
                "inputs",
                "give one source of wells: wells, samples_csv, or collars_csv + intervals_csv",
            ));
        }
        if sources > 1 {
            return Err(InputError::new(
                "inputs",
                "give only one source of wells: wells, samples_csv, or the drill-hole tables",
            ));
        }
        if has_tables {
            if self.collars_csv.is_none() {
                return Err(InputError::new(
                    "collars_csv",
                    "the drill-hole tables need a collar table",
                ));
            }
            if self.intervals_csv.is_none() {
                return Err(InputError::new(
                    "intervals_csv",
                    "the drill-hole tables need an interval table",
                ));
            }
        }
        if self.thresholds.values().is_empty() {
            return Err(InputError::new("thresholds", "give at least one threshold"));
        }
        self.options().check()?;
        if let Some(l) = self.composite_length
            && (!l.is_finite() || l <= 0.0)
        {
            return Err(InputError::new(
                "composite_length",
                "must be a positive finite number",
            ));
        }
        if let Some(unit) = &self.unit
            && unit != "m"
            && unit != "ft"
        {
            return Err(InputError::new("unit", "must be \"m\" or \"ft\""));
        }
        if let Some(wells) = &self.wells {
            if !wells.is_object() {
                return Err(InputError::new("wells", "must be a JSON object"));
            }
            let count = wells_sample_count(wells);
            check_points("wells", count, max_points)?;
        }
        for (field, text) in [
            ("samples_csv", &self.samples_csv),
            ("intervals_csv", &self.intervals_csv),
        ] {
            if let Some(text) = text {
                check_points(field, csv_data_rows(text), max_points)?;
            }
        }
        Ok(())
    }

    /// Number of sample rows across the sources (the size used to pick sync or async).
    pub fn point_count(&self) -> usize {
        self.wells.as_ref().map_or(0, wells_sample_count)
            + self.samples_csv.as_deref().map_or(0, csv_data_rows)
            + self.intervals_csv.as_deref().map_or(0, csv_data_rows)
    }

    /// The contouring options, as the CLI's flags of the same names give them.
    pub fn options(&self) -> ContourOptions {
        ContourOptions {
            thresholds: self.thresholds.values(),
            method: self.method.clone(),
            lattice: self.lattice,
            unknown: self.unknown.clone(),
            anisotropy: self.anisotropy,
            azimuth: self.azimuth,
            dip: self.dip,
            min_volume: self.min_volume,
            relax: self.relax,
            variable: self.variable.clone(),
            density: self.density,
            density_column: self.density_column.clone(),
            grade_tonnage: self.grade_tonnage.clone(),
            cross_validate: self.cross_validate,
            interpolant: self.interpolant.clone(),
            ranges: self.ranges,
            orientation: self.orientation,
            sill: self.sill,
            nugget: self.nugget,
            spheroidal_order: self.spheroidal_order,
            transform: self.transform.clone(),
            flag_field: self.flag_field.clone(),
            shape_from: self.shape_from.clone(),
            orientation_field: self.orientation_field.clone(),
            top_cut: self.top_cut,
            resolution: self.resolution,
            max_samples: self.max_samples,
            max_samples_near: self.max_samples_near,
            max_per_hole: self.max_per_hole,
            simplify: self.simplify,
        }
    }

    /// The well-reading half of the request, files named after their input fields.
    pub fn wells_input(&self) -> Input {
        let file = |name: &str, text: &Option<String>| {
            text.as_ref().map(|t| InputFile {
                name: name.to_string(),
                bytes: t.as_bytes().to_vec(),
            })
        };
        Input {
            samples_csv: file("samples_csv", &self.samples_csv),
            wells_json: self.wells.as_ref().map(|w| InputFile {
                name: "wells".to_string(),
                bytes: serde_json::to_vec(w).unwrap_or_default(),
            }),
            collars_csv: file("collars_csv", &self.collars_csv),
            surveys_csv: file("surveys_csv", &self.surveys_csv),
            intervals_csv: file("intervals_csv", &self.intervals_csv),
            variable: self.variable.clone(),
            inside_codes: self.inside.clone(),
            composite_length: self.composite_length,
            crs: self.crs.clone(),
            unit: self.unit.clone(),
            ..Input::default()
        }
    }

    /// The contouring half of the request around already-read samples.
    pub fn contour_request(&self, samples: SampleSet) -> Result<ContourRequest, InputError> {
        Ok(self.options().into_request(Source::Samples(samples))?)
    }
}

fn check_points(field: &str, count: usize, max_points: usize) -> Result<(), InputError> {
    if count > max_points {
        return Err(InputError::new(
            field,
            format!("{count} samples exceed this server's limit of {max_points}"),
        ));
    }
    Ok(())
}

/// Non-empty lines after the header.
fn csv_data_rows(text: &str) -> usize {
    text.lines()
        .filter(|line| !line.trim().is_empty())
        .count()
        .saturating_sub(1)
}

fn wells_sample_count(wells: &serde_json::Value) -> usize {
    wells
        .get("wells")
        .and_then(|w| w.as_array())
        .map_or(0, |wells| {
            wells
                .iter()
                .map(|well| {
                    well.get("samples")
                        .and_then(|s| s.as_array())
                        .map_or(0, Vec::len)
                })
                .sum()
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(rows: usize) -> ProcessInputs {
        let mut csv = String::from("well,x,y,z,value\n");
        for i in 0..rows {
            csv.push_str(&format!("w{i},0,0,{i},1\n"));
        }
        ProcessInputs {
            samples_csv: Some(csv),
            thresholds: Thresholds::One(0.5),
            ..ProcessInputs::default()
        }
    }

    #[test]
    fn a_plain_samples_request_is_valid() {
        assert_eq!(samples(3).validate(10), Ok(()));
        assert_eq!(samples(3).point_count(), 3);
    }

    #[test]
    fn too_many_samples_name_the_field() {
        let err = samples(11).validate(10).unwrap_err();
        assert_eq!(err.field, "samples_csv");
        assert!(err.reason.contains("11"), "{}", err.reason);
    }

    #[test]
    fn bad_thresholds_method_and_anisotropy_name_their_field() {
        let mut inputs = samples(1);
        inputs.thresholds = Thresholds::Many(vec![]);
        assert_eq!(inputs.validate(10).unwrap_err().field, "thresholds");
        inputs.thresholds = Thresholds::Many(vec![0.5, f64::NAN]);
        assert_eq!(inputs.validate(10).unwrap_err().field, "thresholds");
        inputs.thresholds = Thresholds::One(0.5);
        inputs.method = Some("best".into());
        assert_eq!(inputs.validate(10).unwrap_err().field, "method");
        inputs.method = Some("IBC".into());
        inputs.anisotropy = Some([1.0, 0.0, 1.0]);
        assert_eq!(inputs.validate(10).unwrap_err().field, "anisotropy");
        inputs.anisotropy = Some([1.0, 2.0, 1.0]);
        inputs.unknown = Some("maybe".into());
        assert_eq!(inputs.validate(10).unwrap_err().field, "unknown");
    }

    #[test]
    fn relaxation_sweeps_are_bounded_and_reach_the_request() {
        let mut inputs = samples(3);
        inputs.relax = Some(51);
        let err = inputs.validate(10).unwrap_err();
        assert_eq!(err.field, "relax");
        assert!(err.reason.contains("50"), "{}", err.reason);
        let set = crate::wells::SampleSet {
            origin: glam::DVec3::ZERO,
            crs: None,
            unit: "m".into(),
            wells: Vec::new(),
            points: Vec::new(),
            values: Vec::new(),
            well_of: Vec::new(),
            report: Default::default(),
        };
        inputs.relax = Some(0);
        assert_eq!(inputs.validate(10), Ok(()));
        assert_eq!(inputs.contour_request(set.clone()).unwrap().relax, 0);
        inputs.relax = None;
        assert_eq!(
            inputs.contour_request(set).unwrap().relax,
            crate::dmt::relax::DEFAULT_SWEEPS
        );
    }

    #[test]
    fn no_source_or_two_sources_are_refused() {
        let mut inputs = samples(1);
        inputs.samples_csv = None;
        assert_eq!(inputs.validate(10).unwrap_err().field, "inputs");
        let mut inputs = samples(1);
        inputs.wells = Some(serde_json::json!({"wells": []}));
        assert_eq!(inputs.validate(10).unwrap_err().field, "inputs");
    }

    #[test]
    fn drill_hole_tables_need_collars_and_intervals() {
        let inputs = ProcessInputs {
            intervals_csv: Some("hole_id,from,to,cu\n".into()),
            thresholds: Thresholds::One(0.5),
            ..ProcessInputs::default()
        };
        assert_eq!(inputs.validate(10).unwrap_err().field, "collars_csv");
    }

    #[test]
    fn wells_json_samples_are_counted() {
        let inputs = ProcessInputs {
            wells: Some(serde_json::json!({"wells": [
                {"id": "a", "x": 0, "y": 0, "samples": [{"depth": 1, "value": 1}, {"depth": 2, "value": 0}]},
                {"id": "b", "x": 1, "y": 0, "samples": [{"depth": 1, "value": null}]}
            ]})),
            thresholds: Thresholds::One(0.5),
            ..ProcessInputs::default()
        };
        assert_eq!(inputs.point_count(), 3);
        assert_eq!(inputs.validate(2).unwrap_err().field, "wells");
    }
}
