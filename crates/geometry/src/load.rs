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
//! A resource string longer than [`MAX_RESOURCE_BYTES`] is refused before anything else.
//!
//! # Access
//! What may be read, and what a refusal says, is an [`Access`]:
//! - [`Access::local`] (the command line's: a local user's own files): any path, and errors that
//!   say why (the OS error, the ament prefixes searched).
//! - [`Access::confined`] (the node's: resources come from any peer on the ROS domain): a
//!   `file://` or plain path only when its canonical path (symbolic links and `..` resolved)
//!   lies under one of the canonical mesh roots; a `package://` resource only when its path,
//!   taken by its text, stays inside the share directory of its package (links installed there
//!   are followed). Every refusal of the file
//!   itself (outside the roots, missing, not permitted, not a regular file, the package not
//!   found) is one message, [`GeometryError::NotReadable`], so that a peer learns nothing of the
//!   host's files; what is wrong with the resource's text (its scheme, its package name, its
//!   extension, its length) and with a file that was opened (its size, its format) is said.
//!
//! # Reading
//! A file is opened without blocking (`O_NONBLOCK`: opening a FIFO with no writer returns at
//! once), and the opened handle's status decides: anything but a regular file (a FIFO, a device
//! such as `/dev/zero` behind a link, a directory, a socket) is refused before a byte is read. A
//! file larger than the access's most bytes ([`Access::max_file_bytes`]) is refused before
//! reading too, and the read itself stops one byte past the bound, so a file growing meanwhile
//! is refused rather than read without end.
//!
//! # Formats
//! By the file name's extension ([`crate::formats`]): STL, OBJ and COLLADA.

use std::collections::HashMap;
use std::fs::File;
use std::io::Read;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::error::GeometryError;
pub use crate::error::MAX_RESOURCE_BYTES;
pub use crate::formats::{check_format, parse_bytes, Triangles};
use crate::mesh::Mesh;

/// The most bytes a mesh file may hold unless an [`Access`] says otherwise: 256 MiB, five times
/// a binary STL of a million triangles (50 bytes each, 50 MB) and above the ASCII STL or OBJ of
/// one (about 250 and 60 MB), while a read of it stays within a second or two and well within
/// the node's memory.
pub const DEFAULT_MAX_FILE_BYTES: u64 = 256 << 20;

/// What files a [`MeshCache`] (or [`load`]) may read, and how much of one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Access {
    /// `None`: any path, errors in detail. `Some`: the canonical mesh roots.
    roots: Option<Vec<PathBuf>>,
    max_file_bytes: u64,
}

impl Default for Access {
    fn default() -> Self {
        Access::local()
    }
}

impl Access {
    /// Any file a local user names, with errors that say why one cannot be read; files of at
    /// most [`DEFAULT_MAX_FILE_BYTES`].
    pub fn local() -> Self {
        Access {
            roots: None,
            max_file_bytes: DEFAULT_MAX_FILE_BYTES,
        }
    }

    /// Only files under `roots` (each canonicalized now, relative ones against the working
    /// directory; one that does not exist or cannot be resolved admits nothing) and inside the
    /// share directory of a `package://` resource's package; every refusal of a file is
    /// [`GeometryError::NotReadable`]. Files of at most [`DEFAULT_MAX_FILE_BYTES`].
    pub fn confined<P: AsRef<Path>>(roots: impl IntoIterator<Item = P>) -> Self {
        let roots = roots
            .into_iter()
            .filter_map(|r| std::fs::canonicalize(r.as_ref()).ok())
            .collect();
        Access {
            roots: Some(roots),
            max_file_bytes: DEFAULT_MAX_FILE_BYTES,
        }
    }

    /// The same access, reading files of at most `max` bytes.
    #[must_use]
    pub fn with_max_file_bytes(mut self, max: u64) -> Self {
        self.max_file_bytes = max;
        self
    }

    /// The most bytes a file may hold.
    pub fn max_file_bytes(&self) -> u64 {
        self.max_file_bytes
    }

    /// The canonical mesh roots of a confined access; `None` for a local one.
    pub fn roots(&self) -> Option<&[PathBuf]> {
        self.roots.as_deref()
    }
}

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

/// A file opened for reading: its handle, the path its format and errors name, and what
/// identifies its content.
#[derive(Debug)]
struct Opened {
    file: File,
    /// The path the format is read from (its extension) and errors print: the resolved path
    /// under a local access; under a confined one, the resource's own text, so that no error
    /// names a directory of the host (a package's install prefix).
    named: PathBuf,
    identity: Identity,
}

