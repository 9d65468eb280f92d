//! Raw sample arrays: scalar types, byte order, and headerless raw volumes.
//!
//! Invariant: bytes are decoded only when their length is exactly `count * size` of the
//! scalar type; anything else is an error naming the file.

use glam::DVec3;

use super::{GridError, GridVolume, point_count};

/// Byte order of multi-byte samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Endian {
    #[default]
    Little,
    Big,
}

impl std::str::FromStr for Endian {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "little" | "le" => Ok(Endian::Little),
            "big" | "be" => Ok(Endian::Big),
            other => Err(format!(
                "unknown byte order {other:?}: expected little or big"
            )),
        }
    }
}

/// Type of one stored sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl ScalarType {
    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::I64 | ScalarType::U64 | ScalarType::F64 => 8,
        }
    }

    /// The short name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ScalarType::I8 => "i8",
            ScalarType::U8 => "u8",
            ScalarType::I16 => "i16",
            ScalarType::U16 => "u16",
            ScalarType::I32 => "i32",
            ScalarType::U32 => "u32",
            ScalarType::I64 => "i64",
            ScalarType::U64 => "u64",
            ScalarType::F32 => "f32",
            ScalarType::F64 => "f64",
        }
    }

    /// Decodes `bytes` (a whole number of samples) into values.
    pub(crate) fn decode(self, bytes: &[u8], endian: Endian) -> Vec<f64> {
        let size = self.size();
        bytes
            .chunks_exact(size)
            .map(|c| {
                let mut b = [0u8; 8];
                b[..size].copy_from_slice(c);
                if endian == Endian::Big {
                    b[..size].reverse();
                }
                match self {
                    ScalarType::I8 => b[0] as i8 as f64,
                    ScalarType::U8 => b[0] as f64,
                    ScalarType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    ScalarType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    ScalarType::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    ScalarType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    ScalarType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    ScalarType::I64 => i64::from_le_bytes(b) as f64,
                    ScalarType::U64 => u64::from_le_bytes(b) as f64,
                    ScalarType::F64 => f64::from_le_bytes(b),
                }
            })
            .collect()
    }
}

impl std::str::FromStr for ScalarType {
    type Err = String;

    /// Parses the short names (`u8`, `i16`, `f32`, ...).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "i8" => ScalarType::I8,
            "u8" => ScalarType::U8,
            "i16" => ScalarType::I16,
            "u16" => ScalarType::U16,
            "i32" => ScalarType::I32,
            "u32" => ScalarType::U32,
            "i64" => ScalarType::I64,
            "u64" => ScalarType::U64,
            "f32" => ScalarType::F32,
            "f64" => ScalarType::F64,
            other => {
                return Err(format!(
                    "unknown sample type {other:?}: expected u8, i8, u16, i16, u32, i32, u64, i64, f32 or f64"
                ));
            }
        })
    }
}

/// Reads a headerless volume: `dims[0] * dims[1] * dims[2]` samples, `i` fastest, the
/// first at `(0, 0, 0)`, `spacing` apart along `x`, `y`, `z`.
pub fn read_raw(
    name: &str,
    bytes: &[u8],
    dims: [usize; 3],
    spacing: DVec3,
    scalar: ScalarType,
    endian: Endian,
) -> Result<GridVolume, GridError> {
    let count = point_count(name, dims)?;
    let expected = count.checked_mul(scalar.size());
    if expected != Some(bytes.len()) {
        return Err(GridError::format(
            name,
            "size",
            format!(
                "{} bytes, but {}x{}x{} samples of {} need {}",
                bytes.len(),
                dims[0],
                dims[1],
                dims[2],
                scalar.name(),
                expected.map_or_else(
                    || "more than can be addressed".to_string(),
                    |e| e.to_string()
                )
            ),
        ));
    }
    if !spacing.is_finite() || spacing.min_element() <= 0.0 {
        return Err(GridError::format(
            name,
            "spacing",
            format!("{spacing}: each spacing must be a positive number"),
        ));
    }
    let values = scalar.decode(bytes, endian);
    let mut grid = GridVolume::regular(name, dims, spacing, values)?;
    grid.variable = scalar.name().to_string();
    Ok(grid)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_both_byte_orders() {
        assert_eq!(
            ScalarType::I16.decode(&[0xff, 0xfe], Endian::Big),
            vec![-2.0]
        );
        assert_eq!(
            ScalarType::I16.decode(&[0xfe, 0xff], Endian::Little),
            vec![-2.0]
        );
        assert_eq!(
            ScalarType::U16.decode(&[0x01, 0x02], Endian::Big),
            vec![258.0]
        );
        let f = 1.5f32.to_be_bytes();
        assert_eq!(ScalarType::F32.decode(&f, Endian::Big), vec![1.5]);
        let d = (-0.25f64).to_le_bytes();
        assert_eq!(ScalarType::F64.decode(&d, Endian::Little), vec![-0.25]);
    }

    #[test]
    fn raw_size_must_match_dims() {
        let err = read_raw(
            "v.raw",
            &[0; 7],
            [2, 2, 2],
            DVec3::ONE,
            ScalarType::U8,
            Endian::Little,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("v.raw") && err.contains("7 bytes"), "{err}");
        let grid = read_raw(
            "v.raw",
            &[7; 16],
            [2, 2, 2],
            DVec3::ONE,
            ScalarType::U16,
            Endian::Big,
        )
        .unwrap();
        assert!(grid.values.iter().all(|v| *v == 0x0707 as f64));
    }
}
