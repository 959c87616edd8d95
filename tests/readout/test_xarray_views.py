"""Read-out results as ``xarray.Dataset`` (issue 30 item 1): the estimates and their σ along
``sample`` with ``units`` attributes, the readings' times as coordinate."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.device.magnetometer import Magnetometer

pytest.importorskip("xarray")
SETUP = mc.Setup.paper()


def test_readout_result_to_xarray() -> None:
    readout = mc.Readout(SETUP, "angle", (0.0, 0.5), table_size=17)
    angles = np.array([0.1, 0.2, 0.3])
    result = readout.read(SETUP.output(angles))
    ds = result.to_xarray(time_s=[0.0, 0.1, 0.2])
    assert "time_s" in ds.coords and ds["time_s"].attrs["units"] == "s"
    assert ds["angle_rad"].dims == ("sample",)
    np.testing.assert_array_equal(ds["angle_rad"].values, result.value)
    np.testing.assert_allclose(ds["angle_rad"].values, angles, atol=1e-3)  # (table of 17)
    np.testing.assert_array_equal(ds["sigma_rad"].values, result.sigma)
    assert ds["sigma_noise_rad"].attrs["units"] == "rad" and ds.attrs["quantity"] == "angle"
    np.testing.assert_array_equal(ds["flags"].values, result.flags)
    assert "units" not in ds["flags"].attrs
    with pytest.raises(MagciliaError, match="time_s must be one time per reading"):
        result.to_xarray(time_s=[0.0])


def test_thermal_result_to_xarray_carries_the_temperature() -> None:
    thermal = mc.ThermalReadout(mc.Readout(SETUP, span=(0.0, 0.5), table_size=17))
    result = thermal.read(np.column_stack([SETUP.output([0.1, 0.2]), [293.15, 310.0]]))
    ds = result.to_xarray()
    np.testing.assert_array_equal(ds["temperature_K"].values, [293.15, 310.0])
    assert ds["temperature_K"].attrs["units"] == "K"
    np.testing.assert_array_equal(ds[f"{result.quantity}_{result.unit}"].values, result.value)
    assert ds[f"sigma_temperature_{result.unit}"].attrs["units"] == result.unit
    assert list(ds.attrs["calibrated_range_K"]) == list(result.calibrated_range)


def test_force_vector_result_to_xarray() -> None:
    setup = mc.Setup.paper(tip_radius=5e-5, n_loops=16, dipoles_per_loop=4)
    sensor = Magnetometer(field_range=1e-3, resolution=1e-9, noise=2e-8, rate=100.0)
    readout = mc.BiaxialReadout(setup, sensor, span=1e-4, table_size=(9, 16))
    result = readout.read(readout.model([1e-5, 5e-5], [0.0, -3e-5]))
    ds = result.to_xarray(time_s=[0.0, 0.01])
    np.testing.assert_array_equal(ds["fx_N"].values, result.fx)
    assert ds["fx_N"].attrs["units"] == "N" and ds["direction_rad"].attrs["units"] == "rad"
    assert ds["cov_xy_N2"].attrs["units"] == "N^2" and ds["chi2"].attrs["units"] == "1"
    assert "time_s" in ds.coords
    with pytest.raises(MagciliaError, match="time_s must be one time per reading"):
        result.to_xarray(time_s=[0.0, 1.0, 2.0])