/// What identifies a file's content without reading it: its device and inode (the file, whatever
/// path or link names it), its size, and its modification and status-change times (a rewrite
/// changes both; the status-change time cannot be set back by a user).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Identity {
    dev: u64,
    ino: u64,
    len: u64,
    modified: (i64, i64),
    changed: (i64, i64),
}

impl Identity {
    fn of(metadata: &std::fs::Metadata) -> Self {
        Identity {
            dev: metadata.dev(),
            ino: metadata.ino(),
            len: metadata.len(),
            modified: (metadata.mtime(), metadata.mtime_nsec()),
            changed: (metadata.ctime(), metadata.ctime_nsec()),
        }
    }
}

/// Opens a file for reading without blocking: `O_NONBLOCK` (a FIFO without a writer opens at
/// once instead of waiting for one), `O_NOCTTY` (a terminal does not become the process's),
/// and, when `no_follow`, `O_NOFOLLOW` (a canonical path's last component turned into a link
/// since is not followed). Whether it is a regular file is the caller's check on the handle.
fn open_nonblocking(path: &Path, no_follow: bool) -> std::io::Result<File> {
    let mut flags = libc::O_NONBLOCK | libc::O_NOCTTY;
    if no_follow {
        flags |= libc::O_NOFOLLOW;
    }
    std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(flags)
        .open(path)
}

/// Refuses a resource string longer than [`MAX_RESOURCE_BYTES`].
fn check_length(resource: &str) -> Result<(), GeometryError> {
    if resource.len() > MAX_RESOURCE_BYTES {
        return Err(GeometryError::ResourceTooLong {
            resource: resource.to_owned(),
        });
    }
    Ok(())
}

/// Opens the file a resource names, as `access` allows: a regular file of at most
/// `access.max_file_bytes()` bytes.
fn open(resource: &str, index: &AmentIndex, access: &Access) -> Result<Opened, GeometryError> {
    check_length(resource)?;
    let path = match &access.roots {
        None => resolve(resource, index)?,
        Some(_) => resolve_name(resource)?,
    };
    check_format(resource, &path)?;
    let (file, named, metadata) = match &access.roots {
        None => open_local(resource, path)?,
        Some(roots) => open_confined(resource, &path, index, roots).ok_or_else(|| {
            GeometryError::NotReadable {
                resource: resource.to_owned(),
            }
        })?,
    };
    if metadata.len() > access.max_file_bytes {
        return Err(GeometryError::FileTooLarge {
            resource: resource.to_owned(),
            max: access.max_file_bytes,
        });
    }
    Ok(Opened {
        file,
        named,
        identity: Identity::of(&metadata),
    })
}

/// A resource's path without looking at the file system: a `package://` resource's path is
/// the resource itself (its package's directory is looked up only once it is to be opened).
/// The checks of the text are [`resolve`]'s.
fn resolve_name(resource: &str) -> Result<PathBuf, GeometryError> {
    if resource.starts_with("package://") {
        resolve(resource, &AmentIndex::default()).or_else(|e| match e {
            GeometryError::PackageNotFound { .. } => Ok(PathBuf::from(resource)),
            other => Err(other),
        })
    } else {
        resolve(resource, &AmentIndex::default())
    }
}

/// Opens any file, with errors that say why not.
fn open_local(
    resource: &str,
    path: PathBuf,
) -> Result<(File, PathBuf, std::fs::Metadata), GeometryError> {
    let unreadable = |path: &Path, source| GeometryError::Unreadable {
        resource: resource.to_owned(),
        path: path.to_owned(),
        source,
    };
    let file = open_nonblocking(&path, false).map_err(|e| unreadable(&path, e))?;
    let metadata = file.metadata().map_err(|e| unreadable(&path, e))?;
    if !metadata.is_file() {
        return Err(GeometryError::NotRegularFile {
            resource: resource.to_owned(),
            path,
        });
    }
    Ok((file, path, metadata))
}

/// Opens a file under the roots (a `package://` one inside its package's share directory), or
/// nothing, whatever the reason.
fn open_confined(
    resource: &str,
    path: &Path,
    index: &AmentIndex,
    roots: &[PathBuf],
) -> Option<(File, PathBuf, std::fs::Metadata)> {
    let canonical = match resource.strip_prefix("package://") {
        Some(rest) => {
            let (package, inside) = rest.split_once('/').unwrap_or((rest, ""));
            // The path is taken inside the share directory by its text (a `..` that would leave
            // it is refused); the links found there are followed, since the package's install
            // put them there (colcon's `--symlink-install` links each file to the source tree).
            let inside = inside_lexically(inside)?;
            let share = index.package_share(package)?;
            std::fs::canonicalize(share.join(inside)).ok()?
        }
        None => {
            let canonical = std::fs::canonicalize(path).ok()?;
            roots
                .iter()
                .any(|root| canonical.starts_with(root))
                .then_some(canonical)?
        }
    };
    let file = open_nonblocking(&canonical, true).ok()?;
    let metadata = file.metadata().ok()?;
    metadata
        .is_file()
        .then(|| (file, path.to_owned(), metadata))
}

