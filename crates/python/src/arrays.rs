//! The numpy arrays a call is given, checked before anything is solved: the type (a numpy
//! array), the dtype, the shape, C order, and every value finite. A refusal is a `ValueError`
//! that names the argument and, for a value, its row and column; nothing is converted silently
//! (a float32 array or a transposed view is refused with what to call instead), so that the
//! numbers solved are the caller's numbers.

use numpy::{
    dtype, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A `ValueError` with `message`.
pub(crate) fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// `(5, 3)`, `(N, 3)`: a shape as numpy prints it, `None` for a length not fixed.
fn shape_text(shape: &[Option<usize>]) -> String {
    let parts: Vec<String> = shape
        .iter()
        .map(|d| d.map_or_else(|| "N".to_string(), |d| d.to_string()))
        .collect();
    match parts.as_slice() {
        [one] => format!("({one},)"),
        _ => format!("({})", parts.join(", ")),
    }
}

/// The shape of `array`, checked against `expected` (`None`: any length) and C order.
fn checked_shape(
    array: &Bound<'_, PyUntypedArray>,
    name: &str,
    expected: &[Option<usize>],
) -> PyResult<Vec<usize>> {
    let shape = array.shape().to_vec();
    let fits = shape.len() == expected.len()
        && shape
            .iter()
            .zip(expected)
            .all(|(&got, want)| want.is_none_or(|w| w == got));
    if !fits {
        let got: Vec<Option<usize>> = shape.iter().copied().map(Some).collect();
        return Err(value_error(format!(
            "{name}: expected an array of shape {}, got shape {}",
            shape_text(expected),
            shape_text(&got)
        )));
    }
    if !array.is_c_contiguous() {
        return Err(value_error(format!(
            "{name}: the array is not C-contiguous (a slice or a transpose of another); pass \
             numpy.ascontiguousarray({name})"
        )));
    }
    Ok(shape)
}

/// `obj` as a numpy array, or a `ValueError` naming `name` and what it is instead.
fn untyped<'a, 'py>(
    obj: &'a Bound<'py, PyAny>,
    name: &str,
) -> PyResult<&'a Bound<'py, PyUntypedArray>> {
    obj.cast::<PyUntypedArray>().map_err(|_| {
        let type_name = obj
            .get_type()
            .name()
            .map_or_else(|_| "an object".to_string(), |n| n.to_string());
        value_error(format!(
            "{name}: expected a numpy array, got {type_name}; pass numpy.asarray({name}, dtype=numpy.float64)"
        ))
    })
}

/// The dtype's name, as numpy prints it (`float32`).
fn dtype_name(array: &Bound<'_, PyUntypedArray>) -> String {
    array
        .dtype()
        .str()
        .map_or_else(|_| "another dtype".to_string(), |s| s.to_string())
}

/// A float64 array of shape `expected`, C-contiguous, every value finite: its values in C order
/// and its shape.
pub(crate) fn floats<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    expected: &[Option<usize>],
) -> PyResult<(PyReadonlyArrayDyn<'py, f64>, Vec<usize>)> {
    let array = untyped(obj, name)?;
    if !array.dtype().is_equiv_to(&dtype::<f64>(obj.py())) {
        return Err(value_error(format!(
            "{name}: expected dtype float64, got {}; pass {name}.astype(numpy.float64)",
            dtype_name(array)
        )));
    }
    let shape = checked_shape(array, name, expected)?;
    let typed = array
        .cast::<PyArrayDyn<f64>>()
        .map_err(|_| value_error(format!("{name}: expected dtype float64")))?;
    let readonly = typed
        .try_readonly()
        .map_err(|e| value_error(format!("{name}: {e}")))?;
    check_finite(name, slice_of(&readonly, name)?, &shape)?;
    Ok((readonly, shape))
}

/// The values of a checked array, in C order.
pub(crate) fn slice_of<'a>(
    array: &'a PyReadonlyArrayDyn<'_, f64>,
    name: &str,
) -> PyResult<&'a [f64]> {
    array
        .as_slice()
        .map_err(|_| value_error(format!("{name}: the array is not C-contiguous")))
}

