"""Magnetic actuation: an external field B(r) that bends the cilium and adds to the sensor's field.

An :class:`Actuation` is either a uniform field (a Helmholtz coil pair: :meth:`Actuation.uniform`,
given in T) or the field of any magpylib source or collection (a coil, a permanent magnet:
:meth:`Actuation.magpylib`), times a ``scale`` (a coil current scaled by k scales its field by k:
:meth:`Actuation.scaled`). Fields are evaluated in the board frame (the README's sensor frame: the
sensing element at the origin, +z up), in m and T.

The cilium's magnetization lies along its local tangent t with magnitude
``setup.spec.magnetization`` (A/m), so its moment per length is μ(s) = M π r(s)²; the field exerts
per unit length the couple ``μ t × B`` and the force ``μ (t·∇)B`` (:mod:`magcilia.mechanics` adds
both to the elastica). The magnetization is taken as rigid (a hard magnet): fields beyond the
particles' coercivity, which would remagnetize the cilium, are not modelled.

Gradients of a magpylib source are central differences with a step of :data:`GRADIENT_STEP` (100 nm,
adjustable with ``step=``): truncation error ~ (step / ℓ)² relative at a distance ℓ from the
source (1e-8 at 1 mm), round-off ~ 1e-16 ℓ / step (1e-12 at 1 mm).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number
from magcilia.constants import GAUSS

F64 = NDArray[np.float64]

#: central-difference step of magpylib field gradients, m
GRADIENT_STEP = 1e-7


def _points(points: ArrayLike) -> F64:
    arr = v.finite_array("points", points, unit="m")
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise v.fail("points", f"an array of shape {arr.shape}", "positions of shape (..., 3), m")
    return arr


def _source(source: Any) -> Any:
    """A checked magpylib source: a single source, a Collection, or a list of them (kept as a
    tuple whose fields add up; the sources themselves are left untouched)."""
    import magpylib

    allowed = "a magpylib source (magnet, current, dipole), a Collection or a list of them"
    many = isinstance(source, Sequence) and not isinstance(source, str)
    items = tuple(source) if many else (source,)
    if not items:
        raise v.fail("source", "an empty list", allowed)
    for item in items:
        if isinstance(item, magpylib.Sensor) or not hasattr(item, "getB"):
            raise v.fail("source", type(item).__name__, allowed)
    source = items if len(items) > 1 else items[0]
    try:
        out = np.asarray(magpylib.getB(source, np.zeros((1, 3)), squeeze=False, sumup=True))
    except Exception as exc:  # anything magpylib refuses is reported as one line
        raise v.fail("source", f"{type(source).__name__} ({type(exc).__name__})",
                     allowed) from exc
    if out.shape[1] != 1:
        raise v.fail("source", f"a source with a path of {out.shape[1]} positions",
                     "a source at one position (path length 1)")
    return source


@dataclass(frozen=True, eq=False, repr=False)
class Actuation(Display):
    """An external actuation field B(r), T, in the board frame.

    Build it with :meth:`uniform` or :meth:`magpylib`.

    Parameters
    ----------
    vector : ndarray, shape (3,), or None
        The uniform field (before ``scale``), T; None for a magpylib source.
    source : magpylib source, Collection or tuple of sources, or None
        The source whose field (``magpylib.getB``, SI; summed over a tuple) is used.
    scale : float
        Factor on the field (a coil current scaled by k: k), dimensionless.
    step : float
        Central-difference step of :meth:`gradient` for a source, m.

    Examples
    --------
    >>> act = Actuation.uniform((0.0, 0.0, 5e-3))
    >>> act.field([[0.0, 0.0, 1e-3], [2e-3, 0.0, 0.0]]).tolist()
    [[0.0, 0.0, 0.005], [0.0, 0.0, 0.005]]
    >>> act.scaled(2.0).field([0.0, 0.0, 0.0]).tolist()
    [0.0, 0.0, 0.01]
    """

    vector: F64 | None = None
    source: Any = None
    scale: float = 1.0
    step: float = GRADIENT_STEP

    def __post_init__(self) -> None:
        if (self.vector is None) == (self.source is None):
            raise v.fail("Actuation", "both or neither of vector/source",
                         "built with Actuation.uniform(b) or Actuation.magpylib(source)")
        if self.vector is not None:
            vec = v.vector3("field", self.vector, "T").copy()  # never freeze the caller's array
            vec.setflags(write=False)
            object.__setattr__(self, "vector", vec)
        else:
            object.__setattr__(self, "source", _source(self.source))
        object.__setattr__(self, "scale", v.real("scale", self.scale))
        object.__setattr__(self, "step", v.positive("step", self.step))

    # -- constructors -------------------------------------------------------------------------
    @classmethod
    def uniform(cls, b: ArrayLike) -> Actuation:
        """A uniform field ``b`` = (Bx, By, Bz), T (a Helmholtz coil pair's)."""
        return cls(vector=v.vector3("field", b, "T"))

    @classmethod
    def magpylib(cls, source: Any, scale: float = 1.0, *, step: float = GRADIENT_STEP
                 ) -> Actuation:
        """The field of a magpylib source or Collection (or a list of sources), times ``scale``.

        Positions and fields are magpylib's SI (m, T), in the board frame. The source must sit at
        one position (a path of length 1).
        """
        return cls(source=source, scale=scale, step=step)

    def scaled(self, k: float) -> Actuation:
        """The same actuation with its field times ``k`` (a coil current scaled by k)."""
        return replace(self, scale=self.scale * v.real("k", k))

    # -- queries ------------------------------------------------------------------------------
    @property
    def is_uniform(self) -> bool:
        """True for a uniform field."""
        return self.vector is not None

    @property
    def kind(self) -> str:
        """``"uniform"`` or ``"magpylib"``."""
        return "uniform" if self.vector is not None else "magpylib"

    @property
    def uniform_field(self) -> F64:
        """The uniform field times the scale, T, shape (3,) (a uniform actuation only)."""
        if self.vector is None:
            raise v.fail("actuation", "a magpylib source", "a uniform field for uniform_field")
        return np.asarray(self.scale * self.vector, dtype=np.float64)

    def field(self, points: ArrayLike) -> F64:
        """Flux density at ``points``, T.

        Parameters
        ----------
        points : array-like, shape (..., 3)
            Positions in the board frame, m.

        Returns
        -------
        ndarray, shape (..., 3)
            B, T (NaN where magpylib has no value, e.g. on a magnet's edge).
        """
        return self.field_unchecked(_points(points))

    def gradient(self, points: ArrayLike) -> F64:
        """Field gradient ``G[..., i, j] = ∂B_i/∂x_j`` at ``points``, T/m.

        Zero for a uniform field; central differences with step :attr:`step` for a source.

        Parameters
        ----------
        points : array-like, shape (..., 3)
            Positions in the board frame, m.

        Returns
        -------
        ndarray, shape (..., 3, 3)
        """
        pts = _points(points)
        if self.vector is not None:
            return np.zeros((*pts.shape, 3))
        eye = np.eye(3) * self.step
        shifted = pts[..., None, :] + np.concatenate([eye, -eye])  # (..., 6, 3)
        b = self.field_unchecked(shifted)
        return np.asarray(np.swapaxes(b[..., :3, :] - b[..., 3:, :], -1, -2) / (2.0 * self.step),
                          dtype=np.float64)

    # -- fast paths (no checks; for the solvers) ----------------------------------------------
    def field_unchecked(self, points: F64) -> F64:
        """:meth:`field` without input checks: ``points`` (..., 3) float64, m -> T."""
        if self.vector is not None:
            return np.broadcast_to(self.scale * self.vector, points.shape).copy()
        import magpylib

        if points.size == 0:
            return np.zeros(points.shape)
        flat = points.reshape(-1, 3)
        with np.errstate(all="ignore"):  # a point on a singularity gives nan/inf: callers check
            b = np.asarray(magpylib.getB(self.source, flat, squeeze=False, sumup=True),
                           dtype=np.float64)
        return np.asarray(self.scale * b.reshape(points.shape), dtype=np.float64)

    def directional(self, points: F64, directions: F64) -> F64:
        """``(d·∇)B`` at ``points`` (..., 3) along ``directions`` (..., 3), T/m per unit of d
        (no checks): zero for a uniform field, a central difference of step :attr:`step`."""
        if self.vector is not None:
            return np.zeros(points.shape)
        h = self.step
        b = self.field_unchecked(np.stack([points + h * directions, points - h * directions]))
        return np.asarray((b[0] - b[1]) / (2.0 * h), dtype=np.float64)

    # -- results protocol ---------------------------------------------------------------------
    def describe(self) -> str:
        """One line: the field (gauss, the display unit of fields, as ``--actuation-field``
        takes it) or the source, and the scale."""
        if self.vector is not None:
            b = self.uniform_field / GAUSS
            return "uniform field (" + ", ".join(f"{c:.4g}" for c in b) + ") G"
        what = f"{len(self.source)} magpylib sources" if isinstance(self.source, tuple) \
            else f"a magpylib {self.source_name}"
        return f"field of {what}" + ("" if self.scale == 1.0 else f" × {self.scale:.6g}")

    @property
    def source_name(self) -> str:
        """The source's class and position (mm), or the number of sources of a Collection."""
        src = self.source
        if src is None:
            return ""
        if isinstance(src, tuple):
            return f"{len(src)} sources"
        children = getattr(src, "sources_all", None)
        if children is not None:
            return f"Collection of {len(children)} sources"
        pos = np.reshape(np.asarray(src.position, dtype=np.float64), (-1, 3))[-1] * 1e3
        return f"{type(src).__name__} at (" + ", ".join(f"{c:.4g}" for c in pos) + ") mm"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI): the kind, the field (uniform, T, scale applied) or the source's
        description, and the scale."""
        out: dict[str, Any] = {"kind": self.kind, "scale": self.scale}
        if self.vector is not None:
            out["field_T"] = self.uniform_field.tolist()
        else:
            out["source"] = self.source_name
            out["gradient_step_m"] = self.step
        return out

    def report(self) -> str:
        """One line for people (gauss, and mT for |B|)."""
        if self.vector is not None:
            b = self.uniform_field
            mag = float(np.linalg.norm(b))
            return (f"{self.describe()}, |B| = {mag / GAUSS:.4g} G ({mag * 1e3:.4g} mT)")
        return self.describe()

    def _display_items(self) -> list[Item]:
        if self.vector is not None:
            b = self.uniform_field
            return [("", "uniform"), ("B", "(" + ", ".join(number(c / GAUSS) for c in b) + ") G"),
                    ("|B|", f"{number(float(np.linalg.norm(b)) / GAUSS)} G")]
        items = [("", "magpylib"), ("source", type(self.source).__name__)]
        if self.scale != 1.0:
            items.append(("scale", number(self.scale)))
        return items
