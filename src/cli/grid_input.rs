//! Grid input arguments (NRRD, raw, PLOT3D) shared by subcommands that contour grids.
//!
//! Invariant: at most one grid source is given (clap enforces it), and [`GridArgs::load`]
//! returns a grid only when the chosen files were read completely.

use std::path::{Path, PathBuf};

use anyhow::Context;
use glam::DVec3;
use wellmesh::grid::{
    CubeSplit, Endian, GridVolume, Plot3dVariable, ScalarType, read_nrrd, read_plot3d, read_raw,
};

/// Three comma-separated numbers, e.g. `64,64,93` or `3.2,3.2,1.5`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triple<T>(pub [T; 3]);

impl<T: std::str::FromStr> std::str::FromStr for Triple<T> {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        let [a, b, c] = parts.as_slice() else {
            return Err(format!("{s:?}: expected three comma-separated numbers"));
        };
        let parse = |v: &str| {
            v.parse::<T>()
                .map_err(|_| format!("{s:?}: {v:?} is not a valid number here"))
        };
        Ok(Triple([parse(a)?, parse(b)?, parse(c)?]))
    }
}

/// Grid input: cuberille (regular) or curvilinear data, split into tetrahedra.
#[derive(Debug, Clone, clap::Args)]
pub struct GridArgs {
    /// NRRD volume: a detached header (.nhdr, data files beside it) or an attached .nrrd.
    #[arg(long, value_name = "FILE.nhdr|FILE.nrrd", conflicts_with_all = ["raw", "plot3d_xyz"])]
    pub grid: Option<PathBuf>,

    /// Headerless volume of samples, i fastest; needs --dims and --dtype.
    #[arg(long, value_name = "FILE", requires_all = ["dims", "dtype"], conflicts_with = "plot3d_xyz")]
    pub raw: Option<PathBuf>,

    /// Samples along x, y, z of a --raw volume.
    #[arg(long, value_name = "NX,NY,NZ", requires = "raw")]
    pub dims: Option<Triple<usize>>,

    /// Sample spacing along x, y, z of a --raw volume (default 1,1,1).
    #[arg(long, value_name = "SX,SY,SZ", requires = "raw")]
    pub spacing: Option<Triple<f64>>,

    /// Sample type of a --raw volume: u8, i8, u16, i16, u32, i32, u64, i64, f32 or f64.
    #[arg(long, value_name = "TYPE", requires = "raw")]
    pub dtype: Option<ScalarType>,

    /// Byte order of a --raw volume: little or big.
    #[arg(long, value_name = "ORDER", requires = "raw")]
    pub endian: Option<Endian>,

    /// PLOT3D grid file (binary xyz); needs --plot3d-q.
    #[arg(long, value_name = "FILE", requires = "plot3d_q")]
    pub plot3d_xyz: Option<PathBuf>,

    /// PLOT3D solution file (binary q) for --plot3d-xyz.
    #[arg(long, value_name = "FILE", requires = "plot3d_xyz")]
    pub plot3d_q: Option<PathBuf>,

    /// Block of a multi-grid PLOT3D file, from 0.
    #[arg(long, value_name = "N", requires = "plot3d_xyz")]
    pub plot3d_block: Option<usize>,

    /// Cube split of grid cells: 5 (alternating) or 6 (CFK, default).
    #[arg(long, value_name = "5|6")]
    pub split: Option<CubeSplit>,
}

impl GridArgs {
    /// Whether a grid input was given.
    pub fn is_set(&self) -> bool {
        self.grid.is_some() || self.raw.is_some() || self.plot3d_xyz.is_some()
    }

    /// The cube split to use.
    pub fn cube_split(&self) -> CubeSplit {
        self.split.unwrap_or_default()
    }

    /// Reads the grid; `variable` (the shared `--variable`) names the PLOT3D quantity
    /// (density, momentum_x|y|z, energy, velocity_x|y|z, velocity_magnitude, pressure or
    /// mach; default density).
    pub fn load_with_variable(&self, variable: Option<&str>) -> anyhow::Result<GridVolume> {
        let variable = match variable {
            Some(name) => Some(
                name.parse::<Plot3dVariable>()
                    .map_err(|e| anyhow::anyhow!("--variable: {e}"))?,
            ),
            None => None,
        };
        if let Some(path) = &self.grid {
            return Ok(read_nrrd(path)?);
        }
        if let Some(path) = &self.raw {
            let dims = self.dims.context("--raw needs --dims NX,NY,NZ")?.0;
            let dtype = self.dtype.context("--raw needs --dtype")?;
            let spacing = self.spacing.map_or(DVec3::ONE, |s| DVec3::from_array(s.0));
            let bytes = read(path)?;
            let name = path.display().to_string();
            return Ok(read_raw(
                &name,
                &bytes,
                dims,
                spacing,
                dtype,
                self.endian.unwrap_or_default(),
            )?);
        }
        if let (Some(xyz), Some(q)) = (&self.plot3d_xyz, &self.plot3d_q) {
            let xyz_bytes = read(xyz)?;
            let q_bytes = read(q)?;
            return Ok(read_plot3d(
                &xyz.display().to_string(),
                &xyz_bytes,
                &q.display().to_string(),
                &q_bytes,
                variable.unwrap_or(Plot3dVariable::Density),
                self.plot3d_block.unwrap_or(0),
            )?);
        }
        anyhow::bail!("no grid input: give --grid, --raw or --plot3d-xyz with --plot3d-q")
    }
}

