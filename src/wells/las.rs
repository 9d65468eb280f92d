//! LAS 2.0 well logs (our own reader): sections `~V ~W ~C ~P ~A`, NULL values, wrapped and
//! unwrapped data, depth units; wells placed from header coordinates or a locations table.
//!
//! Invariant: a parsed [`LasFile`] has as many values per depth row as curves, the index
//! (depth) curve first, finite depths; NULL values are `None`. Anything the reader cannot
//! make sense of is an error naming the file and line, never a panic.

use std::collections::HashMap;

use glam::DVec3;

use super::assemble::{HoleSamples, Holes, examples};
use super::drillhole::{Interval, Issues, interval_samples, resolve_intervals};
use super::table::{Table, aliases, normalize};
use super::{Input, InputFile, ReadReport, Unit, WellsError};

/// One `MNEM.UNIT DATA : DESCRIPTION` header line.
#[derive(Debug, Clone, PartialEq)]
pub struct HeaderItem {
    pub mnemonic: String,
    pub unit: String,
    pub data: String,
    pub description: String,
    pub line: u64,
}

/// A LAS file as read.
#[derive(Debug, Clone, PartialEq)]
pub struct LasFile {
    pub name: String,
    /// `VERS` of the `~V` section, e.g. "2.0".
    pub version: Option<String>,
    pub wrapped: bool,
    /// `~W` items.
    pub well: Vec<HeaderItem>,
    /// `~P` items.
    pub parameters: Vec<HeaderItem>,
    /// `~C` items in data-column order; the first is the index (depth).
    pub curves: Vec<HeaderItem>,
    pub null: Option<f64>,
    /// Depth rows: `rows[r][c]` is curve `c` at row `r`, `None` for NULL.
    pub rows: Vec<Vec<Option<f64>>>,
    /// Notes on what was repaired or skipped.
    pub warnings: Vec<String>,
}

fn err(file: &str, line: u64, message: impl Into<String>) -> WellsError {
    WellsError::BadLine {
        file: file.to_owned(),
        line,
        message: message.into(),
    }
}

/// Splits `MNEM.UNIT DATA : DESCRIPTION` (the description starts after the last colon).
fn header_item(text: &str, line: u64) -> Option<HeaderItem> {
    let dot = text.find('.')?;
    let mnemonic = text[..dot].trim().to_owned();
    if mnemonic.is_empty() {
        return None;
    }
    let after = &text[dot + 1..];
    let unit_end = after
        .find(|c: char| c.is_whitespace() || c == ':')
        .unwrap_or(after.len());
    let unit = after[..unit_end].trim().to_owned();
    let rest = &after[unit_end..];
    let (data, description) = match rest.rfind(':') {
        Some(c) => (rest[..c].trim(), rest[c + 1..].trim()),
        None => (rest.trim(), ""),
    };
    Some(HeaderItem {
        mnemonic,
        unit,
        data: data.to_owned(),
        description: description.to_owned(),
        line,
    })
}

fn is_depth_name(name: &str) -> bool {
    matches!(
        name.to_ascii_uppercase().as_str(),
        "DEPT" | "DEPTH" | "MD" | "TDEP" | "DEP" | "INDEX"
    )
}

/// Parses one LAS 2.0 (or 1.2) file.
pub fn parse(name: &str, bytes: &[u8]) -> Result<LasFile, WellsError> {
    let text = String::from_utf8_lossy(bytes);
    let text = text.trim_start_matches('\u{feff}');
    let lines: Vec<&str> = if text.contains('\n') {
        text.split('\n').collect()
    } else {
        text.split('\r').collect()
    };
    let mut las = LasFile {
        name: name.to_owned(),
        version: None,
        wrapped: false,
        well: Vec::new(),
        parameters: Vec::new(),
        curves: Vec::new(),
        null: None,
        rows: Vec::new(),
        warnings: Vec::new(),
    };
    let sections = read_sections(name, &lines, &mut las)?;
    check_header(name, &sections, lines.len() as u64, &mut las)?;
    if las.wrapped {
        read_wrapped_rows(name, &sections.data_lines, &mut las)?;
    } else {
        read_rows(name, &sections.data_lines, &mut las)?;
    }
    if las.rows.is_empty() {
        return Err(err(
            name,
            sections
                .data_lines
                .first()
                .map_or(lines.len() as u64, |d| d.0),
            "the ~A section holds no depth rows",
        ));
    }
    Ok(las)
}

