//! The field between the holes: a kriging model fitted to the samples, evaluated where the
//! surface is.
//!
//! [`Field::fit`] finds every parameter the request leaves open from the data (sill and
//! nugget from the variance and the down-hole variogram, the ore's orientation and ranges
//! from the intercepts at the lowest level, the plane checked by a variogram map, and the
//! map drawn again around anchors where the plane may turn: [`local`]), builds a
//! [`kriging::BlockKriging`] in the anisotropy ellipsoid's range units, and
//! [`infill::infill`] places the points where the field is evaluated. `contour`
//! tetrahedralizes the samples with those points and runs DMT unchanged on the field's
//! values (docs/field.md).
//!
//! This is a geometry room: no async runtime, no web framework, no database.

pub mod contacts;
pub mod continuity;
pub mod estimate;
pub mod frame;
pub mod infill;
pub mod kernel;
pub mod kriging;
pub mod local;
pub mod transform;
pub mod tune;

use glam::DVec3;
use serde::Serialize;

pub use estimate::{InterceptGeometry, Samples, Spacing};
pub use frame::{Ellipsoid, Orientation};
pub use kriging::Neighbourhood;
pub use transform::{Transform, TransformKind};

/// The signed distances to the contacts are capped at this many minor ranges: far from
/// every contact a sample says "ore" or "waste", not how far (docs/field.md).
pub const CONTACT_CAP_MINOR: f64 = 0.5;

/// What a request may fix of the model; everything left `None` is found from the data.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelOptions {
    /// Ranges along the major, semi-major and minor axes, in input units.
    pub ranges: Option<[f64; 3]>,
    pub orientation: Option<Orientation>,
    /// Sill and nugget in the units of the (transformed) values squared.
    pub sill: Option<f64>,
    pub nugget: Option<f64>,
    /// Order of the spheroidal covariance (3, 5 or 7).
    pub order: u8,
    pub transform: TransformKind,
    /// Values above this are capped to it before the fit.
    pub top_cut: Option<f64>,
    /// Finest infill step along the major axis, input units; `None`: 1/32 of the range.
    pub resolution: Option<f64>,
    pub neighbourhood: Neighbourhood,
    /// How 0/1 values (flags, `--inside CODE`) are modelled.
    pub flag_field: FlagField,
    /// How the orientation and ranges are found when they are not given.
    pub shape_from: ShapeFrom,
    /// Whether the plane may turn in space (`local.rs`).
    pub orientation_field: OrientationField,
}

/// Whether the ore's plane may turn in space.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum OrientationField {
    /// One plane everywhere (the anchors are still drawn and reported).
    #[default]
    Global,
    /// The kriging blocks turn to the planes of the anchors that fit their pairs clearly
    /// better (`local.rs`); the infill lattice and the model's extent keep the global
    /// frame (docs/field.md).
    Varying,
}

impl std::str::FromStr for OrientationField {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "varying" => Ok(OrientationField::Varying),
            "global" => Ok(OrientationField::Global),
            other => Err(format!(
                "unknown orientation field {other:?}: expected varying or global"
            )),
        }
    }
}

/// How the orientation and ranges are found when a request does not give them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShapeFrom {
    /// The rules of docs/field.md: the intercepts' geometry, the plane checked by the
    /// variogram map.
    #[default]
    Rules,
    /// The rules' model, then other planes and scaled ranges, kept when they predict
    /// held-out holes better (`tune.rs`).
    CrossValidation,
}

impl std::str::FromStr for ShapeFrom {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "rules" => Ok(ShapeFrom::Rules),
            "cross-validation" => Ok(ShapeFrom::CrossValidation),
            other => Err(format!(
                "unknown way to find the shape {other:?}: expected rules or cross-validation"
            )),
        }
    }
}

/// How a field of 0/1 values is modelled (grades are modelled as they are).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FlagField {
    /// The signed distance to the contacts down each hole, contoured at zero
    /// (`contacts.rs`).
    #[default]
    Distance,
    /// The kriged 0s and 1s, contoured at the threshold (0.5).
    Indicator,
}

