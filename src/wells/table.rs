//! Delimited text tables (CSV, semicolon or tab separated) with named columns, found by
//! case-insensitive aliases.
//!
//! Invariant: every row remembers the 1-based line on which it starts, so any error about
//! a field can name file, line and column; a UTF-8 byte-order mark never reaches a header.

use super::WellsError;

/// One data row: its line in the file and its fields (missing trailing fields read as "").
#[derive(Debug, Clone)]
pub(crate) struct Row {
    pub line: u64,
    pub fields: Vec<String>,
}

impl Row {
    pub fn get(&self, column: usize) -> &str {
        self.fields.get(column).map(|s| s.trim()).unwrap_or("")
    }
}

/// A parsed table: trimmed headers and rows.
#[derive(Debug, Clone)]
pub(crate) struct Table {
    pub file: String,
    pub headers: Vec<String>,
    pub rows: Vec<Row>,
}

/// Lower-cases and drops everything but letters and digits: `Drillhole ID` -> `drillholeid`.
pub(crate) fn normalize(name: &str) -> String {
    name.chars()
        .filter(|c| c.is_alphanumeric())
        .flat_map(|c| c.to_lowercase())
        .collect()
}

fn sniff_delimiter(bytes: &[u8]) -> u8 {
    let first = bytes.split(|&b| b == b'\n').next().unwrap_or(&[]);
    let count = |d: u8| first.iter().filter(|&&b| b == d).count();
    let (comma, semi, tab) = (count(b','), count(b';'), count(b'\t'));
    if tab > comma && tab >= semi {
        b'\t'
    } else if semi > comma {
        b';'
    } else {
        b','
    }
}

impl Table {
    /// Parses `bytes` (with a header row). Non-UTF-8 bytes are replaced, never rejected.
    pub fn parse(file: &str, bytes: &[u8]) -> Result<Table, WellsError> {
        let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        let delimiter = sniff_delimiter(bytes);
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .delimiter(delimiter)
            .from_reader(bytes);
        let mut headers: Option<Vec<String>> = None;
        let mut rows = Vec::new();
        let mut record = csv::ByteRecord::new();
        loop {
            let line_before = reader.position().line();
            match reader.read_byte_record(&mut record) {
                Ok(false) => break,
                Ok(true) => {}
                Err(err) => {
                    let line = err
                        .position()
                        .map(|p| p.line())
                        .unwrap_or(line_before.max(1));
                    return Err(WellsError::BadLine {
                        file: file.to_owned(),
                        line,
                        message: format!("cannot read CSV: {err}"),
                    });
                }
            }
            let line = record
                .position()
                .map(|p| p.line())
                .unwrap_or(line_before.max(1));
            let fields: Vec<String> = record
                .iter()
                .map(|f| String::from_utf8_lossy(f).into_owned())
                .collect();
            // Fields up to the last non-empty one; none: a blank row, skipped.
            let used = fields
                .iter()
                .rposition(|f| !f.trim().is_empty())
                .map_or(0, |last| last + 1);
            if used == 0 {
                continue;
            }
            match &headers {
                None => {
                    headers = Some(
                        fields
                            .iter()
                            .map(|h| h.trim().trim_start_matches('\u{feff}').to_owned())
                            .collect(),
                    );
                }
                Some(names) => {
                    // A field beyond the header's columns would be read by no column: a
                    // value holding the delimiter unquoted (a decimal comma, say) has
                    // shifted the row. Refused rather than lost; empty ones (a trailing
                    // delimiter, as spreadsheets write) are harmless.
                    if used > names.len() {
                        let hint = if delimiter == b',' {
                            "; decimal commas need ';' or tabs between fields"
                        } else {
                            ""
                        };
                        return Err(WellsError::BadLine {
                            file: file.to_owned(),
                            line,
                            message: format!(
                                "{used} fields, but the header names {} columns (field {used} is '{}'): \
                                 a value holding the delimiter '{}' must be quoted{hint}",
                                names.len(),
                                fields[used - 1].trim(),
                                char::from(delimiter).escape_default(),
                            ),
                        });
                    }
                    rows.push(Row { line, fields });
                }
            }
        }
        let Some(headers) = headers else {
            return Err(WellsError::Empty {
                file: file.to_owned(),
                message: "the file is empty (no header row)".into(),
            });
        };
        Ok(Table {
            file: file.to_owned(),
            headers,
            rows,
        })
    }

    /// The first column whose normalized header equals one of `aliases` (tried in order),
    /// then the first whose normalized header starts with one of `prefixes`.
    pub fn find(&self, aliases: &[&str], prefixes: &[&str]) -> Option<usize> {
        let names: Vec<String> = self.headers.iter().map(|h| normalize(h)).collect();
        for alias in aliases {
            if let Some(i) = names.iter().position(|n| n == alias) {
                return Some(i);
            }
        }
        for prefix in prefixes {
            if let Some(i) = names.iter().position(|n| n.starts_with(prefix)) {
                return Some(i);
            }
        }
        None
    }

