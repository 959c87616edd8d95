"""The one way kernels are compiled (:func:`magcilia._jit.compile_kernel`): its options, the
helpers a kernel calls, the disk cache in a fresh folder, and the fallback without one."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from magcilia._jit import compile_kernel

numba = pytest.importorskip("numba")
SRC = Path(__file__).resolve().parents[1] / "src"


def _from_source(code: str, name: str) -> Any:
    """A function from source text: its file is ``<string>``, for which numba finds no cache
    folder (as where none is writable)."""
    namespace: dict[str, object] = {}
    exec(textwrap.dedent(code), namespace)  # noqa: S102 (our own text)
    return namespace[name]


def _compiled(kernel: Any, *args: Any, **kwargs: Any) -> Any:
    """:func:`compile_kernel`'s dispatcher (numba is here: never None)."""
    out = compile_kernel(kernel, *args, **kwargs)
    assert out is not None
    return out


def test_options_reach_numba() -> None:
    kernel = _from_source("""
        def summed(x):
            s = 0.0
            for v in x:
                s += v
            return s
        """, "summed")

    plain = _compiled(kernel)
    fast = _compiled(kernel, fastmath=True)
    contract = _compiled(kernel, fastmath={"contract"}, boundscheck=False, nogil=False)
    assert _compiled(kernel) is plain  # once per process
    assert _compiled(kernel, frozenset({"contract"}), boundscheck=False, nogil=False) is contract
    assert len({id(plain), id(fast), id(contract)}) == 3
    assert {"error_model": "numpy", "nogil": True}.items() <= plain.targetoptions.items()
    assert "fastmath" not in plain.targetoptions
    assert fast.targetoptions["fastmath"] == {"reassoc", "contract"}
    assert {"error_model": "numpy", "nogil": False, "boundscheck": False,
            "fastmath": {"contract"}}.items() <= contract.targetoptions.items()
    x = np.arange(10.0)
    assert plain(x) == fast(x) == contract(x) == 45.0
    with pytest.raises(ValueError, match=r"\['nnan'\] are not allowed"):
        compile_kernel(kernel, fastmath={"nnan", "contract"})


def test_a_kernel_calls_its_compiled_helpers() -> None:
    kernel = _from_source("""
        def kernel_with_helper(x):
            return twice_helper(x) + 1.0
        """, "kernel_with_helper")
    helper = _from_source("""
        def twice_helper(x):
            return 2.0 * x
        """, "twice_helper")
    compiled_helper = compile_kernel(helper, forceinline=True, cache=False)
    compiled = _compiled(kernel, calls=(compiled_helper,))
    assert compiled(3.0) == 7.0
    assert compile_kernel(kernel, calls=(None,)) is None


def test_without_a_writable_cache_folder_it_compiles_in_memory() -> None:
    kernel = _from_source("""
        def uncachable(x):
            return x * x
        """, "uncachable")
    with pytest.raises(RuntimeError, match="cannot cache"):  # what the fallback catches
        numba.njit(kernel, cache=True)
    compiled = _compiled(kernel)
    assert compiled(3.0) == 9.0
    assert compiled._cache.__class__.__name__ == "NullCache"


def test_without_numba_it_gives_none(monkeypatch: pytest.MonkeyPatch) -> None:
    kernel = _from_source("""
        def identity(x):
            return x
        """, "identity")

    compiled = _compiled(kernel)
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba raises ImportError
    assert compile_kernel(kernel) is None  # (not the kernel compiled before)
    monkeypatch.undo()
    assert compile_kernel(kernel) is compiled  # the None was not remembered


def test_a_fresh_cache_folder_compiles_once_then_loads(tmp_path: Path) -> None:
    """Two fresh processes with a new NUMBA_CACHE_DIR: the first compiles and saves (the kernel
    and its cached helper), the second loads and compiles nothing."""
    module = tmp_path / "jit_probe_kernels.py"
    module.write_text(textwrap.dedent("""
        def probe_helper(x):
            return x + 1.0

        def probe_kernel(x):
            s = 0.0
            for v in x:
                s += probe_helper(v)
            return s
        """))
    code = textwrap.dedent("""
        import numpy as np
        import jit_probe_kernels as k
        from magcilia._jit import compile_kernel
        helper = compile_kernel(k.probe_helper)
        kernel = compile_kernel(k.probe_kernel, fastmath=True, calls=(helper,))
        assert kernel(np.arange(4.0)) == 10.0
        """)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "NUMBA_DEBUG_CACHE": "1",
           "PYTHONPATH": os.pathsep.join([str(SRC), str(tmp_path)])}
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                           timeout=300, check=True, cwd=tmp_path).stdout for _ in range(2)]
    assert "data saved" in runs[0]
    assert "data saved" not in runs[1] and "index saved" not in runs[1], runs[1]
    assert "data loaded" in runs[1]
