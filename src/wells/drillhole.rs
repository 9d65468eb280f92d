//! Drill-hole tables (collar, survey, intervals) to samples: dip convention, azimuth wrap,
//! minimum-curvature desurvey, interval clean-up, midpoints or length-weighted composites.
//!
//! Invariant: every interval that reaches the samples lies in its hole's depth order without
//! overlap (duplicates dropped, overlaps clipped, each counted); a gap between intervals is a
//! "don't know" sample, never an invented value.

use std::collections::HashMap;

use glam::DVec3;

use super::assemble::{HoleSamples, Holes, examples};
use super::desurvey::{Station, Trajectory};
use super::table::{Table, aliases};
use super::values::{Reading, ValueRules, read_code};
use super::{Input, ReadReport, Unit, WellsError};

/// One interval of a hole, depths in input units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Interval {
    /// Line in the source file (for messages).
    pub line: u64,
    pub from: f64,
    pub to: f64,
    pub value: Option<f64>,
    /// Where the midpoint sample goes when it is not `(from + to) / 2` (LAS depth rows).
    pub at: Option<f64>,
}

/// Example lists for the warnings, one per kind of problem.
#[derive(Debug, Default)]
pub(crate) struct Issues {
    pub bad: Vec<String>,
    pub duplicate: Vec<String>,
    pub overlap: Vec<String>,
}

impl Issues {
    pub fn into_warnings(self, file: &str, report: &mut ReadReport) {
        if !self.bad.is_empty() {
            report.warnings.push(format!(
                "{file}: {} intervals dropped (from > to, from = to, or an empty depth): {}",
                self.bad.len(),
                examples(&self.bad)
            ));
        }
        if !self.duplicate.is_empty() {
            report.warnings.push(format!(
                "{file}: {} duplicate intervals dropped (same hole, from and to as an earlier row; the first row is kept): {}",
                self.duplicate.len(),
                examples(&self.duplicate)
            ));
        }
        if !self.overlap.is_empty() {
            report.warnings.push(format!(
                "{file}: {} overlapping intervals clipped to the part not already covered (dropped when nothing is left): {}",
                self.overlap.len(),
                examples(&self.overlap)
            ));
        }
    }
}

/// Sorts a hole's intervals by depth and resolves duplicates and overlaps: an interval with
/// the same `from` and `to` as an earlier (kept) one is dropped; one that starts inside an
/// earlier one is clipped to start where that one ends, or dropped if nothing is left.
/// Within equal `from`, file order decides which is earlier.
pub(crate) fn resolve_intervals(
    hole: &str,
    mut intervals: Vec<Interval>,
    report: &mut ReadReport,
    issues: &mut Issues,
) -> Vec<Interval> {
    intervals.sort_by(|a, b| {
        a.from
            .total_cmp(&b.from)
            .then(a.to.total_cmp(&b.to))
            .then(a.line.cmp(&b.line))
    });
    let mut kept: Vec<Interval> = Vec::with_capacity(intervals.len());
    for mut iv in intervals {
        if let Some(last) = kept.last() {
            if iv.from == last.from && iv.to == last.to {
                report.duplicate_intervals += 1;
                let differs = if iv.value == last.value {
                    ""
                } else {
                    ", different value"
                };
                issues.duplicate.push(format!(
                    "hole {hole} line {} repeats line {}{differs}",
                    iv.line, last.line
                ));
                continue;
            }
            if iv.from < last.to {
                report.overlapping_intervals += 1;
                issues.overlap.push(format!(
                    "hole {hole} line {} ({}-{}) overlaps line {} ({}-{})",
                    iv.line, iv.from, iv.to, last.line, last.from, last.to
                ));
                if iv.to <= last.to {
                    continue;
                }
                iv.from = last.to;
                if iv.at.is_some_and(|a| a < iv.from) {
                    iv.at = None;
                }
            }
        }
        kept.push(iv);
    }
    kept
}

