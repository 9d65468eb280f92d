//! The output flags shared by commands that write a contouring result (`contour`), and
//! writing the files they name.
//!
//! Invariant: every output is built in memory before the first file is written, so a
//! failing output (a tileset without a CRS, a bad level) leaves no partial set of files.

use std::path::{Component, Path, PathBuf};

use anyhow::Context;
use wellmesh::contour::ContourResult;
use wellmesh::export::{self, Levels, OutputOptions};

/// Where to write a contouring result.
#[derive(Debug, Clone, clap::Args)]
pub struct OutputArgs {
    /// GLB (glTF 2.0 binary) of the bodies, Y-up, relative to the origin in its extras.
    #[arg(short = 'o', long = "output", value_name = "OUT.glb")]
    pub output: PathBuf,
    /// Summary JSON: method, origin, CRS, counts, each shell's and body's volume and area.
    #[arg(long, value_name = "OUT.json")]
    pub summary: Option<PathBuf>,
    /// 3D Tiles tileset placing the GLB on the globe (needs a CRS): a `.json` file, or a
    /// directory in which `tileset.json` is written.
    #[arg(long, value_name = "DIR_OR_FILE")]
    pub tileset: Option<PathBuf>,
    /// GeoJSON level plans: the bodies cut at `--levels` elevations into polygons.
    #[arg(long, value_name = "OUT.geojson")]
    pub geojson: Option<PathBuf>,
    /// Elevations of the level plans, comma-separated (default: about ten round levels).
    #[arg(
        long,
        value_name = "Z1,Z2,...",
        value_delimiter = ',',
        allow_hyphen_values = true,
        requires = "geojson"
    )]
    pub levels: Vec<f64>,
    /// Wavefront OBJ of the bodies (local coordinates; the origin is in its header).
    #[arg(long, value_name = "OUT.obj")]
    pub obj: Option<PathBuf>,
    /// VTK unstructured grid of the bodies, in input coordinates.
    #[arg(long, value_name = "OUT.vtu")]
    pub vtu: Option<PathBuf>,
    /// Leave the drill-hole traces and samples out of the GLB.
    #[arg(long)]
    pub no_wells: bool,
    /// Leave the samples (points) out of the GLB but keep the drill-hole traces.
    #[arg(long)]
    pub no_samples: bool,
}

impl OutputArgs {
    /// The exporters' options these flags ask for; `tileset_content_uri` points from the
    /// tileset's directory to the GLB.
    pub fn options(&self) -> anyhow::Result<OutputOptions> {
        let tileset_content_uri = match &self.tileset {
            Some(_) => {
                let tileset = self.tileset_path();
                let dir = tileset
                    .parent()
                    .filter(|d| !d.as_os_str().is_empty())
                    .unwrap_or(Path::new("."));
                relative_uri(dir, &self.output)?
            }
            None => "glb".to_owned(),
        };
        Ok(OutputOptions {
            well_traces: !self.no_wells,
            well_samples: !self.no_wells && !self.no_samples,
            levels: if self.levels.is_empty() {
                Levels::Automatic
            } else {
                Levels::At(self.levels.clone())
            },
            tileset_content_uri,
        })
    }

    /// The tileset file: `--tileset` itself when it ends in `.json`, else
    /// `DIR/tileset.json`.
    fn tileset_path(&self) -> PathBuf {
        let path = self.tileset.clone().unwrap_or_default();
        let is_file = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        if is_file {
            path
        } else {
            path.join("tileset.json")
        }
    }

    /// Writes every requested output of `result`.
    pub fn write(&self, result: &ContourResult) -> anyhow::Result<()> {
        let options = self.options()?;
        let mut files: Vec<(PathBuf, Vec<u8>)> = vec![(
            self.output.clone(),
            export::glb(result, &options).context("writing the GLB")?,
        )];
        if let Some(path) = &self.summary {
            files.push((path.clone(), export::summary_json(&result.summary)?));
        }
        if self.tileset.is_some() {
            let bytes = export::tileset_json(result, &options.tileset_content_uri)
                .context("writing the 3D Tiles tileset")?;
            files.push((self.tileset_path(), bytes));
        }
        if let Some(path) = &self.geojson {
            let bytes = export::geojson_levels(result, &options.levels)
                .context("writing the GeoJSON level plans")?;
            files.push((path.clone(), bytes));
        }
        if let Some(path) = &self.obj {
            files.push((path.clone(), export::obj(result)?));
        }
        if let Some(path) = &self.vtu {
            files.push((path.clone(), export::vtu(result)?));
        }
        for (path, bytes) in files {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("creating directory {}", dir.display()))?;
            }
            std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
        }
        Ok(())
    }
}

