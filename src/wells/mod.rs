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

/// One input file held in memory: its name (for error messages) and its bytes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InputFile {
    pub name: String,
    pub bytes: Vec<u8>,
}

/// Everything a caller (CLI, service, test) can hand to [`Input::load`]. Files are in
/// memory so the service and the CLI share one code path; the CLI reads paths into
/// `InputFile`s. Exactly one kind of source (samples CSV, wells JSON, drill-hole tables,
/// LAS) is expected per load.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Input {
    /// Samples CSV: `well,x,y,z,value` (aliases in design.md).
    pub samples_csv: Option<InputFile>,
    /// Wells JSON (design.md).
    pub wells_json: Option<InputFile>,
    /// Drill-hole tables: collar, survey, interval CSVs.
    pub collars_csv: Option<InputFile>,
    pub surveys_csv: Option<InputFile>,
    pub intervals_csv: Option<InputFile>,
    /// LAS 2.0 files and the table placing each well (name -> x, y, elevation).
    pub las: Vec<InputFile>,
    pub locations_csv: Option<InputFile>,
    /// Column (interval variable or LAS curve) holding the value to contour.
    pub variable: Option<String>,
    /// Categorical codes that count as inside (value 1); others are 0.
    pub inside_codes: Vec<String>,
    /// Composite length (input units); `None` uses interval midpoints.
    pub composite_length: Option<f64>,
    /// `Some(true)`: dips below horizontal are negative numbers; `None`: detect.
    pub dip_down_negative: Option<bool>,
    /// CRS to report when the input does not carry one.
    pub crs: Option<String>,
    /// Horizontal length unit ("m" or "ft"); `None`: metres unless the input says otherwise.
    pub unit: Option<String>,
}
