//! Opening a file and reading it within bounds: without blocking, a regular file only, at most
//! the access's bytes, the read stopping one byte past them; and what identifies the content.

use std::fs::File;
use std::io::Read;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

use crate::error::GeometryError;
use crate::formats::{check_format, parse_bytes, Triangles};

use super::access::{confined_path, Access};
use super::resource::{check_length, resolve, resolve_name, AmentIndex};

/// A file opened for reading: its handle, the path its format and errors name, and what
/// identifies its content.
#[derive(Debug)]
pub(super) struct Opened {
    file: File,
    /// The path the format is read from (its extension) and errors print: the resolved path
    /// under a local access; under a confined one, the resource's own text, so that no error
    /// names a directory of the host (a package's install prefix).
    pub(super) named: PathBuf,
    pub(super) identity: Identity,
}

/// What identifies a file's content without reading it: its device and inode (the file, whatever
/// path or link names it), its size, and its modification and status-change times (a rewrite
/// changes both; the status-change time cannot be set back by a user).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) struct Identity {
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

/// Opens the file a resource names, as `access` allows: a regular file of at most
/// `access.max_file_bytes()` bytes.
pub(super) fn open(
    resource: &str,
    index: &AmentIndex,
    access: &Access,
) -> Result<Opened, GeometryError> {
    check_length(resource)?;
    let path = match access.roots() {
        None => resolve(resource, index)?,
        Some(_) => resolve_name(resource)?,
    };
    check_format(resource, &path)?;
    let (file, named, metadata) = match access.roots() {
        None => open_local(resource, path)?,
        Some(roots) => open_confined(resource, &path, index, roots).ok_or_else(|| {
            GeometryError::NotReadable {
                resource: resource.to_owned(),
            }
        })?,
    };
    if metadata.len() > access.max_file_bytes() {
        return Err(GeometryError::FileTooLarge {
            resource: resource.to_owned(),
            max: access.max_file_bytes(),
        });
    }
    Ok(Opened {
        file,
        named,
        identity: Identity::of(&metadata),
    })
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

/// Opens a file under the roots (a `package://` one inside its package's share directory,
/// [`confined_path`]), or nothing, whatever the reason.
fn open_confined(
    resource: &str,
    path: &Path,
    index: &AmentIndex,
    roots: &[PathBuf],
) -> Option<(File, PathBuf, std::fs::Metadata)> {
    let canonical = confined_path(resource, path, index, roots)?;
    let file = open_nonblocking(&canonical, true).ok()?;
    let metadata = file.metadata().ok()?;
    metadata
        .is_file()
        .then(|| (file, path.to_owned(), metadata))
}

/// The bytes of an opened file: at most `max`, the read stopping one byte past it (a file that
/// grew since it was opened is refused, not read without end).
pub(super) fn read(
    resource: &str,
    opened: &Opened,
    access: &Access,
) -> Result<Vec<u8>, GeometryError> {
    let max = access.max_file_bytes();
    let expected = opened.identity.len.min(max);
    let mut bytes = Vec::with_capacity(usize::try_from(expected).unwrap_or(0));
    let read = (&opened.file)
        .take(max.saturating_add(1))
        .read_to_end(&mut bytes);
    if let Err(source) = read {
        return Err(match access.roots() {
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
pub(super) fn parse_with(
    resource: &str,
    index: &AmentIndex,
    access: &Access,
) -> Result<(Opened, Triangles), GeometryError> {
    let opened = open(resource, index, access)?;
    let bytes = read(resource, &opened, access)?;
    let triangles = parse_bytes(resource, &opened.named, &bytes)?;
    Ok((opened, triangles))
}

/// Read and parse a mesh file (any regular file of at most
/// [`DEFAULT_MAX_FILE_BYTES`](super::DEFAULT_MAX_FILE_BYTES)), without indexing it.
pub fn parse(resource: &str, path: &Path) -> Result<Triangles, GeometryError> {
    check_length(resource)?;
    check_format(resource, path)?;
    let access = Access::local();
    let (file, named, metadata) = open_local(resource, path.to_owned())?;
    if metadata.len() > access.max_file_bytes() {
        return Err(GeometryError::FileTooLarge {
            resource: resource.to_owned(),
            max: access.max_file_bytes(),
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
