//! The GLB writer: glTF 2.0 binary, Y-up, positions relative to the local origin.
//!
//! Invariant: axes are (east, up, -north) = (local x, local z, -local y), a proper
//! rotation, so triangle winding (counter-clockwise from outside) is kept; each body is one
//! mesh of indexed triangles sharing vertices, exactly `Body::triangles`; every figure in
//! `extras` comes from the summary.

use glam::DVec3;
use serde_json::{Map, Value, json};

use super::{ExportError, OutputOptions, body_name, check_consistent, shell_name};
use crate::contour::ContourResult;

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const MODE_POINTS: u32 = 0;
const MODE_LINES: u32 = 1;
const MODE_TRIANGLES: u32 = 4;

/// Opacity of shells that enclose a higher-threshold shell.
const OUTER_SHELL_ALPHA: f64 = 0.35;

/// A local (x east, y north, z up) position in glTF axes (east, up, -north).
fn to_gltf(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.z as f32, (-p.y) as f32]
}

/// The binary chunk under construction and the JSON arrays describing it.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    buffer_views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// Appends `data` as a new buffer view (4-byte aligned) and returns its index.
    fn view(&mut self, data: &[u8], target: u32) -> usize {
        let offset = self.bin.len();
        self.bin.extend_from_slice(data);
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.buffer_views.push(json!({
            "buffer": 0,
            "byteOffset": offset,
            "byteLength": data.len(),
            "target": target,
        }));
        self.buffer_views.len() - 1
    }

    /// A VEC3 float accessor; `with_bounds` adds `min`/`max` (required for POSITION).
    fn vec3(&mut self, values: &[[f32; 3]], with_bounds: bool) -> usize {
        let mut data = Vec::with_capacity(values.len() * 12);
        for v in values {
            for c in v {
                data.extend_from_slice(&c.to_le_bytes());
            }
        }
        let view = self.view(&data, ARRAY_BUFFER);
        let mut accessor = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": values.len(),
            "type": "VEC3",
        });
        if with_bounds {
            let mut min = [f32::INFINITY; 3];
            let mut max = [f32::NEG_INFINITY; 3];
            for v in values {
                for k in 0..3 {
                    min[k] = min[k].min(v[k]);
                    max[k] = max[k].max(v[k]);
                }
            }
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// A SCALAR unsigned-int index accessor.
    fn indices(&mut self, indices: &[u32]) -> usize {
        let mut data = Vec::with_capacity(indices.len() * 4);
        for i in indices {
            data.extend_from_slice(&i.to_le_bytes());
        }
        let view = self.view(&data, ELEMENT_ARRAY_BUFFER);
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": UNSIGNED_INT,
            "count": indices.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }
}

/// Unit vertex normals: the area-weighted mean of the adjacent faces' normals; a vertex
/// whose faces cancel out (or that no face uses) points away from the body's centre.
pub(crate) fn vertex_normals(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<DVec3> {
    let mut sums = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            sums[i as usize] += n;
        }
    }
    let centre = if positions.is_empty() {
        DVec3::ZERO
    } else {
        positions.iter().sum::<DVec3>() / positions.len() as f64
    };
    sums.iter()
        .zip(positions)
        .map(|(&n, &p)| {
            n.try_normalize()
                .or_else(|| (p - centre).try_normalize())
                .unwrap_or(DVec3::Z)
        })
        .collect()
}

/// sRGB-ish ramp from pale yellow (lowest threshold) to deep red (highest), as linear
/// glTF base colours.
fn shell_colour(rank: usize, count: usize) -> [f64; 3] {
    let t = if count > 1 {
        rank as f64 / (count - 1) as f64
    } else {
        1.0
    };
    let low = [0.95, 0.80, 0.20];
    let high = [0.75, 0.08, 0.05];
    [0, 1, 2].map(|k| low[k] + (high[k] - low[k]) * t)
}

/// Blue (low) to red (high) ramp for sample values; grey for "don't know".
fn sample_colour(value: Option<f64>, min: f64, max: f64) -> [f32; 3] {
    match value {
        None => [0.5, 0.5, 0.5],
        Some(v) => {
            let t = if max > min {
                ((v - min) / (max - min)).clamp(0.0, 1.0)
            } else {
                1.0
            };
            [t as f32, 0.15, (1.0 - t) as f32]
        }
    }
}

