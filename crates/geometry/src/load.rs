//! Mesh resources: resolved as ROS resolves them, parsed, indexed, and kept in a bounded cache.
//!
//! # Resources
//! - `package://<pkg>/<path>`: the ament index, as `ament_index_python`'s
//!   `get_package_share_directory` finds it: the package name must match
//!   `[a-zA-Z0-9][a-zA-Z0-9_-]+`; for each prefix of `AMENT_PREFIX_PATH` in order (empty and
//!   missing entries skipped), the first whose `share/ament_index/resource_index/packages/<pkg>`
//!   is a file is the package's prefix, and the file is `<prefix>/share/<pkg>/<path>`.
//! - `file://<path>`: the path after the scheme (`file:///a/b.stl` is `/a/b.stl`).
//! - Anything without `://`: a plain path. Other schemes are refused.
//!
//! # Formats
//! By the file name's extension ([`crate::formats`]): STL, OBJ and COLLADA.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

use crate::error::GeometryError;
pub use crate::formats::{check_format, parse_bytes, Triangles};
use crate::mesh::Mesh;

/// The prefixes of an ament index (`AMENT_PREFIX_PATH`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AmentIndex {
    prefixes: Vec<PathBuf>,
}

impl AmentIndex {
    /// The prefixes in `AMENT_PREFIX_PATH` (none if it is unset).
    pub fn from_env() -> Self {
        let prefixes = std::env::var_os("AMENT_PREFIX_PATH")
            .map(|value| std::env::split_paths(&value).collect())
            .unwrap_or_default();
        AmentIndex { prefixes }
    }

    /// These prefixes, searched in order.
    pub fn new<P: Into<PathBuf>>(prefixes: impl IntoIterator<Item = P>) -> Self {
        AmentIndex {
            prefixes: prefixes.into_iter().map(Into::into).collect(),
        }
    }

    /// The share directory of a package, `<prefix>/share/<package>`, if a prefix has the package
    /// in its index.
    pub fn package_share(&self, package: &str) -> Option<PathBuf> {
        self.prefixes
            .iter()
            .filter(|p| !p.as_os_str().is_empty() && p.exists())
            .find(|p| {
                p.join("share/ament_index/resource_index/packages")
                    .join(package)
                    .is_file()
            })
            .map(|p| p.join("share").join(package))
    }
}

