"""The parameter registry: complete, consistent with the objects it describes, and the one source
of domains, setup-file keys, bounds, spans and display units."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.device.parameters import (
    FITTED,
    MEASURANDS,
    MODEL,
    PARAMETERS,
    STUDIED,
    check_ranges,
    default_bounds,
    default_spans,
    describe_bounds,
    describe_spans,
)
from magcilia.io.setup_files import SCHEMA, setup_to_dict

PARTS = {"cilium": mc.Cilium, "material": mc.Material, "sensor": mc.Sensor}


def test_every_field_of_the_device_objects_is_registered() -> None:
    for part, cls in PARTS.items():
        for f in dataclasses.fields(cls):
            if f.name in ("name", "profile"):  # a label and the measured shape: not parameters
                continue
            assert f.name in PARAMETERS, f"{cls.__name__}.{f.name} is not in the registry"
            assert PARAMETERS[f.name].part == part
    setup_fields = {f.name for f in dataclasses.fields(mc.Setup)} - {*PARTS, "position"}
    assert setup_fields | {"x", "y", "z"} == {n for n, p in PARAMETERS.items()
                                              if p.part == "setup"}


def test_model_parameters_are_the_setup_params() -> None:
    assert set(mc.Setup.paper().params()) == set(MODEL)
    assert FITTED == ("height", "base_radius", "x", "y", "z", "n_loops", "dipoles_per_loop")
    assert STUDIED == ("x", "y", "z", "n_loops", "dipoles_per_loop", "height", "base_radius")


def test_value_reads_every_parameter() -> None:
    setup = mc.Setup.paper(gain=2.0, youngs_modulus=3e6)
    assert setup.value("x") == setup.position[0]
    assert setup.value("gain") == 2.0 and setup.value("youngs_modulus") == 3e6
    assert setup.value("n_loops") == 2 and setup.value("ring") == "mean"
    for name in MODEL:
        assert setup.value(name) == setup.params()[name]
    with pytest.raises(mc.MagciliaError, match="parameter must be one of"):
        setup.value("diameter")


@pytest.mark.parametrize("name", [n for n, p in PARAMETERS.items() if p.file is not None])
def test_every_parameter_round_trips_through_a_setup_file(name: str, tmp_path: Path) -> None:
    p = PARAMETERS[name]
    # a modulus's 1 σ comes with a modulus (the material's carries its own uncertainty)
    base = mc.Setup.paper(tip_radius=2e-5, **({"youngs_modulus": 3e6}
                                              if name == "youngs_modulus_sigma" else {}))
    value = base.value(name)
    changed = 3 if p.domain == "integer" else next(
        (c for c in p.choices if c != value), None)  # another choice (ring "rms", layout …)
    if changed is None:
        changed = (3e6 if value is None else value * 1.1 + (1e-4 if value == 0 else 0.0))
    setup = base.replace(**{name: changed})
    assert p.file is not None and SCHEMA[p.file[0]][p.file[1]] is p
    assert p.file[1] in setup_to_dict(setup)[p.file[0]]
    mc.save_setup(setup, tmp_path / "s.toml")
    back = mc.load_setup(tmp_path / "s.toml").value(name)
    assert back == pytest.approx(changed, rel=1e-11) if p.dimension else back == changed


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("height", -0.003, "height must be a positive length in m; got -0.003"),
        ("cobalt_mass", 0.0, "cobalt_mass must be a positive mass in kg; got 0"),
        ("magnetization_scale", -1.0, "magnetization_scale must be a non-negative factor"),
        ("gain", 0.0, "gain must be a non-zero finite number; got 0"),
        ("n_loops", 2.5, "n_loops must be an integer >= 1; got 2.5"),
        ("ring", "median", "ring must be one of 'mean', 'rms'; got 'median'"),
        ("offset", math.nan, "offset must be a finite number in V"),
    ],
)
def test_domains_give_one_line_errors(name: str, value: object, message: str) -> None:
    with pytest.raises(mc.MagciliaError) as err:
        PARAMETERS[name].check(value)
    assert str(err.value).startswith(message)
    with pytest.raises(mc.MagciliaError) as err:  # the objects use the same checks
        mc.Setup.paper(**{name: value})
    assert str(err.value).startswith(message)


def test_bounds_and_spans() -> None:
    bounds = default_bounds()
    assert tuple(bounds) == FITTED
    check_ranges(bounds)  # the defaults lie in the domains
    initial = mc.Setup.paper_initial().params()
    assert all(lo <= initial[n] <= hi for n, (lo, hi) in bounds.items())
    with pytest.raises(mc.MagciliaError, match=r"bounds\['n_loops'\] must be whole numbers >= 1"):
        check_ranges({"n_loops": (0.5, 3)})
    with pytest.raises(mc.MagciliaError, match=r"bounds\['height'\] must be positive lengths in m"):
        check_ranges({"height": (0.0, 1e-3)})
    spans = default_spans(mc.Setup.paper().params())
    assert spans["x"] == pytest.approx((1.4727e-3 - 1e-3, 1.4727e-3 + 1e-3))
    assert spans["height"] == pytest.approx((0.8 * 3.2613e-3, 1.2 * 3.2613e-3))
    assert spans["z"] == (0.0, 1e-3)
    assert describe_bounds().startswith("height 2:4, base_radius 0.1:0.4, x -3:3")
    assert "x ±1 mm" in describe_spans() and "height ±20 %" in describe_spans()


def test_display_units() -> None:
    assert PARAMETERS["height"].display == "mm"
    assert PARAMETERS["offset"].to_display(2e-3) == pytest.approx(2.0)  # mV
    for p in [*PARAMETERS.values(), *MEASURANDS.values()]:
        assert p.from_display(p.to_display(0.123)) == pytest.approx(0.123, rel=1e-15)
    assert MEASURANDS["angle"].to_display(math.pi) == pytest.approx(180.0)
    assert np.isclose(MEASURANDS["force"].display_factor, 1e-3)


@pytest.mark.parametrize("name", ["height", "base_radius", "tip_radius", "x", "y", "z",
                                  "youngs_modulus", "magnetization_scale"])
def test_accepts_is_check_vectorised(name: str) -> None:
    """``Parameter.accepts`` says of each value what ``check`` does (returns it or raises)."""
    par = PARAMETERS[name]
    edges = [par.minimum, par.maximum, -par.minimum, -par.maximum]
    values = np.array([0.0, -0.0, 1e-3, -1e-3, 2.5e6, np.inf, -np.inf, np.nan, 1e-300,
                       *edges, *(np.nextafter(e, s) for e in edges for s in (-np.inf, np.inf)
                                 if np.isfinite(e))])
    got = par.accepts(values)
    assert got.shape == values.shape
    for value, ok in zip(values, got, strict=True):
        try:
            par.check(float(value))
            passed = True
        except mc.MagciliaError:
            passed = False
        assert ok == passed, (name, value)


def test_accepts_refuses_a_choice() -> None:
    with pytest.raises(ValueError, match="real parameters"):
        PARAMETERS["ring"].accepts(np.zeros(2))
