//! The objects the node knows from MoveIt: each `moveit_msgs/CollisionObject` it heard on
//! `/collision_object` or in a `/planning_scene` diff, by id, as MoveIt's planning scene keeps
//! them (ADD replaces, REMOVE deletes (an empty id: every object), APPEND adds shapes, MOVE gives
//! a new pose), and the table of their mass and friction (the parameter `objects_file`). A
//! `~/rank_grasps` call names one of them by id, or brings its own; [`Scene::grasp_object`]
//! turns it into the `GraspObject` of the pose set the call is answered as.
//!
//! Bounded: at most [`MAX_OBJECTS`] objects and [`MAX_BYTES`] of their shapes are kept; an ADD or
//! APPEND beyond either is dropped with a warning, and the objects already known stay.

use super::session::create_topic;
use crate::config::objects::{missing, ObjectTable};
use crate::msg::moveit::{CollisionObject, PlanningScene, ShapePrimitive};
use crate::msg::{GraspObject, Mesh, MeshTriangle, Point, Pose, SolidPrimitive, Vector3};
use nalgebra::{Isometry3, Quaternion as Q, Translation3, UnitQuaternion};
use ros2_client::{Node, QosProfile, Subscription};
use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};

/// The most objects kept.
pub(crate) const MAX_OBJECTS: usize = 1024;
/// The most bytes of shapes kept, all objects together (a mesh's vertices at 24 bytes and its
/// triangles at 12).
pub(crate) const MAX_BYTES: usize = 64 << 20;
/// The most ids remembered as removed, so that a call naming one is told so.
const MAX_REMOVED: usize = 1024;

/// Where MoveIt publishes objects (before remapping): move_group's topics in the root namespace.
pub(crate) const COLLISION_OBJECT_TOPIC: &str = "/collision_object";
/// Where MoveIt publishes its planning scene's updates.
pub(crate) const PLANNING_SCENE_TOPIC: &str = "/planning_scene";

/// The subscriptions to [`COLLISION_OBJECT_TOPIC`] and [`PLANNING_SCENE_TOPIC`] (or what a remap
/// makes of them): reliable, volatile, keep-last `qos_depth`, as MoveIt's publishers offer.
pub(crate) struct SceneListener {
    /// `/collision_object`.
    pub(crate) objects: Subscription<CollisionObject>,
    /// `/planning_scene`.
    pub(crate) scenes: Subscription<PlanningScene>,
}

impl SceneListener {
    /// Subscribes to both, by their full names.
    pub(crate) fn create(
        node: &mut Node,
        objects: &str,
        scenes: &str,
        qos: &QosProfile,
    ) -> anyhow::Result<Self> {
        let objects_topic = create_topic::<CollisionObject>(node, objects, qos)?;
        let scenes_topic = create_topic::<PlanningScene>(node, scenes, qos)?;
        Ok(Self {
            objects: node
                .create_subscription(&objects_topic, Some(qos.clone()))
                .map_err(|e| anyhow::anyhow!("cannot subscribe to {objects}: {e:?}"))?,
            scenes: node
                .create_subscription(&scenes_topic, Some(qos.clone()))
                .map_err(|e| anyhow::anyhow!("cannot subscribe to {scenes}: {e:?}"))?,
        })
    }
}

/// What the node knows of MoveIt's world.
#[derive(Debug, Default)]
pub(crate) struct Scene {
    table: ObjectTable,
    known: BTreeMap<String, CollisionObject>,
    removed: BTreeSet<String>,
    bytes: usize,
    /// The volume of each known object's mesh, found the first time a density needs it (making
    /// the mesh to find it takes up to a few tenths of a second for the largest meshes allowed):
    /// forgotten when the object's shapes change.
    mesh_volumes: RefCell<BTreeMap<String, Result<f64, String>>>,
}

/// The bytes an object's shapes take, as counted against [`MAX_BYTES`].
fn bytes_of(o: &CollisionObject) -> usize {
    let meshes: usize = o
        .meshes
        .iter()
        .map(|m| m.vertices.len() * 24 + m.triangles.len() * 12)
        .sum();
    meshes + (o.primitives.len() + o.planes.len() + o.subframe_poses.len()) * 64 + 256
}

impl Scene {
    /// A scene with the mass and friction of `table`, no object known.
    pub(crate) fn new(table: ObjectTable) -> Self {
        Self {
            table,
            ..Self::default()
        }
    }