fn valid_package_name(name: &str) -> bool {
    let mut chars = name.chars();
    let first_ok = chars.next().is_some_and(|c| c.is_ascii_alphanumeric());
    first_ok && name.len() >= 2 && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// The file a resource names.
pub fn resolve(resource: &str, index: &AmentIndex) -> Result<PathBuf, GeometryError> {
    if let Some(rest) = resource.strip_prefix("package://") {
        let (package, path) = rest.split_once('/').unwrap_or((rest, ""));
        if !valid_package_name(package) {
            return Err(GeometryError::InvalidPackageName {
                resource: resource.to_owned(),
                package: package.to_owned(),
            });
        }
        let share = index
            .package_share(package)
            .ok_or_else(|| GeometryError::PackageNotFound {
                resource: resource.to_owned(),
                package: package.to_owned(),
                searched: index.prefixes.clone(),
            })?;
        Ok(share.join(path))
    } else if let Some(path) = resource.strip_prefix("file://") {
        Ok(PathBuf::from(path))
    } else if resource.contains("://") {
        Err(GeometryError::UnsupportedScheme {
            resource: resource.to_owned(),
        })
    } else {
        Ok(PathBuf::from(resource))
    }
}

/// Read and parse a mesh file, without indexing it.
pub fn parse(resource: &str, path: &Path) -> Result<Triangles, GeometryError> {
    check_format(resource, path)?;
    let bytes = std::fs::read(path).map_err(|source| GeometryError::Unreadable {
        resource: resource.to_owned(),
        path: path.to_owned(),
        source,
    })?;
    parse_bytes(resource, path, &bytes)
}

/// Resolve, parse and index a mesh resource, scaled per axis into metres.
pub fn load(resource: &str, scale: [f64; 3], index: &AmentIndex) -> Result<Mesh, GeometryError> {
    let path = resolve(resource, index)?;
    let (vertices, triangles) = parse(resource, &path)?;
    Mesh::from_triangles(resource, &vertices, &triangles, scale)
}

/// Loaded meshes, each loaded once per resolved file and scale, holding at most a number of
/// bytes ([`Mesh::bytes`]).
///
/// - **Bound.** When a new mesh does not fit, the least recently used ones are dropped until it
///   does; a mesh larger than the whole bound is returned but not kept. Meshes handed out stay
///   alive while a caller holds them.
/// - **Changed files.** Each lookup reads the file's modification time and size (one `stat`);
///   when either differs from what they were before the kept mesh was read, or the file is gone,
///   the kept mesh is dropped and the file loaded again (or its error returned). A file
///   rewritten with the same size within the file system's timestamp resolution is not noticed.
/// - **Locking.** The cache's lock is held only to look up and to store, never while a file is
///   read, parsed and indexed: a lookup of a kept mesh is not delayed by another resource's
///   load. Callers asking at once for the same resource that is not kept queue on a lock of
///   that resource's own: the first loads it, the others then find it kept. If the first fails,
///   or its mesh is too large to keep, each of the others loads it in turn (and gets its own
///   error): failures are quick, and a mesh beyond the bound is not worth a second mechanism.
#[derive(Debug)]
pub struct MeshCache {
    index: AmentIndex,
    max_bytes: usize,
    inner: Mutex<CacheInner>,
}

/// A file resolved, at a scale (the bits of each factor, `-0.0` as `0.0`).
type Key = (PathBuf, [u64; 3]);

#[derive(Debug, Default)]
struct CacheInner {
    entries: HashMap<Key, Entry>,
    /// The resources being loaded, each with the lock its loader holds while it loads.
    loading: HashMap<Key, Arc<Mutex<()>>>,
    bytes: usize,
    clock: u64,
    loads: u64,
}

#[derive(Debug)]
struct Entry {
    mesh: Arc<Mesh>,
    stamp: Option<Stamp>,
    last_used: u64,
}

/// What tells a file changed: its modification time (when the platform has one) and its size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Stamp {
    modified: Option<SystemTime>,
    len: u64,
}

impl Stamp {
    /// The file's stamp, or `None` when it cannot be read (then no kept mesh matches it).
    fn of(path: &Path) -> Option<Stamp> {
        let metadata = std::fs::metadata(path).ok()?;
        Some(Stamp {
            modified: metadata.modified().ok(),
            len: metadata.len(),
        })
    }
}

impl MeshCache {
    /// An empty cache resolving `package://` through `index`, holding at most `max_bytes`.
    pub fn new(index: AmentIndex, max_bytes: usize) -> Self {
        MeshCache {
            index,
            max_bytes,
            inner: Mutex::new(CacheInner::default()),
        }
    }

    /// The mesh of a resource at a scale: the one kept if its file has not changed since, else
    /// the file loaded (outside the cache's lock) and kept if it fits.
    pub fn get(&self, resource: &str, scale: [f64; 3]) -> Result<Arc<Mesh>, GeometryError> {
        let path = resolve(resource, &self.index)?;
        let key_path = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        let key = (key_path, scale.map(|s| (s + 0.0).to_bits()));
        let stamp = Stamp::of(&path);
        let turn = {
            let mut inner = self.lock();
            if let Some(mesh) = inner.kept(&key, stamp) {
                return Ok(mesh);
            }
            Arc::clone(inner.loading.entry(key.clone()).or_default())
        };
        let held = turn.lock().unwrap_or_else(|e| e.into_inner());
        // Another caller may have loaded it while this one waited its turn.
        let stamp = Stamp::of(&path);
        {
            let mut inner = self.lock();
            if let Some(mesh) = inner.kept(&key, stamp) {
                inner.end_turn(&key, &turn);
                return Ok(mesh);
            }
        }
        let loaded = parse(resource, &path)
            .and_then(|(v, t)| Mesh::from_triangles(resource, &v, &t, scale))
            .map(Arc::new);
        let mut inner = self.lock();
        inner.end_turn(&key, &turn);
        let mesh = loaded?;
        inner.loads += 1;
        inner.keep(key, &mesh, stamp, self.max_bytes);
        drop(inner);
        drop(held);
        Ok(mesh)
    }