    /// Like [`Table::find`] but an error naming the wanted column and the columns found.
    pub fn require(
        &self,
        wanted: &str,
        aliases: &[&str],
        prefixes: &[&str],
    ) -> Result<usize, WellsError> {
        self.find(aliases, prefixes)
            .ok_or_else(|| WellsError::MissingColumn {
                file: self.file.clone(),
                wanted: format!(
                    "{wanted} (e.g. {})",
                    aliases[..aliases.len().min(4)].join(", ")
                ),
                found: self.headers.join(", "),
            })
    }

    /// The column named exactly `name` (normalized comparison), or an error listing
    /// the columns found.
    pub fn named(&self, name: &str) -> Result<usize, WellsError> {
        let wanted = normalize(name);
        self.headers
            .iter()
            .position(|h| normalize(h) == wanted)
            .ok_or_else(|| WellsError::MissingColumn {
                file: self.file.clone(),
                wanted: format!("'{name}'"),
                found: self.headers.join(", "),
            })
    }

    /// Parses a required numeric field: empty, text or non-finite are errors.
    pub fn number(&self, row: &Row, column: usize) -> Result<f64, WellsError> {
        match self.optional_number(row, column)? {
            Some(v) => Ok(v),
            None => Err(WellsError::BadField {
                file: self.file.clone(),
                line: row.line,
                column: self.headers[column].clone(),
                message: "empty, a number is required".into(),
            }),
        }
    }

    /// Parses an optional numeric field: empty is `None`; text or non-finite are errors.
    pub fn optional_number(&self, row: &Row, column: usize) -> Result<Option<f64>, WellsError> {
        let text = row.get(column);
        if text.is_empty() {
            return Ok(None);
        }
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            Ok(_) => Err(WellsError::NotFinite {
                file: self.file.clone(),
                line: row.line,
                column: self.headers[column].clone(),
                text: text.to_owned(),
            }),
            Err(_) => Err(WellsError::BadNumber {
                file: self.file.clone(),
                line: row.line,
                column: self.headers[column].clone(),
                text: text.to_owned(),
            }),
        }
    }
}

/// Column aliases used across the tables (normalized: lower case, letters and digits).
pub(crate) mod aliases {
    pub const HOLE: &[&str] = &[
        "holeid",
        "hole",
        "bhid",
        "dhid",
        "drillholeid",
        "drillhole",
        "holename",
        "well",
        "wellid",
        "wellname",
        "name",
        "id",
    ];
    pub const X: &[&str] = &[
        "x", "easting", "east", "xcollar", "xmga", "xutm", "utmx", "e", "xcoord", "eutm",
    ];
    pub const X_PREFIX: &[&str] = &["easting", "eutm", "xutm", "xmga", "xcollar"];
    pub const Y: &[&str] = &[
        "y", "northing", "north", "ycollar", "ymga", "yutm", "utmy", "n", "ycoord", "nutm",
    ];
    pub const Y_PREFIX: &[&str] = &["northing", "nutm", "yutm", "ymga", "ycollar"];
    pub const Z: &[&str] = &[
        "z",
        "elevation",
        "elev",
        "rl",
        "zcollar",
        "zmga",
        "zutm",
        "collarrl",
        "altitude",
        "height",
    ];
    pub const Z_PREFIX: &[&str] = &["elevation", "zmga", "zcollar"];
    pub const LENGTH: &[&str] = &["depth", "length", "maxdepth", "totaldepth", "eoh", "td"];
    pub const SURVEY_DEPTH: &[&str] = &[
        "depth",
        "at",
        "md",
        "surveydepth",
        "distance",
        "depthm",
        "surveyat",
    ];
    pub const AZIMUTH: &[&str] = &["azimuth", "az", "azi", "brg", "bearing", "azim"];
    pub const DIP: &[&str] = &["dip", "surveydip"];
    /// Degrees from vertical (0 = straight down), used when there is no dip column.
    pub const INCLINATION: &[&str] = &["inclination", "inc", "incl", "incli"];
    pub const FROM: &[&str] = &[
        "from",
        "depthfrom",
        "fromdepth",
        "fromm",
        "mfrom",
        "start",
        "top",
        "depthtop",
    ];
    pub const TO: &[&str] = &[
        "to",
        "depthto",
        "todepth",
        "tom",
        "mto",
        "end",
        "bottom",
        "depthbottom",
    ];
    pub const VALUE: &[&str] = &["value", "grade", "v", "val", "class", "indicator", "assay"];
}
