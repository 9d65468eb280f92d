//! Reading wells: samples CSV, wells JSON (and, later, drill-hole tables and LAS) into a
//! [`SampleSet`].
//!
//! Invariant: every coordinate in a `SampleSet` is finite and relative to
//! `SampleSet::origin` (the bounding-box centre of the input, in input units); a value of
//! `None` is "don't know" and is never silently turned into a number.

use glam::DVec3;
use serde::Serialize;

/// One well (drill hole) as read: its name and, for display, its path in local coordinates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Well {
    /// The hole id as written in the input.
    pub id: String,
    /// Collar (top of hole), local coordinates.
    pub collar: DVec3,
    /// Desurveyed trace from collar to the deepest sample, local coordinates (at least the
    /// collar; vertical holes have two points).
    pub trace: Vec<DVec3>,
}

/// What reading dropped or doubted, for the summary and `wellmesh inspect`.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ReadReport {
    /// Data rows (samples or intervals) read from the input.
    pub rows_read: usize,
    /// Samples whose value is "don't know" (empty, `NA`, `?`, null).
    pub unknown_values: usize,
    /// Human-readable warnings, each naming the file/row/field concerned.
    pub warnings: Vec<String>,
}

/// Samples ready for tetrahedralization.
///
/// `points[i]`, `values[i]` and `well_of[i]` describe sample `i`. Shapes: all three have
/// the same length; `well_of[i]` indexes `wells`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SampleSet {
    /// Local origin, in input units; add it to a local coordinate to get the input's.
    pub origin: DVec3,
    /// Coordinate reference system as given by the input (e.g. "EPSG:32633"), if any.
    pub crs: Option<String>,
    /// Horizontal length unit of the input ("m" or "ft").
    pub unit: String,
    pub wells: Vec<Well>,
    /// Sample positions relative to `origin`.
    pub points: Vec<DVec3>,
    /// Sample values; `None` is "don't know".
    pub values: Vec<Option<f64>>,
    /// Index into `wells` of each sample's well.
    pub well_of: Vec<u32>,
    pub report: ReadReport,
}
