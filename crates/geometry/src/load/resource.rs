//! What a resource names: `package://` through the ament index, `file://` and plain paths, and
//! the bound on a resource's length. Nothing here opens a file.

use std::path::PathBuf;

use crate::error::{GeometryError, MAX_RESOURCE_BYTES};

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

/// Refuses a resource string longer than [`MAX_RESOURCE_BYTES`].
pub(super) fn check_length(resource: &str) -> Result<(), GeometryError> {
    if resource.len() > MAX_RESOURCE_BYTES {
        return Err(GeometryError::ResourceTooLong {
            resource: resource.to_owned(),
        });
    }
    Ok(())
}

/// A resource's path without looking at the file system: a `package://` resource's path is
/// the resource itself (its package's directory is looked up only once it is to be opened).
/// The checks of the text are [`resolve`]'s.
pub(super) fn resolve_name(resource: &str) -> Result<PathBuf, GeometryError> {
    if resource.starts_with("package://") {
        resolve(resource, &AmentIndex::default()).or_else(|e| match e {
            GeometryError::PackageNotFound { .. } => Ok(PathBuf::from(resource)),
            other => Err(other),
        })
    } else {
        resolve(resource, &AmentIndex::default())
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
