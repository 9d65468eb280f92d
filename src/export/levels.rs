//! Level plans: the bodies cut by horizontal planes into polygons with holes, written as
//! GeoJSON in the input's coordinates.
//!
//! Invariant: a vertex exactly on a level counts as above it (symbolic perturbation), so
//! every cut crosses edges between a vertex strictly below and one on or above, each such
//! edge yields one point shared by the two triangles around it, and the cut of a closed,
//! outward-oriented body is a set of closed rings: counter-clockwise outer rings and
//! clockwise holes seen from above (RFC 7946's winding).

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use serde_json::{Value, json};

use super::{ExportError, check_consistent};
use crate::contour::ContourResult;

/// The elevations at which level plans are cut.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Levels {
    /// Round elevations (steps of 1, 2 or 5 times a power of ten) giving about ten plans
    /// across the bodies' vertical extent.
    #[default]
    Automatic,
    /// These elevations, in input units (the same vertical datum as the samples' z).
    At(Vec<f64>),
}

/// About this many automatic levels span the bodies.
const AUTOMATIC_LEVELS: f64 = 10.0;

/// Closed rings (local x, y) where the plane `z = level_z` (local) cuts a closed,
/// outward-oriented triangle mesh. Outer boundaries are counter-clockwise, holes clockwise
/// (seen from above). Chains that do not close (open meshes) are left out.
///
/// Shapes: `positions` #V, `triangles` #F by 3 indices, counter-clockwise from outside.
pub fn level_rings(positions: &[DVec3], triangles: &[[u32; 3]], level_z: f64) -> Vec<Vec<DVec2>> {
    let above = |i: u32| positions[i as usize].z >= level_z;
    let key = |a: u32, b: u32| if a < b { (a, b) } else { (b, a) };
    // Segment from the crossing on one edge to the crossing on the next, interior on the left.
    let mut next: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    let mut starts: Vec<(u32, u32)> = Vec::new();
    for t in triangles {
        let Some(k) = (0..3).find(|&k| {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            above(a) != above(b) && above(b) == above(c)
        }) else {
            continue;
        };
        let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        let (from, to) = if above(a) {
            (key(a, b), key(c, a))
        } else {
            (key(c, a), key(a, b))
        };
        if next.insert(from, to).is_none() {
            starts.push(from);
        }
    }
    let crossing = |(i, j): (u32, u32)| -> DVec2 {
        let (p, q) = (positions[i as usize], positions[j as usize]);
        let (low, high) = if p.z < q.z { (p, q) } else { (q, p) };
        let t = (level_z - low.z) / (high.z - low.z);
        let x = low + (high - low) * t;
        DVec2::new(x.x, x.y)
    };
    let mut rings = Vec::new();
    let mut used: HashMap<(u32, u32), ()> = HashMap::new();
    for start in starts {
        if used.contains_key(&start) {
            continue;
        }
        let mut ring: Vec<DVec2> = Vec::new();
        let mut edge = start;
        let closed = loop {
            if used.insert(edge, ()).is_some() {
                break edge == start;
            }
            let p = crossing(edge);
            if ring.last() != Some(&p) {
                ring.push(p);
            }
            match next.get(&edge) {
                Some(&e) => edge = e,
                None => break false,
            }
        };
        if ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
        if closed && ring.len() >= 3 && signed_area(&ring) != 0.0 {
            rings.push(ring);
        }
    }
    rings
}

/// Shoelace area, positive for counter-clockwise rings.
pub(crate) fn signed_area(ring: &[DVec2]) -> f64 {
    let n = ring.len();
    let o = ring[0];
    (1..n.saturating_sub(1))
        .map(|i| (ring[i] - o).perp_dot(ring[i + 1] - o))
        .sum::<f64>()
        / 2.0
}

