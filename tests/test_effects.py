"""The effects file (sizefx/effects/1): defaults, overrides, and clear errors."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from sizefx.constants import ARCSEC, MICRO_G
from sizefx.effects import IDEAL, effects_template, load_effects
from sizefx.errors import ConfigError


def test_defaults_are_the_papers_high_precision_arms_and_navigation_grade_noise():
    fx = load_effects()
    np.testing.assert_array_equal(fx.arms_total_m(), np.diag([0.0249] * 3))
    assert fx.enabled("gyro_noise") and fx.enabled("accel_noise")
    assert not fx.enabled("accel_delay") and not fx.enabled("level_tilt")


def test_toml_file_overrides_only_what_it_names(tmp_path):
    path = tmp_path / "fx.toml"
    path.write_text(
        'schema = "sizefx/effects/1"\n[lever_arm]\npreset = "compact"\nr_vehicle_m = [0.1, 0, 0]\n'
        "[level_tilt]\nenabled = true\nnorth_arcsec = 3.0\n"
    )
    fx = load_effects(path)
    np.testing.assert_allclose(fx.arms_d_m()[0], [0.0060, 0.0010, 0.0242])
    np.testing.assert_allclose(fx.arms_total_m()[1], [0.1, -0.0172, 0.0])
    np.testing.assert_allclose(fx.tilt_rad(), [3.0 * ARCSEC, -6.0 * ARCSEC, 0.0])  # east keeps its default


def test_ideal_base_then_overrides_gives_exactly_the_named_effects():
    fx = load_effects(overrides={"accel_bias": {"enabled": True}}, base=IDEAL)
    on = [name for name in fx.sections if fx.enabled(name)]
    assert on == ["accel_bias"]
    np.testing.assert_allclose(fx.get("accel_bias", "bias_mps2"), np.array([30.0, -20.0, 50.0]) * MICRO_G)


def test_template_parses_and_equals_the_defaults():
    doc = tomllib.loads(effects_template())
    fx = load_effects(overrides={k: v for k, v in doc.items() if k != "schema"})
    ref = load_effects()
    for name, keys in ref.sections.items():
        for key, value in keys.items():
            got = fx.sections[name][key]
            if value is None or isinstance(value, (bool, str)):
                assert got == value, (name, key)
            else:
                np.testing.assert_allclose(got, value, rtol=1e-6, err_msg=f"{name}.{key}")


@pytest.mark.parametrize(
    "body,words",
    [
        ("[lever_arms]\nenabled = true\n", "unknown section [lever_arms]"),
        ("[lever_arm]\nd_x = [1, 2, 3]\n", "unknown key 'd_x'"),
        ("[lever_arm]\nd_x_m = [1, 2]\n", "expected a list of 3 numbers"),
        ("[accel_delay]\nenabled = 1\n", "must be true or false"),
        ('[lever_arm]\npreset = "big"\n', "must be one of"),
        ('[accel_bias]\nbias_ug = [1, "a", 3]\n', "not numeric"),
        ("[accel_bias\n", "not valid TOML"),
        ('schema = "sizefx/effects/9"\n', "expected 'sizefx/effects/1'"),
    ],
)
def test_bad_effects_files_name_the_key(tmp_path, body, words):
    path = tmp_path / "bad.toml"
    path.write_text(body)
    with pytest.raises(ConfigError) as info:
        load_effects(path)
    assert words in str(info.value) and str(path) in str(info.value)


def test_the_reference_mount_is_read_in_arcsec_and_off_by_default():
    """[reference_mount] arcsec = [x, y, z] becomes psi in rad (sizefx.sensor_model.mount_matrix)."""
    assert not load_effects().enabled("reference_mount")
    assert not load_effects().sensor_params().reference_mount.any()  # off: zeros, whatever the default angles
    fx = load_effects(base=IDEAL, overrides={"reference_mount": {"enabled": True, "arcsec": [30.0, -20.0, 45.0]}})
    np.testing.assert_allclose(
        fx.sensor_params().reference_mount, np.array([30.0, -20.0, 45.0]) * ARCSEC, rtol=1e-15
    )  # one multiplication by the schema's factor
    with pytest.raises(ConfigError, match=r"\[reference_mount\] arcsec has shape \[2\]"):
        load_effects(overrides={"reference_mount": {"arcsec": [1.0, 2.0]}})