/// Sample depths and values of a hole's resolved intervals: midpoints (plus one unknown
/// sample in each gap), or composites of `length` from the first `from`, each the
/// length-weighted mean of the known values it covers, unknown when less than half of it
/// is covered by known values.
///
/// `Err(n)`: the hole would need `n` composites, more than [`MAX_COMPOSITES_PER_HOLE`].
pub(crate) fn interval_samples(
    intervals: &[Interval],
    composite: Option<f64>,
    report: &mut ReadReport,
) -> Result<Vec<(f64, Option<f64>)>, f64> {
    let mut out = Vec::new();
    if intervals.is_empty() {
        return Ok(out);
    }
    match composite {
        None => {
            for (i, iv) in intervals.iter().enumerate() {
                if i > 0 {
                    let prev = intervals[i - 1].to;
                    if iv.from > prev {
                        report.gaps += 1;
                        out.push(((prev + iv.from) * 0.5, None));
                    }
                }
                out.push((iv.at.unwrap_or((iv.from + iv.to) * 0.5), iv.value));
            }
        }
        Some(length) => {
            for i in 1..intervals.len() {
                if intervals[i].from > intervals[i - 1].to {
                    report.gaps += 1;
                }
            }
            let start = intervals[0].from;
            let end = intervals.iter().map(|iv| iv.to).fold(start, f64::max);
            let windows = ((end - start) / length).ceil().max(1.0);
            if windows.is_nan() || windows > MAX_COMPOSITES_PER_HOLE {
                return Err(windows);
            }
            let count = windows as usize;
            let mut first = 0usize;
            for k in 0..count {
                let a = start + k as f64 * length;
                let b = (a + length).min(end);
                if b <= a {
                    break;
                }
                while first < intervals.len() && intervals[first].to <= a {
                    first += 1;
                }
                let (mut known, mut sum) = (0.0, 0.0);
                for iv in &intervals[first..] {
                    if iv.from >= b {
                        break;
                    }
                    let overlap = iv.to.min(b) - iv.from.max(a);
                    if overlap > 0.0
                        && let Some(v) = iv.value
                    {
                        known += overlap;
                        sum += overlap * v;
                    }
                }
                let value = (known >= 0.5 * (b - a) && known > 0.0).then(|| sum / known);
                out.push(((a + b) * 0.5, value));
            }
        }
    }
    Ok(out)
}

/// More composites than this in one hole means the composite length is far too small for
/// the hole (or a depth is absurd): an error rather than an endless loop.
pub(crate) const MAX_COMPOSITES_PER_HOLE: f64 = 1.0e6;

/// The error for [`interval_samples`] refusing to composite.
pub(crate) fn too_many_composites(file: &str, hole: &str, windows: f64) -> WellsError {
    WellsError::Invalid {
        file: file.to_owned(),
        message: format!(
            "hole '{hole}' would need {windows:.0} composites (more than {MAX_COMPOSITES_PER_HOLE}); choose a longer --composite length"
        ),
    }
}

/// One collar row.
#[derive(Debug, Clone)]
struct Collar {
    id: String,
    position: DVec3,
    length: Option<f64>,
}

/// A survey row before the dip convention is applied (an inclination column is stored as
/// the equivalent negative-down dip, `inclination - 90`).
#[derive(Debug, Clone, Copy)]
struct RawStation {
    line: u64,
    depth: f64,
    azimuth: f64,
    dip: f64,
}