/// The URI of `target` relative to directory `from_dir` (both as given, made absolute
/// against the working directory), with `/` separators and spaces escaped.
fn relative_uri(from_dir: &Path, target: &Path) -> anyhow::Result<String> {
    let absolute = |p: &Path| -> anyhow::Result<Vec<String>> {
        let p = std::path::absolute(p).with_context(|| format!("resolving {}", p.display()))?;
        let mut parts: Vec<String> = Vec::new();
        for c in p.components() {
            match c {
                Component::ParentDir => {
                    parts.pop();
                }
                Component::Normal(s) => parts.push(s.to_string_lossy().into_owned()),
                Component::CurDir | Component::RootDir | Component::Prefix(_) => {}
            }
        }
        Ok(parts)
    };
    let from = absolute(from_dir)?;
    let to = absolute(target)?;
    let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<String> = vec!["..".to_owned(); from.len() - common];
    parts.extend(to[common..].iter().cloned());
    Ok(parts
        .join("/")
        .replace('%', "%25")
        .replace(' ', "%20")
        .replace('#', "%23"))
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        outputs: OutputArgs,
    }

    fn parse(args: &[&str]) -> Result<OutputArgs, clap::Error> {
        Cli::try_parse_from(std::iter::once("wellmesh").chain(args.iter().copied()))
            .map(|c| c.outputs)
    }

    /// A result holding one tetrahedron body at UTM coordinates.
    fn tetrahedron_result(crs: Option<&str>) -> ContourResult {
        use glam::DVec3;
        use wellmesh::contour::{BodySummary, ShellSummary, Summary, UnknownMode};
        use wellmesh::dmt::{Body, Quality, Shell, ShellCounts};
        use wellmesh::wells::{ReadReport, SampleSet};

        let origin = DVec3::new(500_000.0, 7_000_000.0, 300.0);
        let positions = vec![
            DVec3::ZERO,
            DVec3::new(10.0, 0.0, 0.0),
            DVec3::new(0.0, 10.0, 0.0),
            DVec3::new(0.0, 0.0, 10.0),
        ];
        let body = Body {
            positions,
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
            volume: 1000.0 / 6.0,
            area: 150.0 + 50.0 * 3f64.sqrt(),
            closed: true,
            truncated: false,
            bbox: [DVec3::ZERO, DVec3::splat(10.0)],
            region: 0,
            mt_fallback: false,
        };
        let body_summary = BodySummary {
            volume: body.volume,
            area: body.area,
            closed: true,
            truncated: false,
            mt_fallback: false,
            bbox: [origin.to_array(), (origin + 10.0).to_array()],
            resource: None,
        };
        ContourResult {
            summary: Summary {
                method: "ibc".into(),
                interpolant: "linear".into(),
                model: None,
                min_volume: None,
                relax_sweeps: 0,
                origin: origin.to_array(),
                crs: crs.map(str::to_owned),
                unit: "m".into(),
                unknown: UnknownMode::Drop,
                binary: true,
                counts: serde_json::Map::new(),
                shells: vec![ShellSummary {
                    threshold: 0.5,
                    volume: body.volume,
                    area: body.area,
                    bodies: vec![body_summary],
                    counts: ShellCounts::default(),
                    quality: Quality::default(),
                    filtered_bodies: 0,
                    filtered_volume: 0.0,
                    volume_range: None,
                    resource: None,
                    simplified: None,
                }],
                report: None,
                warnings: Vec::new(),
            },
            shells: vec![Shell {
                threshold: 0.5,
                bodies: vec![body],
                counts: ShellCounts::default(),
                quality: Quality::default(),
                point_touches: 0,
            }],
            samples: SampleSet {
                origin,
                crs: crs.map(str::to_owned),
                unit: "m".into(),
                wells: Vec::new(),
                points: Vec::new(),
                values: Vec::new(),
                well_of: Vec::new(),
                report: ReadReport::default(),
            },
        }
    }

    fn scratch_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("wellmesh-outputs-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn write_puts_every_requested_file_where_asked() {
        let dir = scratch_dir("all");
        let d = |f: &str| dir.join(f).to_string_lossy().into_owned();
        let args = parse(&[
            "-o",
            &d("model/body.glb"),
            "--summary",
            &d("summary.json"),
            "--tileset",
            &d("tiles"),
            "--geojson",
            &d("plans.geojson"),
            "--levels",
            "305",
            "--obj",
            &d("body.obj"),
            "--vtu",
            &d("body.vtu"),
        ])
        .unwrap();
        args.write(&tetrahedron_result(Some("EPSG:32633"))).unwrap();
        for f in [
            "model/body.glb",
            "summary.json",
            "tiles/tileset.json",
            "plans.geojson",
            "body.obj",
            "body.vtu",
        ] {
            assert!(dir.join(f).is_file(), "{f} missing");
        }
        let tileset: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("tiles/tileset.json")).unwrap())
                .unwrap();
        assert_eq!(tileset["root"]["content"]["uri"], "../model/body.glb");
        let plans: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("plans.geojson")).unwrap()).unwrap();
        assert_eq!(plans["features"].as_array().unwrap().len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_tileset_without_a_crs_fails_before_any_file_is_written() {
        let dir = scratch_dir("nocrs");
        let glb = dir.join("body.glb");
        let args = parse(&[
            "-o",
            glb.to_str().unwrap(),
            "--tileset",
            dir.to_str().unwrap(),
        ])
        .unwrap();
        let err = args.write(&tetrahedron_result(None)).unwrap_err();
        assert!(format!("{err:#}").contains("no CRS"), "{err:#}");
        assert!(!glb.exists());
    }

    #[test]
    fn the_glb_is_required_and_levels_need_a_geojson() {
        assert!(parse(&[]).is_err());
        assert!(parse(&["-o", "a.glb", "--levels", "100,200"]).is_err());
        let args = parse(&[
            "-o",
            "a.glb",
            "--geojson",
            "p.geojson",
            "--levels",
            "-50,120.5",
        ])
        .unwrap();
        assert_eq!(args.levels, [-50.0, 120.5]);
        assert_eq!(
            args.options().unwrap().levels,
            Levels::At(vec![-50.0, 120.5])
        );
        assert!(parse(&["-o", "a.glb", "--geojson", "p", "--levels", "1,x"]).is_err());
    }

    #[test]
    fn wells_can_be_left_out() {
        let options = parse(&["-o", "a.glb", "--no-wells"])
            .unwrap()
            .options()
            .unwrap();
        assert!(!options.well_traces && !options.well_samples);
        let options = parse(&["-o", "a.glb", "--no-samples"])
            .unwrap()
            .options()
            .unwrap();
        assert!(options.well_traces && !options.well_samples);
        let options = parse(&["-o", "a.glb"]).unwrap().options().unwrap();
        assert!(options.well_traces && options.well_samples);
        assert_eq!(options.levels, Levels::Automatic);
    }

    #[test]
    fn the_tileset_points_at_the_glb_relative_to_itself() {
        let uri = |args: &[&str]| parse(args).unwrap().options().unwrap().tileset_content_uri;
        assert_eq!(uri(&["-o", "out/body.glb", "--tileset", "out"]), "body.glb");
        assert_eq!(
            uri(&["-o", "out/body.glb", "--tileset", "out/tiles/t.json"]),
            "../body.glb"
        );
        assert_eq!(
            uri(&["-o", "my model.glb", "--tileset", "tiles"]),
            "../my%20model.glb"
        );
        let args = parse(&["-o", "x.glb", "--tileset", "tiles"]).unwrap();
        assert_eq!(args.tileset_path(), PathBuf::from("tiles/tileset.json"));
    }
}
