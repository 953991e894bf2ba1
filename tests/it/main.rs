//! The integration tests, one binary (one link step instead of one per file): each module is one
//! area, and `util` holds what they share (the independent numerical references, random grasps,
//! the binary under test with temporary folders). `tests/fuzz.rs` is a binary of its own, because
//! its global allocator caps every thread's memory while a case runs.

mod util;

mod cli;
mod extremes;
mod finger_force;
mod golden_bags;
mod invariants;
mod magnitudes;
mod msg_contract;
mod node_start;
mod paper;
mod play;
mod pose_replay;
mod poses;
mod recordings;
mod recover;
mod reference;
mod robust;
mod sets;
mod spatial;
mod spatial_invariants;
mod spatial_robust;