impl std::str::FromStr for FlagField {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "distance" => Ok(FlagField::Distance),
            "indicator" => Ok(FlagField::Indicator),
            other => Err(format!(
                "unknown flag field {other:?}: expected distance or indicator"
            )),
        }
    }
}

impl Default for ModelOptions {
    fn default() -> Self {
        ModelOptions {
            ranges: None,
            orientation: None,
            sill: None,
            nugget: None,
            order: kernel::DEFAULT_ORDER,
            transform: TransformKind::None,
            top_cut: None,
            resolution: None,
            neighbourhood: Neighbourhood::default(),
            flag_field: FlagField::default(),
            shape_from: ShapeFrom::default(),
            orientation_field: OrientationField::default(),
        }
    }
}

/// Where a parameter came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    Given,
    /// From the intercepts at the lowest level.
    Intercepts,
    /// From the down-hole variogram or the variance (sill, nugget), or the variogram map
    /// (the orientation, and the minor range of ore that is not a lens; `continuity.rs`).
    Variogram,
    /// No rule applied (too few holes cut the ore): the documented fallback.
    Default,
    /// The intercepts' ranges scaled by leave-holes-out cross-validation (`tune.rs`).
    CrossValidation,
}

/// Every parameter of a fitted model, as the summary records it: enough to reproduce the
/// run by passing them back as options.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FieldParams {
    pub kernel: String,
    pub order: u8,
    pub sill: f64,
    pub nugget: f64,
    /// Major, semi-major, minor, input units.
    pub ranges: [f64; 3],
    pub orientation: Orientation,
    pub sources: ParamSources,
    pub transform: TransformKind,
    /// How 0/1 values are modelled (the option; it applies only when every value is 0 or 1).
    pub flag_field: FlagField,
    /// The cap of the signed distances, input units, when the field is the distance to the
    /// contacts of a flag; `None` otherwise.
    pub contact_cap: Option<f64>,
    pub top_cut: Option<f64>,
    /// Samples whose value the top-cut lowered.
    pub top_cut_samples: usize,
    pub neighbourhood: Neighbourhood,
    pub spacing: Spacing,
    /// What the intercepts said, when enough holes cut the ore (before the bounds).
    pub intercepts: Option<InterceptGeometry>,
    /// How the orientation and ranges were to be found when not given (the option).
    pub shape_from: ShapeFrom,
    /// The cross-validated candidates (planes and ranges), when they were searched.
    pub shape_search: Option<tune::ShapeSearch>,
    pub orientation_field: OrientationField,
    /// The anchors of orientations that vary in space (`local.rs`), when drawn.
    pub local_planes: Option<local::LocalPlanes>,
    pub samples: usize,
    pub holes: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ParamSources {
    pub sill: Source,
    pub nugget: Source,
    pub orientation: Source,
    pub ranges: Source,
}

/// A fitted model.
#[derive(Debug)]
pub struct Field {
    pub params: FieldParams,
    pub transform: Transform,
    pub ellipsoid: Ellipsoid,
    kriging: kriging::BlockKriging,
    samples_unit: Vec<DVec3>,
}

/// Why a model cannot be fitted.
#[derive(Debug, thiserror::Error)]
pub enum FieldError {
    #[error("no samples with a known value to model")]
    NoSamples,
    #[error("{0}")]
    Option(String),
    #[error("cancelled")]
    Cancelled,
}

impl Field {
    /// Fits the model to `samples` (raw values) for the raw `levels` (thresholds), with
    /// what `options` fixes and the rest from the data.
    pub fn fit(
        samples: &Samples,
        levels: &[f64],
        options: &ModelOptions,
    ) -> Result<Field, FieldError> {
        Field::fit_cancellable(samples, levels, options, &|| false)
    }