fn read_collars(
    table: &Table,
    report: &mut ReadReport,
) -> Result<(Vec<Collar>, HashMap<String, usize>), WellsError> {
    let hole = table.require("hole id", aliases::HOLE, &[])?;
    let x = table.require("x / easting", aliases::X, aliases::X_PREFIX)?;
    let y = table.require("y / northing", aliases::Y, aliases::Y_PREFIX)?;
    let z = table.find(aliases::Z, aliases::Z_PREFIX);
    let length = table.find(aliases::LENGTH, &[]);
    if z.is_none() {
        report.warnings.push(format!(
            "{}: no elevation column (z, elevation, rl...): collars taken at z = 0",
            table.file
        ));
    }
    let mut collars = Vec::new();
    let mut index = HashMap::new();
    let (mut no_coords, mut dups, mut no_id) = (Vec::new(), Vec::new(), Vec::new());
    for row in &table.rows {
        let id = row.get(hole).to_owned();
        if id.is_empty() {
            no_id.push(format!("line {}", row.line));
            continue;
        }
        let xv = table.optional_number(row, x)?;
        let yv = table.optional_number(row, y)?;
        let zv = match z {
            Some(z) => table.optional_number(row, z)?,
            None => Some(0.0),
        };
        let (Some(xv), Some(yv), Some(zv)) = (xv, yv, zv) else {
            report.collars_without_coordinates += 1;
            no_coords.push(format!("{id} (line {})", row.line));
            continue;
        };
        if index.contains_key(&id) {
            report.duplicate_collars += 1;
            dups.push(format!("{id} (line {})", row.line));
            continue;
        }
        let len = match length {
            Some(c) => table.optional_number(row, c)?,
            None => None,
        };
        index.insert(id.clone(), collars.len());
        collars.push(Collar {
            id,
            position: DVec3::new(xv, yv, zv),
            length: len,
        });
    }
    let file = &table.file;
    if !no_id.is_empty() {
        report.warnings.push(format!(
            "{file}: {} collar rows without a hole id skipped: {}",
            no_id.len(),
            examples(&no_id)
        ));
    }
    if !no_coords.is_empty() {
        report.warnings.push(format!(
            "{file}: {} collars with an empty coordinate dropped with their intervals: {}",
            no_coords.len(),
            examples(&no_coords)
        ));
    }
    if !dups.is_empty() {
        report.warnings.push(format!(
            "{file}: {} repeated collar ids ignored (the first row is kept): {}",
            dups.len(),
            examples(&dups)
        ));
    }
    Ok((collars, index))
}

/// Survey stations per collar, and whether they came from an inclination column (degrees
/// from vertical, 0 = down: no sign convention to guess) rather than a dip column.
fn read_surveys(
    table: &Table,
    index: &HashMap<String, usize>,
    report: &mut ReadReport,
) -> Result<(Vec<Vec<RawStation>>, bool), WellsError> {
    let hole = table.require("hole id", aliases::HOLE, &[])?;
    let depth = table.require("survey depth", aliases::SURVEY_DEPTH, &[])?;
    let azimuth = table.require("azimuth", aliases::AZIMUTH, &[])?;
    let (dip, inclination) = match table.find(aliases::DIP, &[]) {
        Some(c) => (c, false),
        None => match table.find(aliases::INCLINATION, &[]) {
            Some(c) => (c, true),
            None => (
                table.require("dip (or inclination)", aliases::DIP, &[])?,
                false,
            ),
        },
    };
    let mut out = vec![Vec::new(); index.len()];
    let (mut orphans, mut empty) = (0usize, Vec::new());
    for row in &table.rows {
        let id = row.get(hole);
        let Some(&h) = index.get(id) else {
            orphans += 1;
            continue;
        };
        let d = table.optional_number(row, depth)?;
        let a = table.optional_number(row, azimuth)?;
        let p = table.optional_number(row, dip)?;
        let (Some(d), Some(a), Some(p)) = (d, a, p) else {
            empty.push(format!("line {}", row.line));
            continue;
        };
        let (valid, p) = if inclination {
            ((0.0..=180.0).contains(&p), p - 90.0)
        } else {
            (p.abs() <= 90.0, p)
        };
        if !valid {
            let range = if inclination { "0..180" } else { "-90..90" };
            return Err(WellsError::BadField {
                file: table.file.clone(),
                line: row.line,
                column: table.headers[dip].clone(),
                message: format!("'{}' is outside {range} degrees", row.get(dip)),
            });
        }
        out[h].push(RawStation {
            line: row.line,
            depth: d,
            azimuth: a,
            dip: p,
        });
    }
    report.survey_rows_dropped += orphans + empty.len();
    if orphans > 0 {
        report.warnings.push(format!(
            "{}: {orphans} survey rows name a hole that has no (usable) collar: ignored",
            table.file
        ));
    }
    if !empty.is_empty() {
        report.warnings.push(format!(
            "{}: {} survey rows with an empty depth, azimuth or dip ignored: {}",
            table.file,
            empty.len(),
            examples(&empty)
        ));
    }
    Ok((out, inclination))
}

