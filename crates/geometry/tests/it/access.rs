//! What a mesh cache may read, and what its refusals say: files opened without blocking and
//! only when regular, a bound on their size, the mesh roots and `package://` confinement of a
//! confined access (the node's), one message for every refusal of a file there, resource
//! strings bounded and abbreviated, and each file parsed once whatever the scales asked.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use grasp_orient_geometry::load::{Access, DEFAULT_MAX_FILE_BYTES, MAX_RESOURCE_BYTES};
use grasp_orient_geometry::{
    cast_fingers, load, AmentIndex, ClosingAxis, GeometryError, GripperPose, Mesh, MeshCache,
    Object,
};
use nalgebra::{Isometry3, Point3};

use crate::files::write_binary_stl;
use crate::objects::{faceted_cylinder, l_prism};
use crate::reference::divergence_volume_centroid;

fn local() -> MeshCache {
    MeshCache::new(AmentIndex::default(), 1 << 30)
}

fn confined(roots: &[&Path], index: AmentIndex) -> MeshCache {
    MeshCache::with_access(index, Access::confined(roots), 1 << 30)
}

fn mkfifo(path: &Path) {
    let made = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(made.success());
}

/// The error of `get`, and how long it took.
fn refused(cache: &MeshCache, resource: &str) -> (GeometryError, Duration) {
    let started = Instant::now();
    let e = match cache.get(resource, [0.001; 3]) {
        Err(e) => e,
        Ok(_) => panic!("{resource} loaded"),
    };
    (e, started.elapsed())
}

fn p(path: &Path) -> String {
    path.display().to_string()
}

/// A FIFO without a writer is refused at once, not waited on (before, the open blocked until a
/// writer came, for ever).
#[test]
fn a_fifo_is_refused_at_once() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let fifo = dir.path().join("pipe.stl");
    mkfifo(&fifo);
    let (e, took) = refused(&local(), &p(&fifo));
    assert!(matches!(e, GeometryError::NotRegularFile { .. }), "{e}");
    assert!(e.to_string().contains("not a regular file"), "{e}");
    assert!(took < Duration::from_secs(1), "{took:?}");
    let (e, took) = refused(&confined(&[dir.path()], AmentIndex::default()), &p(&fifo));
    assert!(matches!(e, GeometryError::NotReadable { .. }), "{e}");
    assert!(took < Duration::from_secs(1), "{took:?}");
}

/// A link to `/dev/zero` is a device, refused before a byte is read (before, it was read
/// without end).
#[test]
fn a_link_to_dev_zero_is_refused_at_once() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let zero = dir.path().join("zero.stl");
    std::os::unix::fs::symlink("/dev/zero", &zero).expect("a link");
    let (e, took) = refused(&local(), &p(&zero));
    assert!(matches!(e, GeometryError::NotRegularFile { .. }), "{e}");
    assert!(took < Duration::from_secs(1), "{took:?}");
    // A directory named like a mesh is no regular file either.
    let folder = dir.path().join("folder.stl");
    fs::create_dir(&folder).expect("a folder");
    let (e, _) = refused(&local(), &p(&folder));
    assert!(matches!(e, GeometryError::NotRegularFile { .. }), "{e}");
}

/// A file larger than the bound is refused from its size, before reading: a sparse 2 GiB file
/// against the default bound, a small one against a small bound; one at the bound loads.
#[test]
fn a_file_over_the_size_bound_is_refused_before_reading() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let big = dir.path().join("big.stl");
    fs::File::create(&big)
        .and_then(|f| f.set_len(2 << 30))
        .expect("a sparse file");
    let (e, took) = refused(&local(), &p(&big));
    assert!(
        matches!(e, GeometryError::FileTooLarge { max, .. } if max == DEFAULT_MAX_FILE_BYTES),
        "{e}"
    );
    assert!(e.to_string().contains("max_mesh_file_bytes"), "{e}");
    assert!(took < Duration::from_secs(1), "{took:?}");

    let l = dir.path().join("l.stl");
    write_binary_stl(&l, &l_prism(64.0, 24.0));
    let size = fs::metadata(&l).expect("stat").len();
    let small = |max| {
        MeshCache::with_access(
            AmentIndex::default(),
            Access::local().with_max_file_bytes(max),
            1 << 30,
        )
    };
    let (e, _) = refused(&small(size - 1), &p(&l));
    assert!(matches!(e, GeometryError::FileTooLarge { .. }), "{e}");
    small(size).get(&p(&l), [0.001; 3]).expect("at the bound");
    let confined = MeshCache::with_access(
        AmentIndex::default(),
        Access::confined([dir.path()]).with_max_file_bytes(size - 1),
        1 << 30,
    );
    let (e, _) = refused(&confined, &p(&l));
    assert!(matches!(e, GeometryError::FileTooLarge { .. }), "{e}");
}

