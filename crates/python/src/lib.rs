//! The Python module `grasp_orient` (its native part, `grasp_orient._grasp_orient`): grasp
//! datasets re-scored in numpy without a node. Three functions (`docs/python.md`):
//!
//! - `solve`: rows of contacts, normals, centre of mass, gravity, mass and friction → one
//!   `GripRecommendation` a row, as columns (`grasps.rs`);
//! - `solve_poses`: 4×4 gripper poses and openings on one mesh given as arrays → the same, and
//!   the contacts, normals and centre of mass the fingers found (`poses.rs`);
//! - `load_mesh`: an STL, OBJ or COLLADA file → its vertices and triangles.
//!
//! Every answer is the root crate's (`grasp_orient::answer`), under the settings that
//! `grasp_orient solve`'s flags of the same names give (`options.rs`), so a row's answer is the
//! one `solve` gives for the same candidate. Arrays are checked before anything is solved
//! (`arrays.rs`); the GIL is released while the rows are answered, on every core unless
//! `threads` says otherwise (`chunks.rs`).

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

mod arrays;
mod chunks;
mod columns;
mod grasps;
mod options;
mod poses;

use arrays::{floats, number, slice_of, three, value_error};
use chunks::Threads;
use grasp_orient::answer::PoseAnswerer;
use grasp_orient::geometry::{parse, resolve, AmentIndex, ClosingAxis};
use grasp_orient::msg::GraspCandidate;
use numpy::{PyArray1, PyArrayMethods};
use options::{Options, RangeArg};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::str::FromStr;

/// The options every solving function takes, after its own arguments.
#[allow(clippy::too_many_arguments)]
fn options(
    objective: String,
    range: &Bound<'_, PyAny>,
    friction_safety_factor: f64,
    max_grip_force: f64,
    gripper_drive: String,
    center_of_mass_tolerance: &Bound<'_, PyAny>,
    mass_tolerance: f64,
) -> PyResult<Options> {
    Ok(Options {
        objective,
        range: RangeArg::extract(range)?,
        friction_safety_factor,
        max_grip_force,
        gripper_drive,
        center_of_mass_tolerance: three(center_of_mass_tolerance, "center_of_mass_tolerance")?,
        mass_tolerance,
    })
}

/// The row count of a checked array, the same as the first's.
fn same_rows(name: &str, shape: &[usize], first: &str, rows: usize) -> PyResult<()> {
    if shape[0] == rows {
        Ok(())
    } else {
        Err(value_error(format!(
            "{name}: {} rows, but {first} has {rows}: every array takes one row a grasp",
            shape[0]
        )))
    }
}

/// An optional argument: `None` when absent or given as Python's None.
fn given<'a, 'py>(o: Option<&'a Bound<'py, PyAny>>) -> Option<&'a Bound<'py, PyAny>> {
    o.filter(|o| !o.is_none())
}

/// The model a name gives: `"planar"` (the x-y plane, z ignored) or `"spatial"` (3D).
fn model_of(model: &str) -> PyResult<u8> {
    match model {
        "planar" => Ok(GraspCandidate::MODEL_PLANAR),
        "spatial" => Ok(GraspCandidate::MODEL_SPATIAL),
        other => Err(value_error(format!(
            "model: {other:?} is not one of planar, spatial"
        ))),
    }
}

