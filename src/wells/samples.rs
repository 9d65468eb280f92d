//! The two point-sample formats of design.md: the samples CSV (`well,x,y,z,value`) and the
//! wells JSON (vertical wells with samples by depth or elevation).
//!
//! Invariant: a sample's coordinates come from its own row or object, are finite, and its
//! value is a number or "don't know"; anything else is an error naming row and column (CSV)
//! or the JSON path.

use std::collections::HashMap;

use glam::DVec3;
use serde_json::Value;

use super::assemble::{HoleSamples, Holes};
use super::table::{Table, aliases};
use super::values::{Reading, ValueRules};
use super::{Input, InputFile, ReadReport, Unit, WellsError};

/// Reads a samples CSV.
pub(crate) fn read_samples_csv(
    file: &InputFile,
    input: &Input,
    _unit: Unit,
) -> Result<Holes, WellsError> {
    let table = Table::parse(&file.name, &file.bytes)?;
    let well = table.find(aliases::HOLE, &[]);
    let x = table.require("x / easting", aliases::X, aliases::X_PREFIX)?;
    let y = table.require("y / northing", aliases::Y, aliases::Y_PREFIX)?;
    let z = table.require("z / elevation", aliases::Z, aliases::Z_PREFIX)?;
    let value = match &input.variable {
        Some(name) => table.named(name)?,
        None => table.require("value", aliases::VALUE, &[])?,
    };
    let mut report = ReadReport {
        source: "samples_csv".into(),
        ..ReadReport::default()
    };
    if well.is_none() {
        report.warnings.push(format!(
            "{}: no well column (well, hole_id, bhid...): all samples belong to one well",
            file.name
        ));
    }
    let rules = ValueRules {
        below: input.below_detection,
        negative_is_below: input.negative_is_below_detection.unwrap_or(false),
    };
    let categorical = !input.inside_codes.is_empty();
    let mut holes: Vec<HoleSamples> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for row in &table.rows {
        report.rows_read += 1;
        let id = well.map(|w| row.get(w)).unwrap_or("all");
        let p = DVec3::new(
            table.number(row, x)?,
            table.number(row, y)?,
            table.number(row, z)?,
        );
        let text = row.get(value);
        let v = if categorical {
            super::values::read_code(text, &input.inside_codes)
        } else {
            let reading = rules.read(text).map_err(|()| WellsError::BadField {
                file: table.file.clone(),
                line: row.line,
                column: table.headers[value].clone(),
                message: format!("'{text}' is not a number nor a don't-know token (empty, NA, ?)"),
            })?;
            match reading {
                Reading::Below(_) => report.below_detection += 1,
                Reading::Above(_) => report.above_detection += 1,
                _ => {}
            }
            rules.number(reading)
        };
        let h = *index.entry(id.to_owned()).or_insert_with(|| {
            holes.push(HoleSamples {
                id: id.to_owned(),
                ..HoleSamples::default()
            });
            holes.len() - 1
        });
        holes[h].samples.push((p, v));
    }
    if table.rows.is_empty() {
        return Err(WellsError::Empty {
            file: file.name.clone(),
            message: "no data rows after the header".into(),
        });
    }
    for hole in &mut holes {
        let mut path: Vec<DVec3> = hole.samples.iter().map(|s| s.0).collect();
        path.sort_by(|a, b| b.z.total_cmp(&a.z));
        path.dedup();
        hole.trace = path;
    }
    report.holes_read = holes.len();
    Ok(Holes {
        name: file.name.clone(),
        holes,
        crs: None,
        report,
    })
}

fn json_error(file: &str, path: &str, message: impl std::fmt::Display) -> WellsError {
    WellsError::Invalid {
        file: file.to_owned(),
        message: format!("{path}: {message}"),
    }
}

fn json_number(file: &str, path: &str, v: &Value) -> Result<f64, WellsError> {
    match v {
        Value::Number(n) => n
            .as_f64()
            .filter(|f| f.is_finite())
            .ok_or_else(|| json_error(file, path, "not a finite number")),
        Value::String(s) => match s.trim().parse::<f64>() {
            Ok(f) if f.is_finite() => Ok(f),
            _ => Err(json_error(
                file,
                path,
                format!("'{s}' is not a finite number"),
            )),
        },
        other => Err(json_error(
            file,
            path,
            format!("expected a number, found {other}"),
        )),
    }
}

