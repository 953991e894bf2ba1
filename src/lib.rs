//! grasp_orient: the object orientation that minimises gripping power in a two-finger planar
//! grasp with friction (Ito et al.), as a library, a command line and a ROS 2 node.
//!
//! Layers, imports pointing down only:
//! 1. [`solver`]: pure math, SI units.
//! 2. [`msg`]: wire structs mirroring `msg/*.msg`, and conversions to and from solver types;
//!    [`config`]: every parameter declared once, typed, read from params files and checked;
//!    [`sets`]: the grip force, the gripper's limit, and sets of candidates answered and ranked.
//! 3. [`record`] and [`replay`]: MCAP recordings; [`node`]: the ROS 2 node on ros2-client;
//!    [`jsonl`]: JSON lines in and out, for `solve`.
//! 4. The command line (`src/cli/`, one `run` per subcommand) belongs to the binary.

pub mod config;
pub mod jsonl;
pub mod msg;
pub mod node;
pub mod record;
pub mod replay;
pub mod sets;
pub mod solver;
