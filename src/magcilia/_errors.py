"""Exceptions shared by the whole package.

Every input error is a :class:`MagciliaError`, a subclass of :class:`ValueError`, whose message is
one line naming the parameter, the offending value and what is allowed, e.g.
``height must be a positive length in m; got -0.003``. The CLI prints that line and exits non-zero.
"""

from __future__ import annotations


class MagciliaError(ValueError):
    """Invalid input to magcilia: a bad value, file, key or range (one-line message)."""


class AcquisitionError(MagciliaError):
    """A source of samples failed: a port that does not exist or is busy, a device that stopped
    sending or vanished, a driver that is missing (one-line message naming the thing)."""


class MissingDependencyError(ImportError):
    """An optional dependency is needed; the message names the package and the extra to install."""


def require(module: str, *, package: str, extra: str, purpose: str) -> object:
    """Import an optional dependency or raise :class:`MissingDependencyError`.

    Parameters
    ----------
    module : str
        Importable module name (e.g. ``"SALib"``).
    package : str
        Name of the package on PyPI.
    extra : str
        The magcilia extra that installs it.
    purpose : str
        What it is needed for, used in the message.
    """
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingDependencyError(
            f"{purpose} needs the optional package {package!r}; "
            f"install it with: pip install 'magcilia[{extra}]'"
        ) from exc


class MagciliaWarning(UserWarning):
    """Something the user should know about a result that is still computed (one-line
    message; the CLI prints it as ``magcilia: warning: ...``)."""


class LayoutWarning(MagciliaWarning):
    """A given dipole layout is coarse for where the field is predicted: its estimated error
    against the exact body exceeds 1 % (:meth:`magcilia.Setup.resolve_layout`)."""