/// What the walk over a LAS file's sections found besides the header items.
struct Sections<'t> {
    /// The letter of the last section (`' '` before any).
    last: char,
    seen_version: bool,
    /// The column names on the `~A` line, if any.
    a_names: Vec<String>,
    /// The `~A` section's non-empty lines with their line numbers.
    data_lines: Vec<(u64, &'t str)>,
    /// Header lines without `MNEMONIC.`, as "line N".
    skipped: Vec<String>,
}

/// Walks the sections of `lines`, taking the `~V ~W ~C ~P` items into `las` and keeping
/// the `~A` lines for later.
fn read_sections<'t>(
    name: &str,
    lines: &[&'t str],
    las: &mut LasFile,
) -> Result<Sections<'t>, WellsError> {
    let mut found = Sections {
        last: ' ',
        seen_version: false,
        a_names: Vec::new(),
        data_lines: Vec::new(),
        skipped: Vec::new(),
    };
    for (i, raw) in lines.iter().enumerate() {
        let line_no = i as u64 + 1;
        let line = raw.trim_end_matches('\r');
        let trimmed = line.trim();
        let section = found.last;
        if let Some(rest) = trimmed.strip_prefix('~') {
            let letter = rest
                .chars()
                .next()
                .map(|c| c.to_ascii_uppercase())
                .unwrap_or(' ');
            if section == 'A' && letter != 'A' {
                return Err(err(
                    name,
                    line_no,
                    format!("section '{trimmed}' after the ~A data section (which must come last)"),
                ));
            }
            if letter == 'A' {
                if section == 'A' {
                    return Err(err(name, line_no, "a second ~A data section"));
                }
                found.a_names = rest.split_whitespace().skip(1).map(str::to_owned).collect();
            }
            if letter == 'V' {
                found.seen_version = true;
            }
            found.last = letter;
            continue;
        }
        if section == 'A' {
            if !trimmed.is_empty() && !trimmed.starts_with('#') {
                found.data_lines.push((line_no, trimmed));
            }
            continue;
        }
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        if section == ' ' {
            return Err(err(
                name,
                line_no,
                "text before the first section: not a LAS file (LAS starts with ~V)",
            ));
        }
        if !matches!(section, 'V' | 'W' | 'C' | 'P') {
            continue; // ~O (other) and unknown sections are free text
        }
        let Some(item) = header_item(line, line_no) else {
            found.skipped.push(format!("line {line_no}"));
            continue;
        };
        take_header_item(name, section, item, las)?;
    }
    Ok(found)
}

/// Takes one header item of section `section` (`V`, `W`, `C` or `P`) into `las`.
fn take_header_item(
    name: &str,
    section: char,
    item: HeaderItem,
    las: &mut LasFile,
) -> Result<(), WellsError> {
    let line_no = item.line;
    match section {
        'V' => {
            match item.mnemonic.to_ascii_uppercase().as_str() {
                "VERS" => las.version = Some(item.data.clone()),
                "WRAP" => las.wrapped = item.data.trim().eq_ignore_ascii_case("YES"),
                _ => {}
            }
            if item.mnemonic.eq_ignore_ascii_case("VERS") && item.data.trim().starts_with('3') {
                return Err(err(
                    name,
                    line_no,
                    format!(
                        "LAS version {} is not supported (2.0 and 1.2 are)",
                        item.data
                    ),
                ));
            }
        }
        'W' => {
            if item.mnemonic.eq_ignore_ascii_case("NULL") {
                match item.data.trim().parse::<f64>() {
                    Ok(v) => las.null = Some(v),
                    Err(_) => las.warnings.push(format!(
                        "{name}, line {line_no}: NULL value '{}' is not a number: ignored",
                        item.data
                    )),
                }
            }
            las.well.push(item);
        }
        'C' => las.curves.push(item),
        _ => las.parameters.push(item),
    }
    Ok(())
}

