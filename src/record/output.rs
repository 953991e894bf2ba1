//! Where the files that commands write go: under a temporary name beside their destination,
//! renamed into place only when complete, and never over one of the command's inputs. A crash
//! or an error therefore leaves the destination as it was (and at worst a hidden `.NAME.*.part`
//! file beside it). Outputs get the mode of any file a command creates: 0666 less the umask.

use std::fs::File;
use std::path::{Path, PathBuf};

/// Why an output cannot be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// The output is one of the inputs.
    #[error("refusing to write {output}: it is the input {input}; write to another file")]
    IsInput {
        /// The output asked for.
        output: PathBuf,
        /// The input it is.
        input: PathBuf,
    },
    /// The temporary file could not be made.
    #[error("cannot write beside {path}: {source}")]
    Create {
        /// The destination.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Whether `a` and `b` name the same existing file (through links, too).
pub(crate) fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
    }
}

/// An output being written under a temporary name in its destination's folder.
#[derive(Debug)]
pub(crate) struct Replacement {
    destination: PathBuf,
    file: File,
    temp: tempfile::TempPath,
}

/// The name a [`Replacement`] waits under, until [`Pending::commit`].
#[derive(Debug)]
pub(crate) struct Pending {
    destination: PathBuf,
    temp: tempfile::TempPath,
}

impl Replacement {
    /// A temporary file beside `destination`; refused when `destination` is one of `inputs`.
    pub(crate) fn create(destination: &Path, inputs: &[&Path]) -> Result<Self, OutputError> {
        if let Some(input) = inputs.iter().find(|i| same_file(i, destination)) {
            return Err(OutputError::IsInput {
                output: destination.to_path_buf(),
                input: input.to_path_buf(),
            });
        }
        let folder = match destination.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let name = destination
            .file_name()
            .map_or_else(|| "output".into(), |n| n.to_string_lossy());
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".part");
        // tempfile creates its files 0600; an output is a file like any other the command
        // creates: 0666 less the umask, which the kernel takes off at creation.
        #[cfg(unix)]
        builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
        let (file, temp) = builder
            .tempfile_in(folder)
            .map_err(|source| OutputError::Create {
                path: destination.to_path_buf(),
                source,
            })?
            .into_parts();
        Ok(Self {
            destination: destination.to_path_buf(),
            file,
            temp,
        })
    }

    /// The temporary file's path.
    pub(crate) fn temporary_path(&self) -> &Path {
        &self.temp
    }

    /// The file to write, and what renames it into place.
    pub(crate) fn into_parts(self) -> (File, Pending) {
        (
            self.file,
            Pending {
                destination: self.destination,
                temp: self.temp,
            },
        )
    }
}

impl Pending {
    /// Makes the temporary file (written in full, and closed) durable and renames it over the
    /// destination. Dropping a `Pending` instead removes the temporary file.
    pub(crate) fn commit(self) -> std::io::Result<()> {
        File::open(&self.temp)?.sync_all()?;
        self.temp.persist(&self.destination).map_err(|e| e.error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_replaces_its_destination_only_when_committed() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let dest = dir.path().join("out.mcap");
        std::fs::write(&dest, b"old").expect("write");
        let input = dir.path().join("in.mcap");
        std::fs::write(&input, b"input").expect("write");

        let r = Replacement::create(&dest, &[&input]).expect("created");
        let temp = r.temporary_path().to_path_buf();
        assert_eq!(temp.parent(), dest.parent(), "beside the destination");
        let (mut file, pending) = r.into_parts();
        std::io::Write::write_all(&mut file, b"new").expect("write");
        assert_eq!(std::fs::read(&dest).expect("read"), b"old");
        drop((file, pending));
        assert!(!temp.exists(), "an abandoned output leaves nothing");
        assert_eq!(std::fs::read(&dest).expect("read"), b"old");

        let (mut file, pending) = Replacement::create(&dest, &[&input])
            .expect("created")
            .into_parts();
        std::io::Write::write_all(&mut file, b"new").expect("write");
        drop(file);
        pending.commit().expect("renamed");
        assert_eq!(std::fs::read(&dest).expect("read"), b"new");
    }

    #[test]
    fn an_input_is_never_an_output_even_through_a_link() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let input = dir.path().join("in.mcap");
        std::fs::write(&input, b"input").expect("write");
        let e = Replacement::create(&input, &[&input]).expect_err("same file");
        assert!(e.to_string().starts_with("refusing to write"), "{e}");
        let link = dir.path().join("link.mcap");
        std::fs::hard_link(&input, &link).expect("a hard link");
        assert!(Replacement::create(&link, &[&input]).is_err());
        let dotted = dir.path().join(".").join("in.mcap");
        assert!(Replacement::create(&dotted, &[&input]).is_err());
    }
}
