//! Wavefront OBJ of the bodies, for desktop tools.
//!
//! Invariant: one `o` object per body with exactly its triangles, counter-clockwise from
//! outside; positions are local (x east, y north, z up, origin subtracted, as written in
//! the header) because desktop tools read OBJ in single precision, which would lose the
//! metres of a UTM coordinate.

use std::fmt::Write;

use super::{ExportError, body_name, check_consistent};
use crate::contour::ContourResult;

/// The OBJ text of every body.
pub fn obj(result: &ContourResult) -> Result<Vec<u8>, ExportError> {
    check_consistent(result)?;
    let summary = &result.summary;
    let mut out = String::new();
    let o = summary.origin;
    // Writing to a String cannot fail.
    let _ = writeln!(out, "# wellmesh {} ore bodies", env!("CARGO_PKG_VERSION"));
    let _ = writeln!(
        out,
        "# axes: x east, y north, z up, relative to origin {} {} {}",
        o[0], o[1], o[2]
    );
    let _ = writeln!(
        out,
        "# crs: {}; unit: {}; method: {}",
        summary.crs.as_deref().unwrap_or("unknown"),
        summary.unit,
        summary.method
    );
    let mut first_vertex = 1usize;
    for (s, (shell, shell_summary)) in result.shells.iter().zip(&summary.shells).enumerate() {
        for (b, (body, body_summary)) in shell.bodies.iter().zip(&shell_summary.bodies).enumerate()
        {
            let _ = writeln!(
                out,
                "o {}\n# volume {} area {} closed {} truncated {}",
                body_name(s, shell.threshold, b).replace(' ', "_"),
                body_summary.volume,
                body_summary.area,
                body_summary.closed,
                body_summary.truncated
            );
            for p in &body.positions {
                let _ = writeln!(out, "v {} {} {}", p.x, p.y, p.z);
            }
            for t in &body.triangles {
                let [a, b, c] = t.map(|i| i as usize + first_vertex);
                let _ = writeln!(out, "f {a} {b} {c}");
            }
            first_vertex += body.positions.len();
        }
    }
    Ok(out.into_bytes())
}
