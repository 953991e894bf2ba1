//! Mesh files written here (binary and ASCII STL, OBJ, COLLADA), read back through `load`,
//! `package://` through a temporary ament prefix, and the cache.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

use grasp_orient_geometry::{load, AmentIndex, Mesh, MeshCache};
use nalgebra::Point3;

use crate::objects::{faceted_cylinder, l_prism, TestMesh};
use crate::reference::divergence_volume_centroid;

/// An L prism in millimetres; every coordinate is exact in f32, as the formats store them.
fn l_mm() -> TestMesh {
    l_prism(64.0, 24.0)
}

fn triangle_corners(m: &TestMesh) -> impl Iterator<Item = [[f64; 3]; 3]> + '_ {
    m.triangles
        .iter()
        .map(|t| t.map(|k| m.vertices[k as usize]))
}

pub fn write_binary_stl(path: &Path, m: &TestMesh) {
    let mut bytes = vec![0u8; 80];
    bytes.extend((m.triangles.len() as u32).to_le_bytes());
    for corners in triangle_corners(m) {
        bytes.extend([0u8; 12]); // the normal: readers recompute it
        for c in corners {
            for v in c {
                bytes.extend((v as f32).to_le_bytes());
            }
        }
        bytes.extend([0u8; 2]);
    }
    fs::write(path, bytes).expect("write STL");
}

fn write_ascii_stl(path: &Path, m: &TestMesh) {
    let mut s = String::from("solid l\n");
    for corners in triangle_corners(m) {
        s.push_str("  facet normal 0 0 0\n    outer loop\n");
        for c in corners {
            let _ = writeln!(s, "      vertex {} {} {}", c[0], c[1], c[2]);
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    s.push_str("endsolid l\n");
    fs::write(path, s).expect("write STL");
}

fn write_obj(path: &Path, m: &TestMesh) {
    let mut s = String::from("# an L prism\no l\n");
    for v in &m.vertices {
        let _ = writeln!(s, "v {} {} {}", v[0], v[1], v[2]);
    }
    for t in &m.triangles {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    fs::write(path, s).expect("write OBJ");
}

/// COLLADA 1.4 with `<unit meter="0.001">`: the loader turns it into metres.
fn write_dae(path: &Path, m: &TestMesh) {
    let positions: Vec<String> = m
        .vertices
        .iter()
        .flat_map(|v| v.map(|x| x.to_string()))
        .collect();
    let indices: Vec<String> = m
        .triangles
        .iter()
        .flat_map(|t| t.map(|k| k.to_string()))
        .collect();
    let s = format!(
        r##"<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="millimeter" meter="0.001"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries>
    <geometry id="l-mesh" name="l">
      <mesh>
        <source id="l-positions">
          <float_array id="l-positions-array" count="{np}">{positions}</float_array>
          <technique_common>
            <accessor source="#l-positions-array" count="{nv}" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="l-vertices"><input semantic="POSITION" source="#l-positions"/></vertices>
        <triangles count="{nt}">
          <input semantic="VERTEX" source="#l-vertices" offset="0"/>
          <p>{indices}</p>
        </triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene">
      <node id="l" name="l"><instance_geometry url="#l-mesh"/></node>
    </visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"##,
        np = positions.len(),
        nv = m.vertices.len(),
        nt = m.triangles.len(),
        positions = positions.join(" "),
        indices = indices.join(" "),
    );
    fs::write(path, s).expect("write DAE");
}

/// Volume and centroid of the L in metres, by the reference.
fn expected_l() -> (f64, Point3<f64>) {
    let m = l_mm();
    divergence_volume_centroid(&m.points(0.001), &m.indices())
}

fn assert_is_l(mesh: &Mesh) {
    let (volume, centroid) = expected_l();
    let got = mesh.volume().expect("closed");
    assert!((got - volume).abs() <= 1e-12 * volume, "{got} vs {volume}");
    let c = mesh.centroid().expect("closed");
    assert!((c - centroid).norm() < 1e-12, "{c} vs {centroid}");
    assert_eq!(mesh.vertex_count(), 12);
    assert_eq!(mesh.triangle_count(), 20);
}

#[test]
fn stl_obj_and_collada_files_load_as_the_same_solid() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let m = l_mm();
    let binary = dir.path().join("l_binary.stl");
    let ascii = dir.path().join("l_ascii.STL");
    let obj = dir.path().join("l.obj");
    write_binary_stl(&binary, &m);
    write_ascii_stl(&ascii, &m);
    write_obj(&obj, &m);
    // A binary STL whose header begins with "solid", as some CAD programs write it.
    let solid_header = dir.path().join("l_solid_header.stl");
    write_binary_stl(&solid_header, &m);
    let mut bytes = fs::read(&solid_header).expect("read");
    bytes[..11].copy_from_slice(b"solid part ");
    fs::write(&solid_header, bytes).expect("write");
    for path in [&binary, &ascii, &obj, &solid_header] {
        let resource = format!("file://{}", path.display());
        assert_is_l(&load(&resource, [0.001; 3], &AmentIndex::default()).expect("loads"));
        let plain = path.display().to_string();
        assert_is_l(&load(&plain, [0.001; 3], &AmentIndex::default()).expect("loads"));
    }
    // COLLADA carries its own unit, millimetres, so its scale is 1. mesh-loader applies the
    // unit in single precision (its vertices are f32), so the mesh agrees to f32's precision.
    let dae = dir.path().join("l.dae");
    write_dae(&dae, &m);
    let mesh = load(&dae.display().to_string(), [1.0; 3], &AmentIndex::default()).expect("loads");
    let (volume, centroid) = expected_l();
    let got = mesh.volume().expect("closed");
    assert!((got - volume).abs() <= 1e-6 * volume, "{got} vs {volume}");
    let c = mesh.centroid().expect("closed");
    assert!((c - centroid).norm() <= 1e-6 * 0.064, "{c} vs {centroid}");
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (12, 20));
}

/// A prefix with `share/ament_index/resource_index/packages/<pkg>` and the mesh under
/// `share/<pkg>/meshes/`.
fn ament_prefix(root: &Path, name: &str, package: &str, marker: bool) -> PathBuf {
    let prefix = root.join(name);
    let index = prefix.join("share/ament_index/resource_index/packages");
    fs::create_dir_all(&index).expect("mkdir");
    if marker {
        fs::write(index.join(package), "").expect("marker");
    }
    let meshes = prefix.join("share").join(package).join("meshes");
    fs::create_dir_all(&meshes).expect("mkdir");
    prefix
}

#[test]
fn package_resources_resolve_through_the_ament_index() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    // The first prefix has the files but no marker: ament skips it, and so must we.
    let unmarked = ament_prefix(dir.path(), "unmarked", "grasp_objects", false);
    let marked = ament_prefix(dir.path(), "marked", "grasp_objects", true);
    let shadowed = ament_prefix(dir.path(), "later", "grasp_objects", true);
    let m = l_mm();
    write_binary_stl(&marked.join("share/grasp_objects/meshes/l.stl"), &m);
    // A bad file in an unmarked prefix and in a later prefix: never read.
    fs::write(
        unmarked.join("share/grasp_objects/meshes/l.stl"),
        "not a mesh",
    )
    .expect("write");
    fs::write(
        shadowed.join("share/grasp_objects/meshes/l.stl"),
        "not a mesh",
    )
    .expect("write");
    let index = AmentIndex::new([
        PathBuf::new(),
        dir.path().join("missing"),
        unmarked,
        marked.clone(),
        shadowed,
    ]);
    assert_eq!(
        index.package_share("grasp_objects"),
        Some(marked.join("share/grasp_objects"))
    );
    let mesh = load("package://grasp_objects/meshes/l.stl", [0.001; 3], &index).expect("resolves");
    assert_is_l(&mesh);
}

