//! The answers of a call as columns: one array per field of `GripRecommendation` that has one
//! value a row (vectors and quaternions as rows of an `(N, k)` array), and, for poses, the
//! geometry of `PoseRecommendation`. Filled chunk by chunk, in row order, then handed to Python
//! as a dict of numpy arrays (and lists of str for the text fields).

use grasp_orient::msg::{
    CompactString, GripRecommendation, Point, PoseRecommendation, Quaternion, Vector3,
};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};
use std::collections::HashMap;

/// The columns of a recommendation's fields.
#[derive(Debug, Default)]
pub(crate) struct Columns {
    status: Vec<u8>,
    message: Texts,
    wrist_rotation: Vec<f64>,
    rotation: Vec<f64>,
    rotation_axis: Vec<f64>,
    gravity_direction: Vec<f64>,
    gravity_angle: Vec<f64>,
    gripping_power: Vec<f64>,
    gripping_power_nominal: Vec<f64>,
    internal_force: Vec<f64>,
    finger_force: Vec<f64>,
    contact_forces: Vec<f64>,
    gripping_power_current: Vec<f64>,
    internal_force_current: Vec<f64>,
    finger_force_current: Vec<f64>,
    candidate_c: Vec<u8>,
    grasp_case: Texts,
    recommended_label: Texts,
    objective: Texts,
    /// The pose fields, filled by [`Columns::push_pose`] only.
    geometry: Geometry,
}

/// The geometry of a pose's answer, and the quaternion its pose's rotation became.
#[derive(Debug, Default)]
struct Geometry {
    contact_1: Vec<f64>,
    contact_2: Vec<f64>,
    normal_1: Vec<f64>,
    normal_2: Vec<f64>,
    center_of_mass: Vec<f64>,
    grasp_orientation: Vec<f64>,
    /// `x, y, z, qx, qy, qz, qw` of the tool pose to carry the object in.
    tool_pose: Vec<f64>,
}

fn point(out: &mut Vec<f64>, p: &Point) {
    out.extend_from_slice(&[p.x, p.y, p.z]);
}

fn vector(out: &mut Vec<f64>, v: &Vector3) {
    out.extend_from_slice(&[v.x, v.y, v.z]);
}

fn quaternion(out: &mut Vec<f64>, q: &Quaternion) {
    out.extend_from_slice(&[q.x, q.y, q.z, q.w]);
}

impl Columns {
    /// Room for `rows` rows.
    pub(crate) fn with_capacity(rows: usize) -> Self {
        Columns {
            status: Vec::with_capacity(rows),
            message: Texts::with_capacity(rows),
            wrist_rotation: Vec::with_capacity(rows),
            rotation: Vec::with_capacity(4 * rows),
            rotation_axis: Vec::with_capacity(3 * rows),
            gravity_direction: Vec::with_capacity(3 * rows),
            gravity_angle: Vec::with_capacity(rows),
            gripping_power: Vec::with_capacity(rows),
            gripping_power_nominal: Vec::with_capacity(rows),
            internal_force: Vec::with_capacity(rows),
            finger_force: Vec::with_capacity(rows),
            contact_forces: Vec::with_capacity(4 * rows),
            gripping_power_current: Vec::with_capacity(rows),
            internal_force_current: Vec::with_capacity(rows),
            finger_force_current: Vec::with_capacity(rows),
            candidate_c: Vec::with_capacity(rows),
            grasp_case: Texts::with_capacity(rows),
            recommended_label: Texts::with_capacity(rows),
            objective: Texts::with_capacity(rows),
            geometry: Geometry::default(),
        }
    }

    /// Rows so far.
    pub(crate) fn len(&self) -> usize {
        self.status.len()
    }