/// A relative path with its `.` and `..` taken away by its text alone, or `None` when a `..`
/// would climb above its start or a component is absolute.
fn inside_lexically(path: &str) -> Option<PathBuf> {
    let mut kept: Vec<&std::ffi::OsStr> = Vec::new();
    for component in Path::new(path).components() {
        match component {
            std::path::Component::Normal(name) => kept.push(name),
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                kept.pop()?;
            }
            std::path::Component::RootDir | std::path::Component::Prefix(_) => return None,
        }
    }
    Some(kept.iter().collect())
}

/// The bytes of an opened file: at most `max`, the read stopping one byte past it (a file that
/// grew since it was opened is refused, not read without end).
fn read(resource: &str, opened: &Opened, access: &Access) -> Result<Vec<u8>, GeometryError> {
    let max = access.max_file_bytes;
    let expected = opened.identity.len.min(max);
    let mut bytes = Vec::with_capacity(usize::try_from(expected).unwrap_or(0));
    let read = (&opened.file)
        .take(max.saturating_add(1))
        .read_to_end(&mut bytes);
    if let Err(source) = read {
        return Err(match access.roots {
            None => GeometryError::Unreadable {
                resource: resource.to_owned(),
                path: opened.named.clone(),
                source,
            },
            Some(_) => GeometryError::NotReadable {
                resource: resource.to_owned(),
            },
        });
    }
    if bytes.len() as u64 > max {
        return Err(GeometryError::FileTooLarge {
            resource: resource.to_owned(),
            max,
        });
    }
    Ok(bytes)
}

/// Opens, reads and parses a file as `access` allows.
fn parse_with(
    resource: &str,
    index: &AmentIndex,
    access: &Access,
) -> Result<(Opened, Triangles), GeometryError> {
    let opened = open(resource, index, access)?;
    let bytes = read(resource, &opened, access)?;
    let triangles = parse_bytes(resource, &opened.named, &bytes)?;
    Ok((opened, triangles))
}

/// Read and parse a mesh file (any regular file of at most [`DEFAULT_MAX_FILE_BYTES`]), without
/// indexing it.
pub fn parse(resource: &str, path: &Path) -> Result<Triangles, GeometryError> {
    check_length(resource)?;
    check_format(resource, path)?;
    let access = Access::local();
    let (file, named, metadata) = open_local(resource, path.to_owned())?;
    if metadata.len() > access.max_file_bytes {
        return Err(GeometryError::FileTooLarge {
            resource: resource.to_owned(),
            max: access.max_file_bytes,
        });
    }
    let opened = Opened {
        file,
        named,
        identity: Identity::of(&metadata),
    };
    let bytes = read(resource, &opened, &access)?;
    parse_bytes(resource, path, &bytes)
}

/// Resolve, parse and index a mesh resource, scaled per axis into metres (a local access: any
/// regular file of at most [`DEFAULT_MAX_FILE_BYTES`]).
pub fn load(resource: &str, scale: [f64; 3], index: &AmentIndex) -> Result<Mesh, GeometryError> {
    let (_, (vertices, triangles)) = parse_with(resource, index, &Access::local())?;
    Mesh::from_triangles(resource, &vertices, &triangles, scale)
}

/// Refuses a scale that is zero, negative or not finite on an axis, before any file is read.
fn check_scale(resource: &str, scale: [f64; 3]) -> Result<(), GeometryError> {
    if scale.iter().all(|s| s.is_finite() && *s > 0.0) {
        return Ok(());
    }
    Err(GeometryError::BadScale {
        resource: resource.to_owned(),
        scale,
    })
}

/// The bits of a scale, `-0.0` as `0.0`.
fn scale_bits(scale: [f64; 3]) -> [u64; 3] {
    scale.map(|s| (s + 0.0).to_bits())
}

const UNIT: [f64; 3] = [1.0; 3];

