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
//!
//! # Files
//! One concern each, imports pointing down the list: `load/resource.rs` (what a resource names,
//! its length), `load/access.rs` ([`Access`] and the confinement), `load/file.rs` (opening a
//! file and reading it within bounds; [`parse`]), `load/cache.rs` ([`MeshCache`]); this file
//! re-exports them and holds [`load`].

mod access;
mod cache;
mod file;
mod resource;

use crate::error::GeometryError;
pub use crate::error::MAX_RESOURCE_BYTES;
pub use crate::formats::{check_format, parse_bytes, Triangles};
use crate::mesh::Mesh;
pub use access::{Access, DEFAULT_MAX_FILE_BYTES};
pub use cache::MeshCache;
pub use file::parse;
use file::parse_with;
pub use resource::{resolve, AmentIndex};

/// Resolve, parse and index a mesh resource, scaled per axis into metres (a local access: any
/// regular file of at most [`DEFAULT_MAX_FILE_BYTES`]).
pub fn load(resource: &str, scale: [f64; 3], index: &AmentIndex) -> Result<Mesh, GeometryError> {
    let (_, (vertices, triangles)) = parse_with(resource, index, &Access::local())?;
    Mesh::from_triangles(resource, &vertices, &triangles, scale)
}
