//! The GLB writer: glTF 2.0 binary, Y-up, positions relative to the local origin, built as
//! a typed glTF document (`gltf::json`) and packed by `gltf::binary`.
//!
//! Invariant: axes are (east, up, -north) = (local x, local z, -local y), a proper
//! rotation, so triangle winding (counter-clockwise from outside) is kept; each body is one
//! mesh of indexed triangles sharing vertices, exactly `Body::triangles` except where two
//! vertices round to one single-precision position (welded, [`welded_indices`]); every
//! figure in `extras` comes from the summary.

use std::borrow::Cow;

use glam::DVec3;
use gltf::binary::{Glb, Header};
use gltf::json::accessor::{ComponentType, GenericComponentType, Type};
use gltf::json::buffer::Target;
use gltf::json::material::{AlphaMode, PbrBaseColorFactor, PbrMetallicRoughness, StrengthFactor};
use gltf::json::mesh::{Mode, Primitive, Semantic};
use gltf::json::validation::Checked::Valid;
use gltf::json::validation::USize64;
use gltf::json::{self, Index};
use serde::Serialize;

use super::{ExportError, OutputOptions, body_name, check_consistent, shell_name};
use crate::contour::{ContourResult, ShellSummary, Summary};
use crate::dmt::{Body, Shell};
use crate::wells::SampleSet;

/// Opacity of shells that enclose a higher-threshold shell.
const OUTER_SHELL_ALPHA: f32 = 0.35;

/// A local (x east, y north, z up) position in glTF axes (east, up, -north).
fn to_gltf(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.z as f32, (-p.y) as f32]
}

/// The `extras` of a typed glTF object: `value` as raw JSON.
fn extras(value: &impl Serialize) -> Result<json::Extras, ExportError> {
    Ok(Some(serde_json::value::to_raw_value(value)?))
}

/// Figures of one body, on its node and its mesh.
#[derive(Serialize)]
struct BodyExtras<'a> {
    shell: usize,
    body: usize,
    threshold: f64,
    volume: f64,
    area: f64,
    closed: bool,
    truncated: bool,
    mt_fallback: bool,
    bbox: &'a [[f64; 3]; 2],
}

/// Figures of one shell, on its node.
#[derive(Serialize)]
struct ShellExtras {
    shell: usize,
    threshold: f64,
    volume: f64,
    area: f64,
    bodies: usize,
}

/// The georeference, on the scene.
#[derive(Serialize)]
struct SceneExtras<'a> {
    origin: [f64; 3],
    crs: &'a Option<String>,
    unit: &'a str,
    method: &'a str,
    axes: &'static str,
}

/// The hole ids, on the `drill holes` node.
#[derive(Serialize)]
struct TraceExtras<'a> {
    wells: Vec<&'a str>,
}

/// The sample count and value range, on the `samples` node (the range only when some
/// value is known).
#[derive(Serialize)]
struct SampleExtras {
    samples: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    value_min: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    value_max: Option<f64>,
}

/// The glTF document under construction and its binary chunk (buffer 0).
#[derive(Default)]
struct Document {
    root: json::Root,
    bin: Vec<u8>,
}

