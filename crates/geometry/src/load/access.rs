//! Who may read which file ([`Access`]): a local user any path, the node only files under its
//! mesh roots and inside a `package://` resource's share directory (the confinement).

use std::path::{Path, PathBuf};

use super::resource::AmentIndex;

/// The most bytes a mesh file may hold unless an [`Access`] says otherwise: 256 MiB, five times
/// a binary STL of a million triangles (50 bytes each, 50 MB) and above the ASCII STL or OBJ of
/// one (about 250 and 60 MB), while a read of it stays within a second or two and well within
/// the node's memory.
pub const DEFAULT_MAX_FILE_BYTES: u64 = 256 << 20;

/// What files a [`MeshCache`](super::MeshCache) (or [`load`](fn@super::load)) may read, and how
/// much of one.
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
    /// [`GeometryError::NotReadable`](crate::GeometryError::NotReadable). Files of at most
    /// [`DEFAULT_MAX_FILE_BYTES`].
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

/// The canonical path of a file a confined access admits: under the roots (a `package://` one
/// inside its package's share directory), or nothing, whatever the reason.
pub(super) fn confined_path(
    resource: &str,
    path: &Path,
    index: &AmentIndex,
    roots: &[PathBuf],
) -> Option<PathBuf> {
    match resource.strip_prefix("package://") {
        Some(rest) => {
            let (package, inside) = rest.split_once('/').unwrap_or((rest, ""));
            // The path is taken inside the share directory by its text (a `..` that would leave
            // it is refused); the links found there are followed, since the package's install
            // put them there (colcon's `--symlink-install` links each file to the source tree).
            let inside = inside_lexically(inside)?;
            let share = index.package_share(package)?;
            std::fs::canonicalize(share.join(inside)).ok()
        }
        None => {
            let canonical = std::fs::canonicalize(path).ok()?;
            roots
                .iter()
                .any(|root| canonical.starts_with(root))
                .then_some(canonical)
        }
    }
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
