//! The table of named objects' mass and friction (the parameter `objects_file`): MoveIt's
//! CollisionObjects carry a shape and a pose but no mass nor friction, and a pose candidate may
//! name a mesh resource whose mass and friction the caller does not know. The table gives them:
//!
//! ```yaml
//! objects:                       # by CollisionObject id
//!   mug:
//!     mass: 0.3                  # kg; or density (kg/m³), times the shape's volume
//!     friction: 0.6              # Coulomb coefficient at both contacts
//!     center_of_mass: [0, 0, 0.04]   # optional, m, in the object's frame
//! meshes:                        # by mesh resource, for pose candidates
//!   "package://grasp_orient/meshes/box.stl":
//!     mass: 0.2
//!     friction: 0.5
//! ```
//!
//! The file is input the node did not write: it is read up to [`MAX_OBJECTS_FILE_BYTES`], holds
//! at most [`MAX_ENTRIES`] entries with names of at most [`MAX_NAME_BYTES`] bytes, and every
//! number is checked here, once, with an error naming the entry and the field. The errors are
//! the start-up's (a local user's file); what a peer on the network is told about a missing
//! entry ([`missing`]) names the object and the parameter, never the file's path.

use crate::msg::GraspObject;
use crate::solver::{MAX_COORDINATE, MAX_FRICTION, MAX_MASS};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// The largest objects file read, bytes.
pub(crate) const MAX_OBJECTS_FILE_BYTES: u64 = 1 << 20;
/// The most entries (objects and meshes together).
pub(crate) const MAX_ENTRIES: usize = 10_000;
/// The longest object id or mesh resource, bytes (a message's text bound).
pub(crate) const MAX_NAME_BYTES: usize = crate::msg::MAX_TEXT_BYTES;
/// The largest density, kg/m³: above any solid (osmium, 22 590 kg/m³) by a margin.
pub(crate) const MAX_DENSITY: f64 = 1e5;

/// How much matter an entry gives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Amount {
    /// The mass, kg.
    Mass(f64),
    /// The density, kg/m³: the mass is it times the shape's volume.
    Density(f64),
}

/// One named object's matter and friction.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Entry {
    /// Its mass, or its density.
    pub(crate) amount: Amount,
    /// Coulomb coefficient at both contacts.
    pub(crate) friction: f64,
    /// The centre of mass in the object's frame, m; `None`: the shape's centroid.
    pub(crate) center_of_mass: Option<[f64; 3]>,
}

impl Entry {
    /// The mass of this object, whose shape has `volume` m³ (asked only for a density).
    pub(crate) fn mass(&self, volume: impl FnOnce() -> Result<f64, String>) -> Result<f64, String> {
        match self.amount {
            Amount::Mass(m) => Ok(m),
            Amount::Density(rho) => {
                let v = volume()?;
                let m = rho * v;
                if m.is_finite() && m > 0.0 && m <= MAX_MASS {
                    Ok(m)
                } else {
                    Err(format!(
                        "density {rho} kg/m³ times the shape's volume {v} m³ is not a mass in \
                         (0, {MAX_MASS}] kg"
                    ))
                }
            }
        }
    }
}

/// The table: objects by id, meshes by resource.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct ObjectTable {
    objects: BTreeMap<String, Entry>,
    meshes: BTreeMap<String, Entry>,
}

/// An entry as the file writes it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEntry {
    mass: Option<f64>,
    density: Option<f64>,
    friction: f64,
    center_of_mass: Option<[f64; 3]>,
}

/// The file as it writes it.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawTable {
    #[serde(default)]
    objects: BTreeMap<String, RawEntry>,
    #[serde(default)]
    meshes: BTreeMap<String, RawEntry>,
}

impl ObjectTable {
    /// The table in the file `path` (the parameter `objects_file`); empty for an empty path.
    pub(crate) fn load(path: &str) -> Result<Self, String> {
        if path.is_empty() {
            return Ok(Self::default());
        }
        let text = super::read_text(Path::new(path), MAX_OBJECTS_FILE_BYTES)
            .map_err(|e| format!("objects_file {path:?}: {e}"))?;
        Self::parse(&text).map_err(|e| format!("objects_file {path:?}: {e}"))
    }

    /// The table in `text`.
    pub(crate) fn parse(text: &str) -> Result<Self, String> {
        if text.trim().is_empty() {
            return Ok(Self::default());
        }
        let raw: RawTable = serde_yaml_ng::from_str(text).map_err(|e| e.to_string())?;
        let count = raw.objects.len() + raw.meshes.len();
        if count > MAX_ENTRIES {
            return Err(format!("{count} entries, more than {MAX_ENTRIES}"));
        }
        let mut table = Self::default();
        for (section, raw, into, density_allowed) in [
            ("objects", raw.objects, &mut table.objects, true),
            ("meshes", raw.meshes, &mut table.meshes, false),
        ] {
            for (name, entry) in raw {
                let e = check(&name, entry, density_allowed)
                    .map_err(|why| format!("{section}: {name:?}: {why}"))?;
                into.insert(name, e);
            }
        }
        Ok(table)
    }

