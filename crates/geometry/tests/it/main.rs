//! The geometry crate's integration tests, one binary: the independent reference
//! (`reference.rs`, sharing no code with the crate), the test objects (`objects.rs`), and the
//! checks.

mod access;
mod agreement;
mod bad_input;
mod edges;
mod files;
mod objects;
mod reference;