    /// One answer; `message` is its message as the caller reports it (the row named).
    pub(crate) fn push(&mut self, r: &GripRecommendation, message: CompactString) {
        self.status.push(r.status);
        self.message.push(&message);
        self.wrist_rotation.push(r.wrist_rotation);
        quaternion(&mut self.rotation, &r.rotation);
        vector(&mut self.rotation_axis, &r.rotation_axis);
        vector(&mut self.gravity_direction, &r.gravity_direction);
        self.gravity_angle.push(r.gravity_angle);
        self.gripping_power.push(r.gripping_power);
        self.gripping_power_nominal.push(r.gripping_power_nominal);
        self.internal_force.push(r.internal_force);
        self.finger_force.push(r.finger_force);
        self.contact_forces.extend_from_slice(&r.contact_forces);
        self.gripping_power_current.push(r.gripping_power_current);
        self.internal_force_current.push(r.internal_force_current);
        self.finger_force_current.push(r.finger_force_current);
        self.candidate_c.push(r.candidate_c);
        self.grasp_case.push(&r.grasp_case);
        self.recommended_label.push(&r.recommended_label);
        self.objective.push(&r.objective);
    }

    /// One pose's answer, and the quaternion `orientation` its pose's rotation became.
    pub(crate) fn push_pose(
        &mut self,
        p: &PoseRecommendation,
        message: CompactString,
        orientation: &Quaternion,
    ) {
        self.push(&p.recommendation, message);
        let g = &mut self.geometry;
        point(&mut g.contact_1, &p.contact_1);
        point(&mut g.contact_2, &p.contact_2);
        vector(&mut g.normal_1, &p.normal_1);
        vector(&mut g.normal_2, &p.normal_2);
        point(&mut g.center_of_mass, &p.center_of_mass);
        quaternion(&mut g.grasp_orientation, orientation);
        point(&mut g.tool_pose, &p.tool_pose.pose.position);
        quaternion(&mut g.tool_pose, &p.tool_pose.pose.orientation);
    }

    /// `other`'s rows after these.
    pub(crate) fn append(&mut self, mut other: Columns) {
        macro_rules! each {
            ($($field:ident).+) => {
                self.$($field).+.append(&mut other.$($field).+);
            };
        }
        each!(status);
        self.message.append(other.message);
        each!(wrist_rotation);
        each!(rotation);
        each!(rotation_axis);
        each!(gravity_direction);
        each!(gravity_angle);
        each!(gripping_power);
        each!(gripping_power_nominal);
        each!(internal_force);
        each!(finger_force);
        each!(contact_forces);
        each!(gripping_power_current);
        each!(internal_force_current);
        each!(finger_force_current);
        each!(candidate_c);
        self.grasp_case.append(other.grasp_case);
        self.recommended_label.append(other.recommended_label);
        self.objective.append(other.objective);
        each!(geometry.contact_1);
        each!(geometry.contact_2);
        each!(geometry.normal_1);
        each!(geometry.normal_2);
        each!(geometry.center_of_mass);
        each!(geometry.grasp_orientation);
        each!(geometry.tool_pose);
    }