fn read(path: &Path) -> anyhow::Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("reading {}", path.display()))
}

/// Where the tests find the shared corpus of real data (they skip with a note without it).
#[cfg(test)]
#[path = "../../tests/common/mod.rs"]
mod common;

#[cfg(test)]
mod tests {
    use super::common::shared_data;
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        grid: GridArgs,
    }

    #[test]
    fn raw_needs_dims_and_dtype() {
        assert!(Cli::try_parse_from(["t", "--raw", "v.raw"]).is_err());
        let cli = Cli::try_parse_from(["t", "--raw", "v.raw", "--dims", "4,5,6", "--dtype", "u16"])
            .unwrap();
        assert!(cli.grid.is_set());
        assert_eq!(cli.grid.dims, Some(Triple([4, 5, 6])));
        assert_eq!(cli.grid.cube_split(), CubeSplit::Six);
    }

    #[test]
    fn sources_are_exclusive_and_plot3d_needs_both_files() {
        assert!(Cli::try_parse_from(["t", "--grid", "a.nhdr", "--plot3d-xyz", "x"]).is_err());
        assert!(Cli::try_parse_from(["t", "--plot3d-xyz", "x"]).is_err());
        assert!(Cli::try_parse_from(["t", "--dims", "2,2,2"]).is_err());
        let cli =
            Cli::try_parse_from(["t", "--plot3d-xyz", "x", "--plot3d-q", "q", "--split", "5"])
                .unwrap();
        assert_eq!(cli.grid.cube_split(), CubeSplit::Five);
        assert!(!Cli::try_parse_from(["t"]).unwrap().grid.is_set());
    }

    #[test]
    fn bad_triples_are_rejected() {
        assert!("1,2".parse::<Triple<usize>>().is_err());
        assert!("1,x,3".parse::<Triple<f64>>().is_err());
        assert_eq!(
            "1, 2.5,3".parse::<Triple<f64>>().unwrap(),
            Triple([1.0, 2.5, 3.0])
        );
    }

    #[test]
    fn missing_files_are_named() {
        let cli = Cli::try_parse_from([
            "t",
            "--raw",
            "/nonexistent/v.raw",
            "--dims",
            "2,2,2",
            "--dtype",
            "u8",
        ])
        .unwrap();
        let err = format!("{:#}", cli.grid.load_with_variable(None).unwrap_err());
        assert!(err.contains("/nonexistent/v.raw"), "{err}");
    }

    #[test]
    fn loads_a_raw_volume_and_the_real_nrrd_and_plot3d_files() {
        let path = std::env::temp_dir().join(format!("wellmesh-grid-{}.raw", std::process::id()));
        let samples: Vec<u8> = (0..24u16).flat_map(|v| v.to_be_bytes()).collect();
        std::fs::write(&path, &samples).unwrap();
        let cli = Cli::try_parse_from([
            "t",
            "--raw",
            path.to_str().unwrap(),
            "--dims",
            "2,3,4",
            "--spacing",
            "1,2,0.5",
            "--dtype",
            "u16",
            "--endian",
            "big",
        ])
        .unwrap();
        let grid = cli.grid.load_with_variable(None).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(grid.dims, [2, 3, 4]);
        assert_eq!(grid.values[23], 23.0);
        assert_eq!(grid.points[23] - grid.points[0], DVec3::new(1.0, 4.0, 1.5));

        // The real files are in the shared corpus; without it the raw volume above is all.
        let (Some(head), Some(fin)) = (
            shared_data("vtk_headsq/quarter.nhdr"),
            shared_data("vtk_plot3d_bluntfin_combustor"),
        ) else {
            return;
        };
        let cli = Cli::try_parse_from(["t", "--grid", head.to_str().unwrap()]).unwrap();
        assert_eq!(
            cli.grid.load_with_variable(None).unwrap().dims,
            [64, 64, 93]
        );

        let cli = Cli::try_parse_from([
            "t",
            "--plot3d-xyz",
            fin.join("bluntfinxyz.bin").to_str().unwrap(),
            "--plot3d-q",
            fin.join("bluntfinq.bin").to_str().unwrap(),
        ])
        .unwrap();
        let grid = cli
            .grid
            .load_with_variable(Some("velocity_magnitude"))
            .unwrap();
        assert_eq!(grid.dims, [40, 32, 32]);
        assert_eq!(grid.variable, "velocity_magnitude");
    }
}
