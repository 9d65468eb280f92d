//! `wellmesh contour`: samples, drill holes, LAS logs or a grid in; closed ore bodies out
//! (GLB, summary JSON and the other formats of `OutputArgs`).
//!
//! Invariant: the files written and the JSON printed come from one `contour::run` result,
//! so the summary's figures are those of the triangles in the GLB.
use std::process::ExitCode;

use wellmesh::contour::{self, ContourOptions, GridSource, Source};

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

    /// Lattice resolution N of the curvature placement (candidates (aP+bQ+cR+dS)/N, N from
    /// 4 to 12; default 7).
    #[arg(long, value_name = "N")]
    pub lattice: Option<u32>,

    /// Sweeps of the shape relaxation of ibc and coi vertices: each slides within its
    /// tetrahedron's marching-tetrahedra polygon to cut slivers (triangles with an angle
    /// under 10 degrees); bodies keep marching tetrahedra's volume. 0 keeps the paper's
    /// positions. Default 3, at most 50.
    #[arg(long, value_name = "SWEEPS")]
    pub relax: Option<u32>,

    /// "Don't know" samples: drop (default) or bounds.
    #[arg(long, value_enum)]
    pub unknown: Option<UnknownArg>,

    /// Scale x, y, z before tetrahedralizing (in the rotated frame when --azimuth/--dip are
    /// given), inverted on output; e.g. 1,1,5 makes vertical distances count five times.
    #[arg(long, value_name = "SX,SY,SZ", value_parser = parse_triple)]
    pub anisotropy: Option<[f64; 3]>,

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

    /// Simplify the bodies: remove vertices while every removed one stays within this
    /// distance (input units) of the surface kept, each body closed, no triangle turned by
    /// more than 45 degrees nor made thinner than 10 degrees. 0 keeps every triangle.
    /// Default: a model's surfaces within a quarter of its finest infill step (the summary's
    /// `simplified` gives the tolerance and the counts before); the linear interpolant's and
    /// grids' are not simplified.
    #[arg(long, value_name = "DISTANCE")]
    pub simplify: Option<f64>,

    /// Density in t/m3 for tonnes and metal (the report gives volumes and grades without
    /// one).
    #[arg(long, value_name = "T_PER_M3", conflicts_with = "density_column")]
    pub density: Option<f64>,

    /// Interval-table column holding the density (t/m3), read and interpolated like the
    /// grade; samples without a value are counted and named in the report.
    #[arg(long, value_name = "COLUMN")]
    pub density_column: Option<String>,

    /// Cut-offs of the grade–tonnage curve, FROM:TO:STEP (default: about 20 round
    /// cut-offs over the values' range).
    #[arg(long, value_name = "FROM:TO:STEP")]
    pub grade_tonnage: Option<String>,

    /// Hold out every K-th hole in turn (whole holes, sorted by id), rebuild without it
    /// and predict its samples; the summary and the terminal get the scores.
    #[arg(long, value_name = "K")]
    pub cross_validate: Option<u32>,

    /// Write the grade–tonnage curve as CSV (units in the header).
    #[arg(long, value_name = "OUT.csv")]
    pub report: Option<std::path::PathBuf>,

    /// Write the grade–tonnage chart (tonnes and mean grade against cut-off) as SVG.
    #[arg(long, value_name = "OUT.svg")]
    pub chart: Option<std::path::PathBuf>,
    /// Values between the samples: kriging (default for wells and drill holes: a model
    /// between the holes, evaluated at infill points where the surface is, then contoured by
    /// DMT) or linear (DMT on the samples' own Delaunay tetrahedra, the paper's method; the
    /// only one for grids, and the one --anisotropy selects).
    #[arg(long, value_name = "NAME", help_heading = MODEL)]
    pub interpolant: Option<String>,

    /// The model's ranges along its major, semi-major and minor axes (input units): how far
    /// a sample's influence reaches. Default: from the intercepts at the lowest threshold
    /// (their spread in the ore's plane, bounded by 1.5 to 6 hole spacings; the median true
    /// thickness across).
    #[arg(long, value_name = "MAJOR,SEMI,MINOR", value_parser = parse_triple, help_heading = MODEL)]
    pub ranges: Option<[f64; 3]>,

    /// The ore's orientation: dip direction, dip and pitch in degrees (the plane dips toward
    /// the dip direction; the pitch turns the major axis in the plane from the strike).
    /// Default: the principal axes of the intercepts. Ranges not given are measured along
    /// these axes.
    #[arg(long, value_name = "DIPDIR,DIP,PITCH", value_parser = parse_triple, allow_negative_numbers = true, help_heading = MODEL)]
    pub orientation: Option<[f64; 3]>,

    /// The covariance's sill (default: the variance of the values, after any transform).
    #[arg(long, value_name = "S", help_heading = MODEL)]
    pub sill: Option<f64>,

    /// The nugget: short-scale noise the model does not honour (default: the down-hole
    /// variogram extrapolated to lag zero, at most half the sill).
    #[arg(long, value_name = "N", help_heading = MODEL)]
    pub nugget: Option<f64>,

    /// Order of the spheroidal covariance: 3, 5 or 7 (the default).
    #[arg(long, value_name = "K", help_heading = MODEL)]
    pub spheroidal_order: Option<u8>,

    /// Transform of skewed grades before the fit: none (default), log, or normal-score.
    #[arg(long, value_name = "NAME", help_heading = MODEL)]
    pub transform: Option<String>,

    /// How 0/1 flags (and --inside CODE) are modelled: distance (default: the signed
    /// distance to the contacts down each hole, contoured at zero, which keeps a thin lens's
    /// thickness between holes) or indicator (the kriged 0s and 1s, contoured at 0.5).
    #[arg(long, value_name = "NAME", help_heading = MODEL)]
    pub flag_field: Option<String>,

    /// How the orientation and ranges not given are found: rules (default: the extent,
    /// thickness and plane of the runs of ore down the holes, the plane checked by a
    /// variogram map, the thickness widened when ore continues across the plane more than
    /// a quarter as often as along it) or cross-validation (the rules' model beside other planes
    /// of the map and ranges scaled across the ore by up to 4 and in its plane down to 0.4;
    /// the one whose model puts the samples of held-out holes on the right side of the
    /// threshold most often is kept. For fields of many lenses; two to four times as slow;
    /// every candidate is in the summary's shape_search).
    #[arg(long, value_name = "NAME", help_heading = MODEL)]
    pub shape_from: Option<String>,

    /// Whether the ore's plane may turn in space: global (default: one plane everywhere) or
    /// varying (where an anchor's own plane lies 15+ degrees from the model's and fits its
    /// pairs 15 % better, the kriging blocks near it turn to it; partial: the infill and the
    /// model's extent keep the global frame, so a turned lens is clipped to pieces between
    /// its holes, docs/field.md). The anchors (the variogram map drawn again around
    /// points one semi-major range apart over the ore) are in the summary's local_planes
    /// either way, so a run shows where one plane does not fit. Not drawn when the
    /// orientation is given or found by cross-validation.
    #[arg(long, value_name = "NAME", help_heading = MODEL)]
    pub orientation_field: Option<String>,

    /// Cap values above this before the fit (a top-cut of outliers).
    #[arg(long, value_name = "VALUE", help_heading = MODEL)]
    pub top_cut: Option<f64>,

    /// Finest infill step along the major axis (input units); default 1/32 of the range.
    #[arg(long, value_name = "LENGTH", help_heading = MODEL)]
    pub resolution: Option<f64>,

    /// Most samples in one kriging block's system (default 96).
    #[arg(long, value_name = "N", help_heading = MODEL)]
    pub max_samples: Option<u32>,

    /// Most samples in a block whose nearest --max-samples hold values on both sides of a
    /// threshold, where the surface is: more there average more of the assays' noise
    /// (default 192; at or below --max-samples turns it off).
    #[arg(long, value_name = "N", help_heading = MODEL)]
    pub max_samples_near: Option<u32>,

    /// Most samples of one hole in one kriging block (default 12).
    #[arg(long, value_name = "N", help_heading = MODEL)]
    pub max_per_hole: Option<u32>,

    /// Print the summary JSON on standard output (for CI).
    #[arg(long)]
    pub json: bool,

    /// No progress bar, even on a terminal.
    #[arg(short, long)]
    pub quiet: bool,
}

