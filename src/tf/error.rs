//! The errors of a lookup, worded as tf2's `BufferCore` words them (geometry2, Jazzy:
//! `tf2/src/buffer_core.cpp`, `tf2/src/cache.cpp`), so that a user who knows tf2 recognises them.

use std::fmt;

/// Which argument of a lookup a frame was given as (tf2's `function_name_arg`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Argument {
    /// The frame the result is expressed in.
    Target,
    /// The frame the data comes from.
    Source,
}

impl Argument {
    fn name(self) -> &'static str {
        match self {
            Argument::Target => "lookupTransform argument target_frame",
            Argument::Source => "lookupTransform argument source_frame",
        }
    }
}

/// Why a cache holds no sample for a time (tf2's three `createExtrapolationException`s).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Extrapolation {
    /// One sample, at another time.
    Single {
        /// The time asked for, ns.
        requested: i64,
        /// The one sample's, ns.
        only: i64,
    },
    /// After the latest sample.
    Future {
        /// The time asked for, ns.
        requested: i64,
        /// The latest sample's, ns.
        latest: i64,
    },
    /// Before the earliest sample.
    Past {
        /// The time asked for, ns.
        requested: i64,
        /// The earliest sample's, ns.
        earliest: i64,
    },
}

/// A time as tf2's `displayTimePoint` prints it: seconds with six decimals.
pub(crate) struct Seconds(pub(crate) i64);

impl fmt::Display for Seconds {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // As tf2: the nanoseconds as a double, in seconds, "%.6f".
        write!(f, "{:.6}", self.0 as f64 * 1e-9)
    }
}

impl fmt::Display for Extrapolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Extrapolation::Single { requested, only } => write!(
                f,
                "Lookup would require extrapolation at time {}, but only time {} is in the buffer",
                Seconds(*requested),
                Seconds(*only)
            ),
            Extrapolation::Future { requested, latest } => write!(
                f,
                "Lookup would require extrapolation into the future.  Requested time {} but the \
                 latest data is at time {}",
                Seconds(*requested),
                Seconds(*latest)
            ),
            Extrapolation::Past {
                requested,
                earliest,
            } => write!(
                f,
                "Lookup would require extrapolation into the past.  Requested time {} but the \
                 earliest data is at time {}",
                Seconds(*requested),
                Seconds(*earliest)
            ),
        }
    }
}

/// Why a lookup failed. `Display` gives tf2's text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum TfError {
    /// An empty frame name.
    Empty(Argument),
    /// A frame name starting with `/` (tf2 refuses those in a lookup).
    Slash(Argument, String),
    /// A frame no transform has named.
    Unknown(Argument, String),
    /// No sample at the time asked for on the way from `source` to `target`.
    Extrapolation {
        /// What the cache lacks.
        why: Extrapolation,
        /// The lookup's source frame.
        source: String,
        /// The lookup's target frame.
        target: String,
    },
    /// The two frames are in two different trees.
    NotConnected {
        /// The lookup's source frame.
        source: String,
        /// The lookup's target frame.
        target: String,
    },
    /// The walk up from a frame went deeper than tf2's `MAX_GRAPH_DEPTH` (a loop of parents).
    Loop,
}

impl fmt::Display for TfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TfError::Empty(arg) => write!(
                f,
                "Invalid argument \"\" passed to {} - in tf2 frame_ids cannot be empty",
                arg.name()
            ),
            TfError::Slash(arg, frame) => write!(
                f,
                "Invalid argument \"{frame}\" passed to {} - in tf2 frame_ids cannot start with \
                 a '/'",
                arg.name()
            ),
            TfError::Unknown(arg, frame) => {
                write!(f, "\"{frame}\" passed to {} does not exist. ", arg.name())
            }
            TfError::Extrapolation {
                why,
                source,
                target,
            } => write!(
                f,
                "{why}, when looking up transform from frame [{source}] to frame [{target}]"
            ),
            // tf2's text, its missing space after the first sentence included.
            TfError::NotConnected { source, target } => write!(
                f,
                "Could not find a connection between '{target}' and '{source}' because they are \
                 not part of the same tree.Tf has two or more unconnected trees."
            ),
            TfError::Loop => f.write_str("The tf tree is invalid because it contains a loop."),
        }
    }
}

impl std::error::Error for TfError {}
