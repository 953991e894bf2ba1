//! grasp_orient: the object orientation that minimises gripping power in a two-finger grasp with
//! friction (Ito et al.), as a library, a command line and a ROS 2 node.
//!
//! The library's layers, imports pointing down only (`docs/architecture.md`):
//! 1. [`solver`]: the mathematics, SI units (the `grasp_orient_solver` crate).
//! 2. [`msg`]: wire structs mirroring `msg/*.msg`, and their conversions to and from solver types.
//! 3. [`answer`]: the policy that turns a candidate or a set into its answer: which solver, the
//!    tolerances, the grip force and the gripper's limit, the ranking, the refusals, the markers.
//! 4. [`record`] and [`replay`]: MCAP recordings written, read, recovered and re-solved;
//!    [`jsonl`]: JSON lines in and out, for `solve`; [`config`]: every parameter declared once,
//!    typed, read from params files and checked.
//!
//! The ROS 2 node (`src/node/`, on ros2-client) and the command line (`src/cli/`, one `run` per
//! subcommand) belong to the binary.

pub mod answer;
pub mod config;
pub mod jsonl;
pub mod kind;
pub mod msg;
pub mod record;
pub mod replay;
/// The mathematics, from the `grasp_orient_solver` crate (`crates/solver`).
pub use grasp_orient_geometry as geometry;
pub use grasp_orient_solver as solver;
