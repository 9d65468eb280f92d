//! What a contouring job asks for: the source of values ([`Source`]) and the options,
//! checked once at the door.
//!
//! Invariant: a [`ContourRequest`] holds only validated values — [`Thresholds`] are finite
//! and few, an [`Anisotropy`] is positive and finite, `min_volume` is finite and not
//! negative — so the pipeline never checks them again. Both doors (the CLI's flags and the
//! service's execute inputs) fill the same [`ContourOptions`] and go through
//! [`ContourOptions::into_request`]; an error names the option at fault.

use glam::{DMat3, DVec3};
use serde::Serialize;

use crate::dmt::{self, Method, Placement};
use crate::field::{
    FlagField, ModelOptions, Neighbourhood, Orientation, OrientationField, ShapeFrom, TransformKind,
};
use crate::wells::SampleSet;

/// How the values between the samples are made.
#[derive(Debug, Clone, PartialEq)]
pub enum Interpolant {
    /// The paper's method: DMT on the linear interpolation of the raw samples over their
    /// Delaunay tetrahedra (the only one for grids).
    Linear,
    /// A kriging model between the holes, evaluated at infill points where the surface is
    /// (`field`); the default for samples.
    Kriging(ModelOptions),
}

impl Interpolant {
    pub fn name(&self) -> &'static str {
        match self {
            Interpolant::Linear => "linear",
            Interpolant::Kriging(_) => "kriging",
        }
    }

    /// The default for a source: the model for samples, linear for grids.
    pub fn default_for(source: &Source) -> Self {
        match source {
            Source::Samples(_) => Interpolant::Kriging(ModelOptions::default()),
            Source::Grid(_) => Interpolant::Linear,
        }
    }
}

/// Most thresholds (shells) one request may ask for.
pub const MAX_THRESHOLDS: usize = 64;

/// Where the values to contour come from.
#[derive(Debug, Clone)]
pub enum Source {
    /// Scattered samples (wells, drill holes, LAS logs): tetrahedralized by Delaunay.
    Samples(SampleSet),
    /// A structured grid: its cells are split into tetrahedra, no Delaunay.
    Grid(GridSource),
}

impl Source {
    /// `true` when every known value is 0 or 1 (binary "copper above trace" data).
    pub fn is_binary(&self) -> bool {
        match self {
            Source::Samples(samples) => is_binary(&samples.values),
            Source::Grid(grid) => grid.volume.values.iter().all(|&v| v == 0.0 || v == 1.0),
        }
    }
}

/// A grid input and the cube split that turns it into tetrahedra; `crs` and `unit` are
/// what to report when the grid file carries none.
#[derive(Debug, Clone)]
pub struct GridSource {
    pub volume: crate::grid::GridVolume,
    pub split: crate::grid::CubeSplit,
    pub crs: Option<String>,
    pub unit: String,
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

/// One shell per threshold; a value is inside when `value >= threshold`. Finite, at most
/// [`MAX_THRESHOLDS`]; none asks for the default of 0/1 data (0.5).
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Thresholds(Vec<f64>);

impl Thresholds {
    pub fn new(values: Vec<f64>) -> Result<Self, OptionError> {
        if values.len() > MAX_THRESHOLDS {
            return Err(OptionError::new(
                "thresholds",
                format!("at most {MAX_THRESHOLDS} thresholds"),
            ));
        }
        if let Some(bad) = values.iter().find(|t| !t.is_finite()) {
            return Err(OptionError::new(
                "thresholds",
                format!("{bad} is not a finite number"),
            ));
        }
        Ok(Thresholds(values))
    }

    pub fn values(&self) -> &[f64] {
        &self.0
    }

    /// The thresholds to contour: those given, or 0.5 for 0/1 data when none were.
    pub fn or_default(&self, binary: bool) -> Option<Vec<f64>> {
        match (self.0.is_empty(), binary) {
            (false, _) => Some(self.0.clone()),
            (true, true) => Some(vec![0.5]),
            (true, false) => None,
        }
    }
}

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

impl std::str::FromStr for UnknownMode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "drop" => Ok(UnknownMode::Drop),
            "bounds" => Ok(UnknownMode::Bounds),
            other => Err(format!("unknown mode {other:?}: expected drop or bounds")),
        }
    }
}