/// `name[i, j] is nan` for the first value that is not finite.
fn check_finite(name: &str, values: &[f64], shape: &[usize]) -> PyResult<()> {
    // A block at a time without a branch a value (the check vectorises), then the first value
    // of the first block with one.
    const BLOCK: usize = 64;
    let Some(block) = values
        .chunks(BLOCK)
        .position(|b| b.iter().fold(false, |bad, v| bad | !v.is_finite()))
    else {
        return Ok(());
    };
    let at = block * BLOCK
        + values[block * BLOCK..]
            .iter()
            .position(|v| !v.is_finite())
            .unwrap_or(0);
    Err(value_error(format!(
        "{name}{} is {}: every value must be a finite number",
        index_text(at, shape),
        values[at]
    )))
}

/// `[3, 1]`: the index of the `at`-th value of an array of `shape`, C order.
fn index_text(at: usize, shape: &[usize]) -> String {
    let mut rest = at;
    let mut index = vec![0; shape.len()];
    for (k, &len) in shape.iter().enumerate().rev() {
        if len > 0 {
            index[k] = rest % len;
            rest /= len;
        }
    }
    let parts: Vec<String> = index.iter().map(usize::to_string).collect();
    format!("[{}]", parts.join(", "))
}

/// Triangles as vertex indices: an integer array of shape `(T, 3)` (int32, int64, uint32 or
/// uint64: what trimesh and the mesh readers give), every index a row of a vertex array of
/// `vertex_count` rows.
pub(crate) fn triangles(obj: &Bound<'_, PyAny>, vertex_count: usize) -> PyResult<Vec<[u32; 3]>> {
    let name = "triangles";
    let array = untyped(obj, name)?;
    let py = obj.py();
    let descr = array.dtype();
    let indices: Vec<i128> = if descr.is_equiv_to(&dtype::<i64>(py)) {
        integers::<i64>(array, name)?
    } else if descr.is_equiv_to(&dtype::<i32>(py)) {
        integers::<i32>(array, name)?
    } else if descr.is_equiv_to(&dtype::<u32>(py)) {
        integers::<u32>(array, name)?
    } else if descr.is_equiv_to(&dtype::<u64>(py)) {
        integers::<u64>(array, name)?
    } else {
        return Err(value_error(format!(
            "{name}: expected an integer dtype (int32, int64, uint32 or uint64), got {}",
            dtype_name(array)
        )));
    };
    let mut out = Vec::with_capacity(indices.len() / 3);
    for (t, corners) in indices.chunks_exact(3).enumerate() {
        let mut triangle = [0u32; 3];
        for (k, (&index, slot)) in corners.iter().zip(&mut triangle).enumerate() {
            *slot = u32::try_from(index)
                .ok()
                .filter(|&i| (i as usize) < vertex_count)
                .ok_or_else(|| {
                    value_error(format!(
                        "{name}[{t}, {k}] is {index}: not a row of vertices (it has {vertex_count} rows)"
                    ))
                })?;
        }
        out.push(triangle);
    }
    Ok(out)
}

/// The values of an integer array of shape `(T, 3)`, C order, widened.
fn integers<T>(array: &Bound<'_, PyUntypedArray>, name: &str) -> PyResult<Vec<i128>>
where
    T: numpy::Element + Copy + Into<i128>,
{
    checked_shape(array, name, &[None, Some(3)])?;
    let typed = array
        .cast::<PyArrayDyn<T>>()
        .map_err(|_| value_error(format!("{name}: expected an integer array")))?;
    let readonly = typed
        .try_readonly()
        .map_err(|e| value_error(format!("{name}: {e}")))?;
    let values = readonly
        .as_slice()
        .map_err(|_| value_error(format!("{name}: the array is not C-contiguous")))?;
    Ok(values.iter().map(|&v| v.into()).collect())
}

/// A vector of three finite numbers given as a numpy array or any sequence of three numbers
/// (`gravity`, `center_of_mass`, a scale per axis).
pub(crate) fn three(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<[f64; 3]> {
    let values: Vec<f64> = obj.extract().map_err(|_| {
        value_error(format!(
            "{name}: expected three numbers (a sequence or an array of shape (3,))"
        ))
    })?;
    let v: [f64; 3] = values.as_slice().try_into().map_err(|_| {
        value_error(format!(
            "{name}: expected three numbers, got {}",
            values.len()
        ))
    })?;
    check_finite(name, &v, &[3])?;
    Ok(v)
}

/// One finite number.
pub(crate) fn number(value: f64, name: &str) -> PyResult<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(value_error(format!(
            "{name} is {value}: expected a finite number"
        )))
    }
}