    /// The table.
    pub(crate) fn table(&self) -> &ObjectTable {
        &self.table
    }

    /// How many objects are known.
    pub(crate) fn len(&self) -> usize {
        self.known.len()
    }

    /// Takes one CollisionObject as MoveIt's planning scene does; a warning when it is not kept.
    pub(crate) fn apply(&mut self, o: CollisionObject) -> Result<(), String> {
        match o.operation {
            CollisionObject::ADD => self.add(o),
            CollisionObject::REMOVE => {
                if o.id.is_empty() {
                    let ids: Vec<String> = self.known.keys().cloned().collect();
                    for id in ids {
                        self.remove(&id);
                    }
                } else {
                    self.remove(&o.id);
                }
                Ok(())
            }
            CollisionObject::APPEND => self.append(o),
            CollisionObject::MOVE => self.move_to(&o),
            other => Err(format!(
                "collision object {:?}: operation {other} is not ADD, REMOVE, APPEND or MOVE; \
                 ignored",
                crate::msg::clip(&o.id)
            )),
        }
    }

    /// Takes the world's collision objects of a planning scene: a diff's in order; a whole
    /// scene (is_diff false) replaces every object known.
    pub(crate) fn apply_scene(&mut self, scene: PlanningScene) -> Vec<String> {
        if !scene.is_diff {
            let ids: Vec<String> = self.known.keys().cloned().collect();
            for id in ids {
                self.remove(&id);
            }
        }
        scene
            .world
            .collision_objects
            .into_iter()
            .filter_map(|o| self.apply(o).err())
            .collect()
    }

    fn add(&mut self, o: CollisionObject) -> Result<(), String> {
        let old = self.known.get(&o.id).map_or(0, bytes_of);
        let new = bytes_of(&o);
        if !self.known.contains_key(&o.id) && self.known.len() >= MAX_OBJECTS {
            return Err(format!(
                "collision object {:?} dropped: {MAX_OBJECTS} objects are known already",
                crate::msg::clip(&o.id)
            ));
        }
        if self.bytes - old + new > MAX_BYTES {
            return Err(format!(
                "collision object {:?} dropped: its shapes would take the objects known past \
                 {MAX_BYTES} bytes",
                crate::msg::clip(&o.id)
            ));
        }
        self.bytes = self.bytes - old + new;
        self.removed.remove(&o.id);
        self.mesh_volumes.borrow_mut().remove(&o.id);
        self.known.insert(o.id.clone(), o);
        Ok(())
    }

    fn remove(&mut self, id: &str) {
        if let Some(o) = self.known.remove(id) {
            self.bytes -= bytes_of(&o);
            self.mesh_volumes.borrow_mut().remove(id);
            if self.removed.len() >= MAX_REMOVED {
                self.removed.pop_first();
            }
            self.removed.insert(id.to_string());
        }
    }

    /// APPEND: the message's shapes added to the known object's, their poses taken against the
    /// known object's pose (the message's header and pose are left alone), as MoveIt's
    /// `World::addToObject` does; an object not known is added as by ADD.
    fn append(&mut self, o: CollisionObject) -> Result<(), String> {
        let Some(known) = self.known.get(&o.id) else {
            return self.add(o);
        };
        let mut merged = known.clone();
        merged.primitives.extend(o.primitives);
        merged.primitive_poses.extend(o.primitive_poses);
        merged.meshes.extend(o.meshes);
        merged.mesh_poses.extend(o.mesh_poses);
        merged.planes.extend(o.planes);
        merged.plane_poses.extend(o.plane_poses);
        merged.operation = CollisionObject::ADD;
        self.add(merged)
    }

    /// MOVE: a new header and pose for the known object, its shapes kept. Shapes in the message
    /// are ignored with a warning, as MoveIt's `processCollisionObjectMove` does.
    fn move_to(&mut self, o: &CollisionObject) -> Result<(), String> {
        let id = crate::msg::clip(&o.id);
        let Some(known) = self.known.get_mut(&o.id) else {
            return Err(format!(
                "collision object {id:?}: MOVE of an unknown object; ignored"
            ));
        };
        known.header = o.header.clone();
        known.pose = o.pose.clone();
        if !o.primitives.is_empty() || !o.meshes.is_empty() || !o.planes.is_empty() {
            return Err(format!(
                "collision object {id:?}: moved; the shapes in the MOVE message are ignored"
            ));
        }
        Ok(())
    }

