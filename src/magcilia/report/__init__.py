"""Figures and written reports (matplotlib imported lazily; display units only here).

* :mod:`.figures`: figure construction and the field/output plots;
* :mod:`.calibration`: the paper's Fig. 8, residuals and ``report.md`` of a calibration;
* :mod:`.sensitivity`: figs. 9–12 equivalents, the x–y map, Sobol bars and ``summary.md``;
* :mod:`.design`: design metrics and bent shapes.
"""

from __future__ import annotations