    /// [`Field::fit`], stopping with [`FieldError::Cancelled`] when `cancelled` turns true.
    pub fn fit_cancellable(
        samples: &Samples,
        levels: &[f64],
        options: &ModelOptions,
        cancelled: &(dyn Fn() -> bool + Sync),
    ) -> Result<Field, FieldError> {
        if samples.values.is_empty() {
            return Err(FieldError::NoSamples);
        }
        let kernel = kernel::Spheroidal::new(options.order).ok_or_else(|| {
            FieldError::Option(format!(
                "spheroidal order {} is not one of {:?}",
                options.order,
                kernel::ORDERS
            ))
        })?;
        let (values, top_cut_samples) = top_cut(&samples.values, options.top_cut);
        let transform = Transform::fit(options.transform, &values);
        let t = Samples {
            points: samples.points.clone(),
            values: values.iter().map(|&v| transform.apply(v)).collect(),
            holes: samples.holes.clone(),
        };
        let holes = t.by_hole();
        let spacing = estimate::spacing(&t, &holes);
        let (sill, nugget, sill_nugget_sources) = sill_and_nugget(&t, &holes, options);
        let level = levels.iter().copied().fold(f64::INFINITY, f64::min);
        let cuts = estimate::intercepts(&t, &holes, transform.apply(level), spacing.sample);
        let geometry = ore_geometry(
            &t,
            &cuts,
            transform.apply(level),
            spacing,
            options.orientation,
        );
        let (orientation, ranges, mut orientation_source, mut range_source) =
            shape(options, geometry.as_ref(), spacing);
        let search = options.shape_from == ShapeFrom::CrossValidation
            && matches!(range_source, Source::Intercepts | Source::Variogram);
        let planes = if search {
            plane_candidates(
                &t,
                &cuts,
                transform.apply(level),
                spacing,
                orientation,
                options,
            )
        } else {
            Vec::new()
        };
        // Where the ore's plane turns (not when the plane is given or searched for).
        let local_planes = (!search
            && matches!(orientation_source, Source::Intercepts | Source::Variogram))
        .then(|| {
            let global = Ellipsoid::new(orientation, ranges);
            local::LocalPlanes::estimate(&t, transform.apply(level), spacing.hole, &global)
        })
        .flatten();
        let (transform, t, sill, nugget) = to_contacts(
            t,
            &holes,
            (transform, level),
            (sill, nugget),
            ranges,
            options,
        );
        let nugget_share = if sill > 0.0 {
            (nugget / sill).clamp(0.0, 0.99)
        } else {
            0.0
        };
        let shape_search = if search {
            let problem = tune::Problem {
                samples: &t,
                level: transform.apply(level),
                orientations: planes,
                ranges,
                min_plane: estimate::RANGE_HOLE_SPACINGS.0 * spacing.hole,
                kernel,
                nugget_share,
                neighbourhood: options.neighbourhood,
            };
            tune::search(&problem, cancelled).map_err(|tune::Cancelled| FieldError::Cancelled)?
        } else {
            None
        };
        let (orientation, ranges) = chosen_shape(
            shape_search.as_ref(),
            (orientation, ranges),
            (&mut orientation_source, &mut range_source),
        );
        let ellipsoid = Ellipsoid::new(orientation, ranges);
        let samples_unit: Vec<DVec3> = t.points.iter().map(|p| ellipsoid.to_unit(*p)).collect();
        let model_levels: Vec<f64> = levels.iter().map(|&l| transform.apply(l)).collect();
        let frames = local_planes
            .as_ref()
            .filter(|_| options.orientation_field == OrientationField::Varying)
            .and_then(|p| local::LocalFrames::new(p, ellipsoid));
        let kriging = kriging::BlockKriging::new(
            kernel,
            nugget_share,
            samples_unit.clone(),
            t.values.clone(),
            t.holes.clone(),
            options.neighbourhood,
        )
        .with_frames(frames)
        .with_levels(&model_levels);
        let params = FieldParams {
            kernel: "spheroidal".into(),
            order: kernel.order(),
            sill,
            nugget,
            ranges,
            orientation,
            sources: ParamSources {
                sill: sill_nugget_sources.0,
                nugget: sill_nugget_sources.1,
                orientation: orientation_source,
                ranges: range_source,
            },
            transform: options.transform,
            flag_field: options.flag_field,
            contact_cap: match transform {
                Transform::Contacts { cap, .. } => Some(cap),
                _ => None,
            },
            top_cut: options.top_cut,
            top_cut_samples,
            neighbourhood: options.neighbourhood,
            spacing,
            intercepts: geometry,
            shape_from: options.shape_from,
            shape_search,
            orientation_field: options.orientation_field,
            local_planes,
            samples: t.values.len(),
            holes: holes.len(),
        };
        Ok(Field {
            params,
            transform,
            ellipsoid,
            kriging,
            samples_unit,
        })
    }