    /// Whether the mesh of a resource at a scale is kept (a `get` would not load it); false for
    /// a resource that does not resolve.
    pub fn holds(&self, resource: &str, scale: [f64; 3]) -> bool {
        let Ok(path) = resolve(resource, &self.index) else {
            return false;
        };
        let key_path = std::fs::canonicalize(&path).unwrap_or(path);
        let key = (key_path, scale.map(|s| (s + 0.0).to_bits()));
        self.lock().entries.contains_key(&key)
    }

    /// The bytes the kept meshes hold.
    pub fn bytes(&self) -> usize {
        self.lock().bytes
    }

    /// How many meshes are kept.
    pub fn len(&self) -> usize {
        self.lock().entries.len()
    }

    /// Whether no mesh is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// How many files have been loaded (parsed and indexed) so far.
    pub fn loads(&self) -> u64 {
        self.lock().loads
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, CacheInner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl CacheInner {
    /// The kept mesh of `key` if its file's stamp is still `stamp`; a kept mesh whose file
    /// changed is dropped.
    fn kept(&mut self, key: &Key, stamp: Option<Stamp>) -> Option<Arc<Mesh>> {
        self.clock += 1;
        let now = self.clock;
        let entry = self.entries.get_mut(key)?;
        if stamp.is_some() && entry.stamp == stamp {
            entry.last_used = now;
            return Some(Arc::clone(&entry.mesh));
        }
        self.remove(key);
        None
    }

    /// The resource's lock is no longer the one to queue on, if it still is `turn` (callers
    /// already queued on it find the mesh kept, or load it in turn).
    fn end_turn(&mut self, key: &Key, turn: &Arc<Mutex<()>>) {
        if self.loading.get(key).is_some_and(|t| Arc::ptr_eq(t, turn)) {
            self.loading.remove(key);
        }
    }

    /// Keeps a mesh just loaded, dropping the least recently used ones to make room; not at all
    /// if it is larger than the whole bound.
    fn keep(&mut self, key: Key, mesh: &Arc<Mesh>, stamp: Option<Stamp>, max_bytes: usize) {
        self.remove(&key);
        let size = mesh.bytes();
        if size > max_bytes {
            return;
        }
        while self.bytes + size > max_bytes && !self.entries.is_empty() {
            self.evict_oldest();
        }
        self.bytes += size;
        let entry = Entry {
            mesh: Arc::clone(mesh),
            stamp,
            last_used: self.clock,
        };
        self.entries.insert(key, entry);
    }

    fn remove(&mut self, key: &Key) {
        if let Some(entry) = self.entries.remove(key) {
            self.bytes -= entry.mesh.bytes();
        }
    }

    fn evict_oldest(&mut self) {
        let oldest = self
            .entries
            .iter()
            .min_by_key(|(_, e)| e.last_used)
            .map(|(k, _)| k.clone());
        match oldest {
            Some(key) => self.remove(&key),
            None => self.bytes = 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn package_names_follow_ament() {
        assert!(valid_package_name("grasp_orient"));
        assert!(valid_package_name("a-1"));
        assert!(!valid_package_name("a"));
        assert!(!valid_package_name("_a"));
        assert!(!valid_package_name("a/b"));
        assert!(!valid_package_name("a.b"));
    }

    #[test]
    fn schemes() {
        let index = AmentIndex::default();
        assert_eq!(
            resolve("file:///tmp/a.stl", &index).ok(),
            Some(PathBuf::from("/tmp/a.stl"))
        );
        assert_eq!(
            resolve("meshes/a.stl", &index).ok(),
            Some(PathBuf::from("meshes/a.stl"))
        );
        assert!(matches!(
            resolve("http://example/a.stl", &index),
            Err(GeometryError::UnsupportedScheme { .. })
        ));
        assert!(matches!(
            resolve("package://x/a.stl", &index),
            Err(GeometryError::InvalidPackageName { .. })
        ));
        assert!(matches!(
            resolve("package://nowhere/a.stl", &index),
            Err(GeometryError::PackageNotFound { .. })
        ));
    }
}
