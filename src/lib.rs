//! grasp_orient: the object orientation that minimises gripping power in a two-finger planar
//! grasp with friction (Ito et al.), as a library, a command line and a ROS 2 node.
//!
//! Layers, imports pointing down only:
//! 1. [`solver`]: pure math, SI units.
//! 2. [`msg`]: wire structs mirroring `msg/*.msg`, and conversions to and from solver types.
//! 3. [`config`]: the typed settings read from `config/grasp_orient.yaml`.
//! 3. [`node`]: the ROS 2 node on ros2-client.
//! 4. [`cli`]: one `run` per subcommand.

pub mod cli;
pub mod config;
pub mod msg;
pub mod node;
pub mod record;
pub mod replay;
pub mod solver;