    /// The object a `~/rank_grasps` call asks about: the one it brings (with shapes), or the
    /// known object of its id; as the `GraspObject` of a pose set, its pose in its own header
    /// frame (`frame_id`; the node turns it into the grasps' frame by TF), its mass and friction
    /// from the table. Status 2's words when it cannot be.
    pub(crate) fn grasp_object(&self, asked: &CollisionObject) -> Result<GraspObject, String> {
        let id = crate::msg::clip(&asked.id);
        let brings =
            !asked.primitives.is_empty() || !asked.meshes.is_empty() || !asked.planes.is_empty();
        let o = if brings {
            asked
        } else if let Some(known) = self.known.get(&asked.id) {
            known
        } else if self.removed.contains(&asked.id) {
            return Err(format!(
                "object {id:?} was removed from the planning scene (REMOVE) before this call; \
                 add it again or send it with its shapes"
            ));
        } else {
            return Err(format!(
                "object {id:?} is not known: no CollisionObject of that id was heard on \
                 /collision_object or /planning_scene ({} known); send it with its shapes",
                self.known.len()
            ));
        };
        if self.table.object(&o.id).is_none() {
            return Err(missing(&o.id));
        }
        // A known object's mesh volume is found once; one a call brings, each time.
        let volume = |m: &Mesh| -> Result<f64, String> {
            if brings {
                return mesh_volume(m);
            }
            self.mesh_volumes
                .borrow_mut()
                .entry(o.id.clone())
                .or_insert_with(|| mesh_volume(m))
                .clone()
        };
        to_grasp_object(o, &self.table, &volume).map_err(|why| format!("object {id:?}: {why}"))
    }
}

/// A CollisionObject of exactly one primitive or one mesh, with its entry in `table`, as a
/// `GraspObject`.
fn to_grasp_object(
    o: &CollisionObject,
    table: &ObjectTable,
    mesh_volume: &dyn Fn(&Mesh) -> Result<f64, String>,
) -> Result<GraspObject, String> {
    if !o.planes.is_empty() {
        return Err("a plane cannot be grasped; give one primitive or one mesh".into());
    }
    let shapes = o.primitives.len() + o.meshes.len();
    if shapes != 1 {
        return Err(format!(
            "{} primitives and {} meshes: exactly one primitive or one mesh is answered",
            o.primitives.len(),
            o.meshes.len()
        ));
    }
    let (shape_pose, poses_given) = match (o.primitives.first(), o.meshes.first()) {
        (Some(_), _) => (o.primitive_poses.first(), o.primitive_poses.len()),
        (None, _) => (o.mesh_poses.first(), o.mesh_poses.len()),
    };
    if poses_given != 1 {
        return Err(format!("one shape and {poses_given} poses for it"));
    }
    let Some(entry) = table.object(&o.id) else {
        return Err("no entry in objects_file".into());
    };
    // The shape's frame, against the object's header frame: the object's pose, then the
    // shape's against it.
    let shape_in_object = iso(shape_pose.unwrap_or(&Pose::default()));
    let placed = iso(&o.pose) * shape_in_object;
    let mut out = GraspObject {
        pose: Pose::from(&placed),
        scale: Vector3 {
            x: 1.0,
            y: 1.0,
            z: 1.0,
        },
        friction: entry.friction,
        frame_id: o.header.frame_id.as_str().into(),
        ..GraspObject::default()
    };
    if let Some(p) = o.primitives.first() {
        out.primitive = SolidPrimitive {
            kind: p.kind,
            dimensions: p.dimensions.clone(),
        };
        out.mass = entry.mass(|| primitive_volume(p))?;
    } else if let Some(m) = o.meshes.first() {
        out.inline_mesh = Mesh {
            triangles: m
                .triangles
                .iter()
                .map(|t| MeshTriangle {
                    vertex_indices: t.vertex_indices,
                })
                .collect(),
            vertices: m.vertices.clone(),
        };
        out.mass = entry.mass(|| mesh_volume(&out.inline_mesh))?;
    }
    if let Some(c) = entry.center_of_mass {
        // Given in the object's frame; the GraspObject's frame is the shape's.
        let local = shape_in_object.inverse() * nalgebra::Point3::new(c[0], c[1], c[2]);
        out.has_center_of_mass = true;
        out.center_of_mass = Point {
            x: local.x,
            y: local.y,
            z: local.z,
        };
    }
    Ok(out)
}