    /// How many entries it holds.
    pub(crate) fn len(&self) -> usize {
        self.objects.len() + self.meshes.len()
    }

    /// The entry of the object `id`.
    pub(crate) fn object(&self, id: &str) -> Option<&Entry> {
        self.objects.get(id)
    }

    /// Fills a pose candidate's object from the entry of its mesh resource, when it has a mesh
    /// resource in the table: its mass where 0, its friction where 0, and its centre of mass
    /// where it gives none and the entry does. Whether anything was filled.
    pub(crate) fn fill(&self, o: &mut GraspObject) -> bool {
        if o.mesh.is_empty() || (o.mass != 0.0 && o.friction != 0.0) {
            return false;
        }
        let Some(entry) = self.meshes.get(o.mesh.as_str()) else {
            return false;
        };
        let Amount::Mass(mass) = entry.amount else {
            return false;
        };
        if o.mass == 0.0 {
            o.mass = mass;
        }
        if o.friction == 0.0 {
            o.friction = entry.friction;
        }
        if let (false, Some(c)) = (o.has_center_of_mass, entry.center_of_mass) {
            o.has_center_of_mass = true;
            o.center_of_mass = crate::msg::Point {
                x: c[0],
                y: c[1],
                z: c[2],
            };
        }
        true
    }
}

/// The words of a refusal for an object with no entry: its id and the parameter to set.
pub(crate) fn missing(id: &str) -> String {
    format!(
        "object {:?} has no mass and friction: give it an entry under objects: in the file the \
         parameter objects_file names (docs/node.md#objects)",
        crate::msg::clip(id)
    )
}

