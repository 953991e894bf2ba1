//! The input limits: the largest and smallest values the solver accepts, so that every force it
//! computes stays within the range of a double.

/// Largest accepted coordinate magnitude, m.
pub const MAX_COORDINATE: f64 = 1e6;
/// Largest accepted normal component magnitude (normals may have any length up to this).
pub const MAX_NORMAL_COMPONENT: f64 = 1e9;
/// Largest accepted friction coefficient.
pub const MAX_FRICTION: f64 = 1e3;
/// Largest accepted mass, kg.
pub const MAX_MASS: f64 = 1e9;
/// Largest accepted gravity component magnitude, m/s².
pub const MAX_GRAVITY: f64 = 1e4;
/// Smallest accepted friction coefficient: below it a grasp that holds at all needs a squeeze
/// beyond about `1/μ` times the weight, which overflows the arithmetic long before `μ` reaches
/// the smallest double.
pub const MIN_FRICTION: f64 = 1e-6;
/// Largest accepted friction safety factor: with [`MIN_FRICTION`] it keeps the effective
/// friction at 1e-9 or more.
pub const MAX_SAFETY_FACTOR: f64 = 1e3;
/// Smallest weight `m |g|` (N, in-plane gravity) the forces can be computed for: the smallest
/// normal double. Below it the weight itself has lost its precision (subnormal) or is zero.
pub const MIN_WEIGHT: f64 = f64::MIN_POSITIVE;