/// Files under a root load; files outside, and links under a root to files outside, do not; a
/// local access reads them all.
#[test]
fn only_files_under_the_mesh_roots_are_read() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let (root, outside) = (dir.path().join("root"), dir.path().join("outside"));
    fs::create_dir_all(root.join("sub")).expect("folders");
    fs::create_dir_all(&outside).expect("folders");
    let m = l_prism(64.0, 24.0);
    write_binary_stl(&root.join("sub/in.stl"), &m);
    write_binary_stl(&outside.join("out.stl"), &m);
    std::os::unix::fs::symlink(outside.join("out.stl"), root.join("link.stl")).expect("link");
    std::os::unix::fs::symlink(&outside, root.join("door")).expect("link");
    let cache = confined(&[&root], AmentIndex::default());
    cache
        .get(&p(&root.join("sub/in.stl")), [0.001; 3])
        .expect("under the root");
    cache
        .get(
            &format!("file://{}", p(&root.join("sub/in.stl"))),
            [0.001; 3],
        )
        .expect("under the root");
    cache
        .get(&p(&root.join("sub/../sub/in.stl")), [0.001; 3])
        .expect("`..` that stays under the root");
    for escape in [
        p(&outside.join("out.stl")),
        p(&root.join("link.stl")),
        p(&root.join("door/out.stl")),
        p(&root.join("../outside/out.stl")),
        format!("file://{}", p(&outside.join("out.stl"))),
    ] {
        let (e, _) = refused(&cache, &escape);
        assert!(
            matches!(e, GeometryError::NotReadable { .. }),
            "{escape}: {e}"
        );
        local()
            .get(&escape, [0.001; 3])
            .expect("a local access reads it");
    }
    // No roots: no file at all.
    let none = confined(&[], AmentIndex::default());
    let (e, _) = refused(&none, &p(&root.join("sub/in.stl")));
    assert!(matches!(e, GeometryError::NotReadable { .. }), "{e}");
}

/// An ament prefix holding package `grasp_objects` with `meshes/l.stl`.
fn ament_prefix(prefix: &Path) -> PathBuf {
    let marker = prefix.join("share/ament_index/resource_index/packages");
    fs::create_dir_all(&marker).expect("folders");
    fs::write(marker.join("grasp_objects"), "").expect("marker");
    let share = prefix.join("share/grasp_objects");
    fs::create_dir_all(share.join("meshes")).expect("folders");
    write_binary_stl(&share.join("meshes/l.stl"), &l_prism(64.0, 24.0));
    share
}

/// `package://` stays inside the package's share directory: a `..` that leaves it is refused,
/// with the message of any refusal, which names neither the prefix nor the environment; a
/// package not found says the same. A link the package's install put in its share directory is
/// followed (colcon's `--symlink-install` links every file to the source tree).
#[test]
fn package_resources_stay_inside_their_package() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let prefix = dir.path().join("install");
    let share = ament_prefix(&prefix);
    write_binary_stl(&dir.path().join("secret.stl"), &l_prism(64.0, 24.0));
    std::os::unix::fs::symlink(dir.path().join("secret.stl"), share.join("meshes/out.stl"))
        .expect("link");
    let index = AmentIndex::new([prefix.clone()]);
    let cache = confined(&[], index.clone());
    cache
        .get("package://grasp_objects/meshes/l.stl", [0.001; 3])
        .expect("inside the package");
    cache
        .get("package://grasp_objects/meshes/../meshes/l.stl", [0.001; 3])
        .expect("`..` that stays inside");
    cache
        .get("package://grasp_objects/meshes/out.stl", [0.001; 3])
        .expect("a link installed in the package");
    let escape = "package://grasp_objects/../../../secret.stl";
    local_escape_reads(&index, escape);
    let refusals: Vec<String> = [
        escape,
        "package://grasp_objects/meshes/../../../../secret.stl",
        "package://grasp_objects//etc/passwd.stl",
        "package://grasp_objects/meshes/missing.stl",
        "package://no_such_package/meshes/l.stl",
    ]
    .iter()
    .map(|r| {
        let (e, _) = refused(&cache, r);
        assert!(matches!(e, GeometryError::NotReadable { .. }), "{r}: {e}");
        let text = e.to_string();
        assert!(
            !text.contains(&p(&prefix)) && !text.contains("install"),
            "{text}"
        );
        text.replace(r, "<resource>")
    })
    .collect();
    assert!(refusals.iter().all(|t| *t == refusals[0]), "{refusals:#?}");
    assert_eq!(
        refusals[0],
        "mesh resource \"<resource>\": not under mesh_roots or not readable"
    );
}

