//! The description of the `dmt-contour` process (OGC API - Processes Part 1): what it
//! does, its inputs and outputs, with links.
//!
//! Invariant: the input descriptions are generated from the [`ProcessInputs`] schema, the
//! same one the OpenAPI document and the request parser use, so they cannot drift apart.

use std::collections::BTreeMap;

use serde::Serialize;
use utoipa::ToSchema;

use super::ProcessInputs;

pub const PROCESS_ID: &str = "dmt-contour";

/// A link (OGC API - Common).
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema)]
pub struct Link {
    pub href: String,
    pub rel: String,
    #[serde(rename = "type", skip_serializing_if = "Option::is_none")]
    pub media_type: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
}

impl Link {
    pub fn new(href: impl Into<String>, rel: &str, media_type: &str, title: &str) -> Self {
        Link {
            href: href.into(),
            rel: rel.to_string(),
            media_type: Some(media_type.to_string()),
            title: Some(title.to_string()),
        }
    }
}

/// A process in the list.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ProcessSummary {
    pub id: String,
    pub title: String,
    pub description: String,
    pub version: String,
    #[serde(rename = "jobControlOptions")]
    pub job_control_options: Vec<String>,
    #[serde(rename = "outputTransmission")]
    pub output_transmission: Vec<String>,
    pub links: Vec<Link>,
}

/// One input of a process description.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct InputDescription {
    pub title: String,
    pub description: String,
    /// JSON Schema of the input's value.
    #[schema(value_type = Object)]
    pub schema: serde_json::Value,
    #[serde(rename = "minOccurs")]
    pub min_occurs: u32,
    #[serde(rename = "maxOccurs")]
    pub max_occurs: u32,
}

/// One output of a process description.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct OutputDescription {
    pub title: String,
    pub description: String,
    #[schema(value_type = Object)]
    pub schema: serde_json::Value,
}

/// `GET /processes/dmt-contour`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ProcessDescription {
    #[serde(flatten)]
    pub summary: ProcessSummary,
    pub inputs: BTreeMap<String, InputDescription>,
    pub outputs: BTreeMap<String, OutputDescription>,
}

pub fn process_summary() -> ProcessSummary {
    ProcessSummary {
        id: PROCESS_ID.to_string(),
        title: "Closed ore bodies from wells (Dual Marching Tetrahedra)".to_string(),
        description: "Tetrahedralizes the samples of wells or drill holes (exact 3D Delaunay) \
             and extracts one closed, oriented surface per threshold with Dual Marching \
             Tetrahedra; returns a summary (volumes, areas, bodies) and a glTF model."
            .to_string(),
        version: env!("CARGO_PKG_VERSION").to_string(),
        job_control_options: vec![
            "sync-execute".to_string(),
            "async-execute".to_string(),
            "dismiss".to_string(),
        ],
        output_transmission: vec!["value".to_string(), "reference".to_string()],
        links: vec![
            Link::new(
                format!("/processes/{PROCESS_ID}"),
                "self",
                "application/json",
                "process description",
            ),
            Link::new(
                format!("/processes/{PROCESS_ID}/execution"),
                "http://www.opengis.net/def/rel/ogc/1.0/execute",
                "application/json",
                "execute",
            ),
        ],
    }
}

/// The title of each execute input, by name; every input of [`ProcessInputs`] has one
/// (a test checks it).
const TITLES: &[(&str, &str)] = &[
    ("wells", "Wells JSON"),
    ("samples_csv", "Samples CSV"),
    ("collars_csv", "Collar table"),
    ("surveys_csv", "Survey table"),
    ("intervals_csv", "Interval table"),
    ("variable", "Variable"),
    ("inside", "Inside codes"),
    ("composite_length", "Composite length"),
    ("crs", "CRS"),
    ("unit", "Length unit"),
    ("thresholds", "Thresholds"),
    ("method", "Vertex placement"),
    ("lattice", "Curvature lattice"),
    ("unknown", "Don't-know samples"),
    ("anisotropy", "Anisotropy"),
    ("azimuth", "Anisotropy azimuth"),
    ("dip", "Anisotropy dip"),
    ("min_volume", "Minimum body volume"),
    ("simplify", "Simplification tolerance"),
    ("relax", "Shape relaxation sweeps"),
    ("density", "Density"),
    ("density_column", "Density column"),
    ("grade_tonnage", "Grade–tonnage cut-offs"),
    ("cross_validate", "Cross-validation folds"),
    ("interpolant", "Interpolant"),
    ("ranges", "Model ranges"),
    ("orientation", "Model orientation"),
    ("sill", "Sill"),
    ("nugget", "Nugget"),
    ("spheroidal_order", "Spheroidal order"),
    ("transform", "Value transform"),
    ("flag_field", "Flag field"),
    ("shape_from", "How the shape is found"),
    ("orientation_field", "Orientations that vary in space"),
    ("top_cut", "Top-cut"),
    ("resolution", "Infill resolution"),
    ("max_samples", "Samples per kriging block"),
    (
        "max_samples_near",
        "Samples per kriging block near a threshold",
    ),
    ("max_per_hole", "Samples per hole per block"),
    ("well_traces", "Drill-hole traces"),
    ("well_samples", "Samples"),
];