impl Document {
    /// Appends `data` to the binary chunk (4-byte aligned) as a new buffer view.
    fn view(&mut self, data: &[u8], target: Target) -> Index<json::buffer::View> {
        let offset = self.bin.len();
        self.bin.extend_from_slice(data);
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.root.push(json::buffer::View {
            buffer: Index::new(0),
            byte_length: USize64::from(data.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            target: Some(Valid(target)),
            name: None,
            extensions: None,
            extras: None,
        })
    }

    /// An accessor of `count` elements of `type_` over a new view of `data`.
    fn accessor(
        &mut self,
        data: &[u8],
        target: Target,
        component: ComponentType,
        type_: Type,
        count: usize,
        bounds: Option<([f32; 3], [f32; 3])>,
    ) -> Index<json::Accessor> {
        let view = self.view(data, target);
        let (min, max) = match bounds {
            Some((min, max)) => (Some(min.into()), Some(max.into())),
            None => (None, None),
        };
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(GenericComponentType(component)),
            type_: Valid(type_),
            min,
            max,
            normalized: false,
            sparse: None,
            name: None,
            extensions: None,
            extras: None,
        })
    }

    /// A VEC3 float accessor; `with_bounds` adds `min`/`max` (required for POSITION).
    fn vec3(&mut self, values: &[[f32; 3]], with_bounds: bool) -> Index<json::Accessor> {
        let data: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let bounds = with_bounds.then(|| {
            values.iter().fold(
                ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
                |(min, max), v| {
                    (
                        std::array::from_fn(|k| min[k].min(v[k])),
                        std::array::from_fn(|k| max[k].max(v[k])),
                    )
                },
            )
        });
        let (target, count) = (Target::ArrayBuffer, values.len());
        self.accessor(&data, target, ComponentType::F32, Type::Vec3, count, bounds)
    }

    /// A SCALAR unsigned-int index accessor.
    fn indices(&mut self, indices: &[u32]) -> Index<json::Accessor> {
        let data: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let (target, count) = (Target::ElementArrayBuffer, indices.len());
        self.accessor(&data, target, ComponentType::U32, Type::Scalar, count, None)
    }

    /// A matte material of `colour` (linear RGBA), blended when its alpha is below 1.
    fn material(
        &mut self,
        name: String,
        colour: [f32; 4],
        roughness: f32,
    ) -> Index<json::Material> {
        self.root.push(json::Material {
            name: Some(name),
            alpha_mode: Valid(if colour[3] < 1.0 {
                AlphaMode::Blend
            } else {
                AlphaMode::Opaque
            }),
            pbr_metallic_roughness: PbrMetallicRoughness {
                base_color_factor: PbrBaseColorFactor(colour),
                metallic_factor: StrengthFactor(0.0),
                roughness_factor: StrengthFactor(roughness),
                ..PbrMetallicRoughness::default()
            },
            ..json::Material::default()
        })
    }

    /// A mesh of one primitive.
    fn mesh(
        &mut self,
        name: String,
        primitive: Primitive,
        extras: json::Extras,
    ) -> Index<json::Mesh> {
        self.root.push(json::Mesh {
            name: Some(name),
            primitives: vec![primitive],
            weights: None,
            extensions: None,
            extras,
        })
    }

    /// The GLB: the document as the JSON chunk, then the binary chunk (left out when
    /// empty), each padded to 4 bytes.
    fn into_glb(mut self) -> Result<Vec<u8>, ExportError> {
        if !self.bin.is_empty() {
            self.root.push(json::Buffer {
                byte_length: USize64::from(self.bin.len()),
                uri: None,
                name: None,
                extensions: None,
                extras: None,
            });
        }
        let json = serde_json::to_vec(&self.root)?;
        let padded = |n: usize| n.next_multiple_of(4) as u64;
        let total = 12
            + 8
            + padded(json.len())
            + if self.bin.is_empty() {
                0
            } else {
                8 + padded(self.bin.len())
            };
        let length = u32::try_from(total).map_err(|_| ExportError::TooLarge(total))?;
        let glb = Glb {
            header: Header {
                magic: *b"glTF",
                version: 2,
                length,
            },
            json: Cow::Owned(json),
            bin: (!self.bin.is_empty()).then_some(Cow::Owned(self.bin)),
        };
        Ok(glb.to_vec()?)
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
    document(result, options)?.into_glb()
}

/// The glTF document of [`glb`] with its binary chunk.
fn document(result: &ContourResult, options: &OutputOptions) -> Result<Document, ExportError> {
    check_consistent(result)?;
    let mut doc = Document::default();
    let mut roots = add_shells(&mut doc, result)?;
    if options.well_traces {
        roots.extend(add_well_traces(&mut doc, &result.samples)?);
    }
    if options.well_samples {
        roots.extend(add_samples(&mut doc, &result.samples)?);
    }
    let scene = add_scene(&mut doc, &result.summary, roots)?;
    doc.root.scene = Some(scene);
    doc.root.asset = json::Asset {
        version: "2.0".to_owned(),
        generator: Some(concat!("wellmesh ", env!("CARGO_PKG_VERSION")).to_owned()),
        ..json::Asset::default()
    };
    Ok(doc)
}

/// One root node per shell that has bodies, with its material (coloured by the rank of its
/// threshold, translucent unless it is the highest) and one child node per body.
fn add_shells(
    doc: &mut Document,
    result: &ContourResult,
) -> Result<Vec<Index<json::Node>>, ExportError> {
    let mut ranked: Vec<(f64, usize)> = result
        .shells
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.bodies.is_empty())
        .map(|(i, s)| (s.threshold, i))
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    let shown = ranked.len();
    let mut roots = Vec::with_capacity(shown);
    for (s, (shell, shell_summary)) in result.shells.iter().zip(&result.summary.shells).enumerate()
    {
        if shell.bodies.is_empty() {
            continue;
        }
        let rank = ranked.iter().position(|&(_, i)| i == s).unwrap_or(0);
        let [r, g, b] = shell_colour(rank, shown).map(|c| c as f32);
        let alpha = if rank + 1 < shown {
            OUTER_SHELL_ALPHA
        } else {
            1.0
        };
        let material = doc.material(shell_name(s, shell.threshold), [r, g, b, alpha], 0.7);
        roots.push(add_shell(doc, s, shell, shell_summary, material)?);
    }
    Ok(roots)
}