/// The checks and notes on a LAS file's header once its sections are read; puts the
/// curves in the `~A` line's order when it names them all in another order.
fn check_header(
    name: &str,
    sections: &Sections,
    line_count: u64,
    las: &mut LasFile,
) -> Result<(), WellsError> {
    if !sections.seen_version {
        las.warnings
            .push(format!("{name}: no ~V (version) section; read as LAS 2.0"));
    }
    if !sections.skipped.is_empty() {
        las.warnings.push(format!(
            "{name}: {} header lines without 'MNEMONIC.' skipped: {}",
            sections.skipped.len(),
            examples(&sections.skipped)
        ));
    }
    if sections.last != 'A' && sections.data_lines.is_empty() {
        return Err(err(
            name,
            line_count,
            "no ~A (data) section: the file ends before any log data",
        ));
    }
    if las.curves.is_empty() {
        return Err(err(
            name,
            1,
            "no curves: the ~C (curve) section is missing or empty",
        ));
    }
    apply_a_line_order(name, &sections.a_names, las);
    if !is_depth_name(&las.curves[0].mnemonic) {
        las.warnings.push(format!(
            "{name}, line {}: the first curve '{}' is taken as depth",
            las.curves[0].line, las.curves[0].mnemonic
        ));
    }
    Ok(())
}

/// The ~A line may name the columns; when it names every curve in another order, that
/// order is the data's (the depth curve listed last in ~C is a known defect).
fn apply_a_line_order(name: &str, a_names: &[String], las: &mut LasFile) {
    if a_names.len() != las.curves.len() {
        return;
    }
    let mut order = Vec::with_capacity(a_names.len());
    for a in a_names {
        let found = las.curves.iter().position(|c| {
            c.mnemonic.eq_ignore_ascii_case(a) || (is_depth_name(a) && is_depth_name(&c.mnemonic))
        });
        match found {
            Some(f) if !order.contains(&f) => order.push(f),
            _ => {
                order.clear();
                break;
            }
        }
    }
    if order.len() == las.curves.len() && order.iter().enumerate().any(|(i, &o)| i != o) {
        las.warnings.push(format!(
            "{name}: the ~A line lists the curves in another order than ~C; the ~A order is used"
        ));
        las.curves = order.iter().map(|&o| las.curves[o].clone()).collect();
    }
}

/// The value of data token `token` (column `column`, 0-based), `None` for the file's NULL
/// value or a non-finite number.
fn data_value(
    name: &str,
    null: Option<f64>,
    token: &str,
    line: u64,
    column: usize,
) -> Result<Option<f64>, WellsError> {
    let v: f64 = token.parse().map_err(|_| {
        err(
            name,
            line,
            format!("value {} '{token}' is not a number", column + 1),
        )
    })?;
    if !v.is_finite() || null.is_some_and(|nv| v == nv) {
        Ok(None)
    } else {
        Ok(Some(v))
    }
}

/// The tokens of a data line (separated by white space or commas).
fn data_tokens(l: &str) -> Vec<String> {
    l.split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .map(str::to_owned)
        .collect()
}

/// The depth rows of a wrapped `~A` section (`WRAP. YES`): values fill rows across lines.
fn read_wrapped_rows(
    name: &str,
    data_lines: &[(u64, &str)],
    las: &mut LasFile,
) -> Result<(), WellsError> {
    let n = las.curves.len();
    let mut row: Vec<Option<f64>> = Vec::with_capacity(n);
    let mut row_line = 0;
    for &(line_no, l) in data_lines {
        for token in data_tokens(l) {
            if row.is_empty() {
                row_line = line_no;
            }
            row.push(data_value(name, las.null, &token, line_no, row.len())?);
            if row.len() == n {
                check_depth(name, row_line, &row)?;
                las.rows.push(std::mem::take(&mut row));
            }
        }
    }
    if !row.is_empty() {
        las.warnings.push(format!(
            "{name}, line {row_line}: an incomplete last depth row ({} of {n} values) dropped",
            row.len()
        ));
    }
    Ok(())
}