/// The inputs' descriptions, read from the [`ProcessInputs`] schema: one per property,
/// its description moved out of the schema, required ones with `minOccurs` 1.
fn input_descriptions() -> BTreeMap<String, InputDescription> {
    let schema = <ProcessInputs as utoipa::PartialSchema>::schema();
    let schema = serde_json::to_value(schema).unwrap_or_default();
    let required: Vec<&str> = schema["required"]
        .as_array()
        .map(|r| r.iter().filter_map(|v| v.as_str()).collect())
        .unwrap_or_default();
    let mut inputs = BTreeMap::new();
    if let Some(properties) = schema["properties"].as_object() {
        for (name, property) in properties {
            let mut property = property.clone();
            let description = property
                .as_object_mut()
                .and_then(|p| p.remove("description"))
                .and_then(|d| d.as_str().map(str::to_string))
                .unwrap_or_default();
            let title = TITLES
                .iter()
                .find(|(n, _)| n == name)
                .map_or(name.as_str(), |(_, t)| t);
            inputs.insert(
                name.clone(),
                InputDescription {
                    title: title.to_string(),
                    description,
                    schema: property,
                    min_occurs: u32::from(required.contains(&name.as_str())),
                    max_occurs: 1,
                },
            );
        }
    }
    inputs
}

pub fn process_description() -> ProcessDescription {
    use serde_json::json;
    let inputs = input_descriptions();
    let mut outputs = BTreeMap::new();
    let output = |title: &str, description: &str, media_type: &str| OutputDescription {
        title: title.to_string(),
        description: description.to_string(),
        schema: if media_type == "application/json" && title == "Summary" {
            json!({"type": "object", "contentMediaType": media_type})
        } else {
            json!({"type": "string", "contentEncoding": "binary", "contentMediaType": media_type})
        },
    };
    outputs.insert(
        "summary".to_string(),
        output(
            "Summary",
            "Method, origin, CRS, counts, and per threshold the volume, area and bodies; the \
             resource report (tonnes, mean grade, metal and samples inside per body, the \
             grade–tonnage curve, cross-validation) under `report` and `resource`.",
            "application/json",
        ),
    );
    outputs.insert(
        "glb".to_string(),
        output(
            "glTF model",
            "glTF 2.0 binary, Y-up relative to the origin; one mesh per body.",
            "model/gltf-binary",
        ),
    );
    outputs.insert(
        "tileset".to_string(),
        output(
            "3D Tiles tileset",
            "3D Tiles tileset whose root content is the glb output.",
            "application/json",
        ),
    );
    outputs.insert(
        "geojson".to_string(),
        output(
            "Level plans",
            "GeoJSON level plans of the bodies.",
            "application/geo+json",
        ),
    );
    outputs.insert(
        "obj".to_string(),
        output("OBJ model", "Wavefront OBJ of the bodies.", "model/obj"),
    );
    outputs.insert(
        "vtu".to_string(),
        output(
            "VTU mesh",
            "VTK unstructured grid of the bodies.",
            "application/xml",
        ),
    );
    outputs.insert(
        "report".to_string(),
        output(
            "Grade–tonnage table",
            "CSV: per cut-off the volume (m3), tonnes, mean grade and metal, units in the \
             header (when the job has a grade–tonnage curve).",
            "text/csv",
        ),
    );
    outputs.insert(
        "chart".to_string(),
        output(
            "Grade–tonnage chart",
            "SVG: tonnes and mean grade against cut-off, the figures of the report output.",
            "image/svg+xml",
        ),
    );
    ProcessDescription {
        summary: process_summary(),
        inputs,
        outputs,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_input_is_described_with_a_title_and_a_self_contained_schema() {
        let description = process_description();
        let inputs = &description.inputs;
        assert!(inputs.len() >= 20, "{}", inputs.len());
        for (name, input) in inputs {
            assert!(
                TITLES.iter().any(|(n, _)| n == name),
                "input {name} has no title in TITLES"
            );
            assert!(
                !input.description.is_empty(),
                "input {name} has no description"
            );
            let schema = input.schema.to_string();
            assert!(
                !schema.contains("$ref"),
                "input {name} refers outside: {schema}"
            );
        }
        for (name, _) in TITLES {
            assert!(
                inputs.contains_key(*name),
                "TITLES names {name}, not an input"
            );
        }
        assert_eq!(inputs["thresholds"].min_occurs, 1);
        assert_eq!(inputs["method"].min_occurs, 0);
        assert!(
            inputs["samples_csv"]
                .schema
                .to_string()
                .contains("text/csv")
        );
    }
}
