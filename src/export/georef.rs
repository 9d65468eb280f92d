//! Georeference: the affine frame that maps local coordinates (x east, y north, z up,
//! relative to the origin, input units) to Earth-centred Earth-fixed WGS84 metres, and the
//! 3D Tiles `tileset.json` that uses it to place the GLB on the globe.
//!
//! Invariant: the frame is exact at the origin (the origin's projected coordinates go
//! through proj4rs to WGS84 longitude/latitude, then to ECEF), and its x/y columns are the
//! projection's own derivative there, so grid convergence and scale factor are honoured;
//! the only error is the Earth's curvature over the body's extent (about d²/2R: 8 cm at
//! 1 km from the origin).

use glam::DVec3;
use proj4rs::Proj;
use serde_json::json;

use super::{ExportError, check_consistent};
use crate::contour::ContourResult;

/// WGS84 semi-major axis (m) and flattening.
const WGS84_A: f64 = 6_378_137.0;
const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// Step (input units) of the central differences giving the projection's derivative.
const DERIVATIVE_STEP: f64 = 10.0;

/// Where the local frame sits on the Earth.
#[derive(Debug, Clone, PartialEq)]
pub struct EnuFrame {
    /// The origin in WGS84 degrees and metres above the ellipsoid (taken as the input's
    /// elevation: no geoid model is applied).
    pub lon_deg: f64,
    pub lat_deg: f64,
    pub height_m: f64,
    /// Column-major 4x4 matrix taking local (x east, y north, z up) input units to ECEF
    /// metres, as 3D Tiles' `transform` expects.
    pub matrix: [f64; 16],
}

impl EnuFrame {
    /// ECEF metres of a local position.
    pub fn apply(&self, local: DVec3) -> DVec3 {
        let m = &self.matrix;
        DVec3::new(
            m[0] * local.x + m[4] * local.y + m[8] * local.z + m[12],
            m[1] * local.x + m[5] * local.y + m[9] * local.z + m[13],
            m[2] * local.x + m[6] * local.y + m[10] * local.z + m[14],
        )
    }
}

/// ECEF metres of a WGS84 longitude, latitude (radians) and ellipsoidal height (m).
pub(crate) fn geodetic_to_ecef(lon: f64, lat: f64, height_m: f64) -> DVec3 {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let (sin_lat, cos_lat) = lat.sin_cos();
    let (sin_lon, cos_lon) = lon.sin_cos();
    let n = WGS84_A / (1.0 - e2 * sin_lat * sin_lat).sqrt();
    DVec3::new(
        (n + height_m) * cos_lat * cos_lon,
        (n + height_m) * cos_lat * sin_lon,
        (n * (1.0 - e2) + height_m) * sin_lat,
    )
}

/// Parses the CRS spellings users write: `EPSG:32633` (any case), OGC URNs and URLs
/// ending in the EPSG code, or a PROJ string (`+proj=utm +zone=33 ...`).
fn parse_crs(crs: &str) -> Result<Proj, ExportError> {
    let unknown = |reason: String| ExportError::UnknownCrs {
        crs: crs.to_owned(),
        reason,
    };
    let text = crs.trim();
    if text.starts_with('+') {
        return Proj::from_proj_string(text).map_err(|e| unknown(e.to_string()));
    }
    let lower = text.to_ascii_lowercase();
    let code = if let Some(rest) = lower.strip_prefix("epsg:") {
        rest
    } else if lower.contains("epsg") {
        lower.rsplit([':', '/']).next().unwrap_or("")
    } else {
        return Err(unknown(
            "expected EPSG:<code>, an OGC URN/URL with an EPSG code, or a PROJ string".into(),
        ));
    };
    let code: u16 = code
        .trim()
        .parse()
        .map_err(|_| unknown(format!("{code:?} is not an EPSG code")))?;
    Proj::from_epsg_code(code).map_err(|e| unknown(e.to_string()))
}

/// The frame placing local coordinates of a result whose origin is `origin` (input
/// coordinates) in `crs`.
pub fn enu_frame(origin: [f64; 3], crs: &str) -> Result<EnuFrame, ExportError> {
    let source = parse_crs(crs)?;
    if source.is_latlong() || source.is_geocent() {
        return Err(ExportError::GeographicCrs(crs.to_owned()));
    }
    let wgs84 = Proj::from_proj_string("+proj=longlat +datum=WGS84 +no_defs").map_err(|e| {
        ExportError::Projection {
            crs: crs.to_owned(),
            reason: e.to_string(),
        }
    })?;
    let vertical_to_m = source.to_meter();
    let height_m = origin[2] * vertical_to_m;
    let to_ecef = |x: f64, y: f64| -> Result<(f64, f64, DVec3), ExportError> {
        let mut point = (x, y, 0.0);
        proj4rs::transform::transform(&source, &wgs84, &mut point).map_err(|e| {
            ExportError::Projection {
                crs: crs.to_owned(),
                reason: format!("at ({x}, {y}): {e}"),
            }
        })?;
        let (lon, lat) = (point.0, point.1);
        if !lon.is_finite() || !lat.is_finite() {
            return Err(ExportError::Projection {
                crs: crs.to_owned(),
                reason: format!("({x}, {y}) is outside the projection's domain"),
            });
        }
        Ok((lon, lat, geodetic_to_ecef(lon, lat, height_m)))
    };
    let (lon, lat, centre) = to_ecef(origin[0], origin[1])?;
    let h = DERIVATIVE_STEP;
    let east =
        (to_ecef(origin[0] + h, origin[1])?.2 - to_ecef(origin[0] - h, origin[1])?.2) / (2.0 * h);
    let north =
        (to_ecef(origin[0], origin[1] + h)?.2 - to_ecef(origin[0], origin[1] - h)?.2) / (2.0 * h);
    let (sin_lat, cos_lat) = lat.sin_cos();
    let (sin_lon, cos_lon) = lon.sin_cos();
    let up = DVec3::new(cos_lat * cos_lon, cos_lat * sin_lon, sin_lat) * vertical_to_m;
    let matrix = [
        east.x, east.y, east.z, 0.0, //
        north.x, north.y, north.z, 0.0, //
        up.x, up.y, up.z, 0.0, //
        centre.x, centre.y, centre.z, 1.0,
    ];
    Ok(EnuFrame {
        lon_deg: lon.to_degrees(),
        lat_deg: lat.to_degrees(),
        height_m,
        matrix,
    })
}