/// The depth rows of an unwrapped `~A` section: one row per line.
fn read_rows(name: &str, data_lines: &[(u64, &str)], las: &mut LasFile) -> Result<(), WellsError> {
    let n = las.curves.len();
    let last = data_lines.len();
    for (k, &(line_no, l)) in data_lines.iter().enumerate() {
        let tokens = data_tokens(l);
        if tokens.len() != n {
            if k + 1 == last && tokens.len() < n {
                las.warnings.push(format!(
                    "{name}, line {line_no}: an incomplete last line ({} of {n} values) dropped",
                    tokens.len()
                ));
                continue;
            }
            return Err(err(
                name,
                line_no,
                format!(
                    "{} values where the ~C section defines {n} curves (WRAP is NO)",
                    tokens.len()
                ),
            ));
        }
        let row = tokens
            .iter()
            .enumerate()
            .map(|(c, t)| data_value(name, las.null, t, line_no, c))
            .collect::<Result<Vec<_>, _>>()?;
        check_depth(name, line_no, &row)?;
        las.rows.push(row);
    }
    Ok(())
}

fn check_depth(name: &str, line: u64, row: &[Option<f64>]) -> Result<(), WellsError> {
    if row[0].is_none() {
        return Err(err(
            name,
            line,
            "the depth (first value) is NULL or not finite",
        ));
    }
    Ok(())
}

impl LasFile {
    /// The item `mnemonic` of ~W, then of ~P (case-insensitive).
    pub fn item(&self, mnemonic: &str) -> Option<&HeaderItem> {
        self.well
            .iter()
            .chain(&self.parameters)
            .find(|i| i.mnemonic.eq_ignore_ascii_case(mnemonic))
    }

    /// The text value of a header item. LAS 1.2 keeps ~W values in the description
    /// (`WELL. WELL: name`, as lasio reads them): there the description is used when it is not
    /// empty, and a data field that is only a capitalised label (`UNIQUE WELL ID`) is no value.
    pub fn text(&self, mnemonic: &str) -> Option<String> {
        let item = self.item(mnemonic)?;
        let data = item.data.trim();
        let description = item.description.trim();
        let old_style = self
            .version
            .as_deref()
            .is_some_and(|v| v.trim().starts_with('1'));
        let in_well = self.well.iter().any(|w| std::ptr::eq(w, item));
        let value = if old_style && in_well {
            if !description.is_empty() {
                description
            } else if data.chars().all(|c| c.is_ascii_uppercase() || c == ' ') {
                ""
            } else {
                data
            }
        } else {
            data
        };
        (!value.is_empty()).then(|| value.to_owned())
    }

    fn number(&self, mnemonic: &str) -> Option<(f64, String)> {
        let item = self.item(mnemonic)?;
        let v: f64 = item.data.trim().parse().ok()?;
        v.is_finite().then(|| (v, item.unit.clone()))
    }

    /// Unit of depths: the unit of STRT, else of the index curve.
    pub fn depth_unit(&self) -> Option<String> {
        self.item("STRT")
            .map(|i| i.unit.clone())
            .filter(|u| !u.is_empty())
            .or_else(|| Some(self.curves[0].unit.clone()).filter(|u| !u.is_empty()))
    }

    /// Index of the curve `mnemonic` (case-insensitive).
    pub fn curve(&self, mnemonic: &str) -> Option<usize> {
        self.curves
            .iter()
            .position(|c| c.mnemonic.eq_ignore_ascii_case(mnemonic))
    }
}

/// Where a LAS well is, in the output unit.
#[derive(Debug, Clone, Copy)]
struct Location {
    x: f64,
    y: f64,
    elevation: Option<f64>,
}

/// The locations table: every id-like column's values map to the row's location.
fn read_locations(file: &InputFile) -> Result<HashMap<String, Location>, WellsError> {
    let table = Table::parse(&file.name, &file.bytes)?;
    let x = table.require("x / easting", aliases::X, aliases::X_PREFIX)?;
    let y = table.require("y / northing", aliases::Y, aliases::Y_PREFIX)?;
    let z = table.find(
        &[
            "kbm",
            "kb",
            "eref",
            "ekb",
            "elevation",
            "elev",
            "z",
            "rl",
            "edf",
            "gl",
            "egl",
        ],
        &["elevation", "kb"],
    );
    let id_columns: Vec<usize> = (0..table.headers.len())
        .filter(|&c| {
            let n = normalize(&table.headers[c]);
            aliases::HOLE.contains(&n.as_str())
                || ["uwi", "lasfile", "file", "filename", "api", "las"].contains(&n.as_str())
        })
        .collect();
    if id_columns.is_empty() {
        return Err(WellsError::MissingColumn {
            file: file.name.clone(),
            wanted: "a well name (well, uwi, las_file, name...)".into(),
            found: table.headers.join(", "),
        });
    }
    let mut out = HashMap::new();
    for row in &table.rows {
        let (Some(xv), Some(yv)) = (
            table.optional_number(row, x)?,
            table.optional_number(row, y)?,
        ) else {
            continue;
        };
        let elevation = match z {
            Some(z) => table.optional_number(row, z)?,
            None => None,
        };
        let loc = Location {
            x: xv,
            y: yv,
            elevation,
        };
        for &c in &id_columns {
            let key = well_key(row.get(c));
            if !key.is_empty() {
                out.entry(key).or_insert(loc);
            }
        }
    }
    Ok(out)
}

