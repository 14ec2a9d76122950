//! `close`, `__enter__` and `__exit__`, written once for every class that holds a port or a
//! socket: each such class is a context manager whose `close` waits for its `close_job`.

use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// `__exit__`'s rule: the context manager closes the handle and never swallows the
/// exception that ended the `with` block (returns False); `closed` is what `close` returned.
/// `args` are `(exc_type, exc_value, traceback)`. A failed close raises, unless an exception
/// already propagates: that one is the cause the caller needs, and raising here would
/// replace it.
pub fn exit(closed: PyResult<()>, args: &Bound<'_, PyTuple>) -> PyResult<bool> {
    exit_with(closed, propagating(args))
}

/// An exception ended the `with` block: `__exit__`'s `(exc_type, exc_value, traceback)` say so.
pub fn propagating(args: &Bound<'_, PyTuple>) -> bool {
    args.get_item(0).is_ok_and(|exc_type| !exc_type.is_none())
}

/// [`exit`] once [`propagating`] is known (an `__aexit__` decides it before its awaitable runs).
pub fn exit_with(closed: PyResult<()>, propagating: bool) -> PyResult<bool> {
    if !propagating {
        closed?;
    }
    Ok(false)
}

/// `#[pymethods] impl $class { … }` with `close` (documented by `$doc`, waiting for the
/// class's `fn close_job(&self) -> Job<()>` with the GIL released), `__enter__` and `__exit__`
/// appended; with a leading `aio,` also `_aio_close`, the awaitable `close` of `si_serial.aio`.
///
/// The macro wraps the whole block because PyO3 rejects macro calls inside `#[pymethods]` and
/// allows one such block per class (a second needs its `multiple-pymethods` feature and the
/// `inventory` crate). rustfmt does not format inside a macro call: keep the block formatted.
macro_rules! pymethods_with_close {
    (aio, close = $doc:literal; impl $class:ident { $($methods:tt)* }) => {
        $crate::lifecycle::pymethods_with_close! {
            close = $doc;
            impl $class {
                $($methods)*

                /// `close` as an awaitable (`si_serial.aio`).
                fn _aio_close<'py>(
                    &self,
                    py: pyo3::Python<'py>,
                ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                    pyo3_async_runtimes::tokio::future_into_py(py, self.close_job())
                }
            }
        }
    };
    (close = $doc:literal; impl $class:ident { $($methods:tt)* }) => {
        #[pyo3::pymethods]
        impl $class {
            $($methods)*

            #[doc = $doc]
            fn close(&self, py: pyo3::Python<'_>) -> pyo3::PyResult<()> {
                $crate::runtime::wait(py, self.close_job())
            }

            fn __enter__(slf: pyo3::Py<Self>) -> pyo3::Py<Self> {
                slf
            }

            #[pyo3(signature = (*args))]
            fn __exit__(
                &self,
                py: pyo3::Python<'_>,
                args: &pyo3::Bound<'_, pyo3::types::PyTuple>,
            ) -> pyo3::PyResult<bool> {
                $crate::lifecycle::exit(self.close(py), args)
            }
        }
    };
}
pub(crate) use pymethods_with_close;

#[cfg(test)]
mod tests {
    use super::exit;
    use pyo3::exceptions::{PyOSError, PyValueError};
    use pyo3::prelude::*;
    use pyo3::types::PyTuple;

    fn failed_close() -> PyResult<()> {
        Err(PyOSError::new_err("the line failed"))
    }

    #[test]
    fn a_failed_close_raises_when_the_block_ended_normally() {
        Python::initialize();
        Python::attach(|py| {
            let normal_end = PyTuple::new(py, [py.None(), py.None(), py.None()]).unwrap();
            let raised = exit(failed_close(), &normal_end).unwrap_err();
            assert!(raised.is_instance_of::<PyOSError>(py), "{raised}");
            assert!(!exit(Ok(()), &normal_end).unwrap(), "nothing swallowed");
            let no_arguments = PyTuple::empty(py);
            assert!(exit(failed_close(), &no_arguments).is_err());
        });
    }

    #[test]
    fn a_failed_close_does_not_mask_the_propagating_exception() {
        Python::initialize();
        Python::attach(|py| {
            let error = PyValueError::new_err("the test failed");
            let propagating = PyTuple::new(
                py,
                [
                    py.get_type::<PyValueError>().into_any(),
                    error.value(py).clone().into_any(),
                    py.None().into_bound(py),
                ],
            )
            .unwrap();
            // False: the `with` statement re-raises the ValueError, not the close's error.
            assert!(!exit(failed_close(), &propagating).unwrap());
        });
    }
}
