//! COLLADA read as untrusted input: decoded, checked, its unit taken out, and only then given to
//! `mesh-loader`.
//!
//! `mesh-loader` 0.1.13 trusts the file. Its `<node>` parser recurses once per nesting level (10,000
//! nested `<node>` elements overflow the stack, which no `catch_unwind` contains); it reserves
//! memory for whatever a `count` attribute claims before reading the values (a 100-byte
//! `<float_array count="4000000000">` asks for 16 GB, and a failed allocation aborts); and it
//! indexes its vertex, normal and texture-coordinate lists with the file's indices unchecked (an
//! index past the vertices panics). [`check`] refuses each of these before `mesh-loader` sees the
//! text, so that every index it uses is in range and every reservation it makes is bounded by the
//! number of values the file really holds. Anything left that panics is contained by the caller.
//!
//! Units: `mesh-loader` applies `<unit meter>` only to the geometry instanced under the visual
//! scene that `<scene>` names, and nothing else. [`check`] reads the unit itself, refuses one that
//! is not a finite number greater than zero, and blanks the `<unit>` element out of the text it
//! hands on (same length, spaces), so that `mesh-loader` applies none and the caller applies it to
//! every vertex. `<up_axis>` is ignored, as RViz ignores it (docs/poses.md).

use std::collections::HashMap;

use roxmltree::{Document, Node, ParsingOptions};

/// The deepest element nesting read. Exporters write a handful of levels (a scene, a few nested
/// nodes, a geometry's mesh, its source, accessor, param: about 10 to 20); `mesh-loader` recurses
/// once per nested `<node>`, a few hundred bytes of stack each, and 256 levels keep that well
/// inside the smallest thread stack it runs on (a few tens of kB).
pub const MAX_DEPTH: usize = 256;

/// Why a COLLADA file is refused before it is parsed for its meshes.
#[derive(Debug, Clone, PartialEq)]
pub enum Refusal {
    /// The text is not UTF-8 or UTF-16, or not well-formed XML: what the decoder or the XML
    /// parser says (as `mesh-loader` would have refused it).
    Syntax(String),
    /// The file is malformed: the reason.
    Malformed(String),
    /// The document's `<unit meter>` is not a finite number greater than zero: the value as
    /// written.
    Unit(String),
}

/// What [`check`] passes on: the text for `mesh-loader` (its `<unit>` elements blanked out) and
/// the unit, metres per file unit.
#[derive(Debug)]
pub struct Checked {
    pub text: String,
    pub unit: f64,
}

fn malformed(reason: impl Into<String>) -> Refusal {
    Refusal::Malformed(reason.into())
}

/// The bytes as text, decoded as `mesh-loader` decodes them: UTF-8 (with or without its byte
/// order mark) or UTF-16 with its byte order mark; UTF-32 is refused.
fn decode(bytes: &[u8]) -> Result<String, Refusal> {
    const UTF8: &[u8] = &[0xEF, 0xBB, 0xBF];
    let utf16 = |rest: &[u8], big: bool| {
        if !rest.len().is_multiple_of(2) {
            return Err(Refusal::Syntax(
                "invalid utf-16: odd number of bytes".into(),
            ));
        }
        let units = rest.chunks_exact(2).map(|b| {
            if big {
                u16::from_be_bytes([b[0], b[1]])
            } else {
                u16::from_le_bytes([b[0], b[1]])
            }
        });
        char::decode_utf16(units)
            .collect::<Result<String, _>>()
            .map_err(|e| Refusal::Syntax(format!("invalid utf-16: {e}")))
    };
    if bytes.starts_with(&[0xFF, 0xFE, 0, 0]) || bytes.starts_with(&[0, 0, 0xFE, 0xFF]) {
        Err(Refusal::Syntax("utf-32 is not supported".into()))
    } else if let Some(rest) = bytes.strip_prefix(&[0xFE, 0xFF]) {
        utf16(rest, true)
    } else if let Some(rest) = bytes.strip_prefix(&[0xFF, 0xFE]) {
        utf16(rest, false)
    } else {
        let rest = bytes.strip_prefix(UTF8).unwrap_or(bytes);
        String::from_utf8(rest.to_vec()).map_err(|e| Refusal::Syntax(e.to_string()))
    }
}

