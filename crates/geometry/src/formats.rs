//! Mesh file formats: the bytes of an STL (binary or ASCII), OBJ or COLLADA file to triangles.
//!
//! By the file name's extension, case-insensitive: `.stl`, `.obj`, `.dae` (COLLADA, with its
//! `<unit meter>` applied to every vertex and its node transforms applied; `<up_axis>` ignored,
//! as RViz ignores it), parsed by `mesh-loader`. All the meshes in a file are merged into one.
//! Reading the file is [`crate::load`](mod@crate::load)'s concern; this module sees bytes only.
//!
//! The bytes are untrusted: a COLLADA file is checked before `mesh-loader` parses it
//! ([`collada`]: element nesting, the counts it reserves memory for, every index against the
//! source it reads), an OBJ's `mtllib` is never opened (materials are not needed, and a file
//! name in the bytes must not open files), and any panic left inside `mesh-loader` is contained
//! and refused as a malformed file ([`GeometryError::MalformedMesh`]).

use std::io;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use crate::error::GeometryError;

pub mod collada;

pub use collada::MAX_DEPTH;

/// A parsed mesh file: vertices in the file's units, triangles.
pub type Triangles = (Vec<[f64; 3]>, Vec<[u32; 3]>);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Stl,
    Obj,
    Collada,
}

fn format_of(resource: &str, path: &Path) -> Result<Format, GeometryError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("stl") => Ok(Format::Stl),
        Some("obj") => Ok(Format::Obj),
        Some("dae") => Ok(Format::Collada),
        _ => Err(GeometryError::UnknownFormat {
            resource: resource.to_owned(),
        }),
    }
}

/// Whether the file name's extension is one of the formats read here.
pub fn check_format(resource: &str, path: &Path) -> Result<(), GeometryError> {
    format_of(resource, path).map(|_| ())
}