    /// The samples in range units.
    pub fn samples_unit(&self) -> &[DVec3] {
        &self.samples_unit
    }

    /// The (transformed) field at `points` (local coordinates); `None` if cancelled.
    pub fn evaluate(
        &self,
        points: &[DVec3],
        cancelled: &(dyn Fn() -> bool + Sync),
    ) -> Option<Vec<f64>> {
        let unit: Vec<DVec3> = points.iter().map(|p| self.ellipsoid.to_unit(*p)).collect();
        self.kriging.evaluate(&unit, cancelled)
    }

    /// Kriging blocks solved so far.
    pub fn blocks_solved(&self) -> usize {
        self.kriging.blocks_solved()
    }

    /// Refinement levels for a finest major-axis step of `resolution` (input units).
    pub fn levels_for(&self, resolution: Option<f64>) -> u32 {
        match resolution {
            None => infill::DEFAULT_LEVELS,
            Some(r) => {
                let coarse = infill::COARSE_STEP * self.ellipsoid.ranges[0];
                let levels = (coarse / r).log2().ceil();
                levels.clamp(0.0, f64::from(infill::MAX_LEVELS)) as u32
            }
        }
    }
}

/// `true` when values from `lo` to `hi` lie on both sides of one of `levels`: some below
/// it and some at or above it (a value equal to a level is marked, as DMT marks it).
pub(crate) fn straddles(levels: &[f64], lo: f64, hi: f64) -> bool {
    levels.iter().any(|&l| lo < l && l <= hi)
}

/// The ore's geometry from the intercepts, in the plane of their principal axes unless
/// the variogram map finds a plane of clearly better continuity (by more than
/// [`estimate::MAP_MARGIN`]): then in the map's plane. With an orientation `given` by
/// hand, measured along its axes (its extent, thickness and the map's share across it).
fn ore_geometry(
    t: &Samples,
    cuts: &[estimate::Intercept],
    level: f64,
    spacing: Spacing,
    given: Option<Orientation>,
) -> Option<InterceptGeometry> {
    let own = estimate::intercept_geometry(cuts, None)?;
    let map = continuity::DirectionBins::new(t, level, spacing.hole);
    let scores = map
        .as_ref()
        .and_then(|m| Some((m.best()?, m.score(own.orientation.axes()[2])?)));
    let Some((best, own_gamma)) = scores else {
        return match given {
            Some(o) => estimate::intercept_geometry_in(cuts, o),
            None => Some(own),
        };
    };
    let (mut geometry, used, along) = match given {
        Some(o) => {
            let g = estimate::intercept_geometry_in(cuts, o)?;
            let along = map.as_ref().and_then(|m| m.score(o.axes()[2]));
            (g, false, along)
        }
        None => {
            let mapped = (best.gamma < own_gamma * (1.0 - estimate::MAP_MARGIN))
                .then(|| estimate::intercept_geometry(cuts, Some(best.normal)))
                .flatten();
            let used = mapped.is_some();
            let along = if used { best.gamma } else { own_gamma };
            (mapped.unwrap_or(own), used, Some(along))
        }
    };
    let across_gamma = map
        .as_ref()
        .and_then(|m| m.across(geometry.orientation.axes()[2]));
    let across_share = across_gamma
        .zip(along)
        .filter(|&(_, along)| along < 0.5)
        .map(|(a, along)| (1.0 - 2.0 * a) / (1.0 - 2.0 * along));
    geometry.map = Some(estimate::MapScores {
        plane: Orientation::from_axes(geometry.orientation.axes()[0], best.normal),
        gamma: best.gamma,
        intercepts_gamma: own_gamma,
        used,
        across_gamma,
        across_share,
    });
    Some(geometry)
}