/// Solves N two-finger grasps given as arrays: for each row, the wrist rotation that minimises
/// the gripping power, and the grip force there.
///
/// contact_1, normal_1, contact_2, normal_2, center_of_mass, gravity: float64 arrays of shape
/// (N, 3), C-contiguous (m, inward normals of any length > 0, m/s²). mass (kg): float64 of
/// shape (N,). friction: float64 of shape (N,), the Coulomb coefficient at both contacts, or
/// (N, 2), one a contact.
///
/// model: "spatial" (3D) or "planar" (the paper's x-y plane, z ignored). objective, range,
/// friction_safety_factor, max_grip_force, gripper_drive, center_of_mass_tolerance and
/// mass_tolerance mean what grasp_orient solve's flags of the same names mean. threads: None
/// for every core, or a count (1: the calling thread only).
///
/// Returns a dict of arrays, one row a grasp, named as GripRecommendation's fields: status
/// (uint8; 0 ok, 1 no force closure, 2 invalid input, 3 exceeds the gripper), wrist_rotation,
/// rotation (N, 4: x, y, z, w), rotation_axis (N, 3), gripping_power, internal_force,
/// finger_force, contact_forces (N, 4), gravity_direction (N, 3), gravity_angle, the *_current
/// forces, gripping_power_nominal, candidate_c, and lists of str: message (empty where
/// status is 0), grasp_case, recommended_label, objective.
///
/// Raises ValueError for arrays of the wrong type, dtype, shape or order, for a value that is
/// not finite (naming the argument, the row and the column), and for a bad option.
#[pyfunction]
#[pyo3(signature = (
    contact_1, normal_1, contact_2, normal_2, center_of_mass, gravity, mass, friction, *,
    model = "spatial".to_string(), objective = "norm2".to_string(),
    range = None, friction_safety_factor = 1.0, max_grip_force = 0.0,
    gripper_drive = "coupled".to_string(), center_of_mass_tolerance = None,
    mass_tolerance = 0.0, threads = None,
))]
#[allow(clippy::too_many_arguments)]
fn solve<'py>(
    py: Python<'py>,
    contact_1: &Bound<'py, PyAny>,
    normal_1: &Bound<'py, PyAny>,
    contact_2: &Bound<'py, PyAny>,
    normal_2: &Bound<'py, PyAny>,
    center_of_mass: &Bound<'py, PyAny>,
    gravity: &Bound<'py, PyAny>,
    mass: &Bound<'py, PyAny>,
    friction: &Bound<'py, PyAny>,
    model: String,
    objective: String,
    range: Option<&Bound<'py, PyAny>>,
    friction_safety_factor: f64,
    max_grip_force: f64,
    gripper_drive: String,
    center_of_mass_tolerance: Option<&Bound<'py, PyAny>>,
    mass_tolerance: f64,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let vectors = [
        ("contact_1", contact_1),
        ("normal_1", normal_1),
        ("contact_2", contact_2),
        ("normal_2", normal_2),
        ("center_of_mass", center_of_mass),
        ("gravity", gravity),
    ];
    let mut arrays = Vec::with_capacity(8);
    let mut rows = None;
    for (name, obj) in vectors {
        let (array, shape) = floats(obj, name, &[None, Some(3)])?;
        match rows {
            None => rows = Some(shape[0]),
            Some(n) => same_rows(name, &shape, "contact_1", n)?,
        }
        arrays.push((name, array));
    }
    let n = rows.unwrap_or(0);
    let (array, shape) = floats(mass, "mass", &[None])?;
    same_rows("mass", &shape, "contact_1", n)?;
    arrays.push(("mass", array));
    // One coefficient a row for both contacts, or a pair (friction_1, friction_2).
    let per_contact = friction
        .cast::<numpy::PyUntypedArray>()
        .is_ok_and(|a| numpy::PyUntypedArrayMethods::ndim(a) == 2);
    let friction_shape: &[Option<usize>] = if per_contact {
        &[None, Some(2)]
    } else {
        &[None]
    };
    let (array, shape) = floats(friction, "friction", friction_shape)?;
    same_rows("friction", &shape, "contact_1", n)?;
    arrays.push(("friction", array));
    let zero = (0.0, 0.0, 0.0).into_pyobject(py)?.into_any();
    let from_above = "from_above".into_pyobject(py)?.into_any();
    let options = options(
        objective,
        given(range).unwrap_or(&from_above),
        friction_safety_factor,
        max_grip_force,
        gripper_drive,
        given(center_of_mass_tolerance).unwrap_or(&zero),
        mass_tolerance,
    )?;
    let (settings, rules) = options.settings()?;
    let model = model_of(&model)?;
    let threads = Threads::from_arg(threads)?;
    let s: Vec<&[f64]> = arrays
        .iter()
        .map(|(name, a)| slice_of(a, name))
        .collect::<PyResult<_>>()?;
    let grasps = grasps::Grasps {
        contact_1: s[0],
        normal_1: s[1],
        contact_2: s[2],
        normal_2: s[3],
        center_of_mass: s[4],
        gravity: s[5],
        mass: s[6],
        friction: s[7],
        friction_stride: if per_contact { 2 } else { 1 },
        model,
    };
    let columns = py.detach(|| grasps::solve(&grasps, &settings, &rules, &threads));
    columns.into_dict(py, false)
}