/// The command line may follow `..` out of a package (its user reads their own files).
fn local_escape_reads(index: &AmentIndex, escape: &str) {
    load(escape, [0.001; 3], index).expect("a local access follows the path");
}

/// The probes of a peer mapping the host's files: `<p>/../x.stl` where `<p>` is a file, a
/// directory, a missing path, a socket (which even root cannot open) or a link loop, and the
/// same kinds named directly, each outside the roots and under them, all get one message once
/// the resource itself is taken out of it.
#[test]
fn probes_of_the_file_system_get_one_message() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let root = dir.path().join("root");
    let host = dir.path().join("host");
    let (mut texts, mut sockets) = (Vec::new(), Vec::new());
    for base in [&host, &root] {
        fs::create_dir_all(base.join("folder")).expect("folders");
        fs::write(base.join("file"), "secret").expect("a file");
        let socket = std::os::unix::net::UnixListener::bind(base.join("socket"));
        sockets.push(socket.expect("a socket"));
        std::os::unix::fs::symlink(base.join("loop"), base.join("loop")).expect("a loop");
        mkfifo(&base.join("pipe.stl"));
        std::os::unix::fs::symlink("/dev/zero", base.join("zero.stl")).expect("a link");
        fs::create_dir(base.join("folder.stl")).expect("a folder");
    }
    let cache = confined(&[&root], AmentIndex::default());
    for base in [&host, &root] {
        for probe in ["file", "folder", "missing", "socket", "loop"] {
            texts.push(probe_text(&cache, &format!("{}/{probe}/../x.stl", p(base))));
            texts.push(probe_text(&cache, &format!("{}/{probe}.stl", p(base))));
        }
        for direct in ["pipe.stl", "zero.stl", "folder.stl"] {
            texts.push(probe_text(&cache, &format!("{}/{direct}", p(base))));
        }
    }
    // Outside the roots even a mesh file is refused alike.
    write_binary_stl(&host.join("l.stl"), &l_prism(64.0, 24.0));
    texts.push(probe_text(&cache, &p(&host.join("l.stl"))));
    assert!(texts.iter().all(|t| *t == texts[0]), "{texts:#?}");
}

fn probe_text(cache: &MeshCache, resource: &str) -> String {
    match cache.get(resource, [1.0; 3]) {
        Err(e @ GeometryError::NotReadable { .. }) => e.to_string().replace(resource, ""),
        Err(e) => panic!("{resource}: {e}"),
        Ok(_) => panic!("{resource} loaded"),
    }
}

/// A resource longer than 4096 bytes is refused, and no error prints a long resource whole:
/// its first 200 bytes and its length.
#[test]
fn long_resources_are_refused_and_abbreviated() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let cache = confined(&[dir.path()], AmentIndex::default());
    let huge = format!("{}/{}.stl", p(dir.path()), "a".repeat(10 << 20));
    let (e, took) = refused(&cache, &huge);
    assert!(matches!(e, GeometryError::ResourceTooLong { .. }), "{e}");
    let text = e.to_string();
    assert!(text.len() < 300, "{} bytes: {}", text.len(), &text[..300]);
    assert!(text.contains(&format!("…({} bytes)", huge.len())), "{text}");
    assert!(text.contains("longer than 4096 bytes"), "{text}");
    assert!(took < Duration::from_secs(1), "{took:?}");
    assert!(!cache.holds(&huge, [1.0; 3]));
    let (e, _) = refused(&local(), &huge);
    assert!(matches!(e, GeometryError::ResourceTooLong { .. }), "{e}");

    // At the bound: read (here, not found); one byte more: refused.
    let name = |n: usize| {
        let head = format!("{}/", p(dir.path()));
        format!("{head}{}.stl", "b".repeat(n - head.len() - 4))
    };
    let at = name(MAX_RESOURCE_BYTES);
    assert_eq!(at.len(), MAX_RESOURCE_BYTES);
    let (e, _) = refused(&cache, &at);
    assert!(matches!(e, GeometryError::NotReadable { .. }), "{e}");
    assert!(e.to_string().len() < 300, "{e}");
    let (e, _) = refused(&cache, &name(MAX_RESOURCE_BYTES + 1));
    assert!(matches!(e, GeometryError::ResourceTooLong { .. }), "{e}");
}

