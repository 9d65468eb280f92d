//! Reading wells: samples CSV, wells JSON, drill-hole tables (collar, survey, intervals,
//! desurveyed by minimum curvature) and LAS 2.0 logs into a [`SampleSet`].
//!
//! Invariant: every coordinate in a `SampleSet` is finite and relative to
//! `SampleSet::origin` (the bounding-box centre of the input, in input units); a value of
//! `None` is "don't know" and is never silently turned into a number; everything dropped or
//! changed on the way is counted in [`ReadReport`].

mod assemble;
pub mod desurvey;
mod drillhole;
pub mod las;
mod samples;
mod table;
mod values;

use glam::DVec3;
use serde::Serialize;

pub use values::BelowDetection;

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
///
/// Counters are in rows, intervals or holes as named; `warnings` name the file, line and
/// column concerned (long lists are cut after a few examples and summarised).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ReadReport {
    /// What kind of input was read: "samples_csv", "wells_json", "drillholes", "las".
    pub source: String,
    /// Data rows (samples, intervals or LAS depth rows) read from the input.
    pub rows_read: usize,
    /// Samples whose value is "don't know" (empty, `NA`, `?`, null, missing intervals).
    pub unknown_values: usize,
    /// Samples whose value was below detection (`<0.01`, or a negative sentinel in an
    /// assay table) and was replaced per [`BelowDetection`]; they are known values.
    pub below_detection: usize,
    /// Samples given as above an upper detection limit (`>10`), kept as the limit.
    pub above_detection: usize,
    /// Holes (collars, JSON wells, LAS files) read.
    pub holes_read: usize,
    /// Holes that carry at least one sample in the output.
    pub holes_used: usize,
    /// Collars without any interval (or LAS files without the curve): no samples.
    pub holes_without_samples: usize,
    /// Interval rows whose hole has no collar: dropped.
    pub intervals_without_collar: usize,
    /// Collars with an empty coordinate: dropped with their intervals.
    pub collars_without_coordinates: usize,
    /// Repeated collar ids: the first row is kept.
    pub duplicate_collars: usize,
    /// Holes with no survey station, taken as vertical.
    pub unsurveyed_holes: usize,
    /// Survey rows dropped (empty fields, repeated depth, or beyond the end of the hole).
    pub survey_rows_dropped: usize,
    /// Azimuths outside `[0, 360)` that were wrapped into it.
    pub azimuths_wrapped: usize,
    /// Holes with at least one survey station pointing above horizontal.
    pub up_holes: usize,
    /// Dip convention used: "negative-down" or "positive-down" (drill-hole tables only).
    pub dip_convention: Option<String>,
    /// Intervals dropped because `from > to`, `from == to` or a depth was empty.
    pub bad_intervals: usize,
    /// Intervals with exactly the same `from` and `to` as an earlier one: dropped.
    pub duplicate_intervals: usize,
    /// Intervals overlapping an earlier one: clipped to the uncovered part, or dropped when
    /// nothing is left.
    pub overlapping_intervals: usize,
    /// Gaps between consecutive intervals of a hole, each given one "don't know" sample.
    pub gaps: usize,
    /// Human-readable warnings, each naming the file/row/field concerned.
    pub warnings: Vec<String>,
}

/// Samples ready for tetrahedralization.
///
/// `points[i]`, `values[i]` and `well_of[i]` describe sample `i`. Shapes: all three have
/// the same length; `well_of[i]` indexes `wells`.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
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

impl InputFile {
    pub fn new(name: impl Into<String>, bytes: impl Into<Vec<u8>>) -> Self {
        Self {
            name: name.into(),
            bytes: bytes.into(),
        }
    }
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
    /// What a below-detection value becomes (default: half the detection limit).
    pub below_detection: BelowDetection,
    /// Whether a negative number in an interval (assay) table is a below-detection
    /// sentinel (`-0.01` = below 0.01). `None`: yes for interval tables, no elsewhere.
    pub negative_is_below_detection: Option<bool>,
}

