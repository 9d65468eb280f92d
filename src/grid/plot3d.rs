//! PLOT3D curvilinear grids: a binary grid (`xyz`) file and its solution (`q`) file.
//!
//! Layouts recognised by size: either byte order, with or without Fortran record markers,
//! single or multi-grid, 32- or 64-bit reals, with or without IBLANK. The layout is the
//! one that accounts for every byte of the file (trailing zero bytes are tolerated with a
//! warning).
//!
//! Invariant: values come from exactly one block whose grid and solution dimensions agree;
//! a derived variable is only computed where it is defined (positive density, and
//! pressure for the Mach number), anything else is an error naming the point.

use glam::DVec3;

use super::raw::Endian;
use super::{GridError, GridVolume, point_count};

/// Ratio of specific heats used for pressure and Mach number (air).
pub const GAMMA: f64 = 1.4;

/// Most blocks a multi-grid file may declare.
const MAX_BLOCKS: usize = 100_000;

/// What to contour from a PLOT3D solution: the stored `q` arrays or a quantity derived
/// from them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plot3dVariable {
    Density,
    MomentumX,
    MomentumY,
    MomentumZ,
    /// Stagnation energy per unit volume, as stored.
    Energy,
    VelocityX,
    VelocityY,
    VelocityZ,
    VelocityMagnitude,
    /// `(gamma - 1) (e - |m|^2 / (2 rho))`, `gamma` = `GAMMA`.
    Pressure,
    /// `|v| / sqrt(gamma p / rho)`.
    Mach,
}

impl Plot3dVariable {
    pub const ALL: [Plot3dVariable; 11] = [
        Plot3dVariable::Density,
        Plot3dVariable::MomentumX,
        Plot3dVariable::MomentumY,
        Plot3dVariable::MomentumZ,
        Plot3dVariable::Energy,
        Plot3dVariable::VelocityX,
        Plot3dVariable::VelocityY,
        Plot3dVariable::VelocityZ,
        Plot3dVariable::VelocityMagnitude,
        Plot3dVariable::Pressure,
        Plot3dVariable::Mach,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Plot3dVariable::Density => "density",
            Plot3dVariable::MomentumX => "momentum_x",
            Plot3dVariable::MomentumY => "momentum_y",
            Plot3dVariable::MomentumZ => "momentum_z",
            Plot3dVariable::Energy => "energy",
            Plot3dVariable::VelocityX => "velocity_x",
            Plot3dVariable::VelocityY => "velocity_y",
            Plot3dVariable::VelocityZ => "velocity_z",
            Plot3dVariable::VelocityMagnitude => "velocity_magnitude",
            Plot3dVariable::Pressure => "pressure",
            Plot3dVariable::Mach => "mach",
        }
    }
}

impl std::str::FromStr for Plot3dVariable {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let lower = s.to_ascii_lowercase().replace('-', "_");
        Plot3dVariable::ALL
            .into_iter()
            .find(|v| v.name() == lower)
            .ok_or_else(|| {
                let names: Vec<&str> = Plot3dVariable::ALL.iter().map(|v| v.name()).collect();
                format!(
                    "unknown PLOT3D variable {s:?}: expected one of {}",
                    names.join(", ")
                )
            })
    }
}