/// The GLB of a result: one node per shell (that has bodies) with one child node and mesh
/// per body, plus optional `drill holes` (LINES) and `samples` (POINTS) nodes.
pub fn glb(result: &ContourResult, options: &OutputOptions) -> Result<Vec<u8>, ExportError> {
    check_consistent(result)?;
    let summary = &result.summary;
    let mut b = Builder::default();
    let mut nodes: Vec<Value> = Vec::new();
    let mut meshes: Vec<Value> = Vec::new();
    let mut materials: Vec<Value> = Vec::new();
    let mut roots: Vec<usize> = Vec::new();

    // Shells with bodies get a material, coloured by their threshold's rank.
    let mut ranked: Vec<(f64, usize)> = result
        .shells
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.bodies.is_empty())
        .map(|(i, s)| (s.threshold, i))
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    let shown = ranked.len();

    for (s, (shell, shell_summary)) in result.shells.iter().zip(&summary.shells).enumerate() {
        if shell.bodies.is_empty() {
            continue;
        }
        let rank = ranked.iter().position(|&(_, i)| i == s).unwrap_or(0);
        let colour = shell_colour(rank, shown);
        let translucent = rank + 1 < shown;
        let alpha = if translucent { OUTER_SHELL_ALPHA } else { 1.0 };
        let mut material = json!({
            "name": shell_name(s, shell.threshold),
            "pbrMetallicRoughness": {
                "baseColorFactor": [colour[0], colour[1], colour[2], alpha],
                "metallicFactor": 0.0,
                "roughnessFactor": 0.7,
            },
        });
        if translucent {
            material["alphaMode"] = json!("BLEND");
        }
        materials.push(material);
        let material_index = materials.len() - 1;

        let mut children = Vec::with_capacity(shell.bodies.len());
        for (i, (body, body_summary)) in shell.bodies.iter().zip(&shell_summary.bodies).enumerate()
        {
            let positions: Vec<[f32; 3]> = body.positions.iter().map(|&p| to_gltf(p)).collect();
            let normals: Vec<[f32; 3]> = vertex_normals(&body.positions, &body.triangles)
                .into_iter()
                .map(to_gltf)
                .collect();
            let indices: Vec<u32> = body.triangles.iter().flatten().copied().collect();
            let name = body_name(s, shell.threshold, i);
            let extras = json!({
                "shell": s + 1,
                "body": i + 1,
                "threshold": shell.threshold,
                "volume": body_summary.volume,
                "area": body_summary.area,
                "closed": body_summary.closed,
                "truncated": body_summary.truncated,
                "mt_fallback": body_summary.mt_fallback,
                "bbox": body_summary.bbox,
            });
            let mut node = json!({ "name": name, "extras": extras });
            // A body without triangles keeps its node (and figures) but has nothing to draw.
            if !indices.is_empty() {
                let position = b.vec3(&positions, true);
                let normal = b.vec3(&normals, false);
                let index = b.indices(&indices);
                meshes.push(json!({
                    "name": name,
                    "primitives": [{
                        "attributes": { "POSITION": position, "NORMAL": normal },
                        "indices": index,
                        "mode": MODE_TRIANGLES,
                        "material": material_index,
                    }],
                    "extras": extras,
                }));
                node["mesh"] = json!(meshes.len() - 1);
            }
            nodes.push(node);
            children.push(nodes.len() - 1);
        }
        nodes.push(json!({
            "name": shell_name(s, shell.threshold),
            "children": children,
            "extras": {
                "shell": s + 1,
                "threshold": shell.threshold,
                "volume": shell_summary.volume,
                "area": shell_summary.area,
                "bodies": shell.bodies.len(),
            },
        }));
        roots.push(nodes.len() - 1);
    }

    let samples = &result.samples;
    if options.well_traces {
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        let mut ids = Vec::new();
        for well in &samples.wells {
            if well.trace.iter().any(|p| !p.is_finite()) {
                continue;
            }
            // Repeated stations would make zero-length segments.
            let mut trace: Vec<[f32; 3]> = well.trace.iter().map(|&p| to_gltf(p)).collect();
            trace.dedup();
            if trace.len() < 2 {
                continue;
            }
            let first = positions.len() as u32;
            for k in 1..trace.len() as u32 {
                indices.extend([first + k - 1, first + k]);
            }
            positions.extend(trace);
            ids.push(well.id.clone());
        }
        if !indices.is_empty() {
            materials.push(json!({
                "name": "drill holes",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [0.6, 0.6, 0.55, 1.0],
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0,
                },
            }));
            let position = b.vec3(&positions, true);
            let index = b.indices(&indices);
            meshes.push(json!({
                "name": "drill holes",
                "primitives": [{
                    "attributes": { "POSITION": position },
                    "indices": index,
                    "mode": MODE_LINES,
                    "material": materials.len() - 1,
                }],
            }));
            nodes.push(json!({
                "name": "drill holes",
                "mesh": meshes.len() - 1,
                "extras": { "wells": ids },
            }));
            roots.push(nodes.len() - 1);
        }
    }
    if options.well_samples {
        let known = samples
            .values
            .iter()
            .flatten()
            .copied()
            .filter(|v| v.is_finite());
        let (min, max) = known.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        let mut positions = Vec::new();
        let mut colours = Vec::new();
        for (p, v) in samples.points.iter().zip(&samples.values) {
            if !p.is_finite() {
                continue;
            }
            positions.push(to_gltf(*p));
            colours.push(sample_colour(v.filter(|v| v.is_finite()), min, max));
        }
        if !positions.is_empty() {
            materials.push(json!({
                "name": "samples",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0,
                },
            }));
            let position = b.vec3(&positions, true);
            let colour = b.vec3(&colours, false);
            meshes.push(json!({
                "name": "samples",
                "primitives": [{
                    "attributes": { "POSITION": position, "COLOR_0": colour },
                    "mode": MODE_POINTS,
                    "material": materials.len() - 1,
                }],
            }));
            let mut extras = json!({ "samples": positions.len() });
            if min <= max {
                extras["value_min"] = json!(min);
                extras["value_max"] = json!(max);
            }
            nodes.push(json!({
                "name": "samples",
                "mesh": meshes.len() - 1,
                "extras": extras,
            }));
            roots.push(nodes.len() - 1);
        }
    }

    let mut root = Map::new();
    root.insert(
        "asset".into(),
        json!({ "version": "2.0", "generator": concat!("wellmesh ", env!("CARGO_PKG_VERSION")) }),
    );
    root.insert("scene".into(), json!(0));
    root.insert(
        "scenes".into(),
        json!([{
            "name": "wellmesh",
            "nodes": roots,
            "extras": {
                "origin": summary.origin,
                "crs": summary.crs,
                "unit": summary.unit,
                "method": summary.method,
                "axes": "x east, y up, z south (local, relative to origin)",
            },
        }]),
    );
    for (key, array) in [
        ("nodes", nodes),
        ("meshes", meshes),
        ("materials", materials),
        ("accessors", b.accessors),
        ("bufferViews", b.buffer_views),
    ] {
        if !array.is_empty() {
            root.insert(key.into(), Value::Array(array));
        }
    }
    if !b.bin.is_empty() {
        root.insert("buffers".into(), json!([{ "byteLength": b.bin.len() }]));
    }
    let mut json_chunk = serde_json::to_vec(&Value::Object(root))?;
    while !json_chunk.len().is_multiple_of(4) {
        json_chunk.push(b' ');
    }
    let bin_chunk = b.bin;
    let total = 12
        + 8
        + json_chunk.len() as u64
        + if bin_chunk.is_empty() {
            0
        } else {
            8 + bin_chunk.len() as u64
        };
    let total_u32 = u32::try_from(total).map_err(|_| ExportError::TooLarge(total))?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total_u32.to_le_bytes());
    out.extend_from_slice(&(json_chunk.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_chunk);
    if !bin_chunk.is_empty() {
        out.extend_from_slice(&(bin_chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin_chunk);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gltf_axes_are_a_proper_rotation() {
        // east stays x, up becomes y, north becomes -z.
        assert_eq!(to_gltf(DVec3::new(1.0, 2.0, 3.0)), [1.0, 3.0, -2.0]);
        let ex = DVec3::from(to_gltf(DVec3::X).map(f64::from));
        let ey = DVec3::from(to_gltf(DVec3::Y).map(f64::from));
        let ez = DVec3::from(to_gltf(DVec3::Z).map(f64::from));
        assert_eq!(ex.cross(ey).dot(ez), 1.0);
    }

    #[test]
    fn normals_of_a_tetrahedron_point_outwards_and_have_unit_length() {
        let positions = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        // Counter-clockwise seen from outside.
        let triangles = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let centre = positions.iter().sum::<DVec3>() / 4.0;
        for (p, n) in positions.iter().zip(vertex_normals(&positions, &triangles)) {
            assert!((n.length() - 1.0).abs() < 1e-12);
            assert!(n.dot(*p - centre) > 0.0);
        }
    }
}