#[test]
fn the_cache_loads_a_resource_once_and_keeps_within_its_bound() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let m = l_mm();
    let a = dir.path().join("a.stl");
    let b = dir.path().join("b.stl");
    write_binary_stl(&a, &m);
    write_binary_stl(&b, &m);
    let (a, b) = (a.display().to_string(), b.display().to_string());
    let one = load(&a, [0.001; 3], &AmentIndex::default())
        .expect("loads")
        .bytes();

    let cache = MeshCache::new(AmentIndex::default(), 10 * one);
    let first = cache.get(&a, [0.001; 3]).expect("loads");
    let again = cache.get(&format!("file://{a}"), [0.001; 3]).expect("kept");
    assert!(std::sync::Arc::ptr_eq(&first, &again));
    // Kept: the file's mesh at scale 1, and at 0.001.
    assert_eq!((cache.loads(), cache.len()), (1, 2));
    cache
        .get(&a, [0.002; 3])
        .expect("another scale is another mesh, made without a load");
    cache
        .get(&a, [0.001, 0.002, 0.001])
        .expect("a scale per axis too");
    assert_eq!((cache.loads(), cache.len()), (1, 4));

    // Room for one: the least recently used goes.
    let small = MeshCache::new(AmentIndex::default(), one + one / 2);
    small.get(&a, [0.001; 3]).expect("loads");
    small.get(&b, [0.001; 3]).expect("loads");
    assert_eq!((small.len(), small.loads()), (1, 2));
    assert!(small.bytes() <= one + one / 2);
    small.get(&b, [0.001; 3]).expect("kept");
    assert_eq!(small.loads(), 2);
    small.get(&a, [0.001; 3]).expect("loaded again");
    assert_eq!(small.loads(), 3);

    // No room at all: served, never kept.
    let none = MeshCache::new(AmentIndex::default(), one - 1);
    none.get(&a, [0.001; 3]).expect("loads");
    none.get(&a, [0.001; 3]).expect("loads");
    assert_eq!((none.len(), none.loads(), none.bytes()), (0, 2, 0));
}