/// The planes cross-validation chooses among: the run's own `orientation` first, then
/// (unless the orientation is given) the intercepts' plane and the variogram map's
/// [`tune::MAP_PLANES`] lowest minima, each with its major axis from the intercepts and
/// none within [`tune::PLANE_SEPARATION`] of one before it.
fn plane_candidates(
    t: &Samples,
    cuts: &[estimate::Intercept],
    level: f64,
    spacing: Spacing,
    orientation: Orientation,
    options: &ModelOptions,
) -> Vec<Orientation> {
    let mut out = vec![orientation];
    if options.orientation.is_some() {
        return out;
    }
    let mut normals: Vec<DVec3> = Vec::new();
    if let Some(g) = estimate::intercept_geometry(cuts, None) {
        normals.push(g.orientation.axes()[2]);
    }
    if let Some(map) = continuity::DirectionBins::new(t, level, spacing.hole) {
        let minima = map.minima(tune::MAP_PLANES, tune::PLANE_SEPARATION);
        normals.extend(minima.iter().map(|c| c.normal));
    }
    let cos = tune::PLANE_SEPARATION.to_radians().cos();
    for n in normals {
        if out.iter().any(|o| o.axes()[2].dot(n).abs() >= cos) {
            continue;
        }
        if let Some(g) = estimate::intercept_geometry(cuts, Some(n)) {
            out.push(g.orientation);
        }
    }
    out
}

/// The orientation and ranges cross-validation chose, when it chose another candidate than
/// the rules' (whose sources then become [`Source::CrossValidation`]).
fn chosen_shape(
    search: Option<&tune::ShapeSearch>,
    (orientation, ranges): (Orientation, [f64; 3]),
    (orientation_source, range_source): (&mut Source, &mut Source),
) -> (Orientation, [f64; 3]) {
    match search {
        Some(s) if s.chosen != 0 => {
            let c = s.candidates[s.chosen];
            if c.orientation != orientation {
                *orientation_source = Source::CrossValidation;
            }
            if c.ranges != ranges {
                *range_source = Source::CrossValidation;
            }
            (c.orientation, c.ranges)
        }
        _ => (orientation, ranges),
    }
}

/// The samples as signed distances to their contacts, with the sill and nugget that go
/// with them, when they are 0/1 flags modelled by distance (`contacts_cap`); else as
/// they are.
fn to_contacts(
    t: Samples,
    holes: &[Vec<u32>],
    (transform, level): (Transform, f64),
    (sill, nugget): (f64, f64),
    ranges: [f64; 3],
    options: &ModelOptions,
) -> (Transform, Samples, f64, f64) {
    let Some(cap) = contacts_cap(&t, ranges, options) else {
        return (transform, t, sill, nugget);
    };
    let level = transform.apply(level);
    let share = if sill > 0.0 { nugget / sill } else { 0.0 };
    let values = contacts::signed_distances(&t, holes, level, cap);
    let t = Samples { values, ..t };
    let (d_sill, _) = estimate::sill_and_nugget(&t, holes);
    let sill = options.sill.unwrap_or(d_sill);
    let nugget = options.nugget.unwrap_or(share * sill);
    (Transform::Contacts { level, cap }, t, sill, nugget)
}