const MODEL: &str = "The model between the holes";

const EXAMPLES: &str = "\
Examples:
  wellmesh contour sample_wells/copper_wells.csv -o copper.glb --summary copper.json
  wellmesh contour grades.csv -t 0.3 -t 0.5 -t 1.0 --method ibc -o shells.glb
  wellmesh contour --collars collar.csv --surveys survey.csv --intervals assay.csv \\
      --variable Zn -t 1.0 -o zn.glb --tileset out/
  wellmesh contour --grid head.nhdr -t 1150 --split 5 -o head.glb
  wellmesh contour --collars collar.csv --surveys survey.csv --intervals assay.csv \\
      --variable Zn_pct -t 5 --ranges 150,100,12 --orientation 236,33,30 -o zn5.glb
  wellmesh contour grades.csv -t 0.5 --interpolant linear -o raw.glb

Exit codes: 0 success; 1 the input or the computation failed (the message names the file,
row and field); 2 bad command-line arguments (a flag's value out of its range included).";

/// `SX,SY,SZ` as three numbers.
fn parse_triple(text: &str) -> Result<[f64; 3], String> {
    let parts: Result<Vec<f64>, _> = text.split(',').map(|p| p.trim().parse::<f64>()).collect();
    match parts.as_deref() {
        Ok(&[x, y, z]) => Ok([x, y, z]),
        _ => Err(format!("{text:?}: expected three numbers SX,SY,SZ")),
    }
}

impl Args {
    /// The contouring options these flags give, as the service's execute inputs of the same
    /// names would.
    pub fn options(&self) -> ContourOptions {
        ContourOptions {
            thresholds: self.thresholds.clone(),
            method: self.method.clone(),
            lattice: self.lattice,
            unknown: self.unknown.map(|u| {
                match u {
                    UnknownArg::Drop => "drop",
                    UnknownArg::Bounds => "bounds",
                }
                .to_string()
            }),
            anisotropy: self.anisotropy,
            azimuth: self.azimuth,
            dip: self.dip,
            min_volume: self.min_volume,
            relax: self.relax,
            variable: self.input.variable.clone(),
            density: self.density,
            density_column: self.density_column.clone(),
            grade_tonnage: self.grade_tonnage.clone(),
            cross_validate: self.cross_validate,
            interpolant: self.interpolant.clone(),
            ranges: self.ranges,
            orientation: self.orientation,
            sill: self.sill,
            nugget: self.nugget,
            spheroidal_order: self.spheroidal_order,
            transform: self.transform.clone(),
            flag_field: self.flag_field.clone(),
            shape_from: self.shape_from.clone(),
            orientation_field: self.orientation_field.clone(),
            top_cut: self.top_cut,
            resolution: self.resolution,
            max_samples: self.max_samples,
            max_samples_near: self.max_samples_near,
            max_per_hole: self.max_per_hole,
            simplify: self.simplify,
        }
    }

    /// Reads the input: a grid, or samples from wells, drill holes or LAS logs.
    fn source(&self) -> anyhow::Result<Source> {
        if !self.grid.is_set() {
            return Ok(Source::Samples(self.input.load()?));
        }
        let volume = self
            .grid
            .load_with_variable(self.input.variable.as_deref())?;
        Ok(Source::Grid(GridSource {
            volume,
            split: self.grid.cube_split(),
            crs: self.input.crs.clone(),
            unit: self.input.unit_name().unwrap_or("m").to_string(),
        }))
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    // Options are checked before any file is read: a bad flag costs nothing.
    let options = args.options();
    if let Err(e) = options.check() {
        return Ok(super::bad_option(&e));
    }
    let mut request = match options.into_request(args.source()?) {
        Ok(request) => request,
        Err(e) => return Ok(super::bad_option(&e)),
    };
    if args.density_column.is_some() {
        contour::load_density_column(&mut request, &args.input.to_input()?)?;
    }
    let bar = Bar::new(args.quiet);
    let result = contour::run(&request, &bar);
    bar.finish();
    let result = result?;
    args.output.write(&result)?;
    super::report::write(
        &result.summary,
        args.report.as_deref(),
        args.chart.as_deref(),
    )?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&result.summary)?);
    } else {
        if let Some(m) = &result.summary.model {
            let o = &m.params.orientation;
            eprintln!(
                "model: kriging, spheroidal order {}, ranges {:.1}/{:.1}/{:.1} {u} ({:?}), \
                 orientation {:.0}/{:.0}/{:.0} ({:?}), nugget {:.3} of sill {:.3}",
                m.params.order,
                m.params.ranges[0],
                m.params.ranges[1],
                m.params.ranges[2],
                m.params.sources.ranges,
                o.dip_direction,
                o.dip,
                o.pitch,
                m.params.sources.orientation,
                m.params.nugget,
                m.params.sill,
                u = result.summary.unit
            );
        }
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
        super::report::print(&result.summary);
    }
    Ok(ExitCode::SUCCESS)
}