/// Reads the wells JSON of design.md.
pub(crate) fn read_wells_json(
    file: &InputFile,
    input: &Input,
    _unit: Unit,
) -> Result<Holes, WellsError> {
    let name = file.name.as_str();
    let doc: Value = serde_json::from_slice(&file.bytes).map_err(|e| WellsError::BadLine {
        file: name.to_owned(),
        line: e.line() as u64,
        message: format!("invalid JSON: {e}"),
    })?;
    let crs = match doc.get("crs") {
        None | Some(Value::Null) => None,
        Some(Value::String(s)) => Some(s.clone()),
        Some(other) => {
            return Err(json_error(
                name,
                "crs",
                format!("expected a string, found {other}"),
            ));
        }
    };
    let wells = doc
        .get("wells")
        .and_then(Value::as_array)
        .ok_or_else(|| json_error(name, "wells", "expected an array of wells"))?;
    if wells.is_empty() {
        return Err(WellsError::Empty {
            file: name.to_owned(),
            message: "'wells' is empty".into(),
        });
    }
    let rules = ValueRules {
        below: input.below_detection,
        negative_is_below: input.negative_is_below_detection.unwrap_or(false),
    };
    let mut report = ReadReport {
        source: "wells_json".into(),
        ..ReadReport::default()
    };
    let mut holes = Vec::with_capacity(wells.len());
    let mut seen = HashMap::new();
    for (w, well) in wells.iter().enumerate() {
        let at = format!("wells[{w}]");
        if !well.is_object() {
            return Err(json_error(name, &at, "expected an object"));
        }
        let id = match well.get("id") {
            Some(Value::String(s)) => s.clone(),
            Some(Value::Number(n)) => n.to_string(),
            _ => {
                return Err(json_error(
                    name,
                    &format!("{at}.id"),
                    "missing or not a string",
                ));
            }
        };
        if let Some(first) = seen.insert(id.clone(), w) {
            return Err(json_error(
                name,
                &format!("{at}.id"),
                format!("'{id}' repeats wells[{first}].id"),
            ));
        }
        holes.push(json_well(name, &at, id, well, &rules, &mut report)?);
    }
    report.holes_read = holes.len();
    Ok(Holes {
        name: name.to_owned(),
        holes,
        crs,
        report,
    })
}

/// Well `id` (at JSON path `at`) of a wells JSON: its samples and its trace from the
/// collar (or the highest sample) down to the deepest sample.
fn json_well(
    name: &str,
    at: &str,
    id: String,
    well: &Value,
    rules: &ValueRules,
    report: &mut ReadReport,
) -> Result<HoleSamples, WellsError> {
    let x = json_number(
        name,
        &format!("{at}.x"),
        well.get("x").unwrap_or(&Value::Null),
    )?;
    let y = json_number(
        name,
        &format!("{at}.y"),
        well.get("y").unwrap_or(&Value::Null),
    )?;
    let collar_z = match well.get("z") {
        None | Some(Value::Null) => None,
        Some(v) => Some(json_number(name, &format!("{at}.z"), v)?),
    };
    let samples = match well.get("samples") {
        None | Some(Value::Null) => &Vec::new(),
        Some(Value::Array(a)) => a,
        Some(_) => {
            return Err(json_error(
                name,
                &format!("{at}.samples"),
                "expected an array",
            ));
        }
    };
    let mut hole = HoleSamples {
        id,
        ..HoleSamples::default()
    };
    let mut deepest: Option<f64> = None;
    for (s, sample) in samples.iter().enumerate() {
        let sat = format!("{at}.samples[{s}]");
        report.rows_read += 1;
        let z = json_sample_z(name, &sat, sample, collar_z)?;
        let value = json_sample_value(name, &sat, sample, rules, report)?;
        deepest = Some(deepest.map_or(z, |d: f64| d.min(z)));
        hole.samples.push((DVec3::new(x, y, z), value));
    }
    let top = collar_z.or_else(|| hole.samples.iter().map(|s| s.0.z).reduce(f64::max));
    if let (Some(top), Some(bottom)) = (top, deepest) {
        hole.trace = vec![DVec3::new(x, y, top), DVec3::new(x, y, bottom.min(top))];
    }
    Ok(hole)
}

/// The elevation of sample `sat`: its `z`, or its `depth` below the collar's `collar_z`.
fn json_sample_z(
    name: &str,
    sat: &str,
    sample: &Value,
    collar_z: Option<f64>,
) -> Result<f64, WellsError> {
    match (sample.get("z"), sample.get("depth")) {
        (Some(z), _) if !z.is_null() => json_number(name, &format!("{sat}.z"), z),
        (_, Some(d)) if !d.is_null() => {
            let depth = json_number(name, &format!("{sat}.depth"), d)?;
            let Some(top) = collar_z else {
                return Err(json_error(
                    name,
                    &format!("{sat}.depth"),
                    "a depth needs the well's collar elevation 'z'",
                ));
            };
            Ok(top - depth)
        }
        _ => Err(json_error(name, sat, "needs 'depth' or 'z'")),
    }
}

/// The value of sample `sat`: a number, a boolean (1 or 0), a don't-know token or a
/// detection-limit reading (counted in `report`), or `None` for null.
fn json_sample_value(
    name: &str,
    sat: &str,
    sample: &Value,
    rules: &ValueRules,
    report: &mut ReadReport,
) -> Result<Option<f64>, WellsError> {
    Ok(match sample.get("value") {
        None | Some(Value::Null) => None,
        Some(Value::Number(n)) => Some(
            n.as_f64()
                .filter(|f| f.is_finite())
                .ok_or_else(|| json_error(name, &format!("{sat}.value"), "not finite"))?,
        ),
        Some(Value::Bool(b)) => Some(if *b { 1.0 } else { 0.0 }),
        Some(Value::String(t)) => {
            let reading = rules.read(t).map_err(|()| {
                json_error(
                    name,
                    &format!("{sat}.value"),
                    format!("'{t}' is not a number nor a don't-know token"),
                )
            })?;
            match reading {
                Reading::Below(_) => report.below_detection += 1,
                Reading::Above(_) => report.above_detection += 1,
                _ => {}
            }
            rules.number(reading)
        }
        Some(other) => {
            return Err(json_error(
                name,
                &format!("{sat}.value"),
                format!("expected a number or null, found {other}"),
            ));
        }
    })
}
