//! Regular and curvilinear grids: readers (NRRD, raw, PLOT3D) and cube splits into
//! conforming tetrahedra.
//!
//! Invariant: a [`GridVolume`] has at least two samples along each axis, `dims[0] x dims[1]
//! x dims[2]` finite points (relative to `origin`, the bounding-box centre, `i` fastest) and
//! as many values; a value that is not finite is blanked ("don't know"), never used. The
//! [`TetMesh`] built by [`tetrahedralize`] is conforming (every interior face in exactly two
//! tetrahedra) and every tetrahedron is positively oriented.

mod nrrd;
mod plot3d;
mod raw;
mod split;

use glam::DVec3;

pub use nrrd::{parse_nrrd, read_nrrd};
pub use plot3d::{Plot3dVariable, read_plot3d};
pub use raw::{Endian, ScalarType, read_raw};
pub use split::{SplitReport, tetrahedralize, tetrahedralize_with_report};

#[cfg(doc)]
use crate::tet::TetMesh;

/// Why a grid could not be read or split. Every variant names the file (or the grid) and
/// the field concerned.
#[derive(Debug, thiserror::Error)]
pub enum GridError {
    #[error("{file}: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// A header field or a data block is malformed, truncated or inconsistent.
    #[error("{file}: {field}: {message}")]
    Format {
        file: String,
        field: String,
        message: String,
    },
    /// A valid feature of the format that wellmesh does not read.
    #[error("{file}: {field}: {message} is not supported")]
    Unsupported {
        file: String,
        field: String,
        message: String,
    },
    /// The grid as a whole cannot be contoured (too small, too large, no usable cell).
    #[error("grid {grid}: {message}")]
    Shape { grid: String, message: String },
}

impl GridError {
    pub(crate) fn format(file: &str, field: &str, message: impl Into<String>) -> Self {
        GridError::Format {
            file: file.to_string(),
            field: field.to_string(),
            message: message.into(),
        }
    }

    pub(crate) fn unsupported(file: &str, field: &str, message: impl Into<String>) -> Self {
        GridError::Unsupported {
            file: file.to_string(),
            field: field.to_string(),
            message: message.into(),
        }
    }

    pub(crate) fn shape(grid: &str, message: impl Into<String>) -> Self {
        GridError::Shape {
            grid: grid.to_string(),
            message: message.into(),
        }
    }
}

/// Largest number of grid points accepted: vertex indices of a [`TetMesh`] are `u32`.
pub const MAX_GRID_POINTS: usize = u32::MAX as usize - 1;

/// A structured grid of samples: regular (NRRD, raw) or curvilinear (PLOT3D).
///
/// Shapes: `points` and `values` have `dims[0] * dims[1] * dims[2]` entries, point
/// `(i, j, k)` at index `i + dims[0] * (j + dims[1] * k)`; `blanked` is empty (nothing
/// blanked) or has one flag per point.
#[derive(Debug, Clone, PartialEq)]
pub struct GridVolume {
    /// Samples along `i`, `j`, `k`; each at least 2.
    pub dims: [usize; 3],
    /// Local origin, in input units: the bounding-box centre of the input points; add it to
    /// a local coordinate to get the input's.
    pub origin: DVec3,
    /// Point positions relative to `origin`, input units.
    pub points: Vec<DVec3>,
    /// Sample values (blanked points hold 0 and are never used).
    pub values: Vec<f64>,
    /// Points that are "don't know": PLOT3D IBLANK = 0 or a value that is not finite.
    /// Tetrahedra touching one are left out (the paper's rule for unknowns).
    pub blanked: Vec<bool>,
    /// Length unit as the file states it (NRRD `space units`), if it does.
    pub unit: Option<String>,
    /// Coordinate reference system, if known.
    pub crs: Option<String>,
    /// What the values are (NRRD `content` or the PLOT3D variable).
    pub variable: String,
    /// The file(s) read, for messages.
    pub source: String,
    /// What reading tolerated, each naming the file and field.
    pub warnings: Vec<String>,
}

