//! VTK XML unstructured grid (`.vtu`) of the bodies, for ParaView and other VTK tools.
//!
//! Invariant: points are in input coordinates as Float64 (VTK keeps double precision), one
//! triangle cell per body triangle, counter-clockwise from outside; cell data `shell`,
//! `body` and `threshold` say which body each triangle belongs to.

use std::fmt::Write;

use super::{ExportError, check_consistent};
use crate::contour::ContourResult;

/// VTK's cell type for a triangle.
const VTK_TRIANGLE: u8 = 5;

/// The VTU (ASCII) of every body.
pub fn vtu(result: &ContourResult) -> Result<Vec<u8>, ExportError> {
    check_consistent(result)?;
    let o = result.summary.origin;
    let bodies: Vec<(usize, usize, f64, &crate::dmt::Body)> = result
        .shells
        .iter()
        .enumerate()
        .flat_map(|(s, shell)| {
            shell
                .bodies
                .iter()
                .enumerate()
                .map(move |(b, body)| (s, b, shell.threshold, body))
        })
        .collect();
    let points: usize = bodies.iter().map(|(_, _, _, b)| b.positions.len()).sum();
    let cells: usize = bodies.iter().map(|(_, _, _, b)| b.triangles.len()).sum();
    let mut out = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(out, r#"<?xml version="1.0"?>"#);
    let _ = writeln!(
        out,
        r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
    );
    let _ = writeln!(out, "<UnstructuredGrid>");
    let _ = writeln!(out, r#"<FieldData>"#);
    let _ = writeln!(
        out,
        r#"<DataArray type="Float64" Name="origin" NumberOfTuples="1" NumberOfComponents="3" format="ascii">{} {} {}</DataArray>"#,
        o[0], o[1], o[2]
    );
    let _ = writeln!(out, r#"</FieldData>"#);
    let _ = writeln!(
        out,
        r#"<Piece NumberOfPoints="{points}" NumberOfCells="{cells}">"#
    );
    let _ = writeln!(out, "<Points>");
    let _ = writeln!(
        out,
        r#"<DataArray type="Float64" Name="Points" NumberOfComponents="3" format="ascii">"#
    );
    for (_, _, _, body) in &bodies {
        for p in &body.positions {
            let _ = writeln!(out, "{} {} {}", p.x + o[0], p.y + o[1], p.z + o[2]);
        }
    }
    let _ = writeln!(out, "</DataArray>\n</Points>\n<Cells>");
    let _ = writeln!(
        out,
        r#"<DataArray type="Int64" Name="connectivity" format="ascii">"#
    );
    let mut first = 0usize;
    for (_, _, _, body) in &bodies {
        for t in &body.triangles {
            let [a, b, c] = t.map(|i| i as usize + first);
            let _ = writeln!(out, "{a} {b} {c}");
        }
        first += body.positions.len();
    }
    let _ = writeln!(out, "</DataArray>");
    let _ = writeln!(
        out,
        r#"<DataArray type="Int64" Name="offsets" format="ascii">"#
    );
    for k in 1..=cells {
        let _ = write!(out, "{} ", 3 * k);
    }
    let _ = writeln!(out, "\n</DataArray>");
    let _ = writeln!(
        out,
        r#"<DataArray type="UInt8" Name="types" format="ascii">"#
    );
    for _ in 0..cells {
        let _ = write!(out, "{VTK_TRIANGLE} ");
    }
    let _ = writeln!(
        out,
        "\n</DataArray>\n</Cells>\n<CellData Scalars=\"shell\">"
    );
    for (name, kind) in [
        ("shell", "Int32"),
        ("body", "Int32"),
        ("threshold", "Float64"),
    ] {
        let _ = writeln!(
            out,
            r#"<DataArray type="{kind}" Name="{name}" format="ascii">"#
        );
        for (s, b, threshold, body) in &bodies {
            let value = match name {
                "shell" => (s + 1).to_string(),
                "body" => (b + 1).to_string(),
                _ => threshold.to_string(),
            };
            for _ in &body.triangles {
                let _ = write!(out, "{value} ");
            }
        }
        let _ = writeln!(out, "\n</DataArray>");
    }
    let _ = writeln!(
        out,
        "</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>"
    );
    Ok(out.into_bytes())
}