/// One entry checked.
fn check(name: &str, e: RawEntry, density_allowed: bool) -> Result<Entry, String> {
    if name.is_empty() || name.len() > MAX_NAME_BYTES {
        return Err(format!("a name of 1 to {MAX_NAME_BYTES} bytes"));
    }
    let amount = match (e.mass, e.density) {
        (Some(m), None) => {
            if !(m.is_finite() && m > 0.0 && m <= MAX_MASS) {
                return Err(format!("mass must be in (0, {MAX_MASS}] kg, got {m}"));
            }
            Amount::Mass(m)
        }
        (None, Some(rho)) => {
            if !density_allowed {
                return Err(
                    "a mesh resource's entry gives mass, not density (the node has the \
                            volume only of the shapes it learns: CollisionObjects)"
                        .into(),
                );
            }
            if !(rho.is_finite() && rho > 0.0 && rho <= MAX_DENSITY) {
                return Err(format!(
                    "density must be in (0, {MAX_DENSITY}] kg/m³, got {rho}"
                ));
            }
            Amount::Density(rho)
        }
        (Some(_), Some(_)) => return Err("mass or density, not both".into()),
        (None, None) => return Err("mass or density is missing".into()),
    };
    let f = e.friction;
    if !(f.is_finite() && f > 0.0 && f <= MAX_FRICTION) {
        return Err(format!("friction must be in (0, {MAX_FRICTION}], got {f}"));
    }
    if let Some(c) = e.center_of_mass {
        if !c.iter().all(|v| v.is_finite() && v.abs() < MAX_COORDINATE) {
            return Err(format!(
                "center_of_mass must be finite and within ±{MAX_COORDINATE} m, got {c:?}"
            ));
        }
    }
    Ok(Entry {
        amount,
        friction: f,
        center_of_mass: e.center_of_mass,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: &str = "
objects:
  mug: {mass: 0.3, friction: 0.6, center_of_mass: [0, 0, 0.04]}
  brick: {density: 2000, friction: 0.8}
meshes:
  \"package://grasp_orient/meshes/box.stl\": {mass: 0.2, friction: 0.5}
";

    #[test]
    fn a_table_reads_by_id_and_by_resource() {
        let t = ObjectTable::parse(TABLE).expect("a table");
        assert_eq!(t.len(), 3);
        let mug = t.object("mug").expect("mug");
        assert_eq!(mug.amount, Amount::Mass(0.3));
        assert_eq!(mug.center_of_mass, Some([0.0, 0.0, 0.04]));
        let brick = t.object("brick").expect("brick");
        // 2000 kg/m³ times a 0.1 m cube's 0.001 m³.
        let m = brick.mass(|| Ok(0.001)).expect("a mass");
        assert!((m - 2.0).abs() < 1e-12, "{m}");
        assert!(t.object("nothing").is_none());
        let mut o = GraspObject {
            mesh: "package://grasp_orient/meshes/box.stl".into(),
            ..GraspObject::default()
        };
        assert!(t.fill(&mut o));
        assert_eq!(
            (o.mass, o.friction, o.has_center_of_mass),
            (0.2, 0.5, false)
        );
        // A candidate's own mass and friction win.
        let mut given = GraspObject {
            mesh: o.mesh.clone(),
            mass: 1.0,
            friction: 0.9,
            ..GraspObject::default()
        };
        assert!(!t.fill(&mut given));
        assert_eq!((given.mass, given.friction), (1.0, 0.9));
        let mut other = GraspObject {
            mesh: "package://x/y.stl".into(),
            ..GraspObject::default()
        };
        assert!(!t.fill(&mut other));
        assert_eq!(other.mass, 0.0);
    }

    #[test]
    fn bad_entries_are_refused_naming_the_entry_and_the_field() {
        for (text, words) in [
            (
                "objects: {a: {friction: 0.5}}",
                "objects: \"a\": mass or density is missing",
            ),
            (
                "objects: {a: {mass: 1, density: 2, friction: 0.5}}",
                "not both",
            ),
            (
                "objects: {a: {mass: -1, friction: 0.5}}",
                "mass must be in (0",
            ),
            (
                "objects: {a: {mass: .nan, friction: 0.5}}",
                "mass must be in (0",
            ),
            (
                "objects: {a: {mass: 1, friction: 0}}",
                "friction must be in (0",
            ),
            (
                "objects: {a: {density: 1e9, friction: 1}}",
                "density must be in (0",
            ),
            (
                "meshes: {m: {density: 10, friction: 1}}",
                "meshes: \"m\": a mesh resource's entry gives mass",
            ),
            (
                "objects: {a: {mass: 1, friction: 1, center_of_mass: [0, .inf, 0]}}",
                "center_of_mass",
            ),
            (
                "objects: {a: {mass: 1, friction: 1, colour: red}}",
                "unknown field `colour`",
            ),
            ("things: {}", "unknown field `things`"),
            ("objects: [1, 2]", "invalid type"),
        ] {
            let e = ObjectTable::parse(text).expect_err(text);
            assert!(e.contains(words), "{text}: {e}");
        }
        let many: String = (0..=MAX_ENTRIES)
            .map(|i| format!("  o{i}: {{mass: 1, friction: 1}}\n"))
            .collect();
        let e = ObjectTable::parse(&format!("objects:\n{many}")).expect_err("too many");
        assert!(e.contains("more than 10000"), "{e}");
        let e = ObjectTable::parse(&format!(
            "objects:\n  ? \"{}\"\n  : {{mass: 1, friction: 1}}\n",
            "x".repeat(MAX_NAME_BYTES + 1)
        ))
        .expect_err("a long name");
        assert!(e.contains("a name of 1 to"), "{e}");
    }

    #[test]
    fn a_density_that_makes_no_mass_is_refused() {
        let t = ObjectTable::parse("objects: {a: {density: 1000, friction: 1}}").expect("table");
        let e = t
            .object("a")
            .expect("a")
            .mass(|| Ok(0.0))
            .expect_err("no volume");
        assert!(e.contains("is not a mass"), "{e}");
        let e = t
            .object("a")
            .expect("a")
            .mass(|| Err("an open mesh has no volume".into()))
            .expect_err("no volume");
        assert_eq!(e, "an open mesh has no volume");
    }

    #[test]
    fn the_file_is_bounded_and_its_errors_name_it() {
        let dir = tempfile::tempdir().expect("a dir");
        let path = dir.path().join("objects.yaml");
        std::fs::write(&path, TABLE).expect("written");
        let t = ObjectTable::load(path.to_str().expect("utf-8")).expect("a table");
        assert_eq!(t.len(), 3);
        let big = dir.path().join("big.yaml");
        std::fs::write(&big, " ".repeat(MAX_OBJECTS_FILE_BYTES as usize + 1)).expect("written");
        let e = ObjectTable::load(big.to_str().expect("utf-8")).expect_err("too long");
        assert!(
            e.contains("big.yaml") && e.contains("longer than 1048576 bytes"),
            "{e}"
        );
        let e = ObjectTable::load("/nonexistent/objects.yaml").expect_err("missing");
        assert!(
            e.starts_with("objects_file \"/nonexistent/objects.yaml\""),
            "{e}"
        );
        assert!(ObjectTable::load("").expect("no table").len() == 0);
        // What a peer is told names the object and the parameter, not the file.
        let words = missing("mug");
        assert!(
            words.contains("\"mug\"") && words.contains("objects_file"),
            "{words}"
        );
        assert!(!words.contains("objects.yaml"));
    }
}