impl GridVolume {
    /// A lattice `space_origin + i * axes[0] + j * axes[1] + k * axes[2]` (input units).
    /// `axes` may be sheared or left-handed; the split orients each tetrahedron.
    pub fn lattice(
        source: &str,
        dims: [usize; 3],
        space_origin: DVec3,
        axes: [DVec3; 3],
        values: Vec<f64>,
    ) -> Result<GridVolume, GridError> {
        let count = point_count(source, dims)?;
        if !space_origin.is_finite() || axes.iter().any(|a| !a.is_finite()) {
            return Err(GridError::shape(
                source,
                "origin and spacing must be finite numbers",
            ));
        }
        if axes.iter().any(|a| a.length_squared() == 0.0) {
            return Err(GridError::shape(
                source,
                "a spacing of 0 collapses the grid",
            ));
        }
        let mut points = Vec::with_capacity(count);
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    points.push(
                        space_origin + axes[0] * i as f64 + axes[1] * j as f64 + axes[2] * k as f64,
                    );
                }
            }
        }
        GridVolume::curvilinear(source, dims, points, values, Vec::new())
    }

    /// A regular grid with the first sample at the input's `(0, 0, 0)` and the given
    /// spacing along `x`, `y`, `z`.
    pub fn regular(
        source: &str,
        dims: [usize; 3],
        spacing: DVec3,
        values: Vec<f64>,
    ) -> Result<GridVolume, GridError> {
        let axes = [
            DVec3::new(spacing.x, 0.0, 0.0),
            DVec3::new(0.0, spacing.y, 0.0),
            DVec3::new(0.0, 0.0, spacing.z),
        ];
        GridVolume::lattice(source, dims, DVec3::ZERO, axes, values)
    }

    /// A curvilinear grid from point positions in input coordinates (shifted here to the
    /// bounding-box centre). `blanked` is empty or one flag per point.
    pub fn curvilinear(
        source: &str,
        dims: [usize; 3],
        input_points: Vec<DVec3>,
        values: Vec<f64>,
        blanked: Vec<bool>,
    ) -> Result<GridVolume, GridError> {
        let count = point_count(source, dims)?;
        if input_points.len() != count || values.len() != count {
            return Err(GridError::shape(
                source,
                format!(
                    "{} points and {} values for dims {}x{}x{} ({count} expected)",
                    input_points.len(),
                    values.len(),
                    dims[0],
                    dims[1],
                    dims[2]
                ),
            ));
        }
        if !blanked.is_empty() && blanked.len() != count {
            return Err(GridError::shape(
                source,
                format!("{} blanking flags for {count} points", blanked.len()),
            ));
        }
        if let Some(bad) = input_points.iter().position(|p| !p.is_finite()) {
            let [i, j, k] = ijk(dims, bad);
            return Err(GridError::shape(
                source,
                format!("point ({i}, {j}, {k}) has a coordinate that is not a finite number"),
            ));
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &input_points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let origin = (lo + hi) * 0.5;
        let points = input_points.into_iter().map(|p| p - origin).collect();

        let mut warnings = Vec::new();
        let mut blanked = blanked;
        let mut values = values;
        let not_finite = values.iter().filter(|v| !v.is_finite()).count();
        if not_finite > 0 {
            if blanked.is_empty() {
                blanked = vec![false; count];
            }
            for (v, b) in values.iter_mut().zip(blanked.iter_mut()) {
                if !v.is_finite() {
                    *v = 0.0;
                    *b = true;
                }
            }
            warnings.push(format!(
                "{source}: {not_finite} values are not finite numbers and count as \"don't know\""
            ));
        }
        for (v, b) in values.iter_mut().zip(blanked.iter()) {
            if *b {
                *v = 0.0;
            }
        }
        if blanked.iter().all(|b| !*b) {
            blanked.clear();
        }
        Ok(GridVolume {
            dims,
            origin,
            points,
            values,
            blanked,
            unit: None,
            crs: None,
            variable: String::new(),
            source: source.to_string(),
            warnings,
        })
    }

    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Never true for a valid grid (at least 2 x 2 x 2 points); for API completeness.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Index of point `(i, j, k)`.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Whether point `index` is "don't know".
    pub fn is_blanked(&self, index: usize) -> bool {
        self.blanked.get(index).copied().unwrap_or(false)
    }

    /// Number of blanked points.
    pub fn blanked_count(&self) -> usize {
        self.blanked.iter().filter(|b| **b).count()
    }

    /// Smallest and largest value over the points that are not blanked.
    pub fn value_range(&self) -> Option<(f64, f64)> {
        self.values
            .iter()
            .enumerate()
            .filter(|(n, _)| !self.is_blanked(*n))
            .map(|(_, v)| *v)
            .fold(None, |acc, v| match acc {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            })
    }
}

