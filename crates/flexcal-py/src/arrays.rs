//! NumPy arrays in and out: shapes and finiteness are checked here, before
//! any library call, and every error names the argument and the index.

use std::borrow::Cow;

pub use numpy::AllowTypeChange;
use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{
    Element, IntoPyArray, PyArrayDescrMethods, PyArrayDyn, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::{NotFiniteError, ShapeError, array_type_error};

/// An array argument of real numbers: numpy's [`numpy::PyArrayLikeDyn`]
/// (an ndarray, a nested sequence or a scalar, converted as `np.asarray`
/// does), but an array of strings or of complex numbers is refused with
/// `flexcal.ArrayTypeError` (an `InputError` and a `TypeError`) saying
/// what it holds, instead of numpy's `could not convert string to float`
/// or a complex value cast with only a warning. The argument's name is in
/// the exception's note (`while processing 'q'`, shown in tracebacks).
/// Values are always converted (`C` is [`AllowTypeChange`], the only
/// coercion the package uses; it stays in the type to keep numpy's
/// spelling).
#[derive(Debug)]
pub struct PyArrayLikeDyn<'py, T: Element, C>(
    numpy::PyArrayLikeDyn<'py, T, AllowTypeChange>,
    std::marker::PhantomData<C>,
);

impl<'py, T: Element, C> std::ops::Deref for PyArrayLikeDyn<'py, T, C> {
    type Target = numpy::PyArrayLikeDyn<'py, T, AllowTypeChange>;

    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl<'py, C> FromPyObject<'_, 'py> for PyArrayLikeDyn<'py, f64, C> {
    type Error = PyErr;

    fn extract(ob: Borrowed<'_, 'py, PyAny>) -> PyResult<Self> {
        let py = ob.py();
        let array = if ob.cast::<PyUntypedArray>().is_ok() {
            ob.to_owned()
        } else {
            py.import("numpy")?.call_method1("asarray", (ob,))?
        };
        let dtype = array.cast::<PyUntypedArray>()?.dtype();
        let holds = match dtype.kind() {
            b'U' | b'S' => "strings",
            b'c' => "complex numbers",
            _ => {
                return numpy::PyArrayLikeDyn::extract(array.as_borrowed())
                    .map(|inner| Self(inner, std::marker::PhantomData));
            }
        };
        Err(array_type_error(
            py,
            format!("an array of {holds} (dtype {dtype}) where real numbers are expected"),
        ))
    }
}

/// Rows of equal width read from a 1-D (one row) or 2-D (n rows) array,
/// row-major: the array's own memory when it is C-contiguous, else a copy.
#[derive(Debug, Clone)]
pub struct Rows<'a> {
    /// Values, row after row.
    pub data: Cow<'a, [f64]>,
    /// Number of rows.
    pub n: usize,
    /// Values per row.
    pub width: usize,
    /// Whether the input was 2-D (outputs then keep a leading axis).
    pub batched: bool,
}

impl Rows<'_> {
    /// Row `k`.
    pub fn row(&self, k: usize) -> &[f64] {
        &self.data[k * self.width..(k + 1) * self.width]
    }
}

fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Checks that every value is finite, naming the first that is not.
pub fn check_finite(name: &str, data: &[f64], shape: &[usize]) -> PyResult<()> {
    // One pass without an early exit, which the compiler vectorises; the
    // search for the culprit only when there is one.
    if data.iter().fold(true, |all, v| all & v.is_finite()) {
        return Ok(());
    }
    if let Some(flat) = data.iter().position(|v| !v.is_finite()) {
        let mut index = Vec::with_capacity(shape.len());
        let mut rest = flat;
        for (axis, _) in shape.iter().enumerate() {
            let stride: usize = shape[axis + 1..].iter().product();
            index.push(rest / stride.max(1));
            rest %= stride.max(1);
        }
        let index = index
            .iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join(", ");
        return Err(NotFiniteError::new_err(format!(
            "{name}[{index}] is {} (values must be finite)",
            data[flat]
        )));
    }
    Ok(())
}

/// The values of `view` row-major: the array's memory itself when it is
/// C-contiguous (element-wise iteration over a dynamic-dimension view costs
/// several times more than reading it), a copy element by element
/// otherwise. Like NumPy's own routines that release the GIL, the batched
/// calls read a borrowed array while Python code in another thread could
/// still write to it: a caller doing so gets a mix of old and new values.
fn row_major<'a>(view: &numpy::ndarray::ArrayViewD<'a, f64>) -> Cow<'a, [f64]> {
    match view.to_slice() {
        Some(values) => Cow::Borrowed(values),
        None => Cow::Owned(view.iter().copied().collect()),
    }
}

/// Reads `array` as rows of `width` values: shape `(width,)` or `(n, width)`,
/// every value finite. `unit` is said in messages (`rad or m`).
pub fn rows<'a>(
    name: &str,
    array: &'a PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    width: usize,
) -> PyResult<Rows<'a>> {
    let view = array.as_array();
    let shape = view.shape().to_vec();
    let (n, batched) = match shape[..] {
        [w] if w == width => (1, false),
        [n, w] if w == width => (n, true),
        _ => {
            return Err(ShapeError::new_err(format!(
                "{name}: expected shape ({width},) or (n, {width}), got {}",
                shape_text(&shape)
            )));
        }
    };
    let data = row_major(&view);
    check_finite(name, &data, &shape)?;
    Ok(Rows {
        data,
        n,
        width,
        batched,
    })
}

/// Reads `array` with exactly `shape` (a `None` entry matches any length),
/// every value finite; returns the values row-major and the actual shape.
pub fn exact(
    name: &str,
    array: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    shape: &[Option<usize>],
) -> PyResult<(Vec<f64>, Vec<usize>)> {
    let view = array.as_array();
    let actual = view.shape().to_vec();
    let matches = actual.len() == shape.len()
        && actual
            .iter()
            .zip(shape)
            .all(|(a, s)| s.is_none_or(|s| s == *a));
    if !matches {
        let wanted = shape
            .iter()
            .map(|s| s.map_or("n".to_string(), |s| s.to_string()))
            .collect::<Vec<_>>();
        let wanted = if wanted.len() == 1 {
            format!("({},)", wanted[0])
        } else {
            format!("({})", wanted.join(", "))
        };
        return Err(ShapeError::new_err(format!(
            "{name}: expected shape {wanted}, got {}",
            shape_text(&actual)
        )));
    }
    let data = row_major(&view).into_owned();
    check_finite(name, &data, &actual)?;
    Ok((data, actual))
}

/// A NumPy array of `shape` from row-major `data`.
pub fn to_numpy<'py>(
    py: Python<'py>,
    data: Vec<f64>,
    shape: &[usize],
) -> Bound<'py, PyArrayDyn<f64>> {
    // The shape always matches the data the callers computed.
    let array =
        ArrayD::from_shape_vec(IxDyn(shape), data).unwrap_or_else(|_| ArrayD::zeros(IxDyn(&[0])));
    array.into_pyarray(py)
}

/// The configurations `q` (n, dof) with n, dof > 0, row-major, and n, dof.
pub(crate) fn configurations(
    q: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
) -> PyResult<(Vec<f64>, usize, usize)> {
    let (q, q_shape) = exact("q", q, &[None, None])?;
    let (n, dof) = (q_shape[0], q_shape[1]);
    if n == 0 || dof == 0 {
        return Err(ShapeError::new_err(format!(
            "q: expected shape (n, dof) with n, dof > 0, got ({n}, {dof})"
        )));
    }
    Ok((q, n, dof))
}