/// An anisotropic frame: ore bodies are long and flat, so distances along the direction of
/// greatest continuity count less. Points are rotated into the frame whose first axis
/// points along `azimuth_deg` (clockwise from north) and whose second axis is tilted down by
/// `dip_deg` about the first, then scaled per axis; output is mapped back exactly.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Anisotropy {
    scale: DVec3,
    azimuth_deg: f64,
    dip_deg: f64,
}

impl Anisotropy {
    /// Scale factors must be positive and finite, angles finite.
    pub fn new(scale: DVec3, azimuth_deg: f64, dip_deg: f64) -> Result<Self, OptionError> {
        if !scale.is_finite() || scale.min_element() <= 0.0 {
            return Err(OptionError::new(
                "anisotropy",
                "each of [sx, sy, sz] must be a positive finite number",
            ));
        }
        if !azimuth_deg.is_finite() {
            return Err(OptionError::new("azimuth", "must be a finite number"));
        }
        if !dip_deg.is_finite() {
            return Err(OptionError::new("dip", "must be a finite number"));
        }
        Ok(Anisotropy {
            scale,
            azimuth_deg,
            dip_deg,
        })
    }

    /// A pure per-axis scale of x, y, z (azimuth 90, dip 0: no rotation).
    pub fn scale(scale: DVec3) -> Result<Self, OptionError> {
        Anisotropy::new(scale, 90.0, 0.0)
    }

    pub fn scale_factors(&self) -> DVec3 {
        self.scale
    }

    pub fn azimuth_deg(&self) -> f64 {
        self.azimuth_deg
    }

    pub fn dip_deg(&self) -> f64 {
        self.dip_deg
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
}

/// A contouring job, validated.
#[derive(Debug, Clone)]
pub struct ContourRequest {
    pub source: Source,
    pub thresholds: Thresholds,
    /// `None` picks the default by data type ([`default_method`]).
    pub method: Option<Method>,
    /// Lattice resolution of the curvature placement, when the method (given or default)
    /// is curvature; `None` keeps the method's own.
    pub lattice: Option<u32>,
    pub unknown: UnknownMode,
    /// Scale (and rotation) applied before tetrahedralizing and inverted on output.
    pub anisotropy: Option<Anisotropy>,
    /// Bodies with a smaller volume are left out of the output (and counted in the
    /// shell's `filtered_bodies`); `None` keeps every body, folded ones included.
    pub min_volume: Option<f64>,
    /// Sweeps of the shape relaxation of IbC and CoI vertices (`dmt::relax`); 0 keeps the
    /// paper's positions. Other methods ignore it.
    pub relax: usize,
    /// Density, grade unit, grade–tonnage cut-offs and cross-validation of the resource
    /// report.
    pub report: super::ReportRequest,
    /// The values DMT contours: the samples' linear interpolation or the model.
    pub interpolant: Interpolant,
    /// Whether and how far the bodies are simplified (`dmt::simplify`).
    pub simplify: Simplify,
}

/// The simplification a request asks for.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Simplify {
    /// A model's surfaces within a share of its finest infill step
    /// (`model::SIMPLIFY_SHARE`); the linear interpolant's and grids' not at all.
    #[default]
    Default,
    /// Every triangle as extracted.
    Off,
    /// Within this distance (input units, positive).
    Tolerance(f64),
}

impl ContourRequest {
    /// A request with the defaults: method by data type, unknowns dropped, no anisotropy,
    /// every body kept.
    pub fn new(source: Source, thresholds: Thresholds) -> Self {
        ContourRequest {
            interpolant: Interpolant::default_for(&source),
            source,
            thresholds,
            method: None,
            lattice: None,
            unknown: UnknownMode::Drop,
            anisotropy: None,
            min_volume: None,
            relax: dmt::relax::DEFAULT_SWEEPS,
            report: super::ReportRequest::default(),
            simplify: Simplify::Default,
        }
    }

