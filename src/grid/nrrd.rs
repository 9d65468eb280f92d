//! NRRD volumes (teem's "nearly raw raster data"): attached `.nrrd` and detached `.nhdr`
//! headers, single data files, `LIST`s and `printf`-style file sequences; raw, gzip and
//! ASCII encodings.
//!
//! Invariant: a volume is returned only when the header is complete and consistent and the
//! decoded data holds exactly `sizes[0] * sizes[1] * sizes[2]` samples.

use std::io::Read;
use std::path::Path;

use glam::DVec3;

use super::raw::{Endian, ScalarType};
use super::{GridError, GridVolume, point_count};

/// Most data files a header may name (a sequence is at most one file per slice).
const MAX_DATA_FILES: usize = 1 << 16;

/// Reads a NRRD volume from `path`; detached data files are found relative to its folder.
pub fn read_nrrd(path: &Path) -> Result<GridVolume, GridError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| GridError::Io {
        file: name.clone(),
        source,
    })?;
    let folder = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut open = |data_file: &str| -> Result<Vec<u8>, GridError> {
        let data_path = folder.join(data_file);
        std::fs::read(&data_path).map_err(|source| GridError::Io {
            file: data_path.display().to_string(),
            source,
        })
    };
    parse_nrrd(&name, &bytes, &mut open)
}

/// Parses a NRRD header (with attached data or not) held in `bytes`; `open` returns the
/// bytes of a detached data file named as in the header.
pub fn parse_nrrd(
    name: &str,
    bytes: &[u8],
    open: &mut dyn FnMut(&str) -> Result<Vec<u8>, GridError>,
) -> Result<GridVolume, GridError> {
    let (header, data_start) = Header::parse(name, bytes)?;
    let count = point_count(name, header.sizes)?;
    let total_bytes = count.checked_mul(header.scalar.size()).ok_or_else(|| {
        GridError::format(name, "sizes", "the volume is larger than can be addressed")
    })?;

    let values = match &header.data_files {
        None => {
            let attached = &bytes[data_start..];
            let data = header.payload(name, attached, total_bytes, 1)?;
            header.decode(name, &data, count)?
        }
        Some(files) => {
            if files.len() > count {
                return Err(GridError::format(
                    name,
                    "data file",
                    format!("{} data files for {count} samples", files.len()),
                ));
            }
            let per_file = total_bytes / files.len();
            let mut data = Vec::new();
            for file in files {
                let content = open(file)?;
                let mut part = header.payload(file, &content, per_file, files.len())?;
                if header.encoding != Encoding::Ascii && data.len() + part.len() > total_bytes {
                    return Err(GridError::format(
                        file,
                        "data file",
                        format!("the data files hold more than the {total_bytes} bytes of sizes"),
                    ));
                }
                data.append(&mut part);
            }
            header.decode(name, &data, count)?
        }
    };

    let mut grid =
        GridVolume::lattice(name, header.sizes, header.space_origin, header.axes, values)?;
    grid.unit = header.unit;
    grid.variable = header.content.unwrap_or_else(|| header.type_name.clone());
    grid.warnings.splice(0..0, header.warnings);
    Ok(grid)
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Raw,
    Gzip,
    Ascii,
}

#[derive(Debug)]
struct Header {
    sizes: [usize; 3],
    scalar: ScalarType,
    type_name: String,
    endian: Option<Endian>,
    encoding: Encoding,
    axes: [DVec3; 3],
    space_origin: DVec3,
    unit: Option<String>,
    content: Option<String>,
    data_files: Option<Vec<String>>,
    line_skip: usize,
    /// `None` is `byte skip: -1` (the data is the file's last bytes).
    byte_skip: Option<usize>,
    warnings: Vec<String>,
}

impl Header {
    /// Parses the header; returns it and where attached data starts.
    fn parse(name: &str, bytes: &[u8]) -> Result<(Header, usize), GridError> {
        if !bytes.starts_with(b"NRRD000") {
            return Err(GridError::format(
                name,
                "magic",
                "not a NRRD file (it must start with NRRD0001..NRRD0005)",
            ));
        }
        let (lines, data_start) = header_lines(name, bytes)?;
        let mut fields = Fields::new();
        for (line_no, line) in lines.iter().skip(1) {
            if line.starts_with('#') {
                continue;
            }
            if line.contains(":=") {
                continue; // key/value pairs carry no geometry
            }
            let Some((field, value)) = line.split_once(": ") else {
                return Err(GridError::format(
                    name,
                    &format!("line {line_no}"),
                    format!("{line:?} is not \"field: value\""),
                ));
            };
            let field_name = field.trim().to_ascii_lowercase();
            if fields.read(name, &field_name, value.trim(), &lines, *line_no)?
                == NextLines::FileNames
            {
                break; // the remaining lines are the file names
            }
        }
        Ok((fields.into_header(name)?, data_start))
    }

