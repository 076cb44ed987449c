"""The closed forms behind the paper's sway experiment (the experiments themselves run in the demo test)."""

from __future__ import annotations

import numpy as np
import pytest

from sizefx.paper import PAPER, format_results, schuler_response

OMEGA_S = 2 * np.pi / (84.4 * 60.0)


def test_t2_law_holds_early_and_the_schuler_loop_bounds_it():
    b = -3.4e-3  # m/s^2: 24.9 mm at 30 deg/s, d A^2 / 2
    t = np.array([60.0, 300.0, 2531.0, 5063.0])  # 1 min, 5 min, half and one Schuler period
    t2, sch = schuler_response(t, [(0.0, b)], OMEGA_S)
    np.testing.assert_allclose(t2, b * t**2 / 2)
    assert sch[0] == pytest.approx(t2[0], rel=1e-3)  # (w t)^2 / 12 = 4e-4 after a minute
    assert sch[2] == pytest.approx(2 * b / OMEGA_S**2, rel=1e-3)  # the bound, reached at half a period
    assert abs(sch[3]) < 1e-3 * abs(sch[2])  # and back at zero after a full one


def test_steps_superpose():
    t = np.linspace(0, 4000, 50)
    one = schuler_response(t, [(100.0, 1e-3)], OMEGA_S)[1] + schuler_response(t, [(900.0, -4e-4)], OMEGA_S)[1]
    both = schuler_response(t, [(100.0, 1e-3), (900.0, -4e-4)], OMEGA_S)[1]
    np.testing.assert_allclose(one, both)
    assert np.all(schuler_response(t, [(5000.0, 1.0)], OMEGA_S)[1] == 0.0)  # nothing before the step


def test_the_papers_figures_are_as_printed():
    tt = PAPER["turntable"]
    delta = np.asarray(tt["delta_m"])
    assert abs(delta.mean()) * 1e3 == pytest.approx(0.47, abs=0.01)  # its "mean 0.5 mm"
    assert np.abs(delta).max() * 1e3 == pytest.approx(1.6)
    assert PAPER["flight"]["gain_km"] == 1.1 and PAPER["sway"]["divergence_km"] == 3.0
    assert "paper" in format_results.__doc__