/// Solves N gripper poses on one mesh: the fingers close from each pose onto the mesh, and the
/// grasp they make is solved as solve() solves a spatial one.
///
/// vertices: float64 (V, 3), the mesh's units; triangles: integer (T, 3) indices into vertices
/// (what trimesh gives: mesh.vertices, mesh.faces). poses: float64 (N, 4, 4), each the tool
/// frame in the mesh's frame as a homogeneous transform (ACRONYM's and graspnetAPI's layout),
/// its translation in metres; widths: float64 (N,), the opening before closing, m. mass (kg),
/// friction (both contacts) and gravity (three numbers, m/s², in the mesh's frame) are shared
/// by every pose.
///
/// closing_axis: the tool frame's axis the fingers close along ("x", "y" or "z"; docs/python.md
/// says which a dataset's poses take). center_of_mass: three numbers
/// in the mesh's frame (m), or None for the closed mesh's centroid. scale: the factor from the
/// mesh's units to metres, one number or three (0.001 for millimetres). The other options
/// are solve()'s.
///
/// Returns solve()'s dict, and contact_1, contact_2, normal_1, normal_2, center_of_mass
/// (N, 3; NaN where the geometry refused the pose) and grasp_orientation (N, 4: x, y, z, w,
/// the quaternion each pose's rotation became).
#[pyfunction]
#[pyo3(signature = (
    vertices, triangles, poses, widths, mass, friction, gravity, *,
    closing_axis = "y".to_string(), center_of_mass = None, scale = None,
    objective = "norm2".to_string(), range = None, friction_safety_factor = 1.0,
    max_grip_force = 0.0, gripper_drive = "coupled".to_string(),
    center_of_mass_tolerance = None, mass_tolerance = 0.0, threads = None,
))]
#[allow(clippy::too_many_arguments)]
fn solve_poses<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    triangles: &Bound<'py, PyAny>,
    poses: &Bound<'py, PyAny>,
    widths: &Bound<'py, PyAny>,
    mass: f64,
    friction: f64,
    gravity: &Bound<'py, PyAny>,
    closing_axis: String,
    center_of_mass: Option<&Bound<'py, PyAny>>,
    scale: Option<&Bound<'py, PyAny>>,
    objective: String,
    range: Option<&Bound<'py, PyAny>>,
    friction_safety_factor: f64,
    max_grip_force: f64,
    gripper_drive: String,
    center_of_mass_tolerance: Option<&Bound<'py, PyAny>>,
    mass_tolerance: f64,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let (v, v_shape) = floats(vertices, "vertices", &[None, Some(3)])?;
    let vertex_values = slice_of(&v, "vertices")?;
    let triangles = arrays::triangles(triangles, v_shape[0])?;
    let (p, p_shape) = floats(poses, "poses", &[None, Some(4), Some(4)])?;
    let (w, w_shape) = floats(widths, "widths", &[None])?;
    same_rows("widths", &w_shape, "poses", p_shape[0])?;
    let pose_values = slice_of(&p, "poses")?;
    let poses: Vec<_> = pose_values
        .chunks_exact(16)
        .enumerate()
        .map(|(row, m)| poses::pose_of(m, row))
        .collect::<Result<_, _>>()
        .map_err(value_error)?;
    let scale = match given(scale) {
        None => [1.0; 3],
        Some(s) => match s.extract::<f64>() {
            Ok(k) => [number(k, "scale")?; 3],
            Err(_) => three(s, "scale")?,
        },
    };
    let object = poses::Object {
        vertices: vertex_values
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
        triangles,
        scale,
        mass: number(mass, "mass")?,
        friction: number(friction, "friction")?,
        center_of_mass: given(center_of_mass)
            .map(|c| three(c, "center_of_mass"))
            .transpose()?,
    };
    let zero = (0.0, 0.0, 0.0).into_pyobject(py)?.into_any();
    let from_above = "from_above".into_pyobject(py)?.into_any();
    let options = options(
        objective,
        given(range).unwrap_or(&from_above),
        friction_safety_factor,
        max_grip_force,
        gripper_drive,
        given(center_of_mass_tolerance).unwrap_or(&zero),
        mass_tolerance,
    )?;
    let (settings, rules) = options.settings()?;
    let axis = ClosingAxis::from_str(&closing_axis)
        .map_err(|e| value_error(format!("closing_axis: {e}")))?;
    let threads = Threads::from_arg(threads)?;
    let input = poses::Poses {
        object,
        poses,
        widths: slice_of(&w, "widths")?.to_vec(),
        gravity: three(gravity, "gravity")?,
    };
    let answerer = PoseAnswerer::new(axis, AmentIndex::default());
    let columns = py.detach(|| poses::solve(&input, &answerer, &settings, &rules, &threads));
    columns.into_dict(py, true)
}

/// Reads an STL, OBJ or COLLADA file (a path, file://, or package:// through
/// AMENT_PREFIX_PATH) as grasp_orient reads a mesh resource, COLLADA's unit applied.
///
/// Returns (vertices, triangles): float64 (V, 3) in the file's units, and int64 (T, 3)
/// indices, as solve_poses takes them. Raises ValueError naming the resource when it cannot be
/// read or parsed.
#[pyfunction]
fn load_mesh<'py>(
    py: Python<'py>,
    resource: &str,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let parsed = py.detach(|| {
        let path = resolve(resource, &AmentIndex::from_env())?;
        parse(resource, &path)
    });
    let (vertices, triangles) = parsed.map_err(|e| value_error(e.to_string()))?;
    let v = vertices.len();
    let t = triangles.len();
    let flat_v: Vec<f64> = vertices.into_iter().flatten().collect();
    let flat_t: Vec<i64> = triangles.into_iter().flatten().map(i64::from).collect();
    Ok((
        PyArray1::from_vec(py, flat_v).reshape([v, 3])?.into_any(),
        PyArray1::from_vec(py, flat_t).reshape([t, 3])?.into_any(),
    ))
}

/// The module.
#[pymodule]
fn _grasp_orient(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(solve_poses, m)?)?;
    m.add_function(wrap_pyfunction!(load_mesh, m)?)?;
    Ok(())
}