    /// The (decompressed) sample bytes of one data file: skips, then decoding. `expected`
    /// is what this file must hold for raw/gzip data (`files` files share the total).
    fn payload(
        &self,
        file: &str,
        content: &[u8],
        expected: usize,
        files: usize,
    ) -> Result<Vec<u8>, GridError> {
        let mut start = 0;
        for _ in 0..self.line_skip {
            match content[start..].iter().position(|b| *b == b'\n') {
                Some(n) => start += n + 1,
                None => {
                    return Err(GridError::format(
                        file,
                        "line skip",
                        format!("fewer than {} lines", self.line_skip),
                    ));
                }
            }
        }
        let body = match self.byte_skip {
            Some(skip) => content.get(start + skip..).ok_or_else(|| {
                GridError::format(
                    file,
                    "byte skip",
                    format!("file is shorter than {skip} bytes"),
                )
            })?,
            None => {
                let rest = &content[start..];
                if rest.len() < expected {
                    return Err(truncated(file, rest.len(), expected));
                }
                &rest[rest.len() - expected..]
            }
        };
        match self.encoding {
            Encoding::Ascii => Ok(body.to_vec()),
            Encoding::Raw => {
                if files == 1 && body.len() < expected {
                    return Err(truncated(file, body.len(), expected));
                }
                if files == 1 && body.len() > expected {
                    return Err(GridError::format(
                        file,
                        "data",
                        format!(
                            "{} bytes of data, more than the {expected} that sizes and type need",
                            body.len()
                        ),
                    ));
                }
                Ok(body.to_vec())
            }
            Encoding::Gzip => {
                let mut out = Vec::new();
                flate2::read::MultiGzDecoder::new(body)
                    .take(expected as u64 + 1)
                    .read_to_end(&mut out)
                    .map_err(|e| {
                        GridError::format(file, "data", format!("gzip data is corrupt: {e}"))
                    })?;
                if out.len() > expected {
                    return Err(GridError::format(
                        file,
                        "data",
                        format!(
                            "gzip data holds more than the {expected} bytes that sizes and type need"
                        ),
                    ));
                }
                Ok(out)
            }
        }
    }

    /// Decodes the concatenated payloads into exactly `count` values.
    fn decode(&self, name: &str, data: &[u8], count: usize) -> Result<Vec<f64>, GridError> {
        if self.encoding == Encoding::Ascii {
            let text = std::str::from_utf8(data)
                .map_err(|_| GridError::format(name, "data", "ASCII data is not text"))?;
            let mut values = Vec::with_capacity(count.min(data.len() / 2 + 1));
            for (n, word) in text
                .split(|c: char| c.is_whitespace() || c == ',')
                .filter(|w| !w.is_empty())
                .enumerate()
            {
                if n >= count {
                    return Err(GridError::format(
                        name,
                        "data",
                        format!("more than the {count} values that sizes need"),
                    ));
                }
                values.push(word.parse::<f64>().map_err(|_| {
                    GridError::format(
                        name,
                        "data",
                        format!("value {} {word:?} is not a number", n + 1),
                    )
                })?);
            }
            if values.len() != count {
                return Err(GridError::format(
                    name,
                    "data",
                    format!("{} values, but sizes need {count}", values.len()),
                ));
            }
            return Ok(values);
        }
        let expected = count * self.scalar.size();
        if data.len() != expected {
            return Err(truncated(name, data.len(), expected));
        }
        Ok(self
            .scalar
            .decode(data, self.endian.unwrap_or(Endian::Little)))
    }
}

fn truncated(file: &str, found: usize, expected: usize) -> GridError {
    GridError::format(
        file,
        "data",
        format!("{found} bytes of data, but sizes and type need {expected} (truncated?)"),
    )
}