/// Decode, check and take the unit out; see the module's documentation.
pub fn check(bytes: &[u8]) -> Result<Checked, Refusal> {
    let text = decode(bytes)?;
    check_depth(&text)?;
    let options = ParsingOptions {
        allow_dtd: false,
        ..ParsingOptions::default()
    };
    let doc =
        Document::parse_with_options(&text, options).map_err(|e| Refusal::Syntax(e.to_string()))?;
    let (unit, blank) = unit(&doc)?;
    check_geometry(&doc)?;
    drop(doc);
    let mut text = text.into_bytes();
    for range in blank {
        text[range].fill(b' ');
    }
    // Whole elements (from `<` to `>`) replaced by ASCII spaces: still UTF-8.
    let text = String::from_utf8(text).map_err(|_| malformed("its text could not be rewritten"))?;
    Ok(Checked { text, unit })
}

/// The element nesting depth, by a scan of the text that skips comments, CDATA sections,
/// processing instructions, the DOCTYPE and quoted attribute values, and counts a start tag
/// up and an end tag down (an empty-element tag neither). It runs before any XML parser, and in
/// constant stack; a document too deep is refused whatever else it holds.
fn check_depth(text: &str) -> Result<(), Refusal> {
    let b = text.as_bytes();
    let find = |from: usize, pat: &[u8]| -> usize {
        b.get(from..)
            .and_then(|rest| rest.windows(pat.len()).position(|w| w == pat))
            .map_or(b.len(), |at| from + at + pat.len())
    };
    let mut depth = 0usize;
    let mut i = 0;
    while i < b.len() {
        if b[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &b[i..];
        if rest.starts_with(b"<!--") {
            i = find(i + 4, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = find(i + 9, b"]]>");
        } else if rest.starts_with(b"<?") {
            i = find(i + 2, b"?>");
        } else if rest.starts_with(b"<!") {
            // A DOCTYPE (refused by the parser later) or other declaration: to its `>`.
            i = find(i + 2, b">");
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            i = find(i + 2, b">");
        } else {
            // A start tag: to its `>`, outside quoted attribute values.
            let mut j = i + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, b'"' | b'\'') => quote = Some(b[j]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            if j < b.len() && b[j - 1] != b'/' {
                depth += 1;
                if depth > MAX_DEPTH {
                    return Err(malformed(format!(
                        "its elements nest deeper than {MAX_DEPTH} levels"
                    )));
                }
            }
            i = j + 1;
        }
    }
    Ok(())
}

/// [`check_depth`], for the tests of the parent module.
#[cfg(test)]
pub(super) fn check_depth_for_tests(text: &str) -> Result<(), Refusal> {
    check_depth(text)
}

/// The document's unit (the last `<unit meter>` of the last `<asset>` of `<COLLADA>`, as
/// `mesh-loader` reads it; 1 when absent), and the byte ranges of the `<unit>` elements to blank
/// out. A `<unit>` in an element's own `<asset>` that differs from the document's is refused:
/// neither `mesh-loader` nor RViz's loader applies it, and the mesh would be read at the wrong
/// size.
fn unit(doc: &Document) -> Result<(f64, Vec<std::ops::Range<usize>>), Refusal> {
    let root = doc.root_element();
    let mut unit = 1.0;
    let mut blank = Vec::new();
    let read = |node: Node| -> Result<Option<f64>, Refusal> {
        let Some(written) = node.attribute("meter") else {
            return Ok(None);
        };
        let value: f64 = written
            .trim()
            .replace(',', ".")
            .parse()
            .map_err(|_| Refusal::Unit(written.to_owned()))?;
        if value.is_finite() && value > 0.0 {
            Ok(Some(value))
        } else {
            Err(Refusal::Unit(written.to_owned()))
        }
    };
    for asset in root.children().filter(|n| n.has_tag_name("asset")) {
        for node in asset.children().filter(|n| n.has_tag_name("unit")) {
            if let Some(value) = read(node)? {
                unit = value;
            }
            blank.push(node.range());
        }
    }
    for node in root.descendants().filter(|n| n.has_tag_name("unit")) {
        let top = node
            .parent()
            .and_then(|asset| asset.parent())
            .is_some_and(|p| p == root);
        if !top {
            if let Some(value) = read(node)? {
                if value != unit {
                    let owner = node
                        .parent()
                        .and_then(|a| a.parent())
                        .map_or("?", |p| p.tag_name().name());
                    return Err(malformed(format!(
                        "a <unit meter=\"{value}\"> inside <{owner}> differs from the document's {unit}: units of parts are not supported"
                    )));
                }
            }
        }
    }
    Ok((unit, blank))
}

/// Whitespace-separated values of an element's text.
fn values<'a>(node: Node<'a, '_>) -> impl Iterator<Item = &'a str> {
    node.text().unwrap_or("").split_ascii_whitespace()
}

fn attr_u64(node: Node, name: &str) -> Option<u64> {
    node.attribute(name).and_then(|v| v.trim().parse().ok())
}

/// A `<source>` as the checks see it: its accessor's count and stride, and whether it reads a
/// `<float_array>` holding at least `count × stride` values.
#[derive(Debug, Clone)]
struct Source {
    count: u64,
    stride: u64,
    /// Its accessor has at least three `float` params (what `mesh-loader` needs to read it as
    /// positions).
    xyz: bool,
    /// Why `mesh-loader` cannot read it, if it cannot.
    problem: Option<String>,
}

/// The checks on every `<mesh>` of `<library_geometries>` and every array: see [`check`].
fn check_geometry(doc: &Document) -> Result<(), Refusal> {
    // Arrays first: `mesh-loader` reserves `count` values before it reads them.
    for node in doc.descendants().filter(|n| n.is_element()) {
        if node.tag_name().name().ends_with("_array") {
            if let Some(count) = attr_u64(node, "count") {
                let held = values(node).count() as u64;
                if held > 0 && count > held {
                    return Err(malformed(format!(
                        "<{} id=\"{}\"> claims {count} values but holds {held}",
                        node.tag_name().name(),
                        node.attribute("id").unwrap_or("")
                    )));
                }
            }
        }
    }
    // The sources and arrays `mesh-loader` looks references up in: those of the meshes of
    // `<library_geometries>`, by id, a later one replacing an earlier one of the same id.
    let meshes: Vec<Node> = doc
        .root_element()
        .children()
        .filter(|n| n.has_tag_name("library_geometries"))
        .flat_map(|l| l.children().filter(|n| n.has_tag_name("geometry")))
        .flat_map(|g| g.children().filter(|n| n.has_tag_name("mesh")))
        .collect();
    let source_nodes: Vec<Node> = meshes
        .iter()
        .flat_map(|m| m.children().filter(|n| n.has_tag_name("source")))
        .collect();
    // mesh-loader keeps the last array of each source (and the last accessor), so these are
    // the ones looked at here too.
    let arrays: HashMap<&str, Node> = source_nodes
        .iter()
        .filter_map(|s| {
            s.children().rfind(|n| {
                matches!(
                    n.tag_name().name(),
                    "float_array" | "IDREF_array" | "Name_array"
                )
            })
        })
        .filter_map(|n| n.attribute("id").map(|id| (id, n)))
        .collect();
    let sources: HashMap<&str, Source> = source_nodes
        .iter()
        .filter_map(|n| Some((n.attribute("id")?, source(*n, &arrays)?)))
        .collect();
    for mesh in meshes {
        let id = mesh.parent().and_then(|g| g.attribute("id")).unwrap_or("");
        check_mesh(mesh, &sources).map_err(|why| match why {
            Refusal::Malformed(why) => malformed(format!("geometry \"{id}\": {why}")),
            other => other,
        })?;
    }
    Ok(())
}

/// A `<source>`'s accessor, checked against its array; `None` when it has no accessor.
fn source(node: Node, arrays: &HashMap<&str, Node>) -> Option<Source> {
    let id = node.attribute("id").unwrap_or("");
    let accessor = node
        .children()
        .filter(|n| n.has_tag_name("technique_common"))
        .flat_map(|t| t.children())
        .rfind(|n| n.has_tag_name("accessor"))?;
    let count = attr_u64(accessor, "count").unwrap_or(0);
    let stride = attr_u64(accessor, "stride").unwrap_or(1);
    let params = || accessor.children().filter(|n| n.has_tag_name("param"));
    let floats = params()
        .filter(|n| n.attribute("type") == Some("float"))
        .count();
    let all_float = params().all(|n| n.attribute("type") == Some("float"));
    let array = accessor
        .attribute("source")
        .and_then(|s| s.strip_prefix('#'))
        .and_then(|s| arrays.get(s));
    // What `mesh-loader` holds for the array: its `count` values, or none when its text is
    // empty.
    let held = array.map_or(0, |a| {
        if values(*a).next().is_some() {
            attr_u64(*a, "count").unwrap_or(0)
        } else {
            0
        }
    });
    let needed = count.saturating_mul(stride);
    let problem = if !array.is_some_and(|a| a.has_tag_name("float_array")) {
        Some(format!(
            "the accessor of <source id=\"{id}\"> reads no <float_array> of the file's meshes"
        ))
    } else if needed > held {
        Some(format!(
            "the accessor of <source id=\"{id}\"> reads {count} × {stride} values, but its array holds {held}"
        ))
    } else {
        None
    };
    Some(Source {
        count,
        stride,
        xyz: stride >= 3 && floats >= 3 && all_float,
        problem,
    })
}

/// One input of a primitive: its semantic, offset, and the counts its indices must stay under
/// (one for most, the `<vertices>`' inputs for `VERTEX`).
struct Input<'a> {
    semantic: &'a str,
    offset: u64,
    limits: Vec<(&'a str, u64)>,
}

fn lookup<'a>(
    semantic: &str,
    reference: &'a str,
    sources: &HashMap<&str, Source>,
) -> Result<(&'a str, Source), Refusal> {
    let id = reference.strip_prefix('#').unwrap_or(reference);
    match sources.get(id) {
        Some(Source {
            problem: Some(why), ..
        }) => Err(malformed(why.clone())),
        Some(s) => Ok((id, s.clone())),
        None => Err(malformed(format!(
            "input {semantic} refers to {reference:?}, which is no <source> with an accessor"
        ))),
    }
}

/// The semantics `mesh-loader` reads; an input of another semantic is not used and not checked.
fn used(semantic: &str) -> bool {
    matches!(semantic, "POSITION" | "NORMAL" | "TEXCOORD" | "COLOR")
}

fn check_mesh(mesh: Node, sources: &HashMap<&str, Source>) -> Result<(), Refusal> {
    // The last `<vertices>`, as mesh-loader keeps it.
    let vertices = mesh.children().rfind(|n| n.has_tag_name("vertices"));
    let vertices_id = vertices.and_then(|v| v.attribute("id")).unwrap_or("");
    // The `<vertices>`' inputs: the counts a VERTEX index must stay under.
    let mut vertex_limits = Vec::new();
    let mut has_position = false;
    for input in vertices
        .into_iter()
        .flat_map(|v| v.children())
        .filter(|n| n.has_tag_name("input"))
    {
        let semantic = input.attribute("semantic").unwrap_or("");
        if !used(semantic) {
            continue;
        }
        let (id, source) = lookup(semantic, input.attribute("source").unwrap_or(""), sources)?;
        if semantic == "POSITION" {
            has_position = true;
            if !source.xyz {
                return Err(malformed(format!(
                    "the positions <source id=\"{id}\"> do not have three float coordinates (stride {})",
                    source.stride
                )));
            }
        }
        if source.count == 0 {
            return Err(malformed(format!(
                "<source id=\"{id}\"> ({semantic}) has no values"
            )));
        }
        vertex_limits.push((id, source.count));
    }
    for primitive in mesh.children().filter(|n| {
        matches!(
            n.tag_name().name(),
            "lines"
                | "linestrips"
                | "polygons"
                | "polylist"
                | "triangles"
                | "trifans"
                | "tristrips"
        )
    }) {
        let inputs = primitive_inputs(primitive, vertices_id, &vertex_limits, sources)?;
        if inputs.iter().any(|i| i.semantic == "VERTEX") && !has_position {
            return Err(malformed("its <vertices> have no POSITION input"));
        }
        check_primitive(primitive, &inputs)?;
    }
    Ok(())
}

fn primitive_inputs<'a>(
    primitive: Node<'a, '_>,
    vertices_id: &str,
    vertex_limits: &[(&'a str, u64)],
    sources: &HashMap<&str, Source>,
) -> Result<Vec<Input<'a>>, Refusal> {
    let mut inputs = Vec::new();
    for input in primitive.children().filter(|n| n.has_tag_name("input")) {
        let semantic = input.attribute("semantic").unwrap_or("");
        let offset = attr_u64(input, "offset").unwrap_or(0);
        let reference = input.attribute("source").unwrap_or("");
        let limits = if semantic == "VERTEX" {
            if reference.strip_prefix('#') != Some(vertices_id) {
                return Err(malformed(format!(
                    "<{}> input VERTEX refers to {reference:?}, not to its mesh's <vertices id=\"{vertices_id}\">",
                    primitive.tag_name().name()
                )));
            }
            vertex_limits.to_vec()
        } else if used(semantic) {
            let (id, source) = lookup(semantic, reference, sources)?;
            vec![(id, source.count)]
        } else {
            Vec::new()
        };
        inputs.push(Input {
            semantic,
            offset,
            limits,
        });
    }
    Ok(inputs)
}

/// The counts `mesh-loader` reserves for against what the primitive holds, and every index
/// against the sources it reads.
fn check_primitive(primitive: Node, inputs: &[Input]) -> Result<(), Refusal> {
    let kind = primitive.tag_name().name();
    let count = attr_u64(primitive, "count").unwrap_or(0);
    let stride = inputs.iter().map(|i| i.offset + 1).max().unwrap_or(0);
    let ps: Vec<Node> = primitive
        .children()
        .filter(|n| n.has_tag_name("p"))
        .collect();
    let held: u64 = ps.iter().map(|p| values(*p).count() as u64).sum();
    if held > 0 && stride == 0 {
        return Err(malformed(format!("<{kind}> has indices but no <input>")));
    }
    if stride > held.max(1) {
        return Err(malformed(format!(
            "<{kind}> has an input offset of {} but only {held} indices",
            stride - 1
        )));
    }
    let per = match kind {
        "triangles" => Some(3),
        "lines" => Some(2),
        _ => None,
    };
    if let (Some(per), true) = (per, count > 0 && !ps.is_empty()) {
        let expected = count.saturating_mul(per).saturating_mul(stride);
        if expected != held {
            return Err(malformed(format!(
                "<{kind} count=\"{count}\"> needs {expected} indices but holds {held}"
            )));
        }
    }
    if kind == "polylist" {
        let vcount = primitive.children().find(|n| n.has_tag_name("vcount"));
        let sizes = vcount.map_or(0, |v| values(v).count() as u64);
        if count > 0 && count > sizes {
            return Err(malformed(format!(
                "<polylist count=\"{count}\"> has {sizes} <vcount> values"
            )));
        }
        // mesh-loader reserves the indices the first `count` polygon sizes add up to.
        let corners = vcount.map_or(0, |v| {
            values(v)
                .take(usize::try_from(count).unwrap_or(usize::MAX))
                .map(|n| n.parse::<u64>().unwrap_or(u64::MAX))
                .fold(0u64, u64::saturating_add)
        });
        let expected = corners.saturating_mul(stride);
        if count > 0 && !ps.is_empty() && expected != held {
            return Err(malformed(format!(
                "<polylist> sizes need {expected} indices but it holds {held}"
            )));
        }
    } else if per.is_none() && count > ps.len() as u64 {
        return Err(malformed(format!(
            "<{kind} count=\"{count}\"> has {} <p> elements",
            ps.len()
        )));
    }
    for p in ps {
        for (k, value) in values(p).enumerate() {
            let index: u64 = value
                .parse()
                .ok()
                .filter(|v| *v <= u64::from(u32::MAX))
                .ok_or_else(|| {
                    malformed(format!("<{kind}> has {value:?} where an index is expected"))
                })?;
            let offset = k as u64 % stride.max(1);
            for input in inputs.iter().filter(|i| i.offset == offset) {
                if let Some((id, limit)) = input.limits.iter().find(|(_, n)| index >= *n) {
                    return Err(malformed(format!(
                        "<{kind}> input {} has index {index}, past the {limit} values of <source id=\"{id}\">",
                        input.semantic
                    )));
                }
            }
        }
    }
    Ok(())
}