/// Reads block `block` (0-based) of a PLOT3D grid file and its solution file and returns
/// the chosen variable on the curvilinear grid.
pub fn read_plot3d(
    xyz_name: &str,
    xyz: &[u8],
    q_name: &str,
    q: &[u8],
    variable: Plot3dVariable,
    block: usize,
) -> Result<GridVolume, GridError> {
    let mut warnings = Vec::new();
    let grid = detect(xyz_name, xyz, FileKind::Grid, &mut warnings)?;
    let solution = detect(q_name, q, FileKind::Solution, &mut warnings)?;
    let blocks = grid.dims.len();
    if block >= blocks {
        return Err(GridError::format(
            xyz_name,
            "block",
            format!("block {block} asked for, the file has {blocks} (numbered from 0)"),
        ));
    }
    if solution.dims.len() != blocks {
        return Err(GridError::format(
            q_name,
            "blocks",
            format!(
                "{} blocks, but grid file {xyz_name} has {blocks}",
                solution.dims.len()
            ),
        ));
    }
    let dims = grid.dims[block];
    if solution.dims[block] != dims {
        return Err(GridError::format(
            q_name,
            "dims",
            format!(
                "block {block} is {:?}, but grid file {xyz_name} says {dims:?}",
                solution.dims[block]
            ),
        ));
    }
    let count = point_count(xyz_name, dims)?;

    let g = grid.layout;
    let coords = g.reals(&grid.payloads[block][..3 * count * g.real_size()]);
    let blanked = if g.iblank {
        let flags = &grid.payloads[block][3 * count * g.real_size()..];
        flags
            .chunks_exact(4)
            .map(|c| g.int(c) == 0)
            .collect::<Vec<bool>>()
    } else {
        Vec::new()
    };
    let points: Vec<DVec3> = (0..count)
        .map(|n| DVec3::new(coords[n], coords[count + n], coords[2 * count + n]))
        .collect();

    let s = solution.layout;
    let q_values = s.reals(solution.payloads[block]);
    let array = |n: usize| &q_values[n * count..(n + 1) * count];
    let values = derive(
        q_name,
        dims,
        variable,
        [array(0), array(1), array(2), array(3), array(4)],
        &blanked,
    )?;

    let mut volume = GridVolume::curvilinear(
        &format!("{xyz_name} + {q_name}"),
        dims,
        points,
        values,
        blanked,
    )?;
    volume.variable = variable.name().to_string();
    warnings.append(&mut volume.warnings);
    volume.warnings = warnings;
    Ok(volume)
}

/// Computes `variable` at every point from `rho, rho*u, rho*v, rho*w, e`.
fn derive(
    q_name: &str,
    dims: [usize; 3],
    variable: Plot3dVariable,
    [rho, mx, my, mz, e]: [&[f64]; 5],
    blanked: &[bool],
) -> Result<Vec<f64>, GridError> {
    use Plot3dVariable as V;
    let needs_energy = matches!(variable, V::Pressure | V::Mach);
    if needs_energy && e.iter().all(|v| *v == 0.0) {
        return Err(GridError::format(
            q_name,
            "energy",
            format!(
                "the energy array is all zero, so {} is undefined",
                variable.name()
            ),
        ));
    }
    let at = |n: usize| {
        let [i, j, k] = super::ijk(dims, n);
        format!("point ({i}, {j}, {k})")
    };
    let mut values = Vec::with_capacity(rho.len());
    for n in 0..rho.len() {
        if blanked.get(n).copied().unwrap_or(false) {
            values.push(0.0);
            continue;
        }
        let m = DVec3::new(mx[n], my[n], mz[n]);
        let needs_density = !matches!(
            variable,
            V::Density | V::MomentumX | V::MomentumY | V::MomentumZ | V::Energy
        );
        if needs_density && (rho[n].is_nan() || rho[n] <= 0.0) {
            return Err(GridError::format(
                q_name,
                "density",
                format!(
                    "{} has density {}, so {} is undefined",
                    at(n),
                    rho[n],
                    variable.name()
                ),
            ));
        }
        let pressure = || (GAMMA - 1.0) * (e[n] - 0.5 * m.length_squared() / rho[n]);
        let value = match variable {
            V::Density => rho[n],
            V::MomentumX => m.x,
            V::MomentumY => m.y,
            V::MomentumZ => m.z,
            V::Energy => e[n],
            V::VelocityX => m.x / rho[n],
            V::VelocityY => m.y / rho[n],
            V::VelocityZ => m.z / rho[n],
            V::VelocityMagnitude => m.length() / rho[n],
            V::Pressure => pressure(),
            V::Mach => {
                let p = pressure();
                if p.is_nan() || p <= 0.0 {
                    return Err(GridError::format(
                        q_name,
                        "energy",
                        format!(
                            "{} has pressure {p}, so the Mach number is undefined",
                            at(n)
                        ),
                    ));
                }
                (m.length() / rho[n]) / (GAMMA * p / rho[n]).sqrt()
            }
        };
        values.push(value);
    }
    Ok(values)
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum FileKind {
    Grid,
    Solution,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Layout {
    endian: Endian,
    markers: bool,
    multi: bool,
    double: bool,
    /// Grid files only.
    iblank: bool,
}

impl Layout {
    fn real_size(self) -> usize {
        if self.double { 8 } else { 4 }
    }

    fn int(self, b: &[u8]) -> i32 {
        let b = [b[0], b[1], b[2], b[3]];
        match self.endian {
            Endian::Little => i32::from_le_bytes(b),
            Endian::Big => i32::from_be_bytes(b),
        }
    }

    fn reals(self, bytes: &[u8]) -> Vec<f64> {
        let scalar = if self.double {
            super::raw::ScalarType::F64
        } else {
            super::raw::ScalarType::F32
        };
        scalar.decode(bytes, self.endian)
    }

    fn describe(self) -> String {
        format!(
            "{}-endian, {}, {}, {}-bit reals{}",
            if self.endian == Endian::Big {
                "big"
            } else {
                "little"
            },
            if self.markers {
                "Fortran records"
            } else {
                "no record markers"
            },
            if self.multi {
                "multi-grid"
            } else {
                "single grid"
            },
            if self.double { 64 } else { 32 },
            if self.iblank { ", IBLANK" } else { "" },
        )
    }
}

/// A file parsed under one layout.
struct Parsed<'a> {
    layout: Layout,
    dims: Vec<[usize; 3]>,
    /// Per block: coordinates (+ IBLANK) or the five solution arrays.
    payloads: Vec<&'a [u8]>,
    trailing: usize,
}

enum Mismatch {
    /// The header does not read as this layout.
    Header,
    /// Plausible header, but the file ends before the data does.
    Truncated { needed: usize },
}

struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    layout: Layout,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let out = self.bytes.get(self.pos..end)?;
        self.pos = end;
        Some(out)
    }

    /// One Fortran record (or, without markers, `len` plain bytes).
    fn record(&mut self, len: usize) -> Result<&'a [u8], Mismatch> {
        let start = self.pos;
        let needed = || Mismatch::Truncated {
            needed: start.saturating_add(len).saturating_add(8),
        };
        if self.layout.markers {
            let head = self.take(4).ok_or(Mismatch::Header)?;
            if self.layout.int(head) as i64 != len as i64 {
                return Err(Mismatch::Header);
            }
            let body = match self.take(len) {
                Some(b) => b,
                None => return Err(needed()),
            };
            let tail = self.take(4).ok_or_else(needed)?;
            if self.layout.int(tail) as i64 != len as i64 {
                return Err(Mismatch::Header);
            }
            Ok(body)
        } else {
            self.take(len).ok_or_else(needed)
        }
    }
}