/// The header's lines (numbered from 1) up to the blank line, and where the data after it
/// starts (the end of `bytes` when there is none).
fn header_lines(name: &str, bytes: &[u8]) -> Result<(Vec<(usize, String)>, usize), GridError> {
    let mut pos = 0;
    let mut lines: Vec<(usize, String)> = Vec::new();
    let mut data_start = bytes.len();
    let mut line_no = 0;
    while pos < bytes.len() {
        let end = bytes[pos..]
            .iter()
            .position(|b| *b == b'\n')
            .map_or(bytes.len(), |e| pos + e);
        let raw_line = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        line_no += 1;
        let raw_line = raw_line.strip_suffix(b"\r").unwrap_or(raw_line);
        if raw_line.is_empty() {
            data_start = pos;
            break;
        }
        let line = std::str::from_utf8(raw_line).map_err(|_| {
            GridError::format(name, &format!("line {line_no}"), "header text is not UTF-8")
        })?;
        lines.push((line_no, line.to_string()));
    }
    Ok((lines, data_start))
}

/// Whether the header lines after a field are still fields.
#[derive(Debug, PartialEq)]
enum NextLines {
    Fields,
    /// `data file: LIST`: the remaining lines are the data files' names.
    FileNames,
}

/// A NRRD header's fields as read, before they are checked to make a [`Header`].
struct Fields {
    dimension: Option<usize>,
    sizes: Option<Vec<usize>>,
    scalar: Option<(ScalarType, String)>,
    endian: Option<Endian>,
    encoding: Option<Encoding>,
    spacings: Option<Vec<f64>>,
    directions: Option<[DVec3; 3]>,
    space_origin: Option<DVec3>,
    unit: Option<String>,
    content: Option<String>,
    data_files: Option<Vec<String>>,
    line_skip: usize,
    byte_skip: Option<usize>,
    warnings: Vec<String>,
}

impl Fields {
    fn new() -> Self {
        Self {
            dimension: None,
            sizes: None,
            scalar: None,
            endian: None,
            encoding: None,
            spacings: None,
            directions: None,
            space_origin: None,
            unit: None,
            content: None,
            data_files: None,
            line_skip: 0,
            byte_skip: Some(0),
            warnings: Vec::new(),
        }
    }

    /// Reads `field: value` (the field in lower case) of header line `line_no`.
    fn read(
        &mut self,
        name: &str,
        field: &str,
        value: &str,
        lines: &[(usize, String)],
        line_no: usize,
    ) -> Result<NextLines, GridError> {
        match field {
            "dimension" => self.dimension = Some(parse_usize(name, field, value)?),
            "sizes" => {
                let list = value
                    .split_whitespace()
                    .map(|v| parse_usize(name, field, v))
                    .collect::<Result<Vec<_>, _>>()?;
                self.sizes = Some(list);
            }
            "type" => {
                self.scalar = Some((parse_type(name, value)?, value.to_string()));
            }
            "endian" => {
                self.endian = Some(match value.to_ascii_lowercase().as_str() {
                    "little" => Endian::Little,
                    "big" => Endian::Big,
                    _ => {
                        return Err(GridError::format(
                            name,
                            field,
                            format!("{value:?}: expected little or big"),
                        ));
                    }
                })
            }
            "encoding" => {
                self.encoding = Some(match value.to_ascii_lowercase().as_str() {
                    "raw" => Encoding::Raw,
                    "gzip" | "gz" => Encoding::Gzip,
                    "ascii" | "text" | "txt" => Encoding::Ascii,
                    other => {
                        return Err(GridError::unsupported(
                            name,
                            field,
                            format!("encoding {other:?}"),
                        ));
                    }
                })
            }
            "spacings" => {
                let list = value
                    .split_whitespace()
                    .map(|v| parse_f64(name, field, v))
                    .collect::<Result<Vec<_>, _>>()?;
                self.spacings = Some(list);
            }
            "space directions" => self.directions = Some(parse_directions(name, value)?),
            "space origin" => {
                let v = parse_vector(name, field, value)?;
                self.space_origin = Some(v);
            }
            "space units" => {
                let units: Vec<&str> = value
                    .split('"')
                    .map(str::trim)
                    .filter(|u| !u.is_empty())
                    .collect();
                if units.windows(2).any(|w| w[0] != w[1]) {
                    self.warnings.push(format!(
                        "{name}: space units: axes have different units {units:?}; using {:?}",
                        units[0]
                    ));
                }
                self.unit = units.first().map(|u| u.to_string());
            }
            "content" => self.content = Some(value.to_string()),
            "data file" | "datafile" => {
                self.data_files = Some(parse_data_files(name, value, lines, line_no)?);
                if value.split_whitespace().next() == Some("LIST") {
                    return Ok(NextLines::FileNames);
                }
            }
            "line skip" | "lineskip" => self.line_skip = parse_usize(name, field, value)?,
            "byte skip" | "byteskip" => {
                self.byte_skip = if value == "-1" {
                    None
                } else {
                    Some(parse_usize(name, field, value)?)
                }
            }
            "space" | "space dimension" | "kinds" | "centers" | "centerings" | "labels"
            | "units" | "thicknesses" | "axis mins" | "axismins" | "axis maxs" | "axismaxs"
            | "min" | "max" | "old min" | "oldmin" | "old max" | "oldmax" | "sample units"
            | "sampleunits" | "measurement frame" | "number" | "block size" | "blocksize" => {}
            other => self
                .warnings
                .push(format!("{name}: unknown header field {other:?} ignored")),
        }
        Ok(NextLines::Fields)
    }

