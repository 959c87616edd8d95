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
    """A package that a step needs cannot be imported; the message names the package and the
    install line of the magcilia extra that brings it (true whether the package is optional or
    part of the core install, e.g. in a damaged environment)."""


def require(module: str, *, package: str, extra: str, purpose: str) -> object:
    """Import a package that is imported only where it is needed (an optional one, or a core one
    that is heavy or lab-only), or raise :class:`MissingDependencyError`.

    Parameters
    ----------
    module : str
        Importable module name (e.g. ``"SALib"``).
    package : str
        Name of the package on PyPI.
    extra : str
        The magcilia extra that installs it (the lab's extras — tdms, serial, live, dashboard,
        photo — are part of the core install and stay as names for it).
    purpose : str
        What it is needed for, used in the message.
    """
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingDependencyError(
            f"{purpose} needs the package {package!r}; "
            f"install it with: pip install 'magcilia[{extra}]'"
        ) from exc


class MagciliaWarning(UserWarning):
    """Something the user should know about a result that is still computed (one-line
    message; the CLI prints it as ``magcilia: warning: ...``)."""


class LayoutWarning(MagciliaWarning):
    """A given dipole layout is coarse for where the field is predicted: its estimated error
    against the exact body exceeds 1 % (:meth:`magcilia.Setup.resolve_layout`)."""