fn well_key(text: &str) -> String {
    text.trim().to_ascii_uppercase()
}

/// Names under which a LAS file may appear in a locations table.
fn keys_of(las: &LasFile) -> Vec<String> {
    let mut keys = Vec::new();
    for m in ["UWI", "WELL", "API", "LOC"] {
        if let Some(t) = las.text(m) {
            keys.push(well_key(&t));
        }
    }
    let base = las.name.rsplit(['/', '\\']).next().unwrap_or(&las.name);
    keys.push(well_key(base));
    if let Some((stem, _)) = base.rsplit_once('.') {
        keys.push(well_key(stem));
    }
    keys
}

/// Location from the header: X/Y-like items and the depth reference elevation.
fn header_location(las: &LasFile, unit: Unit) -> (Option<(f64, f64)>, Option<f64>) {
    let find = |names: &[&str]| names.iter().find_map(|m| las.number(m));
    let xy = match (
        find(&["X", "XCOORD", "X_COORD", "XWELL", "EAST", "EASTING", "UTMX"]),
        find(&[
            "Y", "YCOORD", "Y_COORD", "YWELL", "NORTH", "NORTHING", "UTMY",
        ]),
    ) {
        (Some((x, _)), Some((y, _))) => Some((x, y)),
        _ => None,
    };
    let mut elevation = None;
    for m in ["EREF", "EKB", "EDF", "KB", "ELEV", "APD", "EGL", "GL"] {
        if let Some((v, u)) = las.number(m) {
            let f = Unit::parse(&u).map_or(1.0, |from| from.factor_to(unit));
            let mut v = v * f;
            if m == "APD"
                && let Some((epd, eu)) = las.number("EPD")
            {
                v += epd * Unit::parse(&eu).map_or(1.0, |from| from.factor_to(unit));
            }
            elevation = Some(v);
            break;
        }
    }
    (xy, elevation)
}

/// Reads LAS files (with a locations table, if given) into vertical holes of samples.
pub(crate) fn read_las_wells(input: &Input, unit: Unit) -> Result<Holes, WellsError> {
    let curve = input.variable.as_deref().ok_or_else(|| {
        WellsError::BadOption("LAS input needs the curve to contour (--variable CURVE)".into())
    })?;
    let locations = match &input.locations_csv {
        Some(file) => Some(read_locations(file)?),
        None => None,
    };
    let mut report = ReadReport {
        source: "las".into(),
        ..ReadReport::default()
    };
    let mut holes = Vec::new();
    let mut without_curve = Vec::new();
    let mut no_elevation = Vec::new();
    let mut ids: HashMap<String, usize> = HashMap::new();
    let mut issues = Issues::default();
    let mut crs = None;
    for file in &input.las {
        let las = parse(&file.name, &file.bytes)?;
        report.holes_read += 1;
        report.warnings.extend(las.warnings.iter().cloned());
        let depth_factor = depth_factor(&las, &file.name, unit, &mut report);
        let mut id = las
            .text("UWI")
            .or_else(|| las.text("WELL"))
            .unwrap_or_else(|| file.name.clone());
        if let Some(n) = ids.get_mut(&id) {
            *n += 1;
            id = format!("{id} ({})", file.name);
        } else {
            ids.insert(id.clone(), 1);
        }
        let (collar, elevation_known) =
            well_location(&las, &file.name, &id, locations.as_ref(), unit)?;
        if !elevation_known {
            no_elevation.push(id.clone());
        }
        let Some(c) = las.curve(curve) else {
            without_curve.push(format!("{} ({id})", file.name));
            holes.push(HoleSamples {
                id,
                trace: vec![collar],
                samples: Vec::new(),
            });
            continue;
        };
        let intervals = depth_intervals(&las, c, depth_factor, &mut report);
        let intervals = resolve_intervals(&id, intervals, &mut report, &mut issues);
        let samples = interval_samples(&intervals, input.composite_length, &mut report)
            .map_err(|n| super::drillhole::too_many_composites(&file.name, &id, n))?;
        let bottom = samples.iter().map(|s| s.0).fold(0.0, f64::max);
        holes.push(HoleSamples {
            id,
            trace: vec![collar, collar - DVec3::Z * bottom],
            samples: samples
                .into_iter()
                .map(|(d, v)| (collar - DVec3::Z * d, v))
                .collect(),
        });
        if crs.is_none() {
            crs = las.text("GDAT").or_else(|| las.text("HZCS"));
        }
    }
    report_las_wells(
        input,
        curve,
        &without_curve,
        &no_elevation,
        issues,
        &mut report,
    )?;
    Ok(Holes {
        name: input
            .las
            .iter()
            .map(|f| f.name.as_str())
            .take(3)
            .collect::<Vec<_>>()
            .join(", "),
        holes,
        crs,
        report,
    })
}