/// Sets a file's modification time.
fn set_modified(path: &Path, time: std::time::SystemTime) {
    fs::File::options()
        .write(true)
        .open(path)
        .and_then(|f| f.set_modified(time))
        .expect("set the modification time");
}

/// A kept mesh whose file changed on disk (its modification time, or its size) is loaded again;
/// an unchanged one is kept, and a file removed is an error, not the old mesh.
#[test]
fn the_cache_reloads_a_file_whose_time_or_size_changed() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("l.stl");
    let resource = path.display().to_string();
    let (large, small) = (l_prism(64.0, 24.0), l_prism(32.0, 24.0));
    let volume = |m: &Mesh| m.volume().expect("closed");
    write_binary_stl(&path, &large);
    let written = fs::metadata(&path)
        .and_then(|m| m.modified())
        .expect("a modification time");
    let cache = MeshCache::new(AmentIndex::default(), 1 << 30);
    let first = cache.get(&resource, [0.001; 3]).expect("loads");
    let again = cache.get(&resource, [0.001; 3]).expect("kept");
    assert!(std::sync::Arc::ptr_eq(&first, &again));
    assert_eq!(cache.loads(), 1);

    // The same size (binary STL: as many triangles), a later time.
    write_binary_stl(&path, &small);
    let later = written + std::time::Duration::from_secs(5);
    set_modified(&path, later);
    let changed = cache.get(&resource, [0.001; 3]).expect("loaded again");
    assert_eq!(cache.loads(), 2);
    assert!((volume(&changed) - volume(&first) / 4.0).abs() < 1e-12 * volume(&first));
    // The former content's meshes are gone; the new one's at scales 1 and 0.001 are kept.
    assert_eq!((cache.len(), cache.bytes()), (2, 2 * changed.bytes()));

    // Another size, the same time.
    write_ascii_stl(&path, &large);
    set_modified(&path, later);
    let back = cache.get(&resource, [0.001; 3]).expect("loaded again");
    assert_eq!(cache.loads(), 3);
    assert_is_l(&back);
    cache.get(&resource, [0.001; 3]).expect("kept");
    assert_eq!(cache.loads(), 3);

    fs::remove_file(&path).expect("remove");
    assert!(cache.get(&resource, [0.001; 3]).is_err());
    assert!(!cache.holds(&resource, [0.001; 3]));
}

/// Callers asking at once for a resource not kept yet load it once: the others wait for that
/// load (a mesh of 80,000 triangles, which takes a while to index).
#[test]
fn callers_asking_at_once_for_a_new_resource_load_it_once() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("cylinder.stl");
    write_binary_stl(&path, &faceted_cylinder(30.0, 100.0, 20_000));
    let resource = path.display().to_string();
    let cache = MeshCache::new(AmentIndex::default(), 1 << 30);
    let callers = 4;
    let start = std::sync::Barrier::new(callers);
    let meshes: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..callers)
            .map(|_| {
                s.spawn(|| {
                    start.wait();
                    cache.get(&resource, [0.001; 3]).expect("loads")
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("no panic"))
            .collect()
    });
    assert_eq!(cache.loads(), 1);
    assert!(meshes.iter().all(|m| std::sync::Arc::ptr_eq(m, &meshes[0])));
}