/// `(i, j, k)` of a point index.
pub(crate) fn ijk(dims: [usize; 3], index: usize) -> [usize; 3] {
    let i = index % dims[0];
    let j = (index / dims[0]) % dims[1];
    let k = index / (dims[0] * dims[1]);
    [i, j, k]
}

/// Checks `dims` and returns the number of points.
pub(crate) fn point_count(source: &str, dims: [usize; 3]) -> Result<usize, GridError> {
    if dims.iter().any(|d| *d < 2) {
        return Err(GridError::shape(
            source,
            format!(
                "dims {}x{}x{}: at least 2 samples are needed along each axis",
                dims[0], dims[1], dims[2]
            ),
        ));
    }
    dims.iter()
        .try_fold(1usize, |acc, d| acc.checked_mul(*d))
        .filter(|n| *n <= MAX_GRID_POINTS)
        .ok_or_else(|| {
            GridError::shape(
                source,
                format!(
                    "dims {}x{}x{}: more than {MAX_GRID_POINTS} points",
                    dims[0], dims[1], dims[2]
                ),
            )
        })
}

/// How each grid cell (a hexahedron of 8 neighbouring points) is cut into tetrahedra.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CubeSplit {
    /// One central tetrahedron and four corners; the two mirror images alternate with the
    /// cell parity `(i + j + k) % 2` so that neighbouring cells share face diagonals.
    Five,
    /// Coxeter-Freudenthal-Kuhn: six tetrahedra around the main diagonal from corner
    /// `(0,0,0)` to `(1,1,1)`, the same in every cell.
    #[default]
    Six,
}

impl CubeSplit {
    /// Tetrahedra per cell.
    pub fn tets_per_cell(self) -> usize {
        match self {
            CubeSplit::Five => 5,
            CubeSplit::Six => 6,
        }
    }
}

impl std::str::FromStr for CubeSplit {
    type Err = String;

    /// Parses `5`, `five`, `6`, `six` or `cfk` (case-insensitive).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "5" | "five" => Ok(CubeSplit::Five),
            "6" | "six" | "cfk" => Ok(CubeSplit::Six),
            other => Err(format!(
                "unknown cube split {other:?}: expected 5 (alternating) or 6 (CFK)"
            )),
        }
    }
}

impl std::fmt::Display for CubeSplit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CubeSplit::Five => "5",
            CubeSplit::Six => "6",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_grid_is_centred_on_its_bounding_box() {
        let grid =
            GridVolume::regular("t", [3, 2, 2], DVec3::new(2.0, 1.0, 4.0), vec![0.0; 12]).unwrap();
        assert_eq!(grid.origin, DVec3::new(2.0, 0.5, 2.0));
        assert_eq!(grid.points[0], DVec3::new(-2.0, -0.5, -2.0));
        assert_eq!(grid.points[grid.index(2, 1, 1)], DVec3::new(2.0, 0.5, 2.0));
    }

    #[test]
    fn non_finite_values_are_blanked_with_a_warning() {
        let mut values = vec![1.0; 8];
        values[3] = f64::NAN;
        let grid = GridVolume::regular("t", [2, 2, 2], DVec3::ONE, values).unwrap();
        assert!(grid.is_blanked(3));
        assert_eq!(grid.blanked_count(), 1);
        assert_eq!(grid.values[3], 0.0);
        assert_eq!(grid.warnings.len(), 1);
    }

    #[test]
    fn flat_or_oversized_dims_are_errors() {
        let err = GridVolume::regular("flat", [4, 4, 1], DVec3::ONE, vec![0.0; 16]).unwrap_err();
        assert!(err.to_string().contains("flat"), "{err}");
        assert!(point_count("big", [1 << 20, 1 << 20, 1 << 20]).is_err());
        assert!(point_count("big", [usize::MAX, 2, 2]).is_err());
    }

    #[test]
    fn split_names_parse() {
        assert_eq!("5".parse::<CubeSplit>().unwrap(), CubeSplit::Five);
        assert_eq!("CFK".parse::<CubeSplit>().unwrap(), CubeSplit::Six);
        assert!("7".parse::<CubeSplit>().is_err());
    }
}