fn parse<'a>(bytes: &'a [u8], kind: FileKind, layout: Layout) -> Result<Parsed<'a>, Mismatch> {
    let mut cur = Cursor {
        bytes,
        pos: 0,
        layout,
    };
    let blocks = if layout.multi {
        let b = cur.record(4)?;
        let n = layout.int(b);
        if n < 1 || n as usize > MAX_BLOCKS {
            return Err(Mismatch::Header);
        }
        n as usize
    } else {
        1
    };
    let dims_bytes = cur.record(12 * blocks).map_err(|_| Mismatch::Header)?;
    let mut dims = Vec::with_capacity(blocks);
    for d in dims_bytes.chunks_exact(12) {
        let v = [
            layout.int(&d[0..4]),
            layout.int(&d[4..8]),
            layout.int(&d[8..12]),
        ];
        if v.iter().any(|x| *x < 1) {
            return Err(Mismatch::Header);
        }
        dims.push(v.map(|x| x as usize));
    }
    let mut payloads = Vec::with_capacity(blocks);
    for d in &dims {
        let count = d[0]
            .checked_mul(d[1])
            .and_then(|n| n.checked_mul(d[2]))
            .ok_or(Mismatch::Header)?;
        if count > bytes.len() {
            return Err(Mismatch::Header);
        }
        match kind {
            FileKind::Grid => {
                let per_point = 3 * layout.real_size() + if layout.iblank { 4 } else { 0 };
                payloads.push(cur.record(count * per_point)?);
            }
            FileKind::Solution => {
                cur.record(4 * layout.real_size())?; // fsmach, alpha, re, time
                payloads.push(cur.record(5 * count * layout.real_size())?);
            }
        }
    }
    Ok(Parsed {
        layout,
        dims,
        payloads,
        trailing: bytes.len() - cur.pos,
    })
}