/// Why an input could not be read. Messages name the file, the line (1-based, as a text
/// editor shows it) and the column or field concerned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WellsError {
    #[error(
        "no input: give a samples CSV, a wells JSON, drill-hole tables (collars + intervals) or LAS files"
    )]
    NoInput,
    #[error("more than one kind of input given ({0}); give one")]
    MixedInput(String),
    #[error("{file}: {message}")]
    Empty { file: String, message: String },
    #[error("{file}: no column for {wanted} (columns found: {found})")]
    MissingColumn {
        file: String,
        wanted: String,
        found: String,
    },
    #[error("{file}, line {line}, column '{column}': '{text}' is not a number")]
    BadNumber {
        file: String,
        line: u64,
        column: String,
        text: String,
    },
    #[error("{file}, line {line}, column '{column}': '{text}' is not a finite number")]
    NotFinite {
        file: String,
        line: u64,
        column: String,
        text: String,
    },
    #[error("{file}, line {line}, column '{column}': {message}")]
    BadField {
        file: String,
        line: u64,
        column: String,
        message: String,
    },
    #[error("{file}, line {line}: {message}")]
    BadLine {
        file: String,
        line: u64,
        message: String,
    },
    #[error("{file}: {message}")]
    Invalid { file: String, message: String },
    #[error("invalid option: {0}")]
    BadOption(String),
}

impl Input {
    /// A samples CSV (`well,x,y,z,value`).
    pub fn from_samples_csv(name: impl Into<String>, bytes: impl Into<Vec<u8>>) -> Self {
        Self {
            samples_csv: Some(InputFile::new(name, bytes)),
            ..Self::default()
        }
    }

    /// A wells JSON document (design.md).
    pub fn from_wells_json(name: impl Into<String>, bytes: impl Into<Vec<u8>>) -> Self {
        Self {
            wells_json: Some(InputFile::new(name, bytes)),
            ..Self::default()
        }
    }

    /// Drill-hole tables; `surveys` may be absent (all holes vertical, reported).
    pub fn from_drillholes(
        collars: InputFile,
        surveys: Option<InputFile>,
        intervals: InputFile,
        variable: Option<&str>,
    ) -> Self {
        Self {
            collars_csv: Some(collars),
            surveys_csv: surveys,
            intervals_csv: Some(intervals),
            variable: variable.map(str::to_owned),
            ..Self::default()
        }
    }

    /// LAS files with an optional locations table and the curve to contour.
    pub fn from_las(las: Vec<InputFile>, locations: Option<InputFile>, curve: &str) -> Self {
        Self {
            las,
            locations_csv: locations,
            variable: Some(curve.to_owned()),
            ..Self::default()
        }
    }

    /// Reads the input into a [`SampleSet`]: one code path for the CLI, the service and
    /// the tests.
    pub fn load(&self) -> Result<SampleSet, WellsError> {
        let unit = self.unit()?;
        if let Some(length) = self.composite_length
            && !(length.is_finite() && length > 0.0)
        {
            return Err(WellsError::BadOption(format!(
                "composite length {length} is not a positive number"
            )));
        }
        let mut kinds = Vec::new();
        if self.samples_csv.is_some() {
            kinds.push("samples CSV");
        }
        if self.wells_json.is_some() {
            kinds.push("wells JSON");
        }
        let tables = self.collars_csv.is_some()
            || self.surveys_csv.is_some()
            || self.intervals_csv.is_some();
        if tables {
            kinds.push("drill-hole tables");
        }
        if !self.las.is_empty() {
            kinds.push("LAS");
        }
        if kinds.len() > 1 {
            return Err(WellsError::MixedInput(kinds.join(", ")));
        }
        if self.locations_csv.is_some() && self.las.is_empty() {
            return Err(WellsError::BadOption(
                "a locations table places LAS wells; give LAS files with it".into(),
            ));
        }
        let holes = if let Some(file) = &self.samples_csv {
            samples::read_samples_csv(file, self, unit)?
        } else if let Some(file) = &self.wells_json {
            samples::read_wells_json(file, self, unit)?
        } else if tables {
            drillhole::read_tables(self, unit)?
        } else if !self.las.is_empty() {
            las::read_las_wells(self, unit)?
        } else {
            return Err(WellsError::NoInput);
        };
        let crs = holes.crs.clone().or_else(|| self.crs.clone());
        assemble::finish(holes, crs, unit)
    }

