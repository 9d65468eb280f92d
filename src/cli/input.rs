//! Input arguments shared by `contour` and `inspect`: files on disk to a [`wells::Input`].
//!
//! Invariant: the CLI only reads files and maps flags; every rule about their content lives
//! in the library (`wells::Input::load`), the one code path the service shares.
use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::ValueEnum;
use wellmesh::wells::{self, BelowDetection, InputFile};

/// Sign of dips below horizontal in the survey table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DipDown {
    /// `-60` is 60 degrees below horizontal (most mining software).
    Negative,
    /// `60` is 60 degrees below horizontal (e.g. Babbitt).
    Positive,
}

/// What a below-detection value becomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BelowArg {
    /// Half the detection limit (`<0.01` -> 0.005).
    Half,
    /// Zero.
    Zero,
}

/// How negative numbers in an interval table are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum NegativeArg {
    /// A below-detection sentinel: `-0.01` is below 0.01 (default for interval tables).
    BelowDetection,
    /// An ordinary value.
    Value,
}

/// Length unit of the input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum UnitArg {
    M,
    Ft,
}

/// Where the samples come from: a samples CSV, a wells JSON, drill-hole tables or LAS logs.
#[derive(Debug, Clone, clap::Args)]
pub struct InputArgs {
    /// Samples CSV (`.csv`: well,x,y,z,value), wells JSON (`.json`) or LAS (`.las`) files.
    #[arg(value_name = "INPUT")]
    pub inputs: Vec<PathBuf>,
    /// Collar table (hole_id,x,y,z[,depth]).
    #[arg(long, value_name = "CSV")]
    pub collars: Option<PathBuf>,
    /// Survey table (hole_id,depth,azimuth,dip); without it holes are vertical.
    #[arg(long, value_name = "CSV")]
    pub surveys: Option<PathBuf>,
    /// Interval table (hole_id,from,to,<variables>).
    #[arg(long, value_name = "CSV")]
    pub intervals: Option<PathBuf>,
    /// Column of the interval table (or LAS curve, or samples CSV column) to contour.
    #[arg(long, value_name = "NAME")]
    pub variable: Option<String>,
    /// Categorical codes counted as inside (1); other codes are 0, empty is don't-know.
    #[arg(long, value_name = "CODE[,CODE]", value_delimiter = ',')]
    pub inside: Vec<String>,
    /// Composite intervals to this length (input units), length-weighted; default: one
    /// sample at each interval's midpoint.
    #[arg(long, value_name = "LENGTH")]
    pub composite: Option<f64>,
    /// Sign of downward dips in the survey table; default: detected, with a warning when
    /// the data disagrees.
    #[arg(long, value_enum)]
    pub dip_down: Option<DipDown>,
    /// What a below-detection value (`<0.01`, negative sentinel) becomes.
    #[arg(long, value_enum, default_value = "half")]
    pub below_detection: BelowArg,
    /// How negative values in an interval table are read.
    #[arg(long, value_enum)]
    pub negative_values: Option<NegativeArg>,
    /// LAS files or directories of LAS files.
    #[arg(long, value_name = "DIR_OR_FILE", num_args = 1..)]
    pub las: Vec<PathBuf>,
    /// Table placing LAS wells: well name, UWI or file name -> x, y, elevation (KB).
    #[arg(long, value_name = "CSV")]
    pub locations: Option<PathBuf>,
    /// CRS to report when the input carries none (e.g. EPSG:32609).
    #[arg(long)]
    pub crs: Option<String>,
    /// Length unit of the input; output stays in it.
    #[arg(long, value_enum)]
    pub unit: Option<UnitArg>,
}

fn read(path: &Path) -> anyhow::Result<InputFile> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(InputFile::new(path.display().to_string(), bytes))
}

fn is_las(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("las"))
}

/// LAS files named directly or found (non-recursively, sorted) in directories.
fn las_files(paths: &[PathBuf]) -> anyhow::Result<Vec<InputFile>> {
    let mut out = Vec::new();
    for path in paths {
        if path.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(path)
                .with_context(|| format!("cannot list {}", path.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && is_las(p))
                .collect();
            found.sort();
            if found.is_empty() {
                anyhow::bail!("{}: no .las files in this directory", path.display());
            }
            for p in found {
                out.push(read(&p)?);
            }
        } else {
            out.push(read(path)?);
        }
    }
    Ok(out)
}

impl InputArgs {
    /// The `--unit` given, by name.
    pub fn unit_name(&self) -> Option<&'static str> {
        self.unit.map(|u| match u {
            UnitArg::M => "m",
            UnitArg::Ft => "ft",
        })
    }

    /// Reads the named files into a [`wells::Input`] (no parsing yet).
    pub fn to_input(&self) -> anyhow::Result<wells::Input> {
        let mut input = wells::Input {
            variable: self.variable.clone(),
            inside_codes: self.inside.clone(),
            composite_length: self.composite,
            dip_down_negative: self.dip_down.map(|d| d == DipDown::Negative),
            crs: self.crs.clone(),
            unit: self.unit_name().map(str::to_owned),
            below_detection: match self.below_detection {
                BelowArg::Half => BelowDetection::Half,
                BelowArg::Zero => BelowDetection::Zero,
            },
            negative_is_below_detection: self
                .negative_values
                .map(|n| n == NegativeArg::BelowDetection),
            ..wells::Input::default()
        };
        let mut las_paths = self.las.clone();
        for path in &self.inputs {
            let ext = path
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or("")
                .to_ascii_lowercase();
            let slot = match ext.as_str() {
                "csv" | "txt" | "tsv" => &mut input.samples_csv,
                "json" => &mut input.wells_json,
                "las" => {
                    las_paths.push(path.clone());
                    continue;
                }
                _ if path.is_dir() => {
                    las_paths.push(path.clone());
                    continue;
                }
                _ => anyhow::bail!(
                    "{}: unknown input kind (expected .csv samples, .json wells or .las logs)",
                    path.display()
                ),
            };
            if slot.is_some() {
                anyhow::bail!(
                    "{}: only one samples CSV or wells JSON per run",
                    path.display()
                );
            }
            *slot = Some(read(path)?);
        }
        input.collars_csv = self.collars.as_deref().map(read).transpose()?;
        input.surveys_csv = self.surveys.as_deref().map(read).transpose()?;
        input.intervals_csv = self.intervals.as_deref().map(read).transpose()?;
        input.locations_csv = self.locations.as_deref().map(read).transpose()?;
        input.las = las_files(&las_paths)?;
        Ok(input)
    }

    /// Reads and parses the input into samples.
    pub fn load(&self) -> anyhow::Result<wells::SampleSet> {
        let input = self.to_input()?;
        Ok(input.load()?)
    }
}