/// Even-odd point-in-polygon test.
fn contains(ring: &[DVec2], p: DVec2) -> bool {
    let mut inside = false;
    let mut j = ring.len() - 1;
    for i in 0..ring.len() {
        let (a, b) = (ring[i], ring[j]);
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// Groups rings into polygons: each clockwise ring (hole) goes into the smallest
/// counter-clockwise ring containing it. Returns (outer, holes) pairs.
fn polygons(rings: Vec<Vec<DVec2>>) -> Vec<(Vec<DVec2>, Vec<Vec<DVec2>>)> {
    let (outers, holes): (Vec<_>, Vec<_>) = rings.into_iter().partition(|r| signed_area(r) > 0.0);
    let mut result: Vec<(Vec<DVec2>, Vec<Vec<DVec2>>)> =
        outers.into_iter().map(|r| (r, Vec::new())).collect();
    for hole in holes {
        let probe = hole[0];
        let owner = result
            .iter()
            .enumerate()
            .filter(|(_, (outer, _))| contains(outer, probe))
            .min_by(|(_, (a, _)), (_, (b, _))| signed_area(a).total_cmp(&signed_area(b)))
            .map(|(i, _)| i);
        if let Some(i) = owner {
            result[i].1.push(hole);
        }
    }
    result
}

/// Round levels across `[z_min, z_max]`, strictly inside.
fn automatic_levels(z_min: f64, z_max: f64) -> Vec<f64> {
    let span = z_max - z_min;
    if !span.is_finite() || span <= 0.0 {
        return Vec::new();
    }
    let raw = span / AUTOMATIC_LEVELS;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * magnitude);
    let mut levels = Vec::new();
    let mut k = (z_min / step).floor() + 1.0;
    while k * step < z_max {
        if k * step > z_min {
            levels.push(k * step);
        }
        k += 1.0;
    }
    levels
}

/// `urn:ogc:def:crs:EPSG::32633` for `EPSG:32633`; other spellings unchanged.
fn crs_urn(crs: &str) -> String {
    match crs.trim().split_once(':') {
        Some((authority, code)) if authority.eq_ignore_ascii_case("epsg") => {
            format!("urn:ogc:def:crs:EPSG::{}", code.trim())
        }
        _ => crs.to_owned(),
    }
}

/// GeoJSON level plans: one Polygon feature (with its holes) per body, level and piece,
/// in input coordinates `[x, y, z]`, with properties `shell`, `body`, `threshold`,
/// `level`, `area`. The CRS is named in a `crs` member (GeoJSON 2008, read by GDAL/QGIS),
/// since the coordinates are not WGS84.
pub fn geojson_levels(result: &ContourResult, levels: &Levels) -> Result<Vec<u8>, ExportError> {
    check_consistent(result)?;
    let origin = DVec3::from(result.summary.origin);
    let levels: Vec<f64> = match levels {
        Levels::At(levels) => {
            if let Some(&bad) = levels.iter().find(|l| !l.is_finite()) {
                return Err(ExportError::BadLevel(bad));
            }
            levels.clone()
        }
        Levels::Automatic => {
            let (lo, hi) = result
                .shells
                .iter()
                .flat_map(|s| &s.bodies)
                .flat_map(|b| &b.positions)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p.z), hi.max(p.z))
                });
            automatic_levels(lo + origin.z, hi + origin.z)
        }
    };
    let mut features = Vec::new();
    for (s, shell) in result.shells.iter().enumerate() {
        for (b, body) in shell.bodies.iter().enumerate() {
            for &level in &levels {
                let local_z = level - origin.z;
                if body.bbox[0].z > local_z || body.bbox[1].z < local_z {
                    continue;
                }
                let rings = level_rings(&body.positions, &body.triangles, local_z);
                for (outer, holes) in polygons(rings) {
                    let area =
                        signed_area(&outer) + holes.iter().map(|h| signed_area(h)).sum::<f64>();
                    let coordinates: Vec<Value> = std::iter::once(&outer)
                        .chain(&holes)
                        .map(|ring| {
                            let mut pts: Vec<[f64; 3]> = ring
                                .iter()
                                .map(|p| [p.x + origin.x, p.y + origin.y, level])
                                .collect();
                            pts.push(pts[0]);
                            json!(pts)
                        })
                        .collect();
                    features.push(json!({
                        "type": "Feature",
                        "properties": {
                            "shell": s + 1,
                            "body": b + 1,
                            "threshold": shell.threshold,
                            "level": level,
                            "area": area,
                        },
                        "geometry": { "type": "Polygon", "coordinates": coordinates },
                    }));
                }
            }
        }
    }
    let mut collection = json!({
        "type": "FeatureCollection",
        "name": "wellmesh level plans",
        "levels": levels,
        "features": features,
    });
    if let Some(crs) = &result.summary.crs {
        collection["crs"] = json!({ "type": "name", "properties": { "name": crs_urn(crs) } });
    }
    let mut bytes = serde_json::to_vec(&collection)?;
    bytes.push(b'\n');
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube [0,1]^3 with a vertex exactly on the cutting plane z = 0 or 1.
    fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let p = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        // Counter-clockwise from outside.
        let quads = [
            [0, 2, 3, 1], // bottom (z=0), normal -z
            [4, 5, 7, 6], // top, +z
            [0, 1, 5, 4], // y=0, -y
            [2, 6, 7, 3], // y=1, +y
            [0, 4, 6, 2], // x=0, -x
            [1, 3, 7, 5], // x=1, +x
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (p, t)
    }

    #[test]
    fn a_cube_cut_in_the_middle_is_one_counter_clockwise_unit_square() {
        let (p, t) = cube();
        let rings = level_rings(&p, &t, 0.5);
        assert_eq!(rings.len(), 1);
        assert!((signed_area(&rings[0]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_cut_through_vertices_counts_them_above() {
        let (p, t) = cube();
        // z = 0: the bottom face's vertices are "above", nothing is below: no ring.
        assert!(level_rings(&p, &t, 0.0).is_empty());
        // z = 1: the top vertices are above, the bottom below: a unit square at the top.
        let rings = level_rings(&p, &t, 1.0);
        assert_eq!(rings.len(), 1);
        assert!((signed_area(&rings[0]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn automatic_levels_are_round_and_inside() {
        assert_eq!(
            automatic_levels(103.0, 151.0),
            vec![
                105.0, 110.0, 115.0, 120.0, 125.0, 130.0, 135.0, 140.0, 145.0, 150.0
            ]
        );
        assert!(automatic_levels(5.0, 5.0).is_empty());
    }

    #[test]
    fn holes_go_into_the_ring_around_them() {
        let square = |h: f64, ccw: bool| {
            let mut r = vec![
                DVec2::new(-h, -h),
                DVec2::new(h, -h),
                DVec2::new(h, h),
                DVec2::new(-h, h),
            ];
            if !ccw {
                r.reverse();
            }
            r
        };
        let polys = polygons(vec![
            square(1.0, false),
            square(3.0, true),
            square(10.0, true),
        ]);
        assert_eq!(polys.len(), 2);
        let (outer, holes) = polys.iter().find(|(_, h)| !h.is_empty()).unwrap();
        assert!((signed_area(outer) - 36.0).abs() < 1e-12);
        assert_eq!(holes.len(), 1);
    }
}
