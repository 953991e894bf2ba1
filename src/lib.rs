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
//! Above them, private to the crate: the ROS 2 node (`src/node/`, on ros2-client) and the
//! command line (`src/cli/`, one `run` per subcommand), which the binary starts through [`run`].
//!
//! # The front door
//! What is public is what a program or a test that uses the library needs: the mathematics
//! ([`solver`], [`geometry`]), the message types ([`msg`]) and their kinds ([`kind`]), the
//! answers ([`answer`]: one candidate, a set, a pose, a pose set), the recording's writer and
//! reader ([`record`]: `BagWriter`, `Recorder`, `bag::read`, `recover`), [`replay`], the
//! parameters ([`config::Config`]) and `solve`'s JSON lines ([`jsonl`]). Everything else is
//! `pub(crate)`, and the `unreachable_pub` lint keeps it so.

#![warn(unreachable_pub)]

mod app;
mod cli;
mod node;
pub use app::main as run;

pub mod answer;
pub mod config;
pub mod jsonl;
pub mod kind;
pub mod msg;
pub mod record;
pub mod replay;
pub(crate) mod tf;
/// The mathematics, from the `grasp_orient_solver` crate (`crates/solver`).
pub use grasp_orient_geometry as geometry;
pub use grasp_orient_solver as solver;