/// A primitive's volume, m³: box `x y z`; sphere `4/3 π r³`; cylinder `π r² h`; cone `π r² h / 3`
/// (shape_msgs' dimensions: cylinder and cone `[height, radius]`).
fn primitive_volume(p: &ShapePrimitive) -> Result<f64, String> {
    use std::f64::consts::PI;
    let d = &p.dimensions;
    let v = match (p.kind, d.as_slice()) {
        (ShapePrimitive::BOX, [x, y, z]) => x * y * z,
        (ShapePrimitive::SPHERE, [r]) => 4.0 / 3.0 * PI * r.powi(3),
        (ShapePrimitive::CYLINDER, [h, r]) => PI * r * r * h,
        (ShapePrimitive::CONE, [h, r]) => PI * r * r * h / 3.0,
        (kind, _) => {
            return Err(format!(
                "no volume for a primitive of type {kind} with {} dimensions, for its density",
                d.len()
            ))
        }
    };
    Ok(v)
}

/// A closed inline mesh's volume, m³.
fn mesh_volume(m: &Mesh) -> Result<f64, String> {
    let vertices: Vec<[f64; 3]> = m.vertices.iter().map(|v| [v.x, v.y, v.z]).collect();
    let triangles: Vec<[u32; 3]> = m.triangles.iter().map(|t| t.vertex_indices).collect();
    let mesh = grasp_orient_geometry::Mesh::from_triangles("mesh", &vertices, &triangles, [1.0; 3])
        .map_err(|e| format!("its mesh: {e}"))?;
    mesh.volume()
        .map_err(|e| format!("its mesh has no volume for its density: {e}"))
}