/// Finds the layout that accounts for the whole file.
fn detect<'a>(
    name: &str,
    bytes: &'a [u8],
    kind: FileKind,
    warnings: &mut Vec<String>,
) -> Result<Parsed<'a>, GridError> {
    let mut exact = Vec::new();
    let mut padded = Vec::new();
    let mut truncated: Option<(Layout, usize)> = None;
    for endian in [Endian::Big, Endian::Little] {
        for markers in [false, true] {
            for multi in [false, true] {
                for double in [false, true] {
                    for iblank in [false, true] {
                        if iblank && kind == FileKind::Solution {
                            continue;
                        }
                        let layout = Layout {
                            endian,
                            markers,
                            multi,
                            double,
                            iblank,
                        };
                        match parse(bytes, kind, layout) {
                            Ok(p) if p.trailing == 0 => exact.push(p),
                            Ok(p) if bytes[bytes.len() - p.trailing..].iter().all(|b| *b == 0) => {
                                padded.push(p)
                            }
                            Ok(_) | Err(Mismatch::Header) => {}
                            Err(Mismatch::Truncated { needed }) => {
                                if truncated.is_none_or(|(_, n)| needed < n) {
                                    truncated = Some((layout, needed));
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    let chosen = if !exact.is_empty() {
        &mut exact
    } else {
        &mut padded
    };
    if chosen.len() > 1 {
        warnings.push(format!(
            "{name}: layout is ambiguous ({} fit); reading it as {}",
            chosen.len(),
            chosen[0].layout.describe()
        ));
    }
    if !chosen.is_empty() {
        let parsed = chosen.swap_remove(0);
        if parsed.trailing > 0 {
            warnings.push(format!(
                "{name}: {} trailing zero bytes after the data ignored",
                parsed.trailing
            ));
        }
        return Ok(parsed);
    }
    let what = match kind {
        FileKind::Grid => "grid (xyz)",
        FileKind::Solution => "solution (q)",
    };
    if let Some((layout, needed)) = truncated {
        return Err(GridError::format(
            name,
            "data",
            format!(
                "truncated PLOT3D {what} file: read as {}, it needs at least {needed} bytes, it has {}",
                layout.describe(),
                bytes.len()
            ),
        ));
    }
    Err(GridError::format(
        name,
        "layout",
        format!(
            "its {} bytes fit no binary 3D PLOT3D {what} layout (either byte order, with or \
             without record markers, single or multi-grid, 32/64-bit reals, with or without \
             IBLANK)",
            bytes.len()
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes a grid and a solution file, big-endian floats, no record markers.
    pub(super) fn files(dims: [usize; 3], markers: bool, iblank: bool) -> (Vec<u8>, Vec<u8>) {
        let n = dims.iter().product::<usize>();
        let rec = |out: &mut Vec<u8>, body: Vec<u8>| {
            if markers {
                out.extend((body.len() as i32).to_be_bytes());
            }
            out.extend(&body);
            if markers {
                out.extend((body.len() as i32).to_be_bytes());
            }
        };
        let dims_bytes: Vec<u8> = dims
            .iter()
            .flat_map(|d| (*d as i32).to_be_bytes())
            .collect();
        let mut xyz = Vec::new();
        rec(&mut xyz, dims_bytes.clone());
        let mut body = Vec::new();
        for axis in 0..3 {
            for p in 0..n {
                let [i, j, k] = super::super::ijk(dims, p);
                body.extend(([i, j, k][axis] as f32 * 2.0).to_be_bytes());
            }
        }
        if iblank {
            for p in 0..n {
                body.extend(i32::from(p != 0).to_be_bytes());
            }
        }
        rec(&mut xyz, body);
        let mut q = Vec::new();
        rec(&mut q, dims_bytes);
        rec(
            &mut q,
            [0.5f32, 0.0, 1e6, 0.0]
                .iter()
                .flat_map(|v| v.to_be_bytes())
                .collect(),
        );
        let mut body = Vec::new();
        for var in 0..5 {
            for p in 0..n {
                let value = match var {
                    0 => 2.0f32,
                    1 => 6.0,
                    2 => 0.0,
                    3 => 8.0,
                    _ => 100.0 + p as f32,
                };
                body.extend(value.to_be_bytes());
            }
        }
        rec(&mut q, body);
        (xyz, q)
    }

    #[test]
    fn reads_plain_and_fortran_layouts() {
        for markers in [false, true] {
            let (xyz, q) = files([3, 2, 2], markers, false);
            let grid = read_plot3d(
                "g.xyz",
                &xyz,
                "g.q",
                &q,
                Plot3dVariable::VelocityMagnitude,
                0,
            )
            .unwrap();
            assert_eq!(grid.dims, [3, 2, 2]);
            assert!(grid.values.iter().all(|v| (*v - 5.0).abs() < 1e-12));
            assert_eq!(grid.points[1] - grid.points[0], DVec3::new(2.0, 0.0, 0.0));
        }
    }

    #[test]
    fn derived_pressure_and_iblank() {
        let (xyz, q) = files([2, 2, 2], false, true);
        let grid = read_plot3d("g.xyz", &xyz, "g.q", &q, Plot3dVariable::Pressure, 0).unwrap();
        assert!(grid.is_blanked(0));
        // p = 0.4 * (e - |m|^2 / (2 rho)) = 0.4 * (100 + n - 25)
        assert!((grid.values[3] - 0.4 * 78.0).abs() < 1e-9);
    }

    #[test]
    fn trailing_zeros_are_tolerated_other_trailing_bytes_are_not() {
        let (xyz, mut q) = files([2, 2, 2], false, false);
        q.extend([0u8; 20]);
        let grid = read_plot3d("g.xyz", &xyz, "g.q", &q, Plot3dVariable::Density, 0).unwrap();
        assert!(grid.warnings.iter().any(|w| w.contains("trailing")));
        q.push(1);
        assert!(read_plot3d("g.xyz", &xyz, "g.q", &q, Plot3dVariable::Density, 0).is_err());
    }

    #[test]
    fn truncated_and_mismatched_files_are_named() {
        let (xyz, q) = files([3, 2, 2], false, false);
        let err = read_plot3d(
            "g.xyz",
            &xyz[..xyz.len() - 3],
            "g.q",
            &q,
            Plot3dVariable::Density,
            0,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("g.xyz") && err.contains("truncated"), "{err}");
        let (_, q2) = files([2, 2, 3], false, false);
        let err = read_plot3d("g.xyz", &xyz, "g.q", &q2, Plot3dVariable::Density, 0)
            .unwrap_err()
            .to_string();
        assert!(err.contains("g.q") && err.contains("dims"), "{err}");
    }

    #[test]
    fn variable_names_parse() {
        assert_eq!(
            "Velocity-Magnitude".parse::<Plot3dVariable>().unwrap(),
            Plot3dVariable::VelocityMagnitude
        );
        assert!("temperature".parse::<Plot3dVariable>().is_err());
    }

    /// A multi-grid, little-endian, 64-bit, Fortran-record grid with IBLANK and its
    /// solution; block `b` has coordinates offset by `100 b` and density `b + 1`.
    fn multigrid(dims: &[[usize; 3]]) -> (Vec<u8>, Vec<u8>) {
        let rec = |out: &mut Vec<u8>, body: &[u8]| {
            out.extend((body.len() as i32).to_le_bytes());
            out.extend(body);
            out.extend((body.len() as i32).to_le_bytes());
        };
        let count = (dims.len() as i32).to_le_bytes();
        let all_dims: Vec<u8> = dims
            .iter()
            .flatten()
            .flat_map(|d| (*d as i32).to_le_bytes())
            .collect();
        let (mut xyz, mut q) = (Vec::new(), Vec::new());
        for out in [&mut xyz, &mut q] {
            rec(out, &count);
            rec(out, &all_dims);
        }
        for (b, d) in dims.iter().enumerate() {
            let n = d.iter().product::<usize>();
            let mut body = Vec::new();
            for axis in 0..3 {
                for p in 0..n {
                    let ijk = super::super::ijk(*d, p);
                    body.extend((ijk[axis] as f64 + 100.0 * b as f64).to_le_bytes());
                }
            }
            for _ in 0..n {
                body.extend(1i32.to_le_bytes());
            }
            rec(&mut xyz, &body);
            rec(&mut q, &[0u8; 32]);
            let mut body = Vec::new();
            for var in 0..5 {
                for _ in 0..n {
                    let v = if var == 0 { b as f64 + 1.0 } else { 0.0 };
                    body.extend(v.to_le_bytes());
                }
            }
            rec(&mut q, &body);
        }
        (xyz, q)
    }

    #[test]
    fn reads_a_block_of_a_multi_grid_file() {
        let (xyz, q) = multigrid(&[[2, 2, 2], [3, 2, 4]]);
        let grid = read_plot3d("m.xyz", &xyz, "m.q", &q, Plot3dVariable::Density, 1).unwrap();
        assert_eq!(grid.dims, [3, 2, 4]);
        assert!(grid.values.iter().all(|v| *v == 2.0));
        assert_eq!(grid.origin, DVec3::new(101.0, 100.5, 101.5));
        assert!(grid.warnings.is_empty(), "{:?}", grid.warnings);
        let err = read_plot3d("m.xyz", &xyz, "m.q", &q, Plot3dVariable::Density, 2)
            .unwrap_err()
            .to_string();
        assert!(err.contains("m.xyz") && err.contains("block 2"), "{err}");
    }
}