/// Shell `s`'s node and its bodies' nodes and meshes.
fn add_shell(
    doc: &mut Document,
    s: usize,
    shell: &Shell,
    shell_summary: &ShellSummary,
    material: Index<json::Material>,
) -> Result<Index<json::Node>, ExportError> {
    let mut children = Vec::with_capacity(shell.bodies.len());
    for (i, (body, body_summary)) in shell.bodies.iter().zip(&shell_summary.bodies).enumerate() {
        let figures = BodyExtras {
            shell: s + 1,
            body: i + 1,
            threshold: shell.threshold,
            volume: body_summary.volume,
            area: body_summary.area,
            closed: body_summary.closed,
            truncated: body_summary.truncated,
            mt_fallback: body_summary.mt_fallback,
            bbox: &body_summary.bbox,
        };
        let name = body_name(s, shell.threshold, i);
        children.push(add_body(doc, name, body, &figures, material)?);
    }
    let figures = ShellExtras {
        shell: s + 1,
        threshold: shell.threshold,
        volume: shell_summary.volume,
        area: shell_summary.area,
        bodies: shell.bodies.len(),
    };
    Ok(doc.root.push(json::Node {
        name: Some(shell_name(s, shell.threshold)),
        children: Some(children),
        extras: extras(&figures)?,
        ..json::Node::default()
    }))
}

/// A body's node, with its mesh of indexed triangles (positions, normals) unless it has no
/// triangles: such a body keeps its node (and figures) but has nothing to draw.
fn add_body(
    doc: &mut Document,
    name: String,
    body: &Body,
    figures: &BodyExtras<'_>,
    material: Index<json::Material>,
) -> Result<Index<json::Node>, ExportError> {
    let positions: Vec<[f32; 3]> = body.positions.iter().map(|&p| to_gltf(p)).collect();
    let indices = welded_indices(&positions, &body.triangles);
    let mesh = if indices.is_empty() {
        None
    } else {
        let normals: Vec<[f32; 3]> = vertex_normals(&body.positions, &body.triangles)
            .into_iter()
            .map(to_gltf)
            .collect();
        let position = doc.vec3(&positions, true);
        let normal = doc.vec3(&normals, false);
        let index = doc.indices(&indices);
        let primitive = Primitive {
            attributes: [
                (Valid(Semantic::Positions), position),
                (Valid(Semantic::Normals), normal),
            ]
            .into(),
            indices: Some(index),
            material: Some(material),
            mode: Valid(Mode::Triangles),
            targets: None,
            extensions: None,
            extras: None,
        };
        Some(doc.mesh(name.clone(), primitive, extras(figures)?))
    };
    Ok(doc.root.push(json::Node {
        name: Some(name),
        mesh,
        extras: extras(figures)?,
        ..json::Node::default()
    }))
}

/// The triangles' indices with vertices that single precision cannot tell apart made one.
///
/// Two vertices of a body may lie closer than an `f32` step (a DMT vertex a few
/// micrometres from its neighbour, a kilometre from the origin); written as they are, a
/// reader that merges equal positions would find their edges shared by four triangles.
/// Every vertex is replaced by the first with the same `f32` position, and triangles left
/// with a repeated vertex (those on the collapsed edge) are dropped: an edge collapse,
/// which keeps a closed body closed. Bodies without such pairs are written unchanged.
fn welded_indices(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<u32> {
    let mut first: std::collections::HashMap<[u32; 3], u32> =
        std::collections::HashMap::with_capacity(positions.len());
    let mut remap: Vec<u32> = Vec::with_capacity(positions.len());
    let mut merged = false;
    for (i, p) in positions.iter().enumerate() {
        let key = p.map(|c| (c + 0.0).to_bits()); // +0.0 folds -0.0 into 0.0
        let kept = *first.entry(key).or_insert(i as u32);
        merged |= kept != i as u32;
        remap.push(kept);
    }
    if !merged {
        return triangles.iter().flatten().copied().collect();
    }
    triangles
        .iter()
        .map(|t| t.map(|v| remap[v as usize]))
        .filter(|[a, b, c]| a != b && b != c && a != c)
        .flatten()
        .collect()
}

/// The `drill holes` node: one LINES primitive of every finite trace with two or more
/// distinct stations; `None` when there is none.
fn add_well_traces(
    doc: &mut Document,
    samples: &SampleSet,
) -> Result<Option<Index<json::Node>>, ExportError> {
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
        ids.push(well.id.as_str());
    }
    if indices.is_empty() {
        return Ok(None);
    }
    let name = "drill holes";
    let material = doc.material(name.to_owned(), [0.6, 0.6, 0.55, 1.0], 1.0);
    let position = doc.vec3(&positions, true);
    let index = doc.indices(&indices);
    let primitive = Primitive {
        attributes: [(Valid(Semantic::Positions), position)].into(),
        indices: Some(index),
        material: Some(material),
        mode: Valid(Mode::Lines),
        targets: None,
        extensions: None,
        extras: None,
    };
    let mesh = doc.mesh(name.to_owned(), primitive, None);
    Ok(Some(doc.root.push(json::Node {
        name: Some(name.to_owned()),
        mesh: Some(mesh),
        extras: extras(&TraceExtras { wells: ids })?,
        ..json::Node::default()
    })))
}