/// Loaded meshes, each file parsed once whatever the scales asked of it, holding at most a
/// number of bytes ([`Mesh::bytes`]).
///
/// - **Keys.** A kept mesh is found by its file's content identity (device, inode, size,
///   modification and status-change times, from the status of the opened file: no read) and
///   its scale. The identity is read at each lookup (one open and one `fstat`), so the same
///   file named by other paths or links is parsed once (its mesh, and errors about it, name the
///   resource that loaded it first), and a file rewritten is parsed again. Hashing the bytes
///   would also catch copies of a file, but would read all of it at every lookup.
/// - **Scales.** A file is parsed and indexed once, at scale 1 (its own units), and that mesh
///   kept; each scale asked is made from it without reading or parsing the file again: a
///   uniform scale scales the built mesh and its BVH ([`Mesh::scaled`]), any other one indexes
///   the kept mesh's vertices and triangles again ([`Mesh::rescaled`]). The vertices are the
///   same, bit for bit, as a load at that scale. [`MeshCache::loads`] counts the parses.
/// - **Access.** What may be read and what refusals say is the cache's [`Access`].
/// - **Bound.** When a new mesh does not fit, the least recently used ones are dropped until it
///   does; a mesh larger than the whole bound is returned but not kept. Meshes handed out stay
///   alive while a caller holds them. A resource whose file changed drops the meshes kept of its
///   former content when it is loaded again.
/// - **Locking.** The cache's lock is held only to look up and to store, never while a file is
///   read, parsed and indexed: a lookup of a kept mesh is not delayed by another file's load.
///   Callers asking at once for a file not kept queue on a lock of that file's own: the first
///   loads it, the others then find it kept. If the first fails, or its mesh is too large to
///   keep, each of the others loads it in turn (and gets its own error): failures are quick,
///   and a mesh beyond the bound is not worth a second mechanism.
#[derive(Debug)]
pub struct MeshCache {
    index: AmentIndex,
    access: Access,
    max_bytes: usize,
    inner: Mutex<CacheInner>,
}

/// A file's content, at a scale (its bits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Key {
    identity: Identity,
    scale: [u64; 3],
}

#[derive(Debug, Default)]
struct CacheInner {
    entries: HashMap<Key, Entry>,
    /// The files being loaded, each with the lock its loader holds while it loads.
    loading: HashMap<Identity, Arc<Mutex<()>>>,
    bytes: usize,
    clock: u64,
    loads: u64,
}

#[derive(Debug)]
struct Entry {
    mesh: Arc<Mesh>,
    last_used: u64,
}

impl MeshCache {
    /// An empty cache resolving `package://` through `index`, holding at most `max_bytes`,
    /// reading any file ([`Access::local`]).
    pub fn new(index: AmentIndex, max_bytes: usize) -> Self {
        MeshCache::with_access(index, Access::local(), max_bytes)
    }

    /// An empty cache resolving `package://` through `index`, reading what `access` allows,
    /// holding at most `max_bytes`.
    pub fn with_access(index: AmentIndex, access: Access, max_bytes: usize) -> Self {
        MeshCache {
            index,
            access,
            max_bytes,
            inner: Mutex::new(CacheInner::default()),
        }
    }

    /// What the cache may read.
    pub fn access(&self) -> &Access {
        &self.access
    }

    /// The mesh of a resource at a scale: the one kept if its file has not changed since, else
    /// made from the file's kept mesh at scale 1, else the file loaded (outside the cache's
    /// lock); what is made is kept if it fits.
    pub fn get(&self, resource: &str, scale: [f64; 3]) -> Result<Arc<Mesh>, GeometryError> {
        check_length(resource)?;
        check_scale(resource, scale)?;
        let opened = open(resource, &self.index, &self.access)?;
        let key = Key {
            identity: opened.identity,
            scale: scale_bits(scale),
        };
        let turn = {
            let mut inner = self.lock();
            if let Some(mesh) = inner.kept(&key) {
                return Ok(mesh);
            }
            Arc::clone(inner.loading.entry(key.identity).or_default())
        };
        let held = turn.lock().unwrap_or_else(|e| e.into_inner());
        let made = self.make(resource, &key, &opened, scale);
        let mut inner = self.lock();
        inner.end_turn(&key.identity, &turn);
        drop(inner);
        drop(held);
        made
    }

