//! The object's shape: an exact `shape_msgs/SolidPrimitive`, or a triangle mesh.
//!
//! Primitives follow `shape_msgs/msg/SolidPrimitive.msg` (Jazzy): every shape's bounding box is
//! centred on the object frame's origin; the cylinder's and the cone's centre line is the z
//! axis; the cone's tip points along +z, so its base disc lies at `z = −height/2` and its tip at
//! `z = +height/2`. Dimensions are in metres.

use std::sync::Arc;

use nalgebra::{Isometry3, Point3};

use crate::error::GeometryError;
use crate::mesh::Mesh;

/// An exact solid primitive, dimensions in metres, in the object frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Primitive {
    /// Side lengths along x, y and z, centred.
    Box {
        /// Length along x, m.
        x: f64,
        /// Length along y, m.
        y: f64,
        /// Length along z, m.
        z: f64,
    },
    /// Centred ball.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// Axis z, centred: caps at `z = ±height/2`.
    Cylinder {
        /// Length along z, m.
        height: f64,
        /// Radius, m.
        radius: f64,
    },
    /// Axis z, bounding box centred: base disc at `z = −height/2`, tip at `z = +height/2`.
    Cone {
        /// Length along z, m.
        height: f64,
        /// Radius of the base, m.
        radius: f64,
    },
}

impl Primitive {
    /// `shape_msgs/SolidPrimitive.BOX`, dimensions `[x, y, z]`.
    pub const BOX: u8 = 1;
    /// `shape_msgs/SolidPrimitive.SPHERE`, dimensions `[radius]`.
    pub const SPHERE: u8 = 2;
    /// `shape_msgs/SolidPrimitive.CYLINDER`, dimensions `[height, radius]`.
    pub const CYLINDER: u8 = 3;
    /// `shape_msgs/SolidPrimitive.CONE`, dimensions `[height, radius]`.
    pub const CONE: u8 = 4;

    /// The primitive a `shape_msgs/SolidPrimitive` describes, from its `type` and `dimensions`.
    ///
    /// Refuses an unknown type (PRISM = 5 included: this crate does not cast on prisms), a
    /// wrong number of dimensions, and a dimension that is not finite and positive.
    pub fn from_shape_msgs(type_number: u8, dimensions: &[f64]) -> Result<Self, GeometryError> {
        let primitive = match (type_number, dimensions) {
            (Self::BOX, &[x, y, z]) => Primitive::Box { x, y, z },
            (Self::SPHERE, &[radius]) => Primitive::Sphere { radius },
            (Self::CYLINDER, &[height, radius]) => Primitive::Cylinder { height, radius },
            (Self::CONE, &[height, radius]) => Primitive::Cone { height, radius },
            (Self::BOX | Self::SPHERE | Self::CYLINDER | Self::CONE, _) => {
                return Err(dimensions_error(type_number, dimensions))
            }
            _ => return Err(GeometryError::UnknownPrimitive { type_number }),
        };
        primitive.check()?;
        Ok(primitive)
    }

    /// The `shape_msgs/SolidPrimitive` type number.
    pub fn type_number(&self) -> u8 {
        match self {
            Primitive::Box { .. } => Self::BOX,
            Primitive::Sphere { .. } => Self::SPHERE,
            Primitive::Cylinder { .. } => Self::CYLINDER,
            Primitive::Cone { .. } => Self::CONE,
        }
    }

    /// The `shape_msgs/SolidPrimitive` dimensions, in its order.
    pub fn dimensions(&self) -> Vec<f64> {
        match *self {
            Primitive::Box { x, y, z } => vec![x, y, z],
            Primitive::Sphere { radius } => vec![radius],
            Primitive::Cylinder { height, radius } | Primitive::Cone { height, radius } => {
                vec![height, radius]
            }
        }
    }

    /// "box", "sphere", "cylinder" or "cone".
    pub fn kind(&self) -> &'static str {
        kind_name(self.type_number())
    }

    /// Every dimension finite and greater than zero.
    pub fn check(&self) -> Result<(), GeometryError> {
        let dimensions = self.dimensions();
        if dimensions.iter().all(|d| d.is_finite() && *d > 0.0) {
            Ok(())
        } else {
            Err(dimensions_error(self.type_number(), &dimensions))
        }
    }

    /// The diagonal of the bounding box, m: the length tolerances scale with it.
    pub fn size(&self) -> f64 {
        match *self {
            Primitive::Box { x, y, z } => (x * x + y * y + z * z).sqrt(),
            Primitive::Sphere { radius } => 2.0 * radius * 3f64.sqrt(),
            Primitive::Cylinder { height, radius } | Primitive::Cone { height, radius } => {
                (4.0 * radius * radius * 2.0 + height * height).sqrt()
            }
        }
    }

    /// The centroid (the centre of mass at uniform density) in the object frame.
    ///
    /// # Formula
    /// Box, sphere and cylinder: the origin, by symmetry. Cone: on the axis at a quarter of the
    /// height above the base, `z = −h/2 + h/4 = −h/4` (the centroid of a cone of height `h` lies
    /// at `h/4` from its base).
    pub fn centroid(&self) -> Point3<f64> {
        match *self {
            Primitive::Cone { height, .. } => Point3::new(0.0, 0.0, -height / 4.0),
            _ => Point3::origin(),
        }
    }

    /// How errors name it, e.g. `cylinder [0.1, 0.02]`.
    pub(crate) fn describe(&self) -> String {
        format!("{} {:?}", self.kind(), self.dimensions())
    }
}

