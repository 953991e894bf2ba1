//! The answers of a call as columns: one array per field of `GripRecommendation` that has one
//! value a row (vectors and quaternions as rows of an `(N, k)` array), and, for poses, the
//! geometry of `PoseRecommendation`. Filled chunk by chunk, in row order, then handed to Python
//! as a dict of numpy arrays (and lists of str for the text fields).

use grasp_orient::msg::{
    CompactString, GripRecommendation, Point, PoseRecommendation, Quaternion, Vector3,
};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyListMethods, PySequenceMethods, PyString};
use std::collections::HashMap;

/// The columns of a recommendation's fields. A vector or quaternion column holds one array a
/// row, flattened into its `(N, k)` array without a copy ([`Vec::into_flattened`]); every array
/// is handed to numpy as it is, without a copy.
#[derive(Debug, Default)]
pub(crate) struct Columns {
    status: Vec<u8>,
    message: Messages,
    wrist_rotation: Vec<f64>,
    rotation: Vec<[f64; 4]>,
    rotation_axis: Vec<[f64; 3]>,
    gravity_direction: Vec<[f64; 3]>,
    gravity_angle: Vec<f64>,
    gripping_power: Vec<f64>,
    gripping_power_nominal: Vec<f64>,
    internal_force: Vec<f64>,
    finger_force: Vec<f64>,
    contact_forces: Vec<[f64; 4]>,
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
    contact_1: Vec<[f64; 3]>,
    contact_2: Vec<[f64; 3]>,
    normal_1: Vec<[f64; 3]>,
    normal_2: Vec<[f64; 3]>,
    center_of_mass: Vec<[f64; 3]>,
    grasp_orientation: Vec<[f64; 4]>,
    /// `x, y, z, qx, qy, qz, qw` of the tool pose to carry the object in.
    tool_pose: Vec<[f64; 7]>,
}

fn point(p: &Point) -> [f64; 3] {
    [p.x, p.y, p.z]
}