    /// The default request on samples.
    pub fn samples(samples: SampleSet, thresholds: Thresholds) -> Self {
        ContourRequest::new(Source::Samples(samples), thresholds)
    }
}

/// The method used when the request names none: the curvature placement (searched near the
/// distance surface) for 0/1 data, IbC for grades and for every modelled field (the model's
/// indicator is smooth: the curvature search has nothing to straighten). See docs/dmt.md
/// for the measurements.
pub fn default_method(binary: bool) -> Method {
    if binary {
        Method::Dmt(Placement::Curvature {
            lattice: dmt::DEFAULT_CURVATURE_LATTICE,
        })
    } else {
        Method::Dmt(Placement::Ibc)
    }
}

impl ContourRequest {
    /// The method this request runs on data of the given kind, with its lattice.
    pub fn resolved_method(&self, binary: bool) -> Method {
        let modelled = matches!(self.interpolant, Interpolant::Kriging(_));
        // A lattice given alone asks for the curvature placement, whatever the default.
        let default = match (self.lattice, modelled) {
            (Some(_), _) => default_method(true),
            (None, modelled) => default_method(binary && !modelled),
        };
        match (self.method.unwrap_or(default), self.lattice) {
            (Method::Dmt(Placement::Curvature { .. }), Some(lattice)) => {
                Method::Dmt(Placement::Curvature { lattice })
            }
            (method, _) => method,
        }
    }
}

/// An option the request refuses: which one (by its name in the execute inputs; the CLI's
/// flag is `--` and the same name) and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct OptionError {
    pub field: &'static str,
    pub reason: String,
}

impl OptionError {
    pub fn new(field: &'static str, reason: impl Into<String>) -> Self {
        OptionError {
            field,
            reason: reason.into(),
        }
    }
}

/// The contouring options as a client gives them, before any check: the one request
/// shape both doors fill (the CLI from its flags, the service from its execute inputs),
/// each field named as the execute input of the same name.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContourOptions {
    pub thresholds: Vec<f64>,
    /// `distance`, `curvature`, `ibc`, `coi`, `midpoint` or `mt`.
    pub method: Option<String>,
    /// Lattice resolution of the curvature placement.
    pub lattice: Option<u32>,
    /// `drop` or `bounds`.
    pub unknown: Option<String>,
    /// Scale factors `[sx, sy, sz]` of the anisotropic frame.
    pub anisotropy: Option<[f64; 3]>,
    /// Azimuth of the frame's first axis (degrees clockwise from north; default 90).
    pub azimuth: Option<f64>,
    /// Dip of the frame's second axis (degrees, default 0).
    pub dip: Option<f64>,
    pub min_volume: Option<f64>,
    pub relax: Option<u32>,
    /// Name of the grade variable (interval column or curve), whose unit the report states
    /// (`Zn_pct` -> %, `Au_gpt` -> g/t, `Ag_ppm` -> ppm, else "as given").
    pub variable: Option<String>,
    /// A constant density, t/m3.
    pub density: Option<f64>,
    /// The interval column holding the density (t/m3), read like the grade.
    pub density_column: Option<String>,
    /// `FROM:TO:STEP` cut-offs of the grade–tonnage curve.
    pub grade_tonnage: Option<String>,
    /// Hold out every K-th hole in turn (K folds).
    pub cross_validate: Option<u32>,
    /// `kriging` (the default for samples) or `linear`.
    pub interpolant: Option<String>,
    /// The model's ranges `[major, semi-major, minor]`, input units.
    pub ranges: Option<[f64; 3]>,
    /// The model's orientation `[dip direction, dip, pitch]`, degrees.
    pub orientation: Option<[f64; 3]>,
    pub sill: Option<f64>,
    pub nugget: Option<f64>,
    /// Order of the spheroidal covariance: 3, 5 or 7.
    pub spheroidal_order: Option<u8>,
    /// `none`, `log` or `normal-score`.
    pub transform: Option<String>,
    /// How 0/1 flags are modelled: `distance` (default) or `indicator`.
    pub flag_field: Option<String>,
    /// How the orientation and ranges not given are found: `rules` (default) or
    /// `cross-validation`.
    pub shape_from: Option<String>,
    /// Whether the plane may turn in space: `global` (default) or `varying`.
    pub orientation_field: Option<String>,
    pub top_cut: Option<f64>,
    /// Finest infill step along the major axis, input units.
    pub resolution: Option<f64>,
    /// Most samples in one kriging block.
    pub max_samples: Option<u32>,
    /// Most samples in a block whose nearest `max_samples` straddle a threshold.
    pub max_samples_near: Option<u32>,
    /// Most samples of one hole in one kriging block.
    pub max_per_hole: Option<u32>,
    /// Simplification tolerance, input units: 0 keeps every triangle; absent, a model's
    /// surfaces are simplified within a quarter of its finest infill step.
    pub simplify: Option<f64>,
}

