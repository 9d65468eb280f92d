//! `wellmesh tetrahedralize`: Delaunay-tetrahedralize a point file, print one line
//! `points N tets T seconds S` (S: the tetrahedralization alone), optionally write a VTU.
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use glam::DVec3;
use wellmesh::export::tet_vtu::write_tet_vtu_file;
use wellmesh::tet::delaunay_owned_without_map;

use super::Bar;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Points: `.xyz` (one `x y z` per line, whitespace separated; `#` comments) or `.csv`
    /// (columns `x,y,z` or `easting,northing,elevation`, or the first three without a header).
    /// Further columns (intensities, values) are ignored; equal points are merged and counted.
    pub points: PathBuf,
    /// Write the tetrahedra as a VTK unstructured grid (`.vtu`).
    #[arg(short, long, value_name = "OUT.vtu")]
    pub output: Option<PathBuf>,
    /// Print the result as one JSON object instead of the `points N tets T seconds S` line.
    #[arg(long)]
    pub json: bool,
    /// No progress bar, even on a terminal (there is none when standard error is not one).
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let points = read_points(&args.points)?;
    let n_points = points.len();
    let started = Instant::now();
    // The VTU holds the mesh's vertices in its own order: no map from input points needed.
    let bar = Bar::new(args.quiet);
    let mesh = delaunay_owned_without_map(points, &bar);
    bar.finish();
    let mesh = mesh.with_context(|| format!("cannot tetrahedralize {}", args.points.display()))?;
    let seconds = started.elapsed().as_secs_f64();
    if let Some(out) = &args.output {
        write_tet_vtu_file(&mesh, out)
            .with_context(|| format!("cannot write {}", out.display()))?;
    }
    if args.json {
        let summary = serde_json::json!({
            "points": n_points,
            "distinct_points": mesh.points.len(),
            "duplicates_merged": mesh.duplicates_merged,
            "tets": mesh.tet_count(),
            "seconds": seconds,
        });
        println!("{summary}");
    } else {
        println!(
            "points {n_points} tets {} seconds {seconds:.3}",
            mesh.tet_count()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// Reads `.xyz` or `.csv` points; errors name the file, line and field.
fn read_points(path: &Path) -> anyhow::Result<Vec<DVec3>> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("csv") => read_csv(path),
        Some("xyz") | Some("txt") => read_xyz(path),
        _ => bail!(
            "{}: unknown point file type (expected .xyz or .csv)",
            path.display()
        ),
    }
}

/// `hint` is asked only when `text` is not a number, and added to that error.
fn parse_coord(
    text: &str,
    path: &Path,
    line: usize,
    field: &str,
    hint: impl FnOnce() -> Option<&'static str>,
) -> anyhow::Result<f64> {
    let value: f64 = text.trim().parse().map_err(|_| {
        let hint = hint().map(|h| format!(" ({h})")).unwrap_or_default();
        anyhow::anyhow!(
            "{}:{line}: {field} is not a number: {text:?}{hint}",
            path.display()
        )
    })?;
    if !value.is_finite() {
        bail!("{}:{line}: {field} is not finite: {text:?}", path.display());
    }
    Ok(value)
}

fn read_xyz(path: &Path) -> anyhow::Result<Vec<DVec3>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut reader = BufReader::with_capacity(1 << 20, file);
    let mut points = Vec::new();
    let mut line = String::new();
    let mut line_no = 0;
    loop {
        line.clear();
        let read = reader
            .read_line(&mut line)
            .with_context(|| format!("cannot read {}", path.display()))?;
        if read == 0 {
            break;
        }
        line_no += 1;
        let content = line.trim();
        if content.is_empty() || content.starts_with('#') {
            continue;
        }
        let mut fields = content.split_whitespace();
        let mut xyz = [0.0; 3];
        for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
            let Some(text) = fields.next() else {
                bail!(
                    "{}:{line_no}: expected 3 numbers `x y z`, found no {name}",
                    path.display()
                );
            };
            xyz[k] = parse_coord(text, path, line_no, name, || {
                xyz_hint(text, points.is_empty())
            })?;
        }
        points.push(DVec3::from_array(xyz));
    }
    Ok(points)
}

/// What most likely went wrong when a `.xyz` field is not a number: a comma-separated
/// file under an `.xyz` name, or a header line before the first point.
fn xyz_hint(text: &str, first_point: bool) -> Option<&'static str> {
    if text.contains([',', ';']) {
        Some(
            "`.xyz` fields are separated by spaces or tabs; for comma-separated points name the file `.csv`",
        )
    } else if first_point {
        Some(
            "`.xyz` takes no header line: start it with `#`, or use a `.csv` file with columns x,y,z",
        )
    } else {
        None
    }
}

fn read_csv(path: &Path) -> anyhow::Result<Vec<DVec3>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(BufReader::with_capacity(1 << 20, file));
    let mut records = reader.records();
    let mut points = Vec::new();
    let Some(first) = records.next() else {
        return Ok(points);
    };
    let first = first.with_context(|| format!("cannot read {}", path.display()))?;
    let numeric = first.len() >= 3 && (0..3).all(|k| first[k].parse::<f64>().is_ok());
    let columns: [usize; 3] = if numeric {
        [0, 1, 2]
    } else {
        let find = |names: &[&str]| {
            first
                .iter()
                .position(|h| names.iter().any(|n| h.eq_ignore_ascii_case(n)))
        };
        match (
            find(&["x", "easting", "east"]),
            find(&["y", "northing", "north"]),
            find(&["z", "elevation", "elev", "rl"]),
        ) {
            (Some(x), Some(y), Some(z)) => [x, y, z],
            _ => {
                let found = first.iter().collect::<Vec<_>>().join(",");
                let hint = if found.contains([';', '\t']) {
                    " (`.csv` fields are separated by commas)"
                } else {
                    ""
                };
                bail!(
                    "{}:1: the first row is neither three numbers nor a header naming columns \
                     x, y, z (or easting, northing, elevation): {found:?}{hint}",
                    path.display()
                )
            }
        }
    };
    let mut push = |record: &csv::StringRecord, line: usize| -> anyhow::Result<()> {
        let mut xyz = [0.0; 3];
        for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
            let Some(text) = record.get(columns[k]) else {
                bail!("{}:{line}: missing column {name}", path.display());
            };
            xyz[k] = parse_coord(text, path, line, name, || None)?;
        }
        points.push(DVec3::from_array(xyz));
        Ok(())
    };
    if numeric {
        push(&first, 1)?;
    }
    for record in records {
        let record = record.with_context(|| format!("cannot read {}", path.display()))?;
        let line = record.position().map_or(0, |p| p.line() as usize);
        if record.iter().all(str::is_empty) {
            continue;
        }
        push(&record, line)?;
    }
    Ok(points)
}