/// Decides the dip convention: the given one, or the sign most non-zero dips carry.
fn dip_convention(
    file: &str,
    stations: &[Vec<RawStation>],
    given: Option<bool>,
    report: &mut ReadReport,
) -> bool {
    let (mut negative, mut positive) = (0usize, 0usize);
    for s in stations.iter().flatten() {
        if s.dip < 0.0 {
            negative += 1;
        } else if s.dip > 0.0 {
            positive += 1;
        }
    }
    let detected = negative >= positive;
    let chosen = given.unwrap_or(detected);
    let name = |neg: bool| {
        if neg {
            "negative-down"
        } else {
            "positive-down"
        }
    };
    report.dip_convention = Some(name(chosen).to_owned());
    let against = if chosen { positive } else { negative };
    if given.is_some_and(|g| g != detected) && negative != positive {
        report.warnings.push(format!(
            "{file}: --dip-down {} was given but {} of {} non-zero dips have the other sign; those stations point up",
            if chosen { "negative" } else { "positive" },
            against,
            negative + positive
        ));
    } else if given.is_none() && against > 0 {
        report.warnings.push(format!(
            "{file}: dip convention detected as {} ({} of {} non-zero dips); the other {} stations are read as pointing up (up-holes). Give --dip-down to override",
            name(chosen),
            negative.max(positive),
            negative + positive,
            against
        ));
    } else if given.is_none() {
        report.warnings.push(format!(
            "{file}: dip convention detected as {} (all {} non-zero dips agree)",
            name(chosen),
            negative + positive
        ));
    }
    chosen
}

/// Reads collar, survey and interval tables into holes of samples.
pub(crate) fn read_tables(input: &Input, _unit: Unit) -> Result<Holes, WellsError> {
    let collars_file = input
        .collars_csv
        .as_ref()
        .ok_or_else(|| WellsError::BadOption("drill-hole tables need a collar table".into()))?;
    let intervals_file = input.intervals_csv.as_ref().ok_or_else(|| {
        WellsError::BadOption("drill-hole tables need an interval (assay or geology) table".into())
    })?;
    let mut report = ReadReport {
        source: "drillholes".into(),
        ..ReadReport::default()
    };
    let collar_table = Table::parse(&collars_file.name, &collars_file.bytes)?;
    let (collars, index) = read_collars(&collar_table, &mut report)?;
    report.holes_read = collars.len();
    if collars.is_empty() {
        return Err(WellsError::Empty {
            file: collars_file.name.clone(),
            message: "no usable collar rows".into(),
        });
    }

    let table = Table::parse(&intervals_file.name, &intervals_file.bytes)?;
    let rules = ValueRules {
        below: input.below_detection,
        negative_is_below: input.negative_is_below_detection.unwrap_or(true),
    };
    let mut issues = Issues::default();
    let mut per_hole = read_intervals(
        &table,
        &index,
        collars.len(),
        input,
        &rules,
        &mut report,
        &mut issues,
    )?;
    let surveys = read_survey_stations(input, &index, collars.len(), &mut report)?;

    let mut holes = Vec::with_capacity(collars.len());
    let mut counts = SurveyCounts::default();
    for (h, collar) in collars.iter().enumerate() {
        let intervals = resolve_intervals(
            &collar.id,
            std::mem::take(&mut per_hole[h]),
            &mut report,
            &mut issues,
        );
        let samples = interval_samples(&intervals, input.composite_length, &mut report)
            .map_err(|n| too_many_composites(&table.file, &collar.id, n))?;
        let deepest = intervals.iter().map(|iv| iv.to).fold(0.0, f64::max);
        let hole_length = collar.length.unwrap_or(deepest).max(deepest);
        let stations = hole_stations(
            &surveys.raw[h],
            hole_length,
            surveys.negative_down,
            &mut report,
            &mut counts,
        );
        holes.push(desurvey_hole(
            collar,
            &stations,
            samples,
            &mut report,
            &mut counts,
        ));
    }
    report_surveys(&surveys.name, input, &counts, &mut report);
    report_below_detection(&table.file, &rules, &mut report);
    issues.into_warnings(&table.file, &mut report);
    Ok(Holes {
        name: format!("{} + {}", collars_file.name, intervals_file.name),
        holes,
        crs: None,
        report,
    })
}