    /// The mesh of `key` made and kept, the caller holding its file's turn: kept already (by
    /// the caller before in the queue), or made from the file's mesh at scale 1, loaded first
    /// if it is not kept.
    fn make(
        &self,
        resource: &str,
        key: &Key,
        opened: &Opened,
        scale: [f64; 3],
    ) -> Result<Arc<Mesh>, GeometryError> {
        let unit = {
            let mut inner = self.lock();
            if let Some(mesh) = inner.kept(key) {
                return Ok(mesh);
            }
            inner.unit_of(&key.identity)
        };
        let unit = match unit {
            Some(unit) => unit,
            None => {
                let bytes = read(resource, opened, &self.access)?;
                let (vertices, triangles) = parse_bytes(resource, &opened.named, &bytes)?;
                drop(bytes);
                let unit = Mesh::from_triangles(resource, &vertices, &triangles, UNIT);
                drop((vertices, triangles));
                let unit = Arc::new(unit?);
                let mut inner = self.lock();
                inner.loads += 1;
                inner.forget_former(resource, &key.identity);
                let unit_key = Key {
                    scale: scale_bits(UNIT),
                    ..*key
                };
                inner.keep(unit_key, &unit, self.max_bytes);
                unit
            }
        };
        let mesh = if key.scale == scale_bits(UNIT) {
            unit
        } else if scale[0] == scale[1] && scale[1] == scale[2] {
            Arc::new(unit.scaled(scale[0])?)
        } else {
            Arc::new(unit.rescaled(scale)?)
        };
        self.lock().keep(*key, &mesh, self.max_bytes);
        Ok(mesh)
    }

    /// Whether the mesh of a resource at a scale is kept (a `get` would neither load nor make
    /// it); false for a resource whose file cannot be opened.
    pub fn holds(&self, resource: &str, scale: [f64; 3]) -> bool {
        if check_length(resource).is_err() {
            return false;
        }
        let Ok(opened) = open(resource, &self.index, &self.access) else {
            return false;
        };
        let key = Key {
            identity: opened.identity,
            scale: scale_bits(scale),
        };
        self.lock().entries.contains_key(&key)
    }

    /// The bytes the kept meshes hold.
    pub fn bytes(&self) -> usize {
        self.lock().bytes
    }

    /// How many meshes are kept (a file's mesh at scale 1 among them).
    pub fn len(&self) -> usize {
        self.lock().entries.len()
    }

    /// Whether no mesh is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// How many files have been loaded (read, parsed and indexed) so far; a mesh made from a
    /// kept one at another scale is not a load.
    pub fn loads(&self) -> u64 {
        self.lock().loads
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, CacheInner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl CacheInner {
    /// The kept mesh of `key`, marked as used.
    fn kept(&mut self, key: &Key) -> Option<Arc<Mesh>> {
        self.clock += 1;
        let now = self.clock;
        let entry = self.entries.get_mut(key)?;
        entry.last_used = now;
        Some(Arc::clone(&entry.mesh))
    }

    /// A kept mesh of the file at scale 1, whatever resource named it.
    fn unit_of(&mut self, identity: &Identity) -> Option<Arc<Mesh>> {
        self.clock += 1;
        let now = self.clock;
        let unit = scale_bits(UNIT);
        let (_, entry) = self
            .entries
            .iter_mut()
            .find(|(k, _)| k.identity == *identity && k.scale == unit)?;
        entry.last_used = now;
        Some(Arc::clone(&entry.mesh))
    }

    /// Drops the meshes loaded through `resource` of a file's former content (any identity but
    /// `identity`): the resource's file changed since.
    fn forget_former(&mut self, resource: &str, identity: &Identity) {
        let former: Vec<Key> = self
            .entries
            .iter()
            .filter(|(k, e)| e.mesh.resource() == resource && k.identity != *identity)
            .map(|(k, _)| *k)
            .collect();
        for key in &former {
            self.remove(key);
        }
    }

    /// The file's lock is no longer the one to queue on, if it still is `turn` (callers
    /// already queued on it find the mesh kept, or load it in turn).
    fn end_turn(&mut self, identity: &Identity, turn: &Arc<Mutex<()>>) {
        if self
            .loading
            .get(identity)
            .is_some_and(|t| Arc::ptr_eq(t, turn))
        {
            self.loading.remove(identity);
        }
    }

    /// Keeps a mesh just made, dropping the least recently used ones to make room; not at all
    /// if it is larger than the whole bound.
    fn keep(&mut self, key: Key, mesh: &Arc<Mesh>, max_bytes: usize) {
        self.remove(&key);
        let size = mesh.bytes();
        if size > max_bytes {
            return;
        }
        while self.bytes + size > max_bytes && !self.entries.is_empty() {
            self.evict_oldest();
        }
        self.clock += 1;
        self.bytes += size;
        let entry = Entry {
            mesh: Arc::clone(mesh),
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
            .map(|(k, _)| *k);
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