impl ContourOptions {
    /// The validated method and curvature lattice.
    fn method(&self) -> Result<(Option<Method>, Option<u32>), OptionError> {
        let method = match &self.method {
            Some(name) => Some(
                name.parse::<Method>()
                    .map_err(|e| OptionError::new("method", e))?,
            ),
            None => None,
        };
        let Some(lattice) = self.lattice else {
            return Ok((method, None));
        };
        let lowest = dmt::curvature::MIN_LATTICE;
        let highest = dmt::curvature::MAX_LATTICE;
        if !(lowest..=highest).contains(&lattice) {
            return Err(OptionError::new(
                "lattice",
                format!("must be from {lowest} to {highest}"),
            ));
        }
        match method {
            None | Some(Method::Dmt(Placement::Curvature { .. })) => Ok((method, Some(lattice))),
            Some(other) => Err(OptionError::new(
                "lattice",
                format!("applies to the curvature method only, not {}", other.name()),
            )),
        }
    }

    /// The validated options of the resource report. A density column's values are read by
    /// the door afterwards ([`super::load_density_column`]).
    fn report(&self) -> Result<super::ReportRequest, OptionError> {
        let density = match (self.density, &self.density_column) {
            (Some(_), Some(_)) => {
                return Err(OptionError::new(
                    "density_column",
                    "give either a constant density or a density column, not both",
                ));
            }
            (Some(r), None) if !(r.is_finite() && r > 0.0) => {
                return Err(OptionError::new(
                    "density",
                    format!("{r} is not a positive number of t/m3"),
                ));
            }
            (Some(r), None) => super::Density::Constant(r),
            (None, Some(name)) if name.trim().is_empty() => {
                return Err(OptionError::new("density_column", "is empty"));
            }
            (None, Some(name)) => super::Density::Column {
                name: name.clone(),
                values: Vec::new(),
            },
            (None, None) => super::Density::None,
        };
        let grade_tonnage = match &self.grade_tonnage {
            Some(text) => Some(
                crate::report::CutoffSweep::parse(text)
                    .map_err(|e| OptionError::new("grade_tonnage", e))?,
            ),
            None => None,
        };
        if let Some(k) = self.cross_validate
            && k < 2
        {
            return Err(OptionError::new(
                "cross_validate",
                format!("{k} folds: give K of at least 2"),
            ));
        }
        Ok(super::ReportRequest {
            density,
            grade_unit: Some(crate::report::GradeUnit::from_variable(
                self.variable.as_deref(),
            )),
            grade_tonnage,
            cross_validate: self.cross_validate,
        })
    }