/// Parse the bytes of a mesh file (its format from `path`'s extension), without indexing it.
pub fn parse_bytes(resource: &str, path: &Path, bytes: &[u8]) -> Result<Triangles, GeometryError> {
    let format = format_of(resource, path)?;
    let malformed = |reason: String| GeometryError::MalformedMesh {
        resource: resource.to_owned(),
        reason,
    };
    let unparsable = |source: io::Error| GeometryError::Unparsable {
        resource: resource.to_owned(),
        path: path.to_owned(),
        source,
    };
    let (text, unit) = if format == Format::Collada {
        match collada::check(bytes) {
            Ok(checked) => (Some(checked.text), checked.unit),
            Err(collada::Refusal::Syntax(why)) => {
                return Err(unparsable(io::Error::new(io::ErrorKind::InvalidData, why)))
            }
            Err(collada::Refusal::Malformed(reason)) => return Err(malformed(reason)),
            Err(collada::Refusal::Unit(unit)) => {
                return Err(GeometryError::BadUnit {
                    resource: resource.to_owned(),
                    unit,
                })
            }
        }
    } else {
        (None, 1.0)
    };
    // `mesh-loader` may still panic on input the checks above do not foresee (it has `unwrap`s,
    // `assert`s and unchecked indexing): the panic is caught here (the workspace unwinds) and the
    // file refused. The closure reads only `bytes` and `text`, and what it built is dropped with
    // it, so nothing half-made is seen after a panic.
    let parsed = catch_unwind(AssertUnwindSafe(|| match format {
        Format::Stl => mesh_loader::stl::from_slice(bytes),
        Format::Obj => mesh_loader::obj::from_slice::<Vec<u8>, _>(bytes, None, |_| {
            Err(io::Error::other("material files are not read"))
        }),
        Format::Collada => mesh_loader::collada::from_str(text.as_deref().unwrap_or("")),
    }));
    let scene = match parsed {
        Ok(scene) => scene.map_err(unparsable)?,
        Err(_) => {
            return Err(malformed(
                "the parser failed on it (a structure it does not expect)".to_owned(),
            ))
        }
    };
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for mesh in scene.meshes {
        let offset = u32::try_from(vertices.len()).unwrap_or(u32::MAX);
        vertices.extend(mesh.vertices.iter().map(|v| v.map(|x| f64::from(x) * unit)));
        triangles.extend(
            mesh.faces
                .iter()
                .map(|f| f.map(|k| k.saturating_add(offset))),
        );
    }
    Ok((vertices, triangles))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The corners of the cube `[0, 40]³` (in file units) and its 12 triangles, wound outward.
    const CORNERS: &str = "0 0 0 40 0 0 0 40 0 40 40 0 0 0 40 40 0 40 0 40 40 40 40 40";
    const CUBE: &str = "0 2 3 0 3 1 4 5 7 4 7 6 0 1 5 0 5 4 2 6 7 2 7 3 0 4 6 0 6 2 1 3 7 1 7 5";

    /// A COLLADA cube: `asset` goes into `<asset>`, `indices` into `<p>`, and `scene` says whether
    /// a `<scene>` instances the geometry.
    fn dae(asset: &str, indices: &str, scene: bool) -> String {
        let count = indices.split_whitespace().count() / 3;
        let scenes = if scene {
            r##"<library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node></visual_scene></library_visual_scenes><scene><instance_visual_scene url="#s"/></scene>"##
        } else {
            ""
        };
        format!(
            r##"<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset>{asset}</asset>
<library_geometries><geometry id="g"><mesh>
<source id="pos"><float_array id="pos-a" count="24">{CORNERS}</float_array>
<technique_common><accessor source="#pos-a" count="8" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#pos"/></vertices>
<triangles count="{count}"><input semantic="VERTEX" source="#v" offset="0"/><p>{indices}</p></triangles>
</mesh></geometry></library_geometries>{scenes}
</COLLADA>"##
        )
    }

    fn parse(text: &str) -> Result<Triangles, GeometryError> {
        parse_bytes("cube.dae", Path::new("cube.dae"), text.as_bytes())
    }

    fn extent(vertices: &[[f64; 3]]) -> f64 {
        vertices
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()))
    }

    #[test]
    fn an_index_past_the_vertices_is_refused_naming_it() {
        let err = parse(&dae("", &CUBE.replace("0 2 3", "0 2 9"), true)).expect_err("refused");
        let text = err.to_string();
        assert!(matches!(err, GeometryError::MalformedMesh { .. }), "{text}");
        assert!(
            text.contains("index 9, past the 8 values of <source id=\"pos\">"),
            "{text}"
        );
        assert_eq!(err.status(), 2);
    }

    #[test]
    fn a_count_beyond_the_values_held_is_refused_before_it_is_reserved() {
        let text = dae("", CUBE, true).replace("count=\"24\"", "count=\"4000000000\"");
        let err = parse(&text).expect_err("refused");
        assert!(
            err.to_string()
                .contains("claims 4000000000 values but holds 24"),
            "{err}"
        );
        let text = dae("", CUBE, true)
            .replace("<triangles count=\"12\"", "<triangles count=\"1000000000\"");
        let err = parse(&text).expect_err("refused");
        assert!(
            err.to_string()
                .contains("needs 3000000000 indices but holds 36"),
            "{err}"
        );
    }

    #[test]
    fn a_panic_inside_the_parser_is_a_malformed_file() {
        // A primitive without indices whose normals' source is empty passes the checks (no
        // index to check), and mesh-loader panics reading the empty list (an `unwrap` in its
        // iterator): contained, and refused.
        let normals = r##"<source id="nrm"><float_array id="nrm-a" count="0"></float_array>
<technique_common><accessor source="#nrm-a" count="0" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices"##;
        let empty = r##"<triangles count="0"><input semantic="VERTEX" source="#v" offset="0"/><input semantic="NORMAL" source="#nrm" offset="0"/></triangles>
</mesh>"##;
        let text = dae("", CUBE, true)
            .replace("<vertices", normals)
            .replace("</mesh>", empty);
        let err = parse(&text).expect_err("refused");
        assert!(matches!(err, GeometryError::MalformedMesh { .. }), "{err}");
        assert!(err.to_string().contains("the parser failed on it"), "{err}");
    }

    /// `depth` nested `<node>` elements inside the visual scene.
    fn nested(depth: usize) -> String {
        let open = "<node>".repeat(depth);
        let close = "</node>".repeat(depth);
        dae("", CUBE, true).replace(
            r##"<node id="n"><instance_geometry url="#g"/></node>"##,
            &format!(r##"{open}<node id="n"><instance_geometry url="#g"/></node>{close}"##),
        )
    }

    #[test]
    fn elements_nested_too_deep_are_refused_before_any_parser() {
        // On a thread with a small stack: the refusal itself must not recurse.
        let handle = std::thread::Builder::new()
            .stack_size(64 * 1024)
            .spawn(|| {
                parse(&nested(10_000))
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            })
            .expect("a thread");
        let err = handle.join().expect("no overflow").expect_err("refused");
        assert!(err.contains("nest deeper than 256 levels"), "{err}");
        // Within the bound, the nodes are read (the cube at depth 240).
        let (v, t) = parse(&nested(240)).expect("read");
        assert_eq!((v.len(), t.len()), (36, 12));
    }

    #[test]
    fn the_depth_scan_skips_comments_cdata_and_quoted_values() {
        let deep_comment = format!("<!-- {} --><a/>", "<b>".repeat(300));
        assert_eq!(collada::check_depth_for_tests(&deep_comment), Ok(()));
        let cdata = format!("<a><![CDATA[{}]]></a>", "<b>".repeat(300));
        assert_eq!(collada::check_depth_for_tests(&cdata), Ok(()));
        let quoted = format!("<a x=\"{}\"/>", "&gt;<b>".repeat(300));
        assert_eq!(collada::check_depth_for_tests(&quoted), Ok(()));
        let empty = "<b/>".repeat(1000);
        assert_eq!(collada::check_depth_for_tests(&empty), Ok(()));
        assert!(collada::check_depth_for_tests(&"<b>".repeat(257)).is_err());
        assert!(collada::check_depth_for_tests(&"<b>".repeat(256)).is_ok());
    }

    #[test]
    fn the_unit_applies_with_or_without_a_scene() {
        for scene in [true, false] {
            let (v, _) =
                parse(&dae(r#"<unit meter="0.001" name="mm"/>"#, CUBE, scene)).expect("read");
            assert!(
                (extent(&v) - 0.04).abs() < 1e-12,
                "scene {scene}: {}",
                extent(&v)
            );
        }
        // A comma as the decimal mark, as mesh-loader reads it.
        let (v, _) = parse(&dae(r#"<unit meter="0,01"/>"#, CUBE, false)).expect("read");
        assert!((extent(&v) - 0.4).abs() < 1e-12);
        let (v, _) = parse(&dae("", CUBE, false)).expect("read");
        assert_eq!(extent(&v), 40.0);
    }

    #[test]
    fn a_unit_not_positive_or_not_finite_is_refused_naming_it() {
        for unit in ["-0.001", "0", "inf", "NaN", "ten"] {
            let err =
                parse(&dae(&format!(r#"<unit meter="{unit}"/>"#), CUBE, true)).expect_err(unit);
            assert!(
                matches!(err, GeometryError::BadUnit { .. }),
                "{unit}: {err}"
            );
            assert!(
                err.to_string()
                    .contains(&format!("<unit meter=\"{unit}\">")),
                "{err}"
            );
        }
    }

    #[test]
    fn a_part_with_a_unit_of_its_own_is_refused() {
        let text = dae(r#"<unit meter="0.001"/>"#, CUBE, true).replace(
            "<geometry id=\"g\">",
            "<geometry id=\"g\"><asset><unit meter=\"1\"/></asset>",
        );
        let err = parse(&text).expect_err("refused");
        assert!(
            err.to_string().contains("units of parts are not supported"),
            "{err}"
        );
    }

    #[test]
    fn up_axis_is_ignored_as_rviz_ignores_it() {
        let (y, _) = parse(&dae("<up_axis>Y_UP</up_axis>", CUBE, true)).expect("read");
        let (z, _) = parse(&dae("<up_axis>Z_UP</up_axis>", CUBE, true)).expect("read");
        let (x, _) = parse(&dae("<up_axis>X_UP</up_axis>", CUBE, true)).expect("read");
        assert_eq!(y, z);
        assert_eq!(y, x);
    }

    #[test]
    fn an_obj_material_library_is_not_opened() {
        let obj = b"mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let (v, t) = parse_bytes("m.obj", Path::new("/tmp/m.obj"), obj).expect("read");
        assert_eq!((v.len(), t.len()), (3, 1));
    }
}