/// The value column of the interval table: `--variable`, else the only column besides
/// hole id, from and to.
fn value_column(
    table: &Table,
    input: &Input,
    hole: usize,
    from: usize,
    to: usize,
) -> Result<usize, WellsError> {
    if let Some(name) = &input.variable {
        return table.named(name);
    }
    let others: Vec<usize> = (0..table.headers.len())
        .filter(|&c| c != hole && c != from && c != to)
        .filter(|&c| !table.headers[c].trim().is_empty())
        .collect();
    match others.as_slice() {
        [only] => Ok(*only),
        _ => Err(WellsError::Invalid {
            file: table.file.clone(),
            message: format!(
                "choose the value column with --variable among: {}",
                others
                    .iter()
                    .map(|&c| table.headers[c].as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }),
    }
}

/// The interval table's rows as intervals of each collar's hole (`index`: hole id ->
/// collar); rows of holes without a collar and bad intervals are counted and dropped.
fn read_intervals(
    table: &Table,
    index: &HashMap<String, usize>,
    holes: usize,
    input: &Input,
    rules: &ValueRules,
    report: &mut ReadReport,
    issues: &mut Issues,
) -> Result<Vec<Vec<Interval>>, WellsError> {
    let hole = table.require("hole id", aliases::HOLE, &[])?;
    let from = table.require("from depth", aliases::FROM, &[])?;
    let to = table.require("to depth", aliases::TO, &[])?;
    let variable = value_column(table, input, hole, from, to)?;
    let categorical = !input.inside_codes.is_empty();
    let mut per_hole: Vec<Vec<Interval>> = vec![Vec::new(); holes];
    let mut orphan_ids: Vec<String> = Vec::new();
    for row in &table.rows {
        report.rows_read += 1;
        let id = row.get(hole);
        let Some(&h) = index.get(id) else {
            report.intervals_without_collar += 1;
            if !orphan_ids.iter().any(|o| o == id) {
                orphan_ids.push(id.to_owned());
            }
            continue;
        };
        let f = table.optional_number(row, from)?;
        let t = table.optional_number(row, to)?;
        let text = row.get(variable);
        let value = if categorical {
            read_code(text, &input.inside_codes)
        } else {
            let reading = rules.read(text).map_err(|()| WellsError::BadField {
                file: table.file.clone(),
                line: row.line,
                column: table.headers[variable].clone(),
                message: format!(
                    "'{text}' is not a number nor a don't-know token (for a column of codes give --inside CODE[,CODE])"
                ),
            })?;
            match reading {
                Reading::Below(_) => report.below_detection += 1,
                Reading::Above(_) => report.above_detection += 1,
                _ => {}
            }
            rules.number(reading)
        };
        match (f, t) {
            (Some(f), Some(t)) if f < t => per_hole[h].push(Interval {
                line: row.line,
                from: f,
                to: t,
                value,
                at: None,
            }),
            _ => {
                report.bad_intervals += 1;
                issues.bad.push(format!("line {}", row.line));
            }
        }
    }
    if !orphan_ids.is_empty() {
        report.warnings.push(format!(
            "{}: {} interval rows of {} holes without a usable collar dropped: {}",
            table.file,
            report.intervals_without_collar,
            orphan_ids.len(),
            examples(&orphan_ids)
        ));
    }
    if table.rows.is_empty() {
        return Err(WellsError::Empty {
            file: table.file.clone(),
            message: "no interval rows".into(),
        });
    }
    Ok(per_hole)
}

/// Every hole's survey stations as read, and how their dips are to be read.
struct Surveys {
    raw: Vec<Vec<RawStation>>,
    /// Negative dips point down.
    negative_down: bool,
    /// The survey table's file name (for warnings).
    name: String,
}

/// Reads the survey table, if any, and settles the dip convention.
fn read_survey_stations(
    input: &Input,
    index: &HashMap<String, usize>,
    holes: usize,
    report: &mut ReadReport,
) -> Result<Surveys, WellsError> {
    let (raw, inclination) = match &input.surveys_csv {
        Some(file) => {
            let survey_table = Table::parse(&file.name, &file.bytes)?;
            read_surveys(&survey_table, index, report)?
        }
        None => {
            report.warnings.push(
                "no survey table: every hole is taken as vertical from its collar".to_owned(),
            );
            (vec![Vec::new(); holes], false)
        }
    };
    let survey_name = input
        .surveys_csv
        .as_ref()
        .map(|f| f.name.as_str())
        .unwrap_or("surveys");
    let negative_down = if inclination {
        report.dip_convention = Some("inclination (0 = down)".to_owned());
        true
    } else if input.surveys_csv.is_some() {
        dip_convention(survey_name, &raw, input.dip_down_negative, report)
    } else {
        input.dip_down_negative.unwrap_or(true)
    };
    Ok(Surveys {
        raw,
        negative_down,
        name: survey_name.to_owned(),
    })
}

/// What the desurvey of all holes dropped or repaired, for the warnings.
#[derive(Default)]
struct SurveyCounts {
    unsurveyed: Vec<String>,
    beyond_end: usize,
    repeated: usize,
    reversed: usize,
}

/// A hole's stations by depth, the first of a repeated depth kept, down to the first one at
/// or beyond the end of the hole; azimuths wrapped into 0..360 and dips read as pointing
/// down.
fn hole_stations(
    raw: &[RawStation],
    hole_length: f64,
    negative_down: bool,
    report: &mut ReadReport,
    counts: &mut SurveyCounts,
) -> Vec<Station> {
    let mut stations: Vec<RawStation> = raw.to_vec();
    stations.sort_by(|a, b| a.depth.total_cmp(&b.depth).then(a.line.cmp(&b.line)));
    let before = stations.len();
    stations.dedup_by(|b, a| a.depth == b.depth);
    counts.repeated += before - stations.len();
    // Keep stations down to the first one at or beyond the end of the hole; later rows
    // (end-of-hole markers such as depth 90000) are dropped.
    if let Some(end) = stations.iter().position(|s| s.depth >= hole_length) {
        counts.beyond_end += stations.len() - (end + 1);
        stations.truncate(end + 1);
    }
    stations
        .iter()
        .map(|s| {
            let wrapped = s.azimuth.rem_euclid(360.0);
            if wrapped != s.azimuth {
                report.azimuths_wrapped += 1;
            }
            Station {
                depth: s.depth,
                azimuth_deg: wrapped,
                dip_down_deg: if negative_down { -s.dip } else { s.dip },
            }
        })
        .collect()
}

/// The hole of `collar` along its `stations` (minimum curvature): its samples (depth,
/// value) placed, and its trace through the stations down to the deepest sample.
fn desurvey_hole(
    collar: &Collar,
    stations: &[Station],
    samples: Vec<(f64, Option<f64>)>,
    report: &mut ReadReport,
    counts: &mut SurveyCounts,
) -> HoleSamples {
    if stations.iter().any(|s| s.dip_down_deg < 0.0) {
        report.up_holes += 1;
    }
    if stations.is_empty() && !samples.is_empty() {
        report.unsurveyed_holes += 1;
        counts.unsurveyed.push(collar.id.clone());
    }
    let trajectory = Trajectory::new(stations);
    counts.reversed += trajectory.reversed_segments;
    let mut trace = vec![collar.position];
    let bottom = samples.iter().map(|s| s.0).fold(0.0, f64::max);
    for &d in trajectory.station_depths() {
        if d > 0.0 && d < bottom {
            trace.push(collar.position + trajectory.position(d));
        }
    }
    if bottom > 0.0 {
        trace.push(collar.position + trajectory.position(bottom));
    }
    HoleSamples {
        id: collar.id.clone(),
        trace,
        samples: samples
            .into_iter()
            .map(|(d, v)| (collar.position + trajectory.position(d), v))
            .collect(),
    }
}

/// The warnings on the survey stations once every hole is desurveyed.
fn report_surveys(
    survey_name: &str,
    input: &Input,
    counts: &SurveyCounts,
    report: &mut ReadReport,
) {
    let SurveyCounts {
        unsurveyed,
        beyond_end,
        repeated,
        reversed,
    } = counts;
    report.survey_rows_dropped += beyond_end + repeated;
    if *repeated > 0 {
        report.warnings.push(format!(
            "{survey_name}: {repeated} survey stations repeat an earlier depth of their hole: the first is kept"
        ));
    }
    if *beyond_end > 0 {
        report.warnings.push(format!(
            "{survey_name}: {beyond_end} survey stations lie below the first station past the end of their hole (collar depth or deepest interval), e.g. end markers such as 90000: not used"
        ));
    }
    if !unsurveyed.is_empty() && input.surveys_csv.is_some() {
        report.warnings.push(format!(
            "{} holes have no survey station and are taken as vertical: {}",
            unsurveyed.len(),
            examples(unsurveyed)
        ));
    }
    if report.azimuths_wrapped > 0 {
        report.warnings.push(format!(
            "{survey_name}: {} azimuths outside 0..360 wrapped into it (e.g. 385 -> 25)",
            report.azimuths_wrapped
        ));
    }
    if *reversed > 0 {
        report.warnings.push(format!(
            "{survey_name}: {reversed} survey segments turn by 180 degrees; desurveyed by balanced tangential there"
        ));
    }
}

/// The warning on below-detection values replaced, if any.
fn report_below_detection(file: &str, rules: &ValueRules, report: &mut ReadReport) {
    if report.below_detection > 0 {
        report.warnings.push(format!(
            "{}: {} below-detection values ('<limit'{}) replaced by {}",
            file,
            report.below_detection,
            if rules.negative_is_below {
                " or negative sentinels"
            } else {
                ""
            },
            match rules.below {
                super::BelowDetection::Half => "half the detection limit",
                super::BelowDetection::Zero => "zero",
            }
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iv(line: u64, from: f64, to: f64, value: Option<f64>) -> Interval {
        Interval {
            line,
            from,
            to,
            value,
            at: None,
        }
    }

    #[test]
    fn duplicates_are_dropped_and_overlaps_clipped() {
        let mut report = ReadReport::default();
        let mut issues = Issues::default();
        let kept = resolve_intervals(
            "H",
            vec![
                iv(2, 0.0, 2.0, Some(1.0)),
                iv(3, 0.0, 2.0, Some(5.0)),
                iv(4, 1.0, 3.0, Some(2.0)),
                iv(5, 1.5, 2.5, Some(9.0)),
            ],
            &mut report,
            &mut issues,
        );
        assert_eq!(kept.len(), 2);
        assert_eq!((kept[1].from, kept[1].to), (2.0, 3.0));
        assert_eq!(report.duplicate_intervals, 1);
        assert_eq!(report.overlapping_intervals, 2);
    }

    #[test]
    fn composites_are_length_weighted_and_gaps_unknown() {
        let mut report = ReadReport::default();
        let ivs = [iv(1, 0.0, 1.0, Some(1.0)), iv(2, 1.0, 4.0, Some(3.0))];
        let s = interval_samples(&ivs, Some(2.0), &mut report).unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[0], (1.0, Some(2.0)));
        assert_eq!(s[1], (3.0, Some(3.0)));
        let gap = [iv(1, 0.0, 1.0, Some(1.0)), iv(2, 3.0, 4.0, Some(3.0))];
        let s = interval_samples(&gap, None, &mut report).unwrap();
        assert_eq!(s, vec![(0.5, Some(1.0)), (2.0, None), (3.5, Some(3.0))]);
        assert_eq!(report.gaps, 1);
    }
}
