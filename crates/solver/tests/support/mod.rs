//! Helpers of the solver crate's integration tests (and its `batch` benchmark).

pub mod random;
