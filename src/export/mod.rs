//! Writing results: GLB (glTF 2.0 binary) and the summary JSON.
//!
//! Invariant: exporters write exactly the triangles of `ContourResult::shells`, so any
//! reader recomputes the summary's volumes and areas.
pub mod tet_vtu;
