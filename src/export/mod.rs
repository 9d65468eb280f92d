//! Writing results: GLB (glTF 2.0 binary), the summary JSON, a 3D Tiles tileset, GeoJSON
//! level plans, OBJ and VTU.
//!
//! Invariant: exporters write exactly the triangles of `ContourResult::shells`, so any
//! reader recomputes the summary's volumes and areas, and every figure an output carries
//! (GLB extras, GeoJSON properties) is taken from `ContourResult::summary`.

mod georef;
mod glb;
mod levels;
mod obj;
mod report;
pub mod tet_vtu;
mod vtu;

pub use georef::{EnuFrame, enu_frame, tileset_json};
pub use glb::glb;
pub use levels::{Levels, geojson_levels, level_rings};
pub use obj::obj;
pub use report::{chart_title, report_csv, report_svg};
pub use vtu::vtu;

use crate::contour::{ContourResult, Summary};

/// One output file of a job, ready to be written to disk or served.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Output {
    /// Stable id used in the job results (`glb`, `summary`, `tileset`, `geojson`, `obj`,
    /// `vtu`).
    pub id: &'static str,
    /// Suggested file name.
    pub file_name: String,
    /// IANA media type served with the bytes.
    pub media_type: &'static str,
    pub bytes: Vec<u8>,
}

/// What the exporters include. `Default` draws the wells and picks levels automatically.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputOptions {
    /// Draw each drill hole's trace as a line in the GLB (node `wells`).
    pub well_traces: bool,
    /// Draw each sample as a point coloured by its value in the GLB (node `samples`).
    pub well_samples: bool,
    /// Elevations (input units) at which the GeoJSON level plans cut the bodies.
    pub levels: Levels,
    /// URI of the GLB relative to the tileset (`glb` on the service, where the tileset is
    /// served at `.../results/tileset` beside `.../results/glb`).
    pub tileset_content_uri: String,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            well_traces: true,
            well_samples: true,
            levels: Levels::Automatic,
            tileset_content_uri: "glb".to_owned(),
        }
    }
}

/// Why an output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The summary does not describe the shells (different shell or body counts).
    #[error("the summary does not match the shells: {0}")]
    Inconsistent(String),
    /// A position or figure is NaN or infinite.
    #[error("non-finite number in {0}")]
    NonFinite(String),
    /// The GLB would exceed glTF's 4 GiB limit.
    #[error("the GLB would be {0} bytes, over glTF's 4 GiB limit")]
    TooLarge(u64),
    /// A level given for the GeoJSON plans is not a finite number.
    #[error("level {0} is not a finite number")]
    BadLevel(f64),
    /// The result carries no CRS, so it cannot be placed on the globe.
    #[error("no CRS is known for the input; give one (e.g. EPSG:32633) to place the model")]
    NoCrs,
    /// The CRS is not one that the projection library knows.
    #[error("CRS {crs:?} is not recognised: {reason}")]
    UnknownCrs { crs: String, reason: String },
    /// A geographic (longitude/latitude) CRS: local coordinates in degrees have no metric
    /// frame.
    #[error("CRS {0:?} is geographic (degrees); a projected CRS in metres or feet is needed")]
    GeographicCrs(String),
    /// The origin could not be projected to WGS84.
    #[error("cannot project the origin from {crs:?} to WGS84: {reason}")]
    Projection { crs: String, reason: String },
    #[error("JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// The GLB container could not be packed.
    #[error("GLB: {0}")]
    Glb(#[from] gltf::Error),
}

impl ExportError {
    /// `true` for the errors that only mean "this result cannot be placed on the globe".
    pub fn is_georeference(&self) -> bool {
        matches!(
            self,
            ExportError::NoCrs
                | ExportError::UnknownCrs { .. }
                | ExportError::GeographicCrs(_)
                | ExportError::Projection { .. }
        )
    }
}

/// The summary JSON (design.md contract), pretty-printed.
pub fn summary_json(summary: &Summary) -> Result<Vec<u8>, ExportError> {
    let mut bytes = serde_json::to_vec_pretty(summary)?;
    bytes.push(b'\n');
    Ok(bytes)
}