/// A pose as an isometry; an all-zero orientation is the identity, as MoveIt reads it.
fn iso(p: &Pose) -> Isometry3<f64> {
    let o = &p.orientation;
    let q = if [o.x, o.y, o.z, o.w] == [0.0; 4] {
        UnitQuaternion::identity()
    } else {
        UnitQuaternion::from_quaternion(Q::new(o.w, o.x, o.y, o.z))
    };
    Isometry3::from_parts(
        Translation3::new(p.position.x, p.position.y, p.position.z),
        q,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::moveit::{PlanningSceneWorld, ShapeMesh, ShapeMeshTriangle};
    use crate::msg::Quaternion;

    fn table() -> ObjectTable {
        ObjectTable::parse(
            "objects:\n  box: {mass: 0.5, friction: 0.7, center_of_mass: [0.01, 0, 0]}\n  \
             brick: {density: 1000, friction: 0.8}\n  cube: {density: 1000, friction: 0.8}\n",
        )
        .expect("a table")
    }

    fn boxed(id: &str, at: [f64; 3]) -> CollisionObject {
        CollisionObject {
            id: id.into(),
            pose: Pose {
                position: Point {
                    x: at[0],
                    y: at[1],
                    z: at[2],
                },
                orientation: Quaternion::default(),
            },
            primitives: vec![ShapePrimitive {
                kind: ShapePrimitive::BOX,
                dimensions: vec![0.1, 0.2, 0.3],
                ..ShapePrimitive::default()
            }],
            primitive_poses: vec![Pose {
                orientation: Quaternion {
                    z: std::f64::consts::FRAC_1_SQRT_2,
                    w: std::f64::consts::FRAC_1_SQRT_2,
                    ..Quaternion::default()
                },
                ..Pose::default()
            }],
            ..CollisionObject::default()
        }
        .with_frame("world")
    }

    trait WithFrame {
        fn with_frame(self, f: &str) -> Self;
    }
    impl WithFrame for CollisionObject {
        fn with_frame(mut self, f: &str) -> Self {
            self.header.frame_id = f.into();
            self
        }
    }

    /// ADD, MOVE, APPEND and REMOVE as MoveIt's scene takes them; a removed object's call is
    /// told so, an unknown one's too.
    #[test]
    fn operations_change_the_known_objects() {
        let mut s = Scene::new(table());
        s.apply(boxed("box", [1.0, 0.0, 0.0])).expect("added");
        let o = s.grasp_object(&CollisionObject {
            id: "box".into(),
            ..CollisionObject::default()
        });
        let o = o.expect("known");
        assert_eq!(
            (o.mass, o.friction, o.frame_id.as_str()),
            (0.5, 0.7, "world")
        );
        // Pose: the object's (zero quaternion: identity), then the shape's 90° about z.
        assert_eq!(o.pose.position.x, 1.0);
        assert!((o.pose.orientation.z - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-15);
        // The centre of mass, 1 cm along the object's x, is 1 cm along the shape's -y.
        assert!(o.has_center_of_mass);
        assert!((o.center_of_mass.y + 0.01).abs() < 1e-15 && o.center_of_mass.x.abs() < 1e-15);
        let mut moved = CollisionObject {
            id: "box".into(),
            operation: CollisionObject::MOVE,
            ..CollisionObject::default()
        }
        .with_frame("table");
        moved.pose.position.z = 2.0;
        s.apply(moved).expect("moved");
        let o = s
            .grasp_object(&CollisionObject {
                id: "box".into(),
                ..CollisionObject::default()
            })
            .expect("known");
        assert_eq!((o.frame_id.as_str(), o.pose.position.z), ("table", 2.0));
        let mut more = boxed("box", [0.0; 3]).with_frame("table");
        more.operation = CollisionObject::APPEND;
        s.apply(more).expect("appended");
        let e = s
            .grasp_object(&CollisionObject {
                id: "box".into(),
                ..CollisionObject::default()
            })
            .expect_err("two shapes");
        assert!(e.contains("2 primitives and 0 meshes"), "{e}");
        s.apply(CollisionObject {
            id: "box".into(),
            operation: CollisionObject::REMOVE,
            ..CollisionObject::default()
        })
        .expect("removed");
        assert_eq!(s.len(), 0);
        let e = s
            .grasp_object(&CollisionObject {
                id: "box".into(),
                ..CollisionObject::default()
            })
            .expect_err("removed");
        assert!(e.contains("was removed"), "{e}");
        let e = s
            .grasp_object(&CollisionObject {
                id: "cup".into(),
                ..CollisionObject::default()
            })
            .expect_err("unknown");
        assert!(e.contains("\"cup\" is not known"), "{e}");
        let e = s.apply(CollisionObject {
            id: "cup".into(),
            operation: 9,
            ..CollisionObject::default()
        });
        assert!(e.expect_err("bad operation").contains("operation 9"));
    }

    /// APPEND keeps the known object's pose and takes the new shapes' poses against it; MOVE with
    /// shapes moves the object, ignores the shapes and warns; as MoveIt does.
    #[test]
    fn append_and_move_as_moveit_takes_them() {
        let mut s = Scene::new(table());
        s.apply(boxed("box", [1.0, 0.0, 0.0])).expect("added");
        let mut more = boxed("box", [5.0, 5.0, 5.0]).with_frame("elsewhere");
        more.operation = CollisionObject::APPEND;
        more.primitive_poses[0].position.x = 0.25;
        s.apply(more).expect("appended");
        let known = &s.known["box"];
        assert_eq!(
            (known.header.frame_id.as_str(), known.pose.position.x),
            ("world", 1.0)
        );
        assert_eq!(known.primitives.len(), 2);
        assert_eq!(known.primitive_poses[1].position.x, 0.25);
        let mut moved = boxed("box", [0.0, 3.0, 0.0]);
        moved.operation = CollisionObject::MOVE;
        let warning = s.apply(moved).expect_err("a warning");
        assert!(
            warning.contains("shapes in the MOVE message are ignored"),
            "{warning}"
        );
        let known = &s.known["box"];
        assert_eq!((known.pose.position.y, known.primitives.len()), (3.0, 2));
        let mut lost = boxed("cup", [0.0; 3]);
        lost.operation = CollisionObject::MOVE;
        assert!(s
            .apply(lost)
            .expect_err("unknown")
            .contains("MOVE of an unknown object"));
    }

    /// A planning scene's diff applies in order; a whole scene replaces what is known.
    #[test]
    fn a_planning_scene_diff_and_a_whole_scene() {
        let mut s = Scene::new(table());
        let mut remove = boxed("a", [0.0; 3]);
        remove.operation = CollisionObject::REMOVE;
        let diff = PlanningScene {
            is_diff: true,
            world: PlanningSceneWorld {
                collision_objects: vec![boxed("a", [0.0; 3]), boxed("b", [0.0; 3]), remove],
                ..PlanningSceneWorld::default()
            },
            ..PlanningScene::default()
        };
        assert!(s.apply_scene(diff).is_empty());
        assert_eq!(s.len(), 1);
        let whole = PlanningScene {
            is_diff: false,
            world: PlanningSceneWorld {
                collision_objects: vec![boxed("c", [0.0; 3])],
                ..PlanningSceneWorld::default()
            },
            ..PlanningScene::default()
        };
        assert!(s.apply_scene(whole).is_empty());
        assert_eq!(s.known.keys().collect::<Vec<_>>(), ["c"]);
    }

    /// An object with no entry in the table is refused naming it and the parameter; density
    /// times volume gives the mass, of a primitive and of a closed mesh.
    #[test]
    fn mass_from_the_table_or_a_refusal() {
        let s = Scene::new(table());
        let e = s
            .grasp_object(&boxed("mug", [0.0; 3]))
            .expect_err("no entry");
        assert!(e.contains("\"mug\"") && e.contains("objects_file"), "{e}");
        let brick = s.grasp_object(&boxed("brick", [0.0; 3])).expect("a brick");
        assert!(
            (brick.mass - 1000.0 * 0.1 * 0.2 * 0.3).abs() < 1e-12,
            "{}",
            brick.mass
        );
        // A unit cube of 12 triangles wound outward: 1 m³, 1000 kg.
        let v = |x: f64, y: f64, z: f64| Point { x, y, z };
        let vertices = vec![
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(1.0, 1.0, 0.0),
            v(0.0, 1.0, 0.0),
            v(0.0, 0.0, 1.0),
            v(1.0, 0.0, 1.0),
            v(1.0, 1.0, 1.0),
            v(0.0, 1.0, 1.0),
        ];
        let faces: [[u32; 3]; 12] = [
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [1, 2, 6],
            [1, 6, 5],
            [2, 3, 7],
            [2, 7, 6],
            [3, 0, 4],
            [3, 4, 7],
        ];
        let cube = CollisionObject {
            id: "cube".into(),
            meshes: vec![ShapeMesh {
                triangles: faces
                    .iter()
                    .map(|&t| ShapeMeshTriangle { vertex_indices: t })
                    .collect(),
                vertices,
            }],
            mesh_poses: vec![Pose::default()],
            ..CollisionObject::default()
        };
        let o = s.grasp_object(&cube).expect("a cube");
        assert!((o.mass - 1000.0).abs() < 1e-9, "{}", o.mass);
        assert_eq!(o.inline_mesh.triangles.len(), 12);
        // Known by id: its volume is found once, and again once its shapes change.
        let mut s = s;
        s.apply(cube.clone()).expect("added");
        let by_id = CollisionObject {
            id: "cube".into(),
            ..CollisionObject::default()
        };
        for _ in 0..2 {
            let o = s.grasp_object(&by_id).expect("known");
            assert!((o.mass - 1000.0).abs() < 1e-9, "{}", o.mass);
        }
        assert_eq!(s.mesh_volumes.borrow().len(), 1);
        let mut bigger = cube;
        for v in &mut bigger.meshes[0].vertices {
            (v.x, v.y, v.z) = (2.0 * v.x, 2.0 * v.y, 2.0 * v.z);
        }
        s.apply(bigger).expect("replaced");
        let o = s.grasp_object(&by_id).expect("known");
        assert!((o.mass - 8000.0).abs() < 1e-9, "{}", o.mass);
    }

    /// The known objects are bounded in number.
    #[test]
    fn the_known_objects_are_bounded() {
        let mut s = Scene::new(table());
        for i in 0..MAX_OBJECTS {
            s.apply(boxed(&i.to_string(), [0.0; 3])).expect("kept");
        }
        let e = s.apply(boxed("one more", [0.0; 3])).expect_err("dropped");
        assert!(e.contains("1024 objects are known already"), "{e}");
        // Replacing one already known is still taken.
        s.apply(boxed("0", [1.0; 3])).expect("replaced");
        assert_eq!(s.len(), MAX_OBJECTS);
    }
}
