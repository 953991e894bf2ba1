//! Why settings were refused ([`ConfigError`]), and why one value does not fit its parameter
//! ([`ValueError`]).

/// Why settings were refused.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The YAML is malformed.
    #[error("{origin}: {source}")]
    Yaml {
        /// Where the text came from.
        origin: String,
        /// The cause.
        source: serde_yaml_ng::Error,
    },
    /// No parameter has this name.
    #[error("grasp_orient has no parameter {name}")]
    Unknown {
        /// The name given.
        name: String,
    },
    /// A value is of the wrong type, or out of its domain.
    #[error("parameter {name}: {why}")]
    Value {
        /// The parameter.
        name: &'static str,
        /// What is wrong.
        why: ValueError,
    },
    /// A params file has no `ros__parameters` section for the node.
    #[error("{origin} has no section for node {node} (found: {}); a params file for it starts with `{node}:` or `/**:`, then `ros__parameters:`", if .found.is_empty() { "none".to_string() } else { .found.join(", ") })]
    NoSection {
        /// The file.
        origin: String,
        /// The node's name.
        node: String,
        /// The top-level keys it has.
        found: Vec<String>,
    },
    /// A params file holds a refused parameter.
    #[error("{origin}: {source}")]
    InFile {
        /// The file.
        origin: String,
        /// What is wrong with it.
        source: Box<ConfigError>,
    },
}

/// Why a value does not fit its parameter (in a [`ConfigError`], the words
/// after "parameter NAME: "; for a command-line option, the whole reason).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ValueError {
    /// Not of the parameter's type (the YAML reader's words).
    #[error("{0}")]
    Type(String),
    /// A vector with the wrong number of components.
    #[error("expected 3 numbers [x, y, z], got {0}")]
    Components(usize),
    /// Outside the declared domain.
    #[error("must be {domain}, got {value}")]
    Domain {
        /// The domain, as the parameter table prints it.
        domain: String,
        /// The value given.
        value: String,
    },
    /// One component of a vector is wrong.
    #[error("{axis}: {why}")]
    Component {
        /// `x`, `y` or `z`.
        axis: &'static str,
        /// What is wrong with it.
        why: Box<ValueError>,
    },
    /// Not one of the names a choice takes.
    #[error("{0}")]
    Name(String),
    /// `range_min` and `range_max` bound no interval.
    #[error("bounds need finite range_min < range_max, got {lo} and {hi}")]
    Bounds {
        /// `range_min`, rad.
        lo: f64,
        /// `range_max`, rad.
        hi: f64,
    },
}