    /// The columns as a dict of numpy arrays and lists of str, the pose fields only when
    /// `poses`.
    pub(crate) fn into_dict(self, py: Python<'_>, poses: bool) -> PyResult<Bound<'_, PyDict>> {
        let n = self.len();
        let d = PyDict::new(py);
        d.set_item("status", PyArray1::from_vec(py, self.status))?;
        d.set_item("message", self.message.into_list(py)?)?;
        d.set_item(
            "wrist_rotation",
            PyArray1::from_vec(py, self.wrist_rotation),
        )?;
        d.set_item("rotation", rows(py, self.rotation, n, 4)?)?;
        d.set_item("rotation_axis", rows(py, self.rotation_axis, n, 3)?)?;
        d.set_item("gravity_direction", rows(py, self.gravity_direction, n, 3)?)?;
        d.set_item("gravity_angle", PyArray1::from_vec(py, self.gravity_angle))?;
        d.set_item(
            "gripping_power",
            PyArray1::from_vec(py, self.gripping_power),
        )?;
        d.set_item(
            "gripping_power_nominal",
            PyArray1::from_vec(py, self.gripping_power_nominal),
        )?;
        d.set_item(
            "internal_force",
            PyArray1::from_vec(py, self.internal_force),
        )?;
        d.set_item("finger_force", PyArray1::from_vec(py, self.finger_force))?;
        d.set_item("contact_forces", rows(py, self.contact_forces, n, 4)?)?;
        d.set_item(
            "gripping_power_current",
            PyArray1::from_vec(py, self.gripping_power_current),
        )?;
        d.set_item(
            "internal_force_current",
            PyArray1::from_vec(py, self.internal_force_current),
        )?;
        d.set_item(
            "finger_force_current",
            PyArray1::from_vec(py, self.finger_force_current),
        )?;
        d.set_item("candidate_c", PyArray1::from_vec(py, self.candidate_c))?;
        d.set_item("grasp_case", self.grasp_case.into_list(py)?)?;
        d.set_item("recommended_label", self.recommended_label.into_list(py)?)?;
        d.set_item("objective", self.objective.into_list(py)?)?;
        if poses {
            let g = self.geometry;
            d.set_item("contact_1", rows(py, g.contact_1, n, 3)?)?;
            d.set_item("contact_2", rows(py, g.contact_2, n, 3)?)?;
            d.set_item("normal_1", rows(py, g.normal_1, n, 3)?)?;
            d.set_item("normal_2", rows(py, g.normal_2, n, 3)?)?;
            d.set_item("center_of_mass", rows(py, g.center_of_mass, n, 3)?)?;
            d.set_item("grasp_orientation", rows(py, g.grasp_orientation, n, 4)?)?;
            d.set_item("tool_pose", rows(py, g.tool_pose, n, 7)?)?;
        }
        Ok(d)
    }
}

/// `values` as an `(n, k)` array.
fn rows(py: Python<'_>, values: Vec<f64>, n: usize, k: usize) -> PyResult<Bound<'_, PyAny>> {
    Ok(PyArray1::from_vec(py, values).reshape([n, k])?.into_any())
}

/// A column of texts, each row the index of its text among the column's distinct ones: equal
/// texts are stored once (most rows' messages are empty, and the labels take a few values), and
/// become one str object each, shared by their rows, so a million rows make neither a million
/// strings in Rust nor in Python.
#[derive(Debug, Default)]
struct Texts {
    rows: Vec<usize>,
    distinct: Vec<CompactString>,
    /// The index of each distinct text, once there are more than [`Texts::SCANNED`].
    index: HashMap<CompactString, usize>,
}

impl Texts {
    /// Up to this many distinct texts are found by comparing with each (the labels'
    /// columns never need more); beyond, through `index`.
    const SCANNED: usize = 16;

    fn with_capacity(rows: usize) -> Self {
        Texts {
            rows: Vec::with_capacity(rows),
            ..Texts::default()
        }
    }

    /// The index of `text`, added if new.
    fn intern(&mut self, text: &str) -> usize {
        let found = if self.distinct.len() <= Self::SCANNED {
            self.distinct.iter().position(|d| d == text)
        } else {
            self.index.get(text).copied()
        };
        found.unwrap_or_else(|| {
            let i = self.distinct.len();
            self.distinct.push(text.into());
            if self.distinct.len() > Self::SCANNED {
                if self.index.is_empty() {
                    self.index = self.distinct.iter().cloned().zip(0..).collect();
                } else {
                    self.index.insert(text.into(), i);
                }
            }
            i
        })
    }

    /// One row; a text equal to the row before's takes its index without a look-up.
    fn push(&mut self, text: &str) {
        let i = match self.rows.last() {
            Some(&last) if self.distinct[last] == text => last,
            _ => self.intern(text),
        };
        self.rows.push(i);
    }

    /// `other`'s rows after these.
    fn append(&mut self, other: Texts) {
        let to: Vec<usize> = other.distinct.iter().map(|t| self.intern(t)).collect();
        self.rows.extend(other.rows.iter().map(|&i| to[i]));
    }

    /// The rows as a list of str, one object per distinct text.
    fn into_list(self, py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
        let objects: Vec<Bound<'_, PyString>> =
            self.distinct.iter().map(|t| PyString::new(py, t)).collect();
        PyList::new(py, self.rows.iter().map(|&i| objects[i].clone()))
    }
}