fn kind_name(type_number: u8) -> &'static str {
    match type_number {
        Primitive::BOX => "box",
        Primitive::SPHERE => "sphere",
        Primitive::CYLINDER => "cylinder",
        Primitive::CONE => "cone",
        _ => "unknown",
    }
}

fn dimensions_error(type_number: u8, dimensions: &[f64]) -> GeometryError {
    let expected = match type_number {
        Primitive::BOX => "3 values [x, y, z], each finite and > 0",
        Primitive::SPHERE => "1 value [radius], finite and > 0",
        _ => "2 values [height, radius], each finite and > 0",
    };
    GeometryError::PrimitiveDimensions {
        kind: kind_name(type_number),
        given: dimensions.to_vec(),
        expected,
    }
}

/// The shape of an object: an exact primitive or an indexed mesh (shared, e.g. from a
/// [`crate::MeshCache`]).
#[derive(Debug, Clone)]
pub enum Shape {
    /// An exact primitive.
    Primitive(Primitive),
    /// A scaled, indexed triangle mesh.
    Mesh(Arc<Mesh>),
}

impl Shape {
    /// The diagonal of the bounding box, m.
    pub fn size(&self) -> f64 {
        match self {
            Shape::Primitive(p) => p.size(),
            Shape::Mesh(m) => m.size(),
        }
    }

    /// The resource (a mesh) or the primitive with its dimensions, as errors name it.
    pub fn describe(&self) -> String {
        match self {
            Shape::Primitive(p) => p.describe(),
            Shape::Mesh(m) => m.resource().to_owned(),
        }
    }
}

impl From<Primitive> for Shape {
    fn from(p: Primitive) -> Self {
        Shape::Primitive(p)
    }
}

impl From<Arc<Mesh>> for Shape {
    fn from(m: Arc<Mesh>) -> Self {
        Shape::Mesh(m)
    }
}

impl From<Mesh> for Shape {
    fn from(m: Mesh) -> Self {
        Shape::Mesh(Arc::new(m))
    }
}

/// A pose (the object's in the header frame, or the gripper's tool frame) with every number
/// finite; `field` names it in the error. Beside the shapes, below the casts and the centre of
/// mass, which both take an object pose.
pub(crate) fn check_pose(pose: &Isometry3<f64>, field: &'static str) -> Result<(), GeometryError> {
    let finite = pose.translation.vector.iter().all(|v| v.is_finite())
        && pose.rotation.coords.iter().all(|v| v.is_finite());
    if finite {
        Ok(())
    } else {
        Err(GeometryError::BadNumber {
            field,
            positive: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shape_msgs_numbers_and_dimensions() {
        assert_eq!(
            Primitive::from_shape_msgs(1, &[0.1, 0.2, 0.3]).ok(),
            Some(Primitive::Box {
                x: 0.1,
                y: 0.2,
                z: 0.3
            })
        );
        assert_eq!(
            Primitive::from_shape_msgs(4, &[0.2, 0.05]).ok(),
            Some(Primitive::Cone {
                height: 0.2,
                radius: 0.05
            })
        );
        assert!(matches!(
            Primitive::from_shape_msgs(5, &[0.1]),
            Err(GeometryError::UnknownPrimitive { type_number: 5 })
        ));
        assert!(matches!(
            Primitive::from_shape_msgs(3, &[0.1]),
            Err(GeometryError::PrimitiveDimensions {
                kind: "cylinder",
                ..
            })
        ));
        assert!(matches!(
            Primitive::from_shape_msgs(2, &[-0.1]),
            Err(GeometryError::PrimitiveDimensions { kind: "sphere", .. })
        ));
        assert!(matches!(
            Primitive::from_shape_msgs(1, &[0.1, f64::NAN, 0.1]),
            Err(GeometryError::PrimitiveDimensions { kind: "box", .. })
        ));
    }

    #[test]
    fn cone_centroid_is_a_quarter_height_above_the_base() {
        let cone = Primitive::Cone {
            height: 0.4,
            radius: 0.1,
        };
        // Base at z = -0.2, so the centroid is at -0.2 + 0.1 = -0.1.
        assert!((cone.centroid().z + 0.1).abs() < 1e-15);
    }
}
