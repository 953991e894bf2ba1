//! The mesh cache: each file parsed once whatever the scales asked of it, kept under a bound in
//! bytes, looked up by the file's content identity, loaded outside the cache's lock.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use crate::error::GeometryError;
use crate::formats::parse_bytes;
use crate::mesh::Mesh;

use super::access::Access;
use super::file::{open, read, Identity, Opened};
use super::resource::{check_length, AmentIndex};

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
/// - **Bound.** When a new mesh does not fit, kept meshes are dropped until it does: first those
///   at a scale other than 1, least recently used first (each is remade from its file's mesh at
///   scale 1 in one pass over it, without reading the file), then meshes at scale 1 (whose
///   remaking is a parse), least recently used first. A mesh at another scale never drops its
///   own file's mesh at scale 1: when the two do not fit together, it is returned but not kept.
///   A mesh larger than the whole bound is returned but not kept. Meshes handed out stay alive
///   while a caller holds them. A resource whose file changed drops the meshes kept of its
///   former content when it is loaded again.
/// - **Locking.** The cache's lock is held only to look up and to store, never while a file is
///   read, parsed and indexed: a lookup of a kept mesh is not delayed by another file's load.
///   Callers asking at once for a file's meshes not kept, at any scales, queue on a turn of that
///   file's own: the first loads the file, and its mesh at scale 1 is handed to the others in
///   the queue through the turn (kept or not: a mesh beyond the bound is parsed once for them
///   all), each of which then makes its own scale from it. The turn lasts while callers queue
///   on it. If the load fails, the next in the queue loads the file (and gets its own error):
///   failures are quick.
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
    /// The files whose meshes are being made, each with the turn its callers queue on and how
    /// many callers are in it.
    loading: HashMap<Identity, (Arc<Turn>, usize)>,
    bytes: usize,
    clock: u64,
    loads: u64,
}

/// The turn of a file's callers: held by the one making a mesh of the file, and the file's mesh
/// at scale 1 once one of them has loaded it (for the next, even if the cache does not keep it).
type Turn = Mutex<Option<Arc<Mesh>>>;

/// A caller's place in a file's turn; when dropped (a panic too), the caller leaves the turn,
/// which ends with its last caller.
struct Queued<'a> {
    cache: &'a MeshCache,
    identity: Identity,
    turn: Arc<Turn>,
}

impl Drop for Queued<'_> {
    fn drop(&mut self) {
        self.cache.lock().leave_turn(&self.identity);
    }
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
        let queued = {
            let mut inner = self.lock();
            if let Some(mesh) = inner.kept(&key) {
                return Ok(mesh);
            }
            let (turn, callers) = inner.loading.entry(key.identity).or_default();
            *callers += 1;
            Queued {
                cache: self,
                identity: key.identity,
                turn: Arc::clone(turn),
            }
        };
        let mut held = queued.turn.lock().unwrap_or_else(|e| e.into_inner());
        let made = self.make(resource, &key, &opened, scale, &mut held);
        drop(held);
        drop(queued);
        made
    }

    /// The mesh of `key` made and kept, the caller holding its file's turn: kept already (by
    /// the caller before in the queue), or made from the file's mesh at scale 1 (kept, or handed
    /// over in the turn by the caller that loaded it), loaded first if there is none (and then
    /// handed over in the turn).
    fn make(
        &self,
        resource: &str,
        key: &Key,
        opened: &Opened,
        scale: [f64; 3],
        loaded: &mut Option<Arc<Mesh>>,
    ) -> Result<Arc<Mesh>, GeometryError> {
        let unit = {
            let mut inner = self.lock();
            if let Some(mesh) = inner.kept(key) {
                return Ok(mesh);
            }
            inner.unit_of(&key.identity)
        };
        let unit = match unit.or_else(|| loaded.clone()) {
            Some(unit) => unit,
            None => {
                let bytes = read(resource, opened, &self.access)?;
                let (vertices, triangles) = parse_bytes(resource, &opened.named, &bytes)?;
                drop(bytes);
                let unit = Mesh::from_triangles(resource, &vertices, &triangles, UNIT);
                drop((vertices, triangles));
                let unit = Arc::new(unit?);
                *loaded = Some(Arc::clone(&unit));
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

    /// A caller leaves its file's turn, which ends (is no longer the one to queue on, and lets
    /// the file's mesh it handed over go) with its last caller.
    fn leave_turn(&mut self, identity: &Identity) {
        if let Some((_, callers)) = self.loading.get_mut(identity) {
            *callers -= 1;
            if *callers == 0 {
                self.loading.remove(identity);
            }
        }
    }

    /// Keeps a mesh just made, dropping kept ones to make room ([`CacheInner::to_drop`]); not at
    /// all (and nothing dropped) if it is larger than the whole bound, or than the bound less
    /// the mesh it was made from.
    fn keep(&mut self, key: Key, mesh: &Arc<Mesh>, max_bytes: usize) {
        self.remove(&key);
        let size = mesh.bytes();
        // What may not be dropped for it: the mesh at scale 1 of its file, when it is at another.
        let unit = Key {
            scale: scale_bits(UNIT),
            ..key
        };
        let kept_for_it = match self.entries.get(&unit) {
            Some(entry) if unit != key => entry.mesh.bytes(),
            _ => 0,
        };
        if kept_for_it.saturating_add(size) > max_bytes {
            return;
        }
        while self.bytes + size > max_bytes {
            match self.to_drop(&key) {
                Some(victim) => self.remove(&victim),
                None => return,
            }
        }
        self.clock += 1;
        self.bytes += size;
        let entry = Entry {
            mesh: Arc::clone(mesh),
            last_used: self.clock,
        };
        self.entries.insert(key, entry);
    }

    /// The kept mesh to drop first to make room for `key`'s: the least recently used at a scale
    /// other than 1 (remade from its file's mesh at scale 1 without a parse), else the least
    /// recently used at scale 1, never the mesh at scale 1 of `key`'s file when `key` is at
    /// another scale (it is what `key`'s mesh is made from).
    fn to_drop(&self, key: &Key) -> Option<Key> {
        let unit = scale_bits(UNIT);
        let derived = key.scale != unit;
        self.entries
            .iter()
            .filter(|(k, _)| !(derived && k.scale == unit && k.identity == key.identity))
            .min_by_key(|(k, e)| (k.scale == unit, e.last_used))
            .map(|(k, _)| *k)
    }

    fn remove(&mut self, key: &Key) {
        if let Some(entry) = self.entries.remove(key) {
            self.bytes -= entry.mesh.bytes();
        }
    }
}