fn vector(v: &Vector3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

fn quaternion(q: &Quaternion) -> [f64; 4] {
    [q.x, q.y, q.z, q.w]
}

impl Columns {
    /// Room for `rows` rows.
    pub(crate) fn with_capacity(rows: usize) -> Self {
        Columns {
            status: Vec::with_capacity(rows),
            message: Messages::default(),
            wrist_rotation: Vec::with_capacity(rows),
            rotation: Vec::with_capacity(rows),
            rotation_axis: Vec::with_capacity(rows),
            gravity_direction: Vec::with_capacity(rows),
            gravity_angle: Vec::with_capacity(rows),
            gripping_power: Vec::with_capacity(rows),
            gripping_power_nominal: Vec::with_capacity(rows),
            internal_force: Vec::with_capacity(rows),
            finger_force: Vec::with_capacity(rows),
            contact_forces: Vec::with_capacity(rows),
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

    /// Answers, one row each, in order; `message(row, answer)` is an answer's message as the
    /// caller reports it, `row` its index among `answers`. Filled a column at a time: each
    /// number column is one pass over the answers that writes without checking its room row
    /// by row, and a text is moved, not copied.
    pub(crate) fn push_all(
        &mut self,
        mut answers: Vec<GripRecommendation>,
        message: impl Fn(usize, &GripRecommendation) -> Option<CompactString>,
    ) {
        let first = self.len();
        for (i, r) in answers.iter_mut().enumerate() {
            let text = message(i, r).unwrap_or_else(|| std::mem::take(&mut r.message));
            self.message.push(first + i, text);
            self.grasp_case.push(&r.grasp_case);
            self.recommended_label.push(&r.recommended_label);
            self.objective.push(&r.objective);
        }
        let a = answers.as_slice();
        macro_rules! each {
            ($column:ident, |$r:ident| $value:expr) => {
                self.$column.extend(a.iter().map(|$r| $value));
            };
        }
        each!(status, |r| r.status);
        each!(wrist_rotation, |r| r.wrist_rotation);
        each!(rotation, |r| quaternion(&r.rotation));
        each!(rotation_axis, |r| vector(&r.rotation_axis));
        each!(gravity_direction, |r| vector(&r.gravity_direction));
        each!(gravity_angle, |r| r.gravity_angle);
        each!(gripping_power, |r| r.gripping_power);
        each!(gripping_power_nominal, |r| r.gripping_power_nominal);
        each!(internal_force, |r| r.internal_force);
        each!(finger_force, |r| r.finger_force);
        each!(contact_forces, |r| r.contact_forces);
        each!(gripping_power_current, |r| r.gripping_power_current);
        each!(internal_force_current, |r| r.internal_force_current);
        each!(finger_force_current, |r| r.finger_force_current);
        each!(candidate_c, |r| r.candidate_c);
    }

    /// One answer; `message` is its message as the caller reports it (the row named).
    fn push(&mut self, r: &GripRecommendation, message: CompactString) {
        self.message.push(self.len(), message);
        self.status.push(r.status);
        self.wrist_rotation.push(r.wrist_rotation);
        self.rotation.push(quaternion(&r.rotation));
        self.rotation_axis.push(vector(&r.rotation_axis));
        self.gravity_direction.push(vector(&r.gravity_direction));
        self.gravity_angle.push(r.gravity_angle);
        self.gripping_power.push(r.gripping_power);
        self.gripping_power_nominal.push(r.gripping_power_nominal);
        self.internal_force.push(r.internal_force);
        self.finger_force.push(r.finger_force);
        self.contact_forces.push(r.contact_forces);
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
        g.contact_1.push(point(&p.contact_1));
        g.contact_2.push(point(&p.contact_2));
        g.normal_1.push(vector(&p.normal_1));
        g.normal_2.push(vector(&p.normal_2));
        g.center_of_mass.push(point(&p.center_of_mass));
        g.grasp_orientation.push(quaternion(orientation));
        let (at, q) = (&p.tool_pose.pose.position, &p.tool_pose.pose.orientation);
        g.tool_pose.push([at.x, at.y, at.z, q.x, q.y, q.z, q.w]);
    }

    /// `other`'s rows after these.
    pub(crate) fn append(&mut self, mut other: Columns) {
        macro_rules! each {
            ($($field:ident).+) => {
                self.$($field).+.append(&mut other.$($field).+);
            };
        }
        self.message.append(other.message, self.len());
        each!(status);
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
        d.set_item("message", self.message.into_list(py, n)?)?;
        d.set_item(
            "wrist_rotation",
            PyArray1::from_vec(py, self.wrist_rotation),
        )?;
        d.set_item("rotation", rows(py, self.rotation)?)?;
        d.set_item("rotation_axis", rows(py, self.rotation_axis)?)?;
        d.set_item("gravity_direction", rows(py, self.gravity_direction)?)?;
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
        d.set_item("contact_forces", rows(py, self.contact_forces)?)?;
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
            d.set_item("contact_1", rows(py, g.contact_1)?)?;
            d.set_item("contact_2", rows(py, g.contact_2)?)?;
            d.set_item("normal_1", rows(py, g.normal_1)?)?;
            d.set_item("normal_2", rows(py, g.normal_2)?)?;
            d.set_item("center_of_mass", rows(py, g.center_of_mass)?)?;
            d.set_item("grasp_orientation", rows(py, g.grasp_orientation)?)?;
            d.set_item("tool_pose", rows(py, g.tool_pose)?)?;
        }
        Ok(d)
    }
}

/// Rows of `K` values as an `(n, K)` array, the values not copied.
fn rows<const K: usize>(py: Python<'_>, values: Vec<[f64; K]>) -> PyResult<Bound<'_, PyAny>> {
    let n = values.len();
    Ok(PyArray1::from_vec(py, values.into_flattened())
        .reshape([n, K])?
        .into_any())
}

/// The message column: most rows' messages are empty (every answer with status 0), so only
/// the others are kept, each with its row, in row order. Each becomes a str of its own; the
/// empty rows share one.
#[derive(Debug, Default)]
struct Messages {
    texts: Vec<(usize, CompactString)>,
}

impl Messages {
    /// Row `row`'s message, after every row before it.
    fn push(&mut self, row: usize, text: CompactString) {
        if !text.is_empty() {
            self.texts.push((row, text));
        }
    }

    /// `other`'s rows after `rows` rows.
    fn append(&mut self, other: Messages, rows: usize) {
        self.texts
            .extend(other.texts.into_iter().map(|(row, t)| (rows + row, t)));
    }

    /// The `n` rows as a list of str: `[""] * n` (one repeat, as Python's), then each row
    /// that has a message set to it.
    fn into_list(self, py: Python<'_>, n: usize) -> PyResult<Bound<'_, PyList>> {
        let list = PyList::new(py, [PyString::new(py, "")])?
            .as_sequence()
            .repeat(n)?
            .cast_into::<PyList>()?;
        for (row, text) in self.texts {
            list.set_item(row, PyString::new(py, &text))?;
        }
        Ok(list)
    }
}

/// A column of texts, each row the index of its text among the column's distinct ones: equal
/// texts are stored once (the labels take a few values), and become one str object each, shared by their rows, so a million rows make neither a million
/// strings in Rust nor in Python.
#[derive(Debug, Default)]
struct Texts {
    /// Each row's index into `distinct` (four bytes a row: a column of a million rows writes
    /// 4 MB, not 8).
    rows: Vec<u32>,
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

    /// The index of `text`, added if new. A call has fewer than 2³² rows (their inputs alone
    /// would take 640 GiB), so fewer distinct texts.
    fn intern(&mut self, text: &str) -> u32 {
        let found = if self.distinct.len() <= Self::SCANNED {
            self.distinct.iter().position(|d| d == text)
        } else {
            self.index.get(text).copied()
        };
        let i = found.unwrap_or_else(|| {
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
        });
        u32::try_from(i).unwrap_or(u32::MAX)
    }

    /// One row; a text equal to the row before's takes its index without a look-up.
    fn push(&mut self, text: &str) {
        let i = match self.rows.last() {
            Some(&last) if self.distinct[last as usize] == text => last,
            _ => self.intern(text),
        };
        self.rows.push(i);
    }

    /// `other`'s rows after these.
    fn append(&mut self, other: Texts) {
        let to: Vec<u32> = other.distinct.iter().map(|t| self.intern(t)).collect();
        self.rows.extend(other.rows.iter().map(|&i| to[i as usize]));
    }

    /// The rows as a list of str, one object per distinct text: the most frequent text
    /// repeated (one repeat, as Python's `[t] * n`), then each other row set to its own.
    fn into_list(self, py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
        let objects: Vec<Bound<'_, PyString>> =
            self.distinct.iter().map(|t| PyString::new(py, t)).collect();
        let mut counts = vec![0usize; objects.len()];
        for &i in &self.rows {
            counts[i as usize] += 1;
        }
        let Some(most) = (0..counts.len()).max_by_key(|&i| counts[i]) else {
            return Ok(PyList::empty(py));
        };
        let list = PyList::new(py, [&objects[most]])?
            .as_sequence()
            .repeat(self.rows.len())?
            .cast_into::<PyList>()?;
        for (row, &i) in self.rows.iter().enumerate() {
            if i as usize != most {
                list.set_item(row, &objects[i as usize])?;
            }
        }
        Ok(list)
    }
}
