//! Mesh file formats: the bytes of an STL (binary or ASCII), OBJ or COLLADA file to triangles.
//!
//! By the file name's extension, case-insensitive: `.stl`, `.obj`, `.dae` (COLLADA, with its
//! `<unit meter>` and node transforms applied), parsed by `mesh-loader`. All the meshes in a file
//! are merged into one. Reading the file is [`crate::load`]'s concern; this module sees bytes only.

use std::path::Path;

use crate::error::GeometryError;

/// A parsed mesh file: vertices in the file's units, triangles.
pub type Triangles = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// Whether the file name's extension is one of the formats read here.
pub fn check_format(resource: &str, path: &Path) -> Result<(), GeometryError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(extension.as_deref(), Some("stl" | "obj" | "dae")) {
        return Err(GeometryError::UnknownFormat {
            resource: resource.to_owned(),
        });
    }
    Ok(())
}

/// Parse the bytes of a mesh file (its format from `path`'s extension), without indexing it.
pub fn parse_bytes(resource: &str, path: &Path, bytes: &[u8]) -> Result<Triangles, GeometryError> {
    check_format(resource, path)?;
    let scene = mesh_loader::Loader::default()
        .merge_meshes(true)
        .load_from_slice(bytes, path)
        .map_err(|source| GeometryError::Unparsable {
            resource: resource.to_owned(),
            path: path.to_owned(),
            source,
        })?;
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for mesh in scene.meshes {
        let offset = u32::try_from(vertices.len()).unwrap_or(u32::MAX);
        vertices.extend(mesh.vertices.iter().map(|v| v.map(f64::from)));
        triangles.extend(
            mesh.faces
                .iter()
                .map(|f| f.map(|k| k.saturating_add(offset))),
        );
    }
    Ok((vertices, triangles))
}
