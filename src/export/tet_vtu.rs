//! VTK XML unstructured grid (`.vtu`) of a [`TetMesh`]: points and tetrahedra, binary
//! arrays inline as base64 with 64-bit size headers (read by VTK, ParaView and meshio).
//!
//! Invariant: the file holds exactly the mesh's points (in order) and tetrahedra (vertex
//! order kept, so VTK's tetra orientation equals the mesh's positive orientation), and is
//! streamed: memory use does not grow with the mesh beyond a fixed buffer.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use crate::tet::TetMesh;

/// VTK cell type of a linear tetrahedron.
const VTK_TETRA: u8 = 10;

/// Writes `mesh` to `path` as a `.vtu` file.
pub fn write_tet_vtu_file(mesh: &TetMesh, path: &Path) -> io::Result<()> {
    let mut out = BufWriter::with_capacity(1 << 20, File::create(path)?);
    write_tet_vtu(mesh, &mut out)?;
    out.flush()
}

/// Writes `mesh` as a `.vtu` document to `out`.
pub fn write_tet_vtu<W: Write>(mesh: &TetMesh, out: &mut W) -> io::Result<()> {
    let n_points = mesh.points.len();
    let n_tets = mesh.tet_count();
    // 32-bit indices when they fit (half the file), 64-bit otherwise.
    let wide = n_points > i32::MAX as usize || n_tets.saturating_mul(4) > i32::MAX as usize;
    let int_type = if wide { "Int64" } else { "Int32" };
    let int_bytes = if wide { 8 } else { 4 };
    writeln!(out, r#"<?xml version="1.0"?>"#)?;
    writeln!(
        out,
        r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
    )?;
    writeln!(out, "<UnstructuredGrid>")?;
    writeln!(
        out,
        r#"<Piece NumberOfPoints="{n_points}" NumberOfCells="{n_tets}">"#
    )?;
    writeln!(out, "<Points>")?;
    write!(
        out,
        r#"<DataArray type="Float64" Name="Points" NumberOfComponents="3" format="binary">"#
    )?;
    {
        let mut enc = Base64::new(&mut *out);
        enc.write_all(&((n_points * 24) as u64).to_le_bytes())?;
        for p in &mesh.points {
            for c in [p.x, p.y, p.z] {
                enc.write_all(&c.to_le_bytes())?;
            }
        }
        enc.finish()?;
    }
    writeln!(out, "</DataArray>")?;
    writeln!(out, "</Points>")?;
    writeln!(out, "<Cells>")?;
    write!(
        out,
        r#"<DataArray type="{int_type}" Name="connectivity" format="binary">"#
    )?;
    {
        let mut enc = Base64::new(&mut *out);
        enc.write_all(&((n_tets * 4 * int_bytes) as u64).to_le_bytes())?;
        for t in mesh.tets() {
            for v in t {
                write_int(&mut enc, u64::from(v), wide)?;
            }
        }
        enc.finish()?;
    }
    writeln!(out, "</DataArray>")?;
    write!(
        out,
        r#"<DataArray type="{int_type}" Name="offsets" format="binary">"#
    )?;
    {
        let mut enc = Base64::new(&mut *out);
        enc.write_all(&((n_tets * int_bytes) as u64).to_le_bytes())?;
        for t in 0..n_tets {
            write_int(&mut enc, (t as u64 + 1) * 4, wide)?;
        }
        enc.finish()?;
    }
    writeln!(out, "</DataArray>")?;
    write!(
        out,
        r#"<DataArray type="UInt8" Name="types" format="binary">"#
    )?;
    {
        let mut enc = Base64::new(&mut *out);
        enc.write_all(&(n_tets as u64).to_le_bytes())?;
        let chunk = [VTK_TETRA; 4096];
        let mut left = n_tets;
        while left > 0 {
            let k = left.min(chunk.len());
            enc.write_all(&chunk[..k])?;
            left -= k;
        }
        enc.finish()?;
    }
    writeln!(out, "</DataArray>")?;
    writeln!(out, "</Cells>")?;
    writeln!(out, "</Piece>")?;
    writeln!(out, "</UnstructuredGrid>")?;
    writeln!(out, "</VTKFile>")?;
    Ok(())
}

fn write_int<W: Write>(out: &mut W, value: u64, wide: bool) -> io::Result<()> {
    if wide {
        out.write_all(&value.to_le_bytes())
    } else {
        out.write_all(&(value as u32).to_le_bytes())
    }
}

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Streaming standard base64 (RFC 4648, padded) onto a writer; call `finish` at the end.
struct Base64<W: Write> {
    out: W,
    carry: [u8; 3],
    carried: usize,
    text: Vec<u8>,
}

impl<W: Write> Base64<W> {
    fn new(out: W) -> Self {
        Base64 {
            out,
            carry: [0; 3],
            carried: 0,
            text: Vec::with_capacity(1 << 16),
        }
    }

    fn encode_group(&mut self, g: [u8; 3], len: usize) {
        let n = (u32::from(g[0]) << 16) | (u32::from(g[1]) << 8) | u32::from(g[2]);
        for k in 0..4 {
            if k <= len {
                self.text
                    .push(ALPHABET[((n >> (18 - 6 * k)) & 63) as usize]);
            } else {
                self.text.push(b'=');
            }
        }
    }

    fn flush_text(&mut self) -> io::Result<()> {
        self.out.write_all(&self.text)?;
        self.text.clear();
        Ok(())
    }

    fn finish(mut self) -> io::Result<()> {
        if self.carried > 0 {
            let mut g = [0u8; 3];
            g[..self.carried].copy_from_slice(&self.carry[..self.carried]);
            self.encode_group(g, self.carried);
            self.carried = 0;
        }
        self.flush_text()
    }
}

impl<W: Write> Write for Base64<W> {
    fn write(&mut self, mut buf: &[u8]) -> io::Result<usize> {
        let written = buf.len();
        while self.carried > 0 && self.carried < 3 && !buf.is_empty() {
            self.carry[self.carried] = buf[0];
            self.carried += 1;
            buf = &buf[1..];
        }
        if self.carried == 3 {
            let g = self.carry;
            self.encode_group(g, 3);
            self.carried = 0;
        } else if self.carried > 0 {
            // `buf` ran out before a group was complete: keep the carry.
            return Ok(written);
        }
        let mut groups = buf.chunks_exact(3);
        for g in &mut groups {
            self.encode_group([g[0], g[1], g[2]], 3);
        }
        let rest = groups.remainder();
        self.carry[..rest.len()].copy_from_slice(rest);
        self.carried = rest.len();
        if self.text.len() >= 1 << 16 {
            self.flush_text()?;
        }
        Ok(written)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.flush_text()?;
        self.out.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b64(bytes: &[u8], pieces: usize) -> String {
        let mut out = Vec::new();
        let mut enc = Base64::new(&mut out);
        for chunk in bytes.chunks(pieces.max(1)) {
            enc.write_all(chunk).unwrap();
        }
        enc.finish().unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn base64_matches_rfc_4648_vectors_whatever_the_write_sizes() {
        for pieces in [1, 2, 5, 100] {
            assert_eq!(b64(b"", pieces), "");
            assert_eq!(b64(b"f", pieces), "Zg==");
            assert_eq!(b64(b"fo", pieces), "Zm8=");
            assert_eq!(b64(b"foo", pieces), "Zm9v");
            assert_eq!(b64(b"foob", pieces), "Zm9vYg==");
            assert_eq!(b64(b"fooba", pieces), "Zm9vYmE=");
            assert_eq!(b64(b"foobar", pieces), "Zm9vYmFy");
        }
    }
}
