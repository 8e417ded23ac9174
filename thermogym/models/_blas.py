"""The package's one BLAS thread limiter (threadpoolctl).

Most matrices here are small (tens to hundreds of rows; batches of 20 × 20
matrix exponentials): extra BLAS threads only add synchronisation, and on a
busy machine OpenBLAS's spinning threads made a 1500 × 96 QR take 0.2-1.4 s
instead of 8 ms and a batched ``expm`` 10 times slower (measured). The models,
N4SID and the identification problem therefore run such work under
:func:`blas_threads`.

One :class:`threadpoolctl.ThreadpoolController` is built on first use and
reused: building one scans the process's shared libraries (0.3-6 ms,
measured), and an identification or diagnosis enters the limiter thousands of
times. numpy's and scipy's BLAS are both loaded (imported below) before it
scans, so the limit covers both.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

import numpy as np  # noqa: F401 - numpy's BLAS is loaded before the controller scans
import scipy.linalg  # noqa: F401 - and scipy's own BLAS too
from threadpoolctl import ThreadpoolController

__all__ = ["blas_threads", "single_blas_thread"]

_CONTROLLER: ThreadpoolController | None = None

F = TypeVar("F", bound=Callable[..., Any])


def _controller() -> ThreadpoolController:
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER


@contextlib.contextmanager
def blas_threads(n: int | None = 1) -> Iterator[None]:
    """Run BLAS/LAPACK on at most ``n`` threads inside the block.

    Parameters
    ----------
    n : int or None
        Thread limit; ``None`` leaves the BLAS libraries as they are.

    Examples
    --------
    >>> import numpy as np
    >>> with blas_threads(1):
    ...     (np.ones((2, 3)) @ np.ones((3, 2))).tolist()
    [[3.0, 3.0], [3.0, 3.0]]
    """
    if n is None:
        yield
        return
    with _controller().limit(limits=n, user_api="blas"):
        yield


def single_blas_thread(fn: F) -> F:
    """Decorator: run ``fn`` under ``blas_threads(1)``.

    Examples
    --------
    >>> import numpy as np
    >>> @single_blas_thread
    ... def trace_of_square(a):
    ...     return float(np.trace(a @ a))
    >>> trace_of_square(np.eye(2))
    2.0
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with blas_threads(1):
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