    /// The header the fields make: every required field there, consistent.
    fn into_header(mut self, name: &str) -> Result<Header, GridError> {
        let dimension = self
            .dimension
            .ok_or_else(|| GridError::format(name, "dimension", "missing"))?;
        if dimension != 3 {
            return Err(GridError::unsupported(
                name,
                "dimension",
                format!("a {dimension}-dimensional array (only 3D volumes)"),
            ));
        }
        let sizes = self
            .sizes
            .take()
            .ok_or_else(|| GridError::format(name, "sizes", "missing"))?;
        let sizes: [usize; 3] = sizes.as_slice().try_into().map_err(|_| {
            GridError::format(
                name,
                "sizes",
                format!("{} sizes for dimension 3", sizes.len()),
            )
        })?;
        let (scalar, type_name) = self
            .scalar
            .take()
            .ok_or_else(|| GridError::format(name, "type", "missing"))?;
        let encoding = self
            .encoding
            .ok_or_else(|| GridError::format(name, "encoding", "missing"))?;
        if encoding != Encoding::Ascii && scalar.size() > 1 && self.endian.is_none() {
            return Err(GridError::format(
                name,
                "endian",
                format!("missing (required for {type_name:?} samples)"),
            ));
        }
        if self.byte_skip.is_none() && encoding != Encoding::Raw {
            return Err(GridError::format(
                name,
                "byte skip",
                "-1 is only allowed with raw encoding",
            ));
        }
        let axes = self.axes(name)?;
        Ok(Header {
            sizes,
            scalar,
            type_name,
            endian: self.endian,
            encoding,
            axes,
            space_origin: self.space_origin.unwrap_or(DVec3::ZERO),
            unit: self.unit,
            content: self.content,
            data_files: self.data_files,
            line_skip: self.line_skip,
            byte_skip: self.byte_skip,
            warnings: self.warnings,
        })
    }

    /// The grid's axes: the space directions, else the spacings along x, y and z, else
    /// spacing 1 (with a warning).
    fn axes(&mut self, name: &str) -> Result<[DVec3; 3], GridError> {
        match (self.directions, &self.spacings) {
            (Some(d), _) => Ok(d),
            (None, Some(s)) => {
                if s.len() != 3 {
                    return Err(GridError::format(
                        name,
                        "spacings",
                        format!("{} spacings for dimension 3", s.len()),
                    ));
                }
                if s.iter().any(|v| !v.is_finite() || *v == 0.0) {
                    return Err(GridError::format(
                        name,
                        "spacings",
                        format!("{s:?}: each must be a finite, non-zero number"),
                    ));
                }
                Ok([
                    DVec3::new(s[0], 0.0, 0.0),
                    DVec3::new(0.0, s[1], 0.0),
                    DVec3::new(0.0, 0.0, s[2]),
                ])
            }
            (None, None) => {
                self.warnings.push(format!(
                    "{name}: neither spacings nor space directions given; using spacing 1"
                ));
                Ok([DVec3::X, DVec3::Y, DVec3::Z])
            }
        }
    }
}

fn parse_usize(name: &str, field: &str, value: &str) -> Result<usize, GridError> {
    value
        .trim()
        .parse()
        .map_err(|_| GridError::format(name, field, format!("{value:?} is not a whole number")))
}

fn parse_f64(name: &str, field: &str, value: &str) -> Result<f64, GridError> {
    value
        .trim()
        .parse()
        .map_err(|_| GridError::format(name, field, format!("{value:?} is not a number")))
}