    fn unit(&self) -> Result<Unit, WellsError> {
        match &self.unit {
            None => Ok(Unit::Metre),
            Some(text) => Unit::parse(text).ok_or_else(|| {
                WellsError::BadOption(format!("unit '{text}' is neither 'm' nor 'ft'"))
            }),
        }
    }
}

/// A horizontal and vertical length unit of the input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Unit {
    Metre,
    Foot,
}

impl Unit {
    /// Parses `m`, `metre(s)`, `meter(s)`, `ft`, `f`, `feet`, `foot` (any case).
    pub(crate) fn parse(text: &str) -> Option<Unit> {
        match text.trim().to_ascii_lowercase().as_str() {
            "m" | "metre" | "metres" | "meter" | "meters" => Some(Unit::Metre),
            "ft" | "f" | "feet" | "foot" | "usft" => Some(Unit::Foot),
            _ => None,
        }
    }

    pub(crate) fn name(self) -> &'static str {
        match self {
            Unit::Metre => "m",
            Unit::Foot => "ft",
        }
    }

    /// Length of one of `self` in metres.
    fn metres(self) -> f64 {
        match self {
            Unit::Metre => 1.0,
            Unit::Foot => 0.3048,
        }
    }

    /// Factor turning a length in `self` into a length in `to`.
    pub(crate) fn factor_to(self, to: Unit) -> f64 {
        self.metres() / to.metres()
    }
}

/// Figures describing a [`SampleSet`], for `wellmesh inspect` and service logs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SetSummary {
    pub source: String,
    pub unit: String,
    pub crs: Option<String>,
    /// Local origin (input coordinates).
    pub origin: [f64; 3],
    pub wells: usize,
    pub samples: usize,
    pub known_values: usize,
    pub unknown_values: usize,
    /// Smallest and largest known value, if any value is known.
    pub value_range: Option<[f64; 2]>,
    /// Whether every known value is 0 or 1.
    pub binary: bool,
    /// `[[min x, min y, min z], [max x, max y, max z]]` of the samples, input coordinates.
    pub bbox: [[f64; 3]; 2],
    pub report: ReadReport,
}

impl SampleSet {
    /// Counts, ranges and the read report in one serializable value.
    pub fn summary(&self) -> SetSummary {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &self.points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if self.points.is_empty() {
            lo = DVec3::ZERO;
            hi = DVec3::ZERO;
        }
        let (lo, hi) = (lo + self.origin, hi + self.origin);
        let known: Vec<f64> = self.values.iter().flatten().copied().collect();
        let value_range = known.iter().fold(None, |acc: Option<[f64; 2]>, &v| {
            Some(match acc {
                None => [v, v],
                Some([a, b]) => [a.min(v), b.max(v)],
            })
        });
        SetSummary {
            source: self.report.source.clone(),
            unit: self.unit.clone(),
            crs: self.crs.clone(),
            origin: self.origin.to_array(),
            wells: self.wells.len(),
            samples: self.points.len(),
            known_values: known.len(),
            unknown_values: self.values.len() - known.len(),
            value_range,
            binary: !known.is_empty() && known.iter().all(|&v| v == 0.0 || v == 1.0),
            bbox: [lo.to_array(), hi.to_array()],
            report: self.report.clone(),
        }
    }
}