/// The factor from a LAS file's depth unit to `unit` (1 with a warning when the unit is
/// missing or not recognised).
fn depth_factor(las: &LasFile, file_name: &str, unit: Unit, report: &mut ReadReport) -> f64 {
    match las.depth_unit() {
        Some(u) => match Unit::parse(&u).or_else(|| {
            matches!(
                u.to_ascii_uppercase().as_str(),
                "METER" | "METERS" | "METRE"
            )
            .then_some(Unit::Metre)
        }) {
            Some(from) => from.factor_to(unit),
            None => {
                report.warnings.push(format!(
                    "{file_name}: depth unit '{u}' not recognised; depths read in {}",
                    unit.name()
                ));
                1.0
            }
        },
        None => {
            report.warnings.push(format!(
                "{file_name}: no depth unit; depths read in {}",
                unit.name()
            ));
            1.0
        }
    }
}

/// Well `id`'s collar (x, y, elevation) from the locations table, else its header; and
/// whether its elevation is known (else 0).
fn well_location(
    las: &LasFile,
    file_name: &str,
    id: &str,
    locations: Option<&HashMap<String, Location>>,
    unit: Unit,
) -> Result<(DVec3, bool), WellsError> {
    let table_location =
        locations.and_then(|table| keys_of(las).iter().find_map(|k| table.get(k).copied()));
    let (header_xy, header_elevation) = header_location(las, unit);
    let (x, y) = match (table_location, header_xy) {
        (Some(l), _) => (l.x, l.y),
        (None, Some(xy)) => xy,
        (None, None) => {
            return Err(WellsError::Invalid {
                file: file_name.to_owned(),
                message: format!(
                    "well '{id}' has no X/Y in its header and {}; give a locations table (well name or file -> x, y, elevation)",
                    if locations.is_some() {
                        "is not in the locations table"
                    } else {
                        "no locations table was given"
                    }
                ),
            });
        }
    };
    Ok(
        match (table_location.and_then(|l| l.elevation), header_elevation) {
            (Some(e), _) => (DVec3::new(x, y, e), true),
            (None, Some(e)) => (DVec3::new(x, y, e), true),
            (None, None) => (DVec3::new(x, y, 0.0), false),
        },
    )
}

/// The depth rows of curve `c` as intervals between the midpoints of neighbouring depths
/// (half a `STEP` beyond the first and last), sorted by depth, repeated depths dropped.
fn depth_intervals(
    las: &LasFile,
    c: usize,
    depth_factor: f64,
    report: &mut ReadReport,
) -> Vec<Interval> {
    let mut rows: Vec<(u64, f64, Option<f64>)> = las
        .rows
        .iter()
        .enumerate()
        .filter_map(|(r, row)| Some((r as u64, row[0]? * depth_factor, row[c])))
        .collect();
    report.rows_read += rows.len();
    rows.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    let before = rows.len();
    rows.dedup_by(|b, a| a.1 == b.1);
    report.duplicate_intervals += before - rows.len();
    let step = las
        .number("STEP")
        .map(|(s, _)| (s * depth_factor).abs())
        .filter(|s| *s > 0.0)
        .unwrap_or(depth_factor);
    let mut intervals = Vec::with_capacity(rows.len());
    for (k, &(r, d, v)) in rows.iter().enumerate() {
        let from = if k > 0 {
            (rows[k - 1].1 + d) * 0.5
        } else {
            d - step * 0.5
        };
        let to = if k + 1 < rows.len() {
            (rows[k + 1].1 + d) * 0.5
        } else {
            d + step * 0.5
        };
        intervals.push(Interval {
            line: r,
            from: from.min(d),
            to: to.max(d),
            value: v,
            at: Some(d),
        });
    }
    intervals
}