/// The cap of the signed distances when a flag is modelled by its contacts
/// ([`CONTACT_CAP_MINOR`] minor ranges): `None` for an indicator, or when a value is
/// neither 0 nor 1 (a grade).
fn contacts_cap(t: &Samples, ranges: [f64; 3], options: &ModelOptions) -> Option<f64> {
    let binary = t.values.iter().all(|v| *v == 0.0 || *v == 1.0);
    (binary && options.flag_field == FlagField::Distance).then_some(CONTACT_CAP_MINOR * ranges[2])
}

/// Values capped at `cut`, and how many were.
fn top_cut(values: &[f64], cut: Option<f64>) -> (Vec<f64>, usize) {
    match cut {
        None => (values.to_vec(), 0),
        Some(c) => (
            values.iter().map(|&v| v.min(c)).collect(),
            values.iter().filter(|&&v| v > c).count(),
        ),
    }
}

fn sill_and_nugget(
    t: &Samples,
    holes: &[Vec<u32>],
    options: &ModelOptions,
) -> (f64, f64, (Source, Source)) {
    let (sill, nugget) = estimate::sill_and_nugget(t, holes);
    let sill_used = options.sill.unwrap_or(sill);
    let nugget_used = options
        .nugget
        .unwrap_or(nugget.min(estimate::MAX_NUGGET_SHARE * sill_used));
    let src = |given: bool| {
        if given {
            Source::Given
        } else {
            Source::Variogram
        }
    };
    (
        sill_used,
        nugget_used,
        (src(options.sill.is_some()), src(options.nugget.is_some())),
    )
}

/// The orientation and ranges: given, from the intercepts, or the fallback (flat, in-plane
/// ranges of three hole spacings, the minor a quarter of that).
fn shape(
    options: &ModelOptions,
    geometry: Option<&InterceptGeometry>,
    spacing: Spacing,
) -> (Orientation, [f64; 3], Source, Source) {
    let (orientation, orientation_source) = match (options.orientation, geometry) {
        (Some(o), _) => (o, Source::Given),
        (None, Some(g)) if g.map.is_some_and(|m| m.used) => (g.orientation, Source::Variogram),
        (None, Some(g)) => (g.orientation, Source::Intercepts),
        (None, None) => (Orientation::FLAT, Source::Default),
    };
    if let Some(r) = options.ranges {
        return (orientation, r, orientation_source, Source::Given);
    }
    let (lo, hi) = estimate::RANGE_HOLE_SPACINGS;
    let bound = |r: f64| r.clamp(lo * spacing.hole, hi * spacing.hole);
    let min_minor = estimate::MIN_MINOR_SAMPLES * spacing.sample;
    match geometry {
        Some(g) => {
            let major = bound(g.spread[0]);
            let semi = bound(g.spread[1]).min(major);
            let thickness = g.thickness.max(min_minor);
            let massive = g
                .map
                .and_then(|m| m.across_share)
                .and_then(|share| estimate::massive_minor(thickness, share, semi));
            let (minor, source) = match massive {
                Some(m) => (m, Source::Variogram),
                None => (thickness, Source::Intercepts),
            };
            (
                orientation,
                [major, semi, minor.min(semi)],
                orientation_source,
                source,
            )
        }
        None => {
            let major = 3.0 * spacing.hole;
            let minor = (major / 4.0).max(min_minor).min(major);
            (
                orientation,
                [major, major, minor],
                orientation_source,
                Source::Default,
            )
        }
    }
}

impl Field {
    /// `true` when local point `p` is farther than the inside reach from every sample: on
    /// the model's extent, where bodies are closed by the sentinels.
    pub fn beyond_reach(&self, p: DVec3) -> bool {
        let reach = infill::INSIDE_REACH * (1.0 + 1e-6);
        !self.kriging.any_within(self.ellipsoid.to_unit(p), reach)
    }
}