/// Local bounds (x east, y north, z up) of everything the GLB may draw: bodies, wells and
/// samples; `None` when there is nothing.
fn local_bounds(result: &ContourResult) -> Option<[DVec3; 2]> {
    let bodies = result.shells.iter().flat_map(|s| &s.bodies);
    let points = bodies
        .flat_map(|b| b.positions.iter())
        .chain(result.samples.points.iter())
        .chain(result.samples.wells.iter().flat_map(|w| w.trace.iter()))
        .filter(|p| p.is_finite());
    points.fold(None, |acc, &p| match acc {
        None => Some([p, p]),
        Some([lo, hi]) => Some([lo.min(p), hi.max(p)]),
    })
}

/// A 3D Tiles 1.1 tileset with one tile whose content is the GLB at `content_uri`
/// (relative to the tileset). The root transform is [`enu_frame`]; 3D Tiles rotates glTF's
/// y-up into z-up itself, which turns the GLB's (east, up, -north) back into local
/// (east, north, up).
pub fn tileset_json(result: &ContourResult, content_uri: &str) -> Result<Vec<u8>, ExportError> {
    check_consistent(result)?;
    let summary = &result.summary;
    let crs = summary.crs.as_deref().ok_or(ExportError::NoCrs)?;
    let frame = enu_frame(summary.origin, crs)?;
    let [lo, hi] = local_bounds(result).unwrap_or([DVec3::ZERO, DVec3::ZERO]);
    let centre = (lo + hi) / 2.0;
    // A zero extent is a degenerate box; half a unit keeps it valid and tiny.
    let half = ((hi - lo) / 2.0).max(DVec3::splat(0.5));
    let scale = frame.matrix[0..3]
        .iter()
        .map(|v| v * v)
        .sum::<f64>()
        .sqrt()
        .max(1e-12);
    let geometric_error = 2.0 * half.length() * scale;
    let tileset = json!({
        "asset": {
            "version": "1.1",
            "generator": concat!("wellmesh ", env!("CARGO_PKG_VERSION")),
        },
        "geometricError": geometric_error,
        "root": {
            "transform": frame.matrix,
            "boundingVolume": {
                "box": [
                    centre.x, centre.y, centre.z,
                    half.x, 0.0, 0.0,
                    0.0, half.y, 0.0,
                    0.0, 0.0, half.z,
                ],
            },
            "geometricError": 0.0,
            "refine": "ADD",
            "content": { "uri": content_uri },
        },
        "extras": {
            "origin": summary.origin,
            "crs": crs,
            "unit": summary.unit,
            "origin_wgs84": [frame.lon_deg, frame.lat_deg, frame.height_m],
        },
    });
    let mut bytes = serde_json::to_vec_pretty(&tileset)?;
    bytes.push(b'\n');
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ecef_of_the_equator_and_the_pole() {
        let p = geodetic_to_ecef(0.0, 0.0, 0.0);
        assert!((p - DVec3::new(WGS84_A, 0.0, 0.0)).length() < 1e-6);
        let b = WGS84_A * (1.0 - WGS84_F);
        let q = geodetic_to_ecef(0.0, std::f64::consts::FRAC_PI_2, 100.0);
        assert!((q - DVec3::new(0.0, 0.0, b + 100.0)).length() < 1e-6);
    }

    #[test]
    fn crs_spellings() {
        for crs in [
            "EPSG:32633",
            "epsg:32633",
            "urn:ogc:def:crs:EPSG::32633",
            "http://www.opengis.net/def/crs/EPSG/0/32633",
            "+proj=utm +zone=33 +datum=WGS84 +units=m +no_defs",
        ] {
            assert!(parse_crs(crs).is_ok(), "{crs}");
        }
        assert!(matches!(
            parse_crs("EPSG:99999"),
            Err(ExportError::UnknownCrs { .. })
        ));
        assert!(matches!(
            parse_crs("local grid"),
            Err(ExportError::UnknownCrs { .. })
        ));
        assert!(matches!(
            enu_frame([10.0, 50.0, 0.0], "EPSG:4326"),
            Err(ExportError::GeographicCrs(_))
        ));
    }
}