    /// The interpolant on `source`, with the model's options checked.
    fn interpolant(&self, source: &Source) -> Result<Interpolant, OptionError> {
        let grid = matches!(source, Source::Grid(_));
        let asked = match self
            .interpolant
            .as_deref()
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            None => None,
            Some("linear") => Some(false),
            Some("kriging") => Some(true),
            Some(other) => {
                return Err(OptionError::new(
                    "interpolant",
                    format!("unknown interpolant {other:?}: expected kriging or linear"),
                ));
            }
        };
        if grid && asked == Some(true) {
            return Err(OptionError::new(
                "interpolant",
                "kriging models scattered samples; a grid is contoured as it is (linear)",
            ));
        }
        // --anisotropy stretches the linear interpolation: given alone, it selects it.
        let kriging = asked.unwrap_or(!grid && self.anisotropy.is_none());
        let model_option = self.model_option_given();
        if !kriging {
            if let Some(name) = model_option
                && !grid
            {
                return Err(OptionError::new(
                    name,
                    "applies to the kriging interpolant, not linear",
                ));
            }
            return Ok(Interpolant::Linear);
        }
        if self.anisotropy.is_some() {
            return Err(OptionError::new(
                "anisotropy",
                "stretches the linear interpolant; the kriging model takes ranges and orientation",
            ));
        }
        Ok(Interpolant::Kriging(self.model_options()?))
    }

    /// The name of the first model option given, if any.
    fn model_option_given(&self) -> Option<&'static str> {
        [
            ("ranges", self.ranges.is_some()),
            ("orientation", self.orientation.is_some()),
            ("sill", self.sill.is_some()),
            ("nugget", self.nugget.is_some()),
            ("spheroidal_order", self.spheroidal_order.is_some()),
            ("transform", self.transform.is_some()),
            ("flag_field", self.flag_field.is_some()),
            ("shape_from", self.shape_from.is_some()),
            ("orientation_field", self.orientation_field.is_some()),
            ("top_cut", self.top_cut.is_some()),
            ("resolution", self.resolution.is_some()),
            ("max_samples", self.max_samples.is_some()),
            ("max_samples_near", self.max_samples_near.is_some()),
            ("max_per_hole", self.max_per_hole.is_some()),
        ]
        .into_iter()
        .find(|(_, given)| *given)
        .map(|(name, _)| name)
    }

    fn model_options(&self) -> Result<ModelOptions, OptionError> {
        let positive = |name: &'static str, v: Option<f64>| -> Result<Option<f64>, OptionError> {
            match v {
                Some(x) if !(x.is_finite() && x > 0.0) => {
                    Err(OptionError::new(name, "must be a positive finite number"))
                }
                other => Ok(other),
            }
        };
        if let Some(r) = self.ranges
            && r.iter().any(|x| !(x.is_finite() && *x > 0.0))
        {
            return Err(OptionError::new(
                "ranges",
                "each of [major, semi-major, minor] must be a positive finite number",
            ));
        }
        let orientation = match self.orientation {
            None => None,
            Some([dd, dip, pitch]) => {
                if ![dd, dip, pitch].iter().all(|x| x.is_finite()) || !(0.0..=90.0).contains(&dip) {
                    return Err(OptionError::new(
                        "orientation",
                        "[dip direction, dip, pitch] in degrees, finite, dip from 0 to 90",
                    ));
                }
                Some(Orientation {
                    dip_direction: dd.rem_euclid(360.0),
                    dip,
                    pitch: pitch.rem_euclid(180.0),
                })
            }
        };
        let sill = positive("sill", self.sill)?;
        let nugget = match self.nugget {
            Some(n) if !(n.is_finite() && n >= 0.0) => {
                return Err(OptionError::new("nugget", "must be a finite number >= 0"));
            }
            Some(n) if sill.is_some_and(|s| n >= s) => {
                return Err(OptionError::new("nugget", "must be less than the sill"));
            }
            other => other,
        };
        let order = self
            .spheroidal_order
            .unwrap_or(crate::field::kernel::DEFAULT_ORDER);
        if !crate::field::kernel::ORDERS.contains(&order) {
            return Err(OptionError::new(
                "spheroidal_order",
                format!("must be one of {:?}", crate::field::kernel::ORDERS),
            ));
        }
        let transform = match self.transform.as_deref() {
            None => TransformKind::None,
            Some(t) => t
                .parse::<TransformKind>()
                .map_err(|e| OptionError::new("transform", e))?,
        };
        let flag_field = match self.flag_field.as_deref() {
            None => FlagField::default(),
            Some(f) => f
                .parse::<FlagField>()
                .map_err(|e| OptionError::new("flag_field", e))?,
        };
        let shape_from = match self.shape_from.as_deref() {
            None => ShapeFrom::default(),
            Some(f) => f
                .parse::<ShapeFrom>()
                .map_err(|e| OptionError::new("shape_from", e))?,
        };
        let orientation_field = match self.orientation_field.as_deref() {
            None => OrientationField::default(),
            Some(f) => f
                .parse::<OrientationField>()
                .map_err(|e| OptionError::new("orientation_field", e))?,
        };
        let top_cut = match self.top_cut {
            Some(c) if !c.is_finite() => {
                return Err(OptionError::new("top_cut", "must be a finite number"));
            }
            other => other,
        };
        let resolution = positive("resolution", self.resolution)?;
        let mut neighbourhood = Neighbourhood::default();
        let block_size = |name: &'static str, v: Option<u32>, default: usize| match v {
            Some(m) if !(4..=512).contains(&m) => {
                Err(OptionError::new(name, "must be from 4 to 512"))
            }
            Some(m) => Ok(m as usize),
            None => Ok(default),
        };
        neighbourhood.max_samples =
            block_size("max_samples", self.max_samples, neighbourhood.max_samples)?;
        neighbourhood.max_samples_near = block_size(
            "max_samples_near",
            self.max_samples_near,
            neighbourhood.max_samples_near,
        )?;
        if let Some(m) = self.max_per_hole {
            if m == 0 {
                return Err(OptionError::new("max_per_hole", "must be at least 1"));
            }
            neighbourhood.max_per_hole = m as usize;
        }
        Ok(ModelOptions {
            ranges: self.ranges,
            orientation,
            sill,
            nugget,
            order,
            transform,
            top_cut,
            resolution,
            neighbourhood,
            flag_field,
            shape_from,
            orientation_field,
        })
    }

    /// Checks every option without a source (as [`ContourOptions::into_request`] does).
    pub fn check(&self) -> Result<(), OptionError> {
        self.clone()
            .into_request(Source::Samples(SampleSet::default()))
            .map(|_| ())
    }

    /// Checks every option and builds the request on `source`.
    pub fn into_request(self, source: Source) -> Result<ContourRequest, OptionError> {
        let (method, lattice) = self.method()?;
        let report = self.report()?;
        let interpolant = self.interpolant(&source)?;
        let thresholds = Thresholds::new(self.thresholds)?;
        let unknown = match self.unknown.as_deref() {
            None => UnknownMode::Drop,
            Some(text) => text
                .parse::<UnknownMode>()
                .map_err(|e| OptionError::new("unknown", e))?,
        };
        let anisotropy = match (self.anisotropy, self.azimuth, self.dip) {
            (Some(scale), azimuth, dip) => Some(Anisotropy::new(
                DVec3::from_array(scale),
                azimuth.unwrap_or(90.0),
                dip.unwrap_or(0.0),
            )?),
            (None, Some(_), _) => {
                return Err(OptionError::new(
                    "azimuth",
                    "turns the anisotropic frame: give anisotropy too",
                ));
            }
            (None, None, Some(_)) => {
                return Err(OptionError::new(
                    "dip",
                    "tilts the anisotropic frame: give anisotropy too",
                ));
            }
            (None, None, None) => None,
        };
        if let Some(v) = self.min_volume
            && (!v.is_finite() || v < 0.0)
        {
            return Err(OptionError::new(
                "min_volume",
                "must be a finite number >= 0",
            ));
        }
        let relax = match self.relax {
            Some(r) if r as usize > dmt::relax::MAX_SWEEPS => {
                return Err(OptionError::new(
                    "relax",
                    format!("at most {} sweeps", dmt::relax::MAX_SWEEPS),
                ));
            }
            Some(r) => r as usize,
            None => dmt::relax::DEFAULT_SWEEPS,
        };
        let simplify = match self.simplify {
            None => Simplify::Default,
            Some(0.0) => Simplify::Off,
            Some(t) if t.is_finite() && t > 0.0 => Simplify::Tolerance(t),
            Some(_) => {
                return Err(OptionError::new(
                    "simplify",
                    "must be a finite number >= 0 (0 keeps every triangle)",
                ));
            }
        };
        Ok(ContourRequest {
            source,
            thresholds,
            method,
            lattice,
            unknown,
            anisotropy,
            min_volume: self.min_volume,
            relax,
            report,
            interpolant,
            simplify,
        })
    }
}