/// Six scales of one file (five uniform, one per axis) cost one parse, and each mesh is the one
/// a load at that scale makes: the same corners bit for bit, the same contacts, and the volume
/// and centroid of the independent reference.
#[test]
fn a_scale_sweep_parses_the_file_once() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("cylinder.stl");
    let m = faceted_cylinder(30.0, 100.0, 64);
    write_binary_stl(&path, &m);
    let resource = p(&path);
    let cache = local();
    let scales = [
        [0.001; 3],
        [0.001 + 1e-15; 3],
        [0.0254; 3],
        [1.0; 3],
        [3.7; 3],
        [0.001, 0.002, 0.0005],
    ];
    for scale in scales {
        let kept = cache.get(&resource, scale).expect("loads");
        let direct = load(&resource, scale, &AmentIndex::default()).expect("loads");
        same_mesh(&kept, &direct);
        // The file holds each coordinate in f32.
        let f = |x: f64| f64::from(x as f32);
        let points: Vec<Point3<f64>> = m
            .vertices
            .iter()
            .map(|v| Point3::new(f(v[0]) * scale[0], f(v[1]) * scale[1], f(v[2]) * scale[2]))
            .collect();
        let (volume, centroid) = divergence_volume_centroid(&points, &m.indices());
        let v = kept.volume().expect("closed");
        assert!((v - volume).abs() <= 1e-12 * volume, "{v} against {volume}");
        let c = kept.centroid().expect("closed");
        assert!(
            (c - centroid).norm() <= 1e-12 * kept.size(),
            "{c} against {centroid}"
        );
    }
    assert_eq!(cache.loads(), 1);
    // Asked again: kept, no new mesh made.
    let before = cache.len();
    for scale in scales {
        cache.get(&resource, scale).expect("kept");
    }
    assert_eq!((cache.loads(), cache.len()), (1, before));
}

/// The same corners bit for bit, and the same contacts from a few grippers.
fn same_mesh(a: &Mesh, b: &Mesh) {
    assert_eq!(a.triangle_count(), b.triangle_count());
    let mut ca: Vec<_> = a.corners().map(bits).collect();
    let mut cb: Vec<_> = b.corners().map(bits).collect();
    ca.sort_unstable();
    cb.sort_unstable();
    assert!(ca == cb, "the corners differ");
    assert_eq!(a.size().to_bits(), b.size().to_bits());
    let size = a.size();
    let (a, b): (Object, Object) = (
        Object {
            pose: Isometry3::identity(),
            shape: a.clone().into(),
        },
        Object {
            pose: Isometry3::identity(),
            shape: b.clone().into(),
        },
    );
    for k in 0..8 {
        let t = f64::from(k) / 8.0;
        let gripper = GripperPose {
            tool_pose: Isometry3::new(
                nalgebra::Vector3::new(0.1 * t * size, 0.0, (t - 0.5) * 0.5 * size),
                nalgebra::Vector3::new(0.0, 0.0, t * 3.0),
            ),
            width: 2.0 * size,
            closing_axis: ClosingAxis::Y,
        };
        match (cast_fingers(&gripper, &a), cast_fingers(&gripper, &b)) {
            (Ok(ka), Ok(kb)) => {
                for (x, y) in ka.iter().zip(&kb) {
                    assert_eq!(x.point, y.point);
                }
            }
            (ka, kb) => assert_eq!(format!("{ka:?}"), format!("{kb:?}")),
        }
    }
}

fn bits(c: [[f64; 3]; 3]) -> [[u64; 3]; 3] {
    c.map(|p| p.map(f64::to_bits))
}
