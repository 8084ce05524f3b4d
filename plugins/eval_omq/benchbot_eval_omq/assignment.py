"""SciPy's optimal assignment (``scipy.optimize.linear_sum_assignment``) without importing ``scipy.optimize``.

The function is SciPy's compiled ``scipy.optimize._lsap`` module; ``scipy.optimize`` itself imports its whole
optimiser suite (linear programming, ``scipy.linalg``, ``scipy.sparse``, ...), 0.3 s on the 2-core CPU, which a
command that scores one episode paid for a single call of that one function. :func:`linear_sum_assignment` loads the
compiled module from SciPy's ``optimize`` folder by itself (about 10 ms) and registers it under its own name, so a
later ``import scipy.optimize`` finds the same module. It is the very function ``scipy.optimize`` exports
(``tests/test_omq_extensions.py`` checks that they are one object), so the pairs are the same.

Where that module cannot be found or loaded (another SciPy layout), it falls back to ``from scipy.optimize import
linear_sum_assignment``.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import sys
from pathlib import Path
from typing import Callable

#: The compiled module that holds SciPy's ``linear_sum_assignment``.
LSAP_MODULE = "scipy.optimize._lsap"

_function: Callable | None = None


def _load_compiled() -> Callable | None:
    """``linear_sum_assignment`` of :data:`LSAP_MODULE`, loaded from its file without running
    ``scipy/optimize/__init__.py``; None where that file is not there or does not load."""
    module = sys.modules.get(LSAP_MODULE)
    if module is None:
        try:
            import scipy  # the package's own start (its configuration, numpy's check): a few ms
        except ImportError:
            return None
        folder = Path(scipy.__file__).parent / "optimize"
        files = [folder / f"_lsap{suffix}" for suffix in importlib.machinery.EXTENSION_SUFFIXES]
        path = next((f for f in files if f.is_file()), None)
        if path is None:
            return None
        try:
            loader = importlib.machinery.ExtensionFileLoader(LSAP_MODULE, str(path))
            spec = importlib.util.spec_from_file_location(LSAP_MODULE, str(path), loader=loader)
            module = importlib.util.module_from_spec(spec)
            loader.exec_module(module)
        except (ImportError, OSError):
            return None
        sys.modules[LSAP_MODULE] = module
    return getattr(module, "linear_sum_assignment", None)


def linear_sum_assignment() -> Callable:
    """SciPy's ``linear_sum_assignment(cost) -> (rows, cols)`` (its documentation applies: a rectangular cost
    matrix is allowed, rows come sorted), loaded once per process as the module docstring says.

    Raises:
        ImportError: SciPy is not installed."""
    global _function
    if _function is None:
        _function = _load_compiled()
        if _function is None:
            from scipy.optimize import linear_sum_assignment as public

            _function = public
    return _function