/// The warnings on a set of LAS wells once all are read; an error when no file has the
/// curve.
fn report_las_wells(
    input: &Input,
    curve: &str,
    without_curve: &[String],
    no_elevation: &[String],
    mut issues: Issues,
    report: &mut ReadReport,
) -> Result<(), WellsError> {
    if !without_curve.is_empty() {
        if without_curve.len() == input.las.len() {
            return Err(WellsError::Invalid {
                file: input.las[0].name.clone(),
                message: format!("no LAS file has the curve '{curve}'"),
            });
        }
        report.warnings.push(format!(
            "{} LAS files have no curve '{curve}' and give no samples: {}",
            without_curve.len(),
            examples(without_curve)
        ));
    }
    if !no_elevation.is_empty() {
        report.warnings.push(format!(
            "{} wells have no elevation (EREF/EKB/KB/EGL or a locations table): depths measured from z = 0: {}",
            no_elevation.len(),
            examples(no_elevation)
        ));
    }
    report.warnings.push(
        "LAS wells are taken as vertical below their location (no deviation survey is read)"
            .to_owned(),
    );
    if report.duplicate_intervals > 0 {
        issues.duplicate = vec![format!(
            "{} depth rows repeat a depth of their file; the first is kept",
            report.duplicate_intervals
        )];
    }
    issues.overlap.clear();
    issues.into_warnings("LAS", report);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = "~VERSION\n VERS. 2.0 : v\n WRAP. NO : one line\n~WELL\n STRT.M 10 : start\n STOP.M 10.5 : stop\n STEP.M 0.5 : step\n NULL. -999.25 : null\n WELL. W-1 : name\n~CURVE\n DEPT.M : depth\n GR.API : gamma\n~A\n 10.0 50\n 10.5 -999.25\n";

    #[test]
    fn reads_an_unwrapped_file_with_nulls() {
        let las = parse("w.las", SMALL.as_bytes()).unwrap();
        assert_eq!(las.curves.len(), 2);
        assert_eq!(
            las.rows,
            vec![vec![Some(10.0), Some(50.0)], vec![Some(10.5), None]]
        );
        assert_eq!(las.text("WELL").as_deref(), Some("W-1"));
        assert_eq!(las.depth_unit().as_deref(), Some("M"));
    }

    #[test]
    fn reads_a_wrapped_file() {
        let text = SMALL
            .replace("WRAP. NO", "WRAP. YES")
            .replace(" 10.0 50\n 10.5 -999.25\n", " 10.0\n 50\n 10.5\n -999.25\n");
        let las = parse("w.las", text.as_bytes()).unwrap();
        assert_eq!(las.rows.len(), 2);
        assert_eq!(las.rows[1], vec![Some(10.5), None]);
    }

    #[test]
    fn a_bad_value_names_its_line() {
        let text = SMALL.replace(" 10.5 -999.25", " 10.5 abc");
        let e = parse("w.las", text.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("w.las, line 15"), "{e}");
    }

    #[test]
    fn las_1_2_well_values_come_from_the_description() {
        let text = SMALL.replace("VERS. 2.0", "VERS. 1.2").replace(
            " WELL. W-1 : name",
            " WELL. WELL: BIG OIL 1\n UWI. UNIQUE WELL ID:\n API. 15-023 :",
        );
        let las = parse("w.las", text.as_bytes()).unwrap();
        assert_eq!(las.text("WELL").as_deref(), Some("BIG OIL 1"));
        assert_eq!(las.text("UWI"), None);
        assert_eq!(las.text("API").as_deref(), Some("15-023"));
    }
}