/// The `samples` node: one POINTS primitive of every finite sample, coloured by its value;
/// `None` when there is none.
fn add_samples(
    doc: &mut Document,
    samples: &SampleSet,
) -> Result<Option<Index<json::Node>>, ExportError> {
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
    if positions.is_empty() {
        return Ok(None);
    }
    let name = "samples";
    let material = doc.material(name.to_owned(), [1.0; 4], 1.0);
    let position = doc.vec3(&positions, true);
    let colour = doc.vec3(&colours, false);
    let primitive = Primitive {
        attributes: [
            (Valid(Semantic::Positions), position),
            (Valid(Semantic::Colors(0)), colour),
        ]
        .into(),
        indices: None,
        material: Some(material),
        mode: Valid(Mode::Points),
        targets: None,
        extensions: None,
        extras: None,
    };
    let mesh = doc.mesh(name.to_owned(), primitive, None);
    let range = min <= max;
    let figures = SampleExtras {
        samples: positions.len(),
        value_min: range.then_some(min),
        value_max: range.then_some(max),
    };
    Ok(Some(doc.root.push(json::Node {
        name: Some(name.to_owned()),
        mesh: Some(mesh),
        extras: extras(&figures)?,
        ..json::Node::default()
    })))
}

/// The one scene, holding the root `nodes`, with the georeference in its extras.
fn add_scene(
    doc: &mut Document,
    summary: &Summary,
    nodes: Vec<Index<json::Node>>,
) -> Result<Index<json::Scene>, ExportError> {
    let georeference = SceneExtras {
        origin: summary.origin,
        crs: &summary.crs,
        unit: &summary.unit,
        method: &summary.method,
        axes: "x east, y up, z south (local, relative to origin)",
    };
    Ok(doc.root.push(json::Scene {
        name: Some("wellmesh".to_owned()),
        nodes,
        extras: extras(&georeference)?,
        extensions: None,
    }))
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

    /// Each undirected edge and how many triangles hold it.
    fn edge_counts(indices: &[u32]) -> std::collections::HashMap<(u32, u32), usize> {
        let mut out = std::collections::HashMap::new();
        for t in indices.chunks(3) {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *out.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        out
    }

    /// An octahedron whose edge 0-1 is split by a vertex a nanometre from vertex 0, a
    /// kilometre from the origin: closed in double precision, one position in single. The
    /// welded triangles are the octahedron's again, every edge held by two of them.
    #[test]
    fn vertices_single_precision_cannot_tell_apart_are_welded() {
        let o = DVec3::new(1000.0, 2000.0, 500.0);
        let mut p: Vec<DVec3> = [
            DVec3::X,
            DVec3::Y,
            DVec3::NEG_X,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::NEG_Z,
        ]
        .iter()
        .map(|v| o + *v)
        .collect();
        p.push(p[0] + (p[1] - p[0]) * 1e-9);
        // Octahedron faces around the top (4) and bottom (5), with 0-1 split at 6.
        let triangles: Vec<[u32; 3]> = vec![
            [0, 6, 4],
            [6, 1, 4],
            [1, 2, 4],
            [2, 3, 4],
            [3, 0, 4],
            [6, 0, 5],
            [1, 6, 5],
            [2, 1, 5],
            [3, 2, 5],
            [0, 3, 5],
        ];
        let before: Vec<u32> = triangles.iter().flatten().copied().collect();
        assert!(edge_counts(&before).values().all(|&c| c == 2));
        let positions: Vec<[f32; 3]> = p.iter().map(|&q| to_gltf(q)).collect();
        assert_eq!(positions[0], positions[6]);
        let welded = welded_indices(&positions, &triangles);
        assert_eq!(welded.len(), 8 * 3);
        assert!(!welded.contains(&6));
        let counts = edge_counts(&welded);
        assert_eq!(counts.len(), 12);
        assert!(counts.values().all(|&c| c == 2), "{counts:?}");
        // Without such a pair, the indices are the triangles' own.
        let apart: Vec<[f32; 3]> = p[..6].iter().map(|&q| to_gltf(q)).collect();
        let octahedron = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        let same: Vec<u32> = octahedron.iter().flatten().copied().collect();
        assert_eq!(welded_indices(&apart, &octahedron), same);
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