/// Every output of a job, in the order `glb`, `summary`, `tileset`, `geojson`, `obj`,
/// `vtu`, then `report` (grade–tonnage CSV) and `chart` (its SVG) when there is a curve. The tileset is left out (not an error) when the result has no CRS or a CRS that
/// cannot be placed on the globe; [`tileset_json`] says why.
pub fn all_outputs(
    result: &ContourResult,
    options: &OutputOptions,
) -> Result<Vec<Output>, ExportError> {
    let mut outputs = vec![
        Output {
            id: "glb",
            file_name: "wellmesh.glb".to_owned(),
            media_type: "model/gltf-binary",
            bytes: glb(result, options)?,
        },
        Output {
            id: "summary",
            file_name: "summary.json".to_owned(),
            media_type: "application/json",
            bytes: summary_json(&result.summary)?,
        },
    ];
    match tileset_json(result, &options.tileset_content_uri) {
        Ok(bytes) => outputs.push(Output {
            id: "tileset",
            file_name: "tileset.json".to_owned(),
            media_type: "application/json",
            bytes,
        }),
        Err(err) if err.is_georeference() => {}
        Err(err) => return Err(err),
    }
    outputs.push(Output {
        id: "geojson",
        file_name: "levels.geojson".to_owned(),
        media_type: "application/geo+json",
        bytes: geojson_levels(result, &options.levels)?,
    });
    outputs.push(Output {
        id: "obj",
        file_name: "bodies.obj".to_owned(),
        media_type: "model/obj",
        bytes: obj(result)?,
    });
    outputs.push(Output {
        id: "vtu",
        file_name: "bodies.vtu".to_owned(),
        media_type: "application/xml",
        bytes: vtu(result)?,
    });
    if let Some(bytes) = report_csv(&result.summary) {
        outputs.push(Output {
            id: "report",
            file_name: "grade_tonnage.csv".to_owned(),
            media_type: "text/csv",
            bytes,
        });
    }
    if let Some(bytes) = report_svg(&result.summary) {
        outputs.push(Output {
            id: "chart",
            file_name: "grade_tonnage.svg".to_owned(),
            media_type: "image/svg+xml",
            bytes,
        });
    }
    Ok(outputs)
}

/// Checks that the summary lists exactly the shells and bodies of the result, so that
/// exporters can pair `summary.shells[s].bodies[b]` with `shells[s].bodies[b]`.
pub(crate) fn check_consistent(result: &ContourResult) -> Result<(), ExportError> {
    let summary = &result.summary;
    if summary.shells.len() != result.shells.len() {
        return Err(ExportError::Inconsistent(format!(
            "{} shells in the summary, {} computed",
            summary.shells.len(),
            result.shells.len()
        )));
    }
    for (s, (shell_summary, shell)) in summary.shells.iter().zip(&result.shells).enumerate() {
        if shell_summary.bodies.len() != shell.bodies.len() {
            return Err(ExportError::Inconsistent(format!(
                "shell {}: {} bodies in the summary, {} computed",
                s + 1,
                shell_summary.bodies.len(),
                shell.bodies.len()
            )));
        }
        for (b, body) in shell.bodies.iter().enumerate() {
            if body.positions.iter().any(|p| !p.is_finite()) {
                return Err(ExportError::NonFinite(format!(
                    "shell {} body {} positions",
                    s + 1,
                    b + 1
                )));
            }
            let n = body.positions.len();
            if let Some(t) = body
                .triangles
                .iter()
                .find(|t| t.iter().any(|&i| i as usize >= n))
            {
                return Err(ExportError::Inconsistent(format!(
                    "shell {} body {}: triangle {t:?} indexes past its {n} vertices",
                    s + 1,
                    b + 1
                )));
            }
        }
    }
    let o = summary.origin;
    if !o.iter().all(|v| v.is_finite()) {
        return Err(ExportError::NonFinite("the origin".to_owned()));
    }
    Ok(())
}

/// `"shell 1 threshold 0.5"`: how outputs name a shell (1-based).
pub(crate) fn shell_name(shell_index: usize, threshold: f64) -> String {
    format!("shell {} threshold {}", shell_index + 1, threshold)
}

/// `"shell 1 threshold 0.5 body 2"`: how outputs name a body (1-based).
pub(crate) fn body_name(shell_index: usize, threshold: f64, body_index: usize) -> String {
    format!(
        "{} body {}",
        shell_name(shell_index, threshold),
        body_index + 1
    )
}
