//! `wellmesh contour`: samples, drill holes, LAS logs or a grid in; closed ore bodies out
//! (GLB, summary JSON and the other formats of `OutputArgs`).
//!
//! Invariant: the files written and the JSON printed come from one `contour::run` result,
//! so the summary's figures are those of the triangles in the GLB.
use std::process::ExitCode;

use anyhow::Context;
use glam::DVec3;
use wellmesh::contour::{self, Anisotropy, ContourRequest, GridSource, UnknownMode};
use wellmesh::dmt::{Method, Placement};
use wellmesh::wells::{ReadReport, SampleSet};

use super::Bar;
use super::grid_input::GridArgs;
use super::input::InputArgs;
use super::outputs::OutputArgs;

/// How "don't know" samples are treated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum UnknownArg {
    /// Remove them before tetrahedralizing (the paper's rule).
    Drop,
    /// Also build the bodies with every unknown taken as "no" and as "yes": the summary
    /// gets a volume range per shell that brackets the answer.
    Bounds,
}

#[derive(Debug, clap::Args)]
#[command(after_long_help = EXAMPLES)]
pub struct Args {
    #[command(flatten)]
    pub input: InputArgs,

    #[command(flatten)]
    pub grid: GridArgs,

    #[command(flatten)]
    pub output: OutputArgs,

    /// Threshold: a sample is inside when its value >= T. Repeat for nested grade shells
    /// (`--threshold 0.3 --threshold 0.5`); default 0.5 for 0/1 data.
    #[arg(
        short = 't',
        long = "threshold",
        value_name = "T",
        allow_negative_numbers = true
    )]
    pub thresholds: Vec<f64>,

    /// Vertex placement: curvature (default for 0/1 data: the paper's minimal discrete norm
    /// curvature, searched near the distance surface), distance (IbC on the signed distance
    /// to the nearest sample of the other class, balanced to the midpoint rule's volume),
    /// ibc (default for grades), coi, midpoint, or mt (marching tetrahedra, for comparison).
    #[arg(short, long, value_name = "METHOD")]
    pub method: Option<String>,

    /// Lattice resolution N of the curvature placement (candidates (aP+bQ+cR+dS)/N).
    #[arg(long, value_name = "N", default_value_t = wellmesh::dmt::DEFAULT_CURVATURE_LATTICE)]
    pub lattice: u32,

    /// Sweeps of the shape relaxation of ibc and coi vertices: each slides within its
    /// tetrahedron's marching-tetrahedra polygon to cut slivers (triangles with an angle
    /// under 10 degrees); bodies keep marching tetrahedra's volume. 0 keeps the paper's
    /// positions exactly.
    #[arg(long, value_name = "SWEEPS", default_value_t = wellmesh::dmt::relax::DEFAULT_SWEEPS as u16,
          value_parser = clap::value_parser!(u16).range(0..=wellmesh::dmt::relax::MAX_SWEEPS as i64))]
    pub relax: u16,

    /// "Don't know" samples: drop (default) or bounds.
    #[arg(long, value_enum, default_value = "drop")]
    pub unknown: UnknownArg,

    /// Scale x, y, z before tetrahedralizing (in the rotated frame when --azimuth/--dip are
    /// given), inverted on output; e.g. 1,1,5 makes vertical distances count five times.
    #[arg(long, value_name = "SX,SY,SZ")]
    pub anisotropy: Option<String>,

    /// Azimuth (degrees clockwise from north) of the anisotropy's first axis.
    #[arg(long, value_name = "DEG", requires = "anisotropy")]
    pub azimuth: Option<f64>,

    /// Dip (degrees) of the anisotropy's second axis, tilted down about the first.
    #[arg(long, value_name = "DEG", requires = "anisotropy")]
    pub dip: Option<f64>,

    /// Leave out bodies smaller than this volume (input units cubed); the summary counts
    /// what was left out (`filtered_bodies`, `filtered_volume`). Without it every body is
    /// kept, including tiny ones and folded ones with a negative volume (warned about).
    #[arg(long, value_name = "VOLUME")]
    pub min_volume: Option<f64>,

    /// Print the summary JSON on standard output (for CI).
    #[arg(long)]
    pub json: bool,

    /// No progress bar, even on a terminal.
    #[arg(short, long)]
    pub quiet: bool,
}

const EXAMPLES: &str = "\
Examples:
  wellmesh contour sample_wells/copper_wells.csv -o copper.glb --summary copper.json
  wellmesh contour grades.csv -t 0.3 -t 0.5 -t 1.0 --method ibc -o shells.glb
  wellmesh contour --collars collar.csv --surveys survey.csv --intervals assay.csv \\
      --variable Zn -t 1.0 -o zn.glb --tileset out/
  wellmesh contour --grid head.nhdr -t 1150 --split 5 -o head.glb

Exit codes: 0 success; 1 the input or the computation failed (the message names the file,
row and field); 2 bad command-line arguments.";

fn parse_triple(text: &str) -> anyhow::Result<DVec3> {
    let parts: Vec<f64> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--anisotropy {text:?}: expected three numbers SX,SY,SZ"))?;
    match parts.as_slice() {
        &[x, y, z] => Ok(DVec3::new(x, y, z)),
        _ => anyhow::bail!("--anisotropy {text:?}: expected three numbers SX,SY,SZ"),
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let method = match &args.method {
        Some(name) => Some(
            match name
                .parse::<Method>()
                .map_err(|e| anyhow::anyhow!("--method: {e}"))?
            {
                Method::Dmt(Placement::Curvature { .. }) => Method::Dmt(Placement::Curvature {
                    lattice: args.lattice,
                }),
                m => m,
            },
        ),
        None => None,
    };
    let anisotropy = match &args.anisotropy {
        Some(text) => Some(Anisotropy {
            scale: parse_triple(text)?,
            azimuth_deg: args.azimuth.unwrap_or(90.0),
            dip_deg: args.dip.unwrap_or(0.0),
        }),
        None => None,
    };
    let (samples, grid) = if args.grid.is_set() {
        let volume = args
            .grid
            .load_with_variable(args.input.variable.as_deref())?;
        let samples = SampleSet {
            origin: volume.origin,
            crs: args.input.crs.clone().or_else(|| volume.crs.clone()),
            unit: volume.unit.clone().unwrap_or_else(|| "m".to_string()),
            wells: vec![],
            points: vec![],
            values: vec![],
            well_of: vec![],
            report: ReadReport::default(),
        };
        let split = args.grid.cube_split();
        (samples, Some(GridSource { volume, split }))
    } else {
        (args.input.load()?, None)
    };
    let request = ContourRequest {
        method,
        unknown: match args.unknown {
            UnknownArg::Drop => UnknownMode::Drop,
            UnknownArg::Bounds => UnknownMode::Bounds,
        },
        anisotropy,
        grid,
        min_volume: args.min_volume,
        relax: usize::from(args.relax),
        ..ContourRequest::new(samples, args.thresholds.clone())
    };
    let bar = Bar::new(args.quiet);
    let result = contour::run(&request, &bar);
    bar.finish();
    let result = result?;
    args.output.write(&result)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&result.summary)?);
    } else {
        for shell in &result.summary.shells {
            eprintln!(
                "threshold {}: {} bodies, volume {:.6e} {u}^3, area {:.6e} {u}^2",
                shell.threshold,
                shell.bodies.len(),
                shell.volume,
                shell.area,
                u = result.summary.unit
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