/// With room for one mesh of a large file but not two, a sweep of scales parses the file once: a
/// mesh at another scale never drops the file's mesh at scale 1 it is made from (before, each
/// one did, and the next scale parsed the file again); it is served without being kept, and
/// drops nothing else for room it cannot have. Meshes at other scales go before meshes at
/// scale 1 to make room.
#[test]
fn a_scale_sweep_in_room_for_one_mesh_parses_the_file_once() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let big = dir.path().join("cylinder.stl");
    write_binary_stl(&big, &faceted_cylinder(30.0, 100.0, 2_000));
    let small = dir.path().join("l.stl");
    write_binary_stl(&small, &l_mm());
    let (big, small) = (big.display().to_string(), small.display().to_string());
    let size = |r: &str| {
        load(r, [1.0; 3], &AmentIndex::default())
            .expect("loads")
            .bytes()
    };
    let (b, s) = (size(&big), size(&small));
    assert!(4 * s < b, "{s} and {b} bytes");
    let cache = MeshCache::new(AmentIndex::default(), b + b / 2);
    let scales = [1.0, 1.0 + 1e-12, 1.001, 0.5, 2.0, 1.5];
    for round in 0..2 {
        for k in scales {
            let mesh = cache.get(&big, [k; 3]).expect("made");
            let direct = load(&big, [k; 3], &AmentIndex::default()).expect("loads");
            assert_eq!(mesh.size().to_bits(), direct.size().to_bits(), "{k}");
            assert_eq!(cache.loads(), 1, "round {round}, scale {k}");
        }
    }
    assert_eq!((cache.len(), cache.bytes()), (1, b));
    // The small file at two scales fits beside it.
    cache.get(&small, [1.0; 3]).expect("loads");
    cache.get(&small, [2.0; 3]).expect("made");
    assert_eq!((cache.loads(), cache.len()), (2, 3));
    // Another scale of the large file: not kept, and the small file's meshes stay.
    cache.get(&big, [3.0; 3]).expect("made");
    assert_eq!(
        (cache.loads(), cache.len(), cache.bytes()),
        (2, 3, b + 2 * s)
    );
    // A second large file makes room: the mesh at another scale goes first, then the meshes at
    // scale 1, least recently used first.
    let other = dir.path().join("other.stl");
    write_binary_stl(&other, &faceted_cylinder(30.0, 100.0, 2_000));
    let other = other.display().to_string();
    cache.get(&other, [1.0; 3]).expect("loads");
    assert_eq!((cache.loads(), cache.len()), (3, 1));
    assert!(cache.holds(&other, [1.0; 3]));
}

/// Callers asking at once for one file at different scales wait for one parse, even when its
/// mesh is too large to keep: the loader hands it over to the others through the file's turn
/// (before, each of them parsed the file again in turn).
#[test]
fn callers_at_other_scales_share_one_parse_even_unkept() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("cylinder.stl");
    write_binary_stl(&path, &faceted_cylinder(30.0, 100.0, 20_000));
    let resource = path.display().to_string();
    let cache = MeshCache::new(AmentIndex::default(), 1);
    let scales = [1.0, 1.0 + 1e-12, 1.001, 0.5];
    let start = std::sync::Barrier::new(scales.len());
    let sizes: Vec<f64> = std::thread::scope(|s| {
        let handles: Vec<_> = scales
            .iter()
            .map(|&k| {
                let (cache, resource, start) = (&cache, &resource, &start);
                s.spawn(move || {
                    start.wait();
                    cache.get(resource, [k; 3]).expect("made").size()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("no panic"))
            .collect()
    });
    assert_eq!((cache.loads(), cache.len()), (1, 0));
    for (k, size) in scales.iter().zip(&sizes) {
        let direct = load(&resource, [*k; 3], &AmentIndex::default()).expect("loads");
        assert_eq!(size.to_bits(), direct.size().to_bits(), "{k}");
    }
    // The turn ended with its last caller: the next asks load the file again (nothing is kept).
    cache.get(&resource, [1.0; 3]).expect("loads");
    assert_eq!(cache.loads(), 2);
}

/// The node will share meshes across its solver threads.
#[test]
fn meshes_and_the_cache_can_be_shared_across_threads() {
    fn shared<T: Send + Sync>() {}
    shared::<Mesh>();
    shared::<MeshCache>();
    shared::<grasp_orient_geometry::Shape>();
    shared::<grasp_orient_geometry::Object>();
}

/// A thread loading a mesh holds up no other thread's kept meshes: while a file of 400,000
/// triangles loads (parsed and indexed for a good part of a second), a kept mesh is served at
/// once (before, `get` held the cache's lock while it parsed, and the second `get` waited).
#[test]
fn a_load_does_not_hold_up_the_meshes_kept() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let dir = tempfile::tempdir().expect("a temporary folder");
    let kept = dir.path().join("kept.stl");
    write_binary_stl(&kept, &l_mm());
    let slow = dir.path().join("slow.stl");
    write_binary_stl(&slow, &faceted_cylinder(30.0, 100.0, 100_000));
    let (kept, slow) = (kept.display().to_string(), slow.display().to_string());
    let cache = MeshCache::new(AmentIndex::default(), usize::MAX);
    cache.get(&kept, [0.001; 3]).expect("loads");
    let loaded = AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| {
            cache.get(&slow, [0.001; 3]).expect("loads");
            loaded.store(true, Ordering::SeqCst);
        });
        std::thread::sleep(std::time::Duration::from_millis(20)); // the load is under way
        let started = std::time::Instant::now();
        cache.get(&kept, [0.001; 3]).expect("kept");
        let waited = started.elapsed();
        assert!(
            !loaded.load(Ordering::SeqCst),
            "the kept mesh was served only after the other load ({waited:?})"
        );
    });
    assert_eq!(cache.loads(), 2);
}