/// `(x,y,z)`.
fn parse_vector(name: &str, field: &str, value: &str) -> Result<DVec3, GridError> {
    let inner = value
        .trim()
        .strip_prefix('(')
        .and_then(|v| v.strip_suffix(')'))
        .ok_or_else(|| GridError::format(name, field, format!("{value:?} is not (x,y,z)")))?;
    let parts = inner
        .split(',')
        .map(|v| parse_f64(name, field, v))
        .collect::<Result<Vec<_>, _>>()?;
    match parts.as_slice() {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(GridError::format(
            name,
            field,
            format!("{value:?} is not three finite numbers (x,y,z)"),
        )),
    }
}

/// `(a,b,c) (d,e,f) (g,h,i)`: one vector per axis.
fn parse_directions(name: &str, value: &str) -> Result<[DVec3; 3], GridError> {
    let field = "space directions";
    let vectors = value
        .split_whitespace()
        .map(|v| {
            if v == "none" {
                Err(GridError::unsupported(
                    name,
                    field,
                    "a non-spatial axis (\"none\")".to_string(),
                ))
            } else {
                parse_vector(name, field, v)
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    let axes: [DVec3; 3] = vectors.as_slice().try_into().map_err(|_| {
        GridError::format(
            name,
            field,
            format!("{} vectors for dimension 3", vectors.len()),
        )
    })?;
    Ok(axes)
}

fn parse_type(name: &str, value: &str) -> Result<ScalarType, GridError> {
    let normalised = value.split_whitespace().collect::<Vec<_>>().join(" ");
    Ok(match normalised.as_str() {
        "signed char" | "int8" | "int8_t" => ScalarType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => ScalarType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            ScalarType::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            ScalarType::U16
        }
        "int" | "signed int" | "int32" | "int32_t" => ScalarType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => ScalarType::U32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => ScalarType::I64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            ScalarType::U64
        }
        "float" => ScalarType::F32,
        "double" => ScalarType::F64,
        "block" => return Err(GridError::unsupported(name, "type", "\"block\" samples")),
        other => {
            return Err(GridError::format(
                name,
                "type",
                format!("{other:?} is not a NRRD sample type"),
            ));
        }
    })
}

/// The data file list: one name, `LIST [subdim]` (names on the following lines) or
/// `format min max step [subdim]` with a `printf` integer conversion in `format`.
fn parse_data_files(
    name: &str,
    value: &str,
    lines: &[(usize, String)],
    line_no: usize,
) -> Result<Vec<String>, GridError> {
    let field = "data file";
    let words: Vec<&str> = value.split_whitespace().collect();
    if words.first() == Some(&"LIST") {
        let files: Vec<String> = lines
            .iter()
            .filter(|(n, _)| *n > line_no)
            .map(|(_, l)| l.trim().to_string())
            .filter(|l| !l.is_empty())
            .collect();
        if files.is_empty() || files.len() > MAX_DATA_FILES {
            return Err(GridError::format(
                name,
                field,
                format!("LIST names {} files", files.len()),
            ));
        }
        return Ok(files);
    }
    if words.len() >= 4 && words[0].contains('%') {
        let number = |w: &str| -> Result<i128, GridError> {
            w.parse::<i64>()
                .map(i128::from)
                .map_err(|_| GridError::format(name, field, format!("{w:?} is not an integer")))
        };
        let (min, max, step) = (number(words[1])?, number(words[2])?, number(words[3])?);
        if step == 0 || (max - min).signum() * step.signum() < 0 {
            return Err(GridError::format(
                name,
                field,
                format!("{min} to {max} by {step} is not a sequence"),
            ));
        }
        let count = (max - min) / step + 1;
        if count > MAX_DATA_FILES as i128 {
            return Err(GridError::format(
                name,
                field,
                format!("{count} files is more than {MAX_DATA_FILES}"),
            ));
        }
        return (0..count)
            .map(|n| format_number(name, words[0], (min + n * step) as i64))
            .collect();
    }
    if words.is_empty() {
        return Err(GridError::format(name, field, "empty"));
    }
    Ok(value.trim().to_string()).map(|f| vec![f])
}

/// Replaces the one `%d`, `%Nd` or `%0Nd` conversion of `format` with `n`.
fn format_number(name: &str, format: &str, n: i64) -> Result<String, GridError> {
    let bad = || {
        GridError::format(
            name,
            "data file",
            format!("{format:?} needs exactly one %d, %Nd or %0Nd conversion"),
        )
    };
    let start = format.find('%').ok_or_else(bad)?;
    let rest = &format[start + 1..];
    let end = rest.find('d').ok_or_else(bad)?;
    let spec = &rest[..end];
    let after = &rest[end + 1..];
    if after.contains('%') || !spec.chars().all(|c| c.is_ascii_digit()) || spec.len() > 3 {
        return Err(bad());
    }
    let width: usize = if spec.is_empty() {
        0
    } else {
        spec.parse().map_err(|_| bad())?
    };
    let digits = if spec.starts_with('0') {
        format!("{n:0width$}")
    } else {
        format!("{n:width$}")
    };
    Ok(format!("{}{digits}{after}", &format[..start]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn no_files(_: &str) -> Result<Vec<u8>, GridError> {
        Err(GridError::format(
            "none",
            "data file",
            "no detached files in this test",
        ))
    }

    #[test]
    fn attached_raw_volume() {
        let mut bytes = b"NRRD0004\n# comment\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspacings: 1 2 3\nencoding: raw\nspace units: \"mm\" \"mm\" \"mm\"\n\n".to_vec();
        bytes.extend(0u8..8);
        let grid = parse_nrrd("a.nrrd", &bytes, &mut no_files).unwrap();
        assert_eq!(grid.values, (0..8).map(f64::from).collect::<Vec<_>>());
        assert_eq!(grid.unit.as_deref(), Some("mm"));
        let extent = grid.points[7] - grid.points[0];
        assert_eq!(extent, DVec3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn detached_sequence_with_gzip_and_big_endian() {
        use std::io::Write;
        let header = b"NRRD0004\ndimension: 3\nsizes: 2 2 3\ntype: short\nendian: big\nencoding: gzip\nspace directions: (1,0,0) (0,1,0) (0,0,2)\nspace origin: (10,20,30)\ndata file: s%03d.gz 1 3 1\n";
        let mut files = HashMap::new();
        for n in 1..=3 {
            let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
            for v in 0..4i16 {
                gz.write_all(&(v * n).to_be_bytes()).unwrap();
            }
            files.insert(format!("s{n:03}.gz"), gz.finish().unwrap());
        }
        let mut open = |f: &str| {
            files
                .get(f)
                .cloned()
                .ok_or_else(|| GridError::format(f, "data file", "missing"))
        };
        let grid = parse_nrrd("h.nhdr", header, &mut open).unwrap();
        assert_eq!(&grid.values[8..], &[0.0, 3.0, 6.0, 9.0]);
        assert_eq!(grid.origin, DVec3::new(10.5, 20.5, 32.0));
    }

    #[test]
    fn truncated_data_is_an_error_naming_the_file() {
        let mut bytes =
            b"NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\n\n"
                .to_vec();
        bytes.extend([0u8; 31]);
        let err = parse_nrrd("cut.nrrd", &bytes, &mut no_files)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("cut.nrrd") && err.contains("31 bytes"),
            "{err}"
        );
    }

    #[test]
    fn missing_endian_is_named() {
        let bytes = b"NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n";
        let err = parse_nrrd("e.nrrd", bytes, &mut no_files)
            .unwrap_err()
            .to_string();
        assert!(err.contains("endian"), "{err}");
    }

    #[test]
    fn ascii_and_byte_skip_minus_one() {
        let text = b"NRRD0004\ntype: double\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n\n1 2 3 4\n5 6 7 8.5\n";
        let grid = parse_nrrd("t.nrrd", text, &mut no_files).unwrap();
        assert_eq!(grid.values[7], 8.5);

        let mut open = |_: &str| Ok(vec![9u8, 9, 0, 1, 2, 3, 4, 5, 6, 7]);
        let header = b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: -1\ndata file: v.raw\n";
        let grid = parse_nrrd("v.nhdr", header, &mut open).unwrap();
        assert_eq!(grid.values[0], 0.0);
        assert_eq!(grid.values[7], 7.0);
    }

    #[test]
    fn printf_formats() {
        assert_eq!(format_number("h", "quarter.%d", 7).unwrap(), "quarter.7");
        assert_eq!(format_number("h", "s%03d.raw", 7).unwrap(), "s007.raw");
        assert!(format_number("h", "s%s", 7).is_err());
        assert!(format_number("h", "%d%d", 7).is_err());
    }
}
