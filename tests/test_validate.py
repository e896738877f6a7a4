"""navstack.validate: the field checks every configuration dataclass uses, and the configurations that use them."""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from navstack.animate import AnimationConfig
from navstack.control.config import ControlConfig
from navstack.estimate import EstimatorConfig
from navstack.generate.checks import CheckConfig
from navstack.planner.escape import EscapeConfig
from navstack.planner.field import FieldPlannerConfig
from navstack.planner.map import MapConfig
from navstack.planner.opening import OpeningConfig
from navstack.planner.potential import Repulsion
from navstack.planner.reactive import PlannerConfig
from navstack.planner.search import ArmShape, SearchConfig
from navstack.planner.steering import SteeringConfig
from navstack.render import View
from navstack.scripted import ScriptedConfig
from navstack.sensing import SensorConfig, SensorReading
from navstack.sim.servo import ServoConfig
from navstack.trial import TrialConfig
from navstack.urdf import UrdfOptions
from navstack.validate import (
    MAX_SEED,
    finite,
    flag,
    in_range,
    instance,
    integer,
    is_integer,
    is_number,
    is_seed,
    non_negative,
    positive,
)


@dataclass(frozen=True)
class Cfg:
    """A stand-in configuration: one field of any value."""

    x: Any = 1.0


NOT_NUMBERS = ["1.0", "abc", None, True, False, np.bool_(True), [1.0], (1.0,), 1j, {"x": 1}]
NON_FINITE = [math.nan, math.inf, -math.inf, np.float64("nan"), np.float32("inf"), 10**400, -(10**400)]
NUMPY_NUMBERS = [np.float64(0.5), np.float32(0.5), np.int64(2), np.int32(3), np.uint8(4), np.float16(0.5)]


def _refused(check, value, what: str) -> None:
    """``check(Cfg(value))`` raises ValueError ``Cfg.x must be <what>, got <repr>``."""
    message = f"Cfg.x must be {what}, got {value!r}"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        check(Cfg(value))


# --------------------------------------------------------------------------- predicates
def test_is_number_and_is_integer():
    for v in [0, -3, 2.5, math.inf, *NUMPY_NUMBERS]:
        assert is_number(v), v
    for v in ["1", None, True, np.bool_(False), 1j, [1], np.array(1.0)]:
        assert not is_number(v), v
    for v in [0, -3, 10**400, np.int64(2), np.uint8(4)]:
        assert is_integer(v), v
    for v in [1.0, np.float64(2.0), True, np.bool_(True), "1", None]:
        assert not is_integer(v), v


def test_is_seed_is_an_integer_from_0_to_2_63_minus_1():
    assert MAX_SEED == 9223372036854775807  # int64's largest: what readers of result.json and results.jsonl hold
    for v in [0, 1, 2**62, MAX_SEED, np.int64(MAX_SEED), np.uint8(0)]:
        assert is_seed(v), v
    for v in [-1, np.int64(-1), MAX_SEED + 1, 2**64, 10**30, 0.5, 1.0, True, "1", None]:
        assert not is_seed(v), v


# --------------------------------------------------------------------------- positive
@pytest.mark.parametrize("value", [1, 0.5, 1e-300, 1e300, *NUMPY_NUMBERS])
def test_positive_accepts_positive_numbers_and_keeps_them_as_given(value):
    cfg = Cfg(value)
    positive(cfg, "x")
    assert cfg.x is value


@pytest.mark.parametrize("value", [0, 0.0, -0.0, -1, -1e-300, np.float32(-0.5), *NOT_NUMBERS, *NON_FINITE])
def test_positive_refuses_everything_else(value):
    _refused(lambda c: positive(c, "x"), value, "a positive number")


def test_positive_with_inf_ok():
    for value in [math.inf, 10**400, np.float64("inf"), 0.5]:
        positive(Cfg(value), "x", inf_ok=True)
    for value in [math.nan, -math.inf, -(10**400), 0.0, -1.0, "inf", True, None]:
        _refused(lambda c: positive(c, "x", inf_ok=True), value, "a positive number or inf")


def test_the_first_bad_field_of_several_is_named():
    @dataclass(frozen=True)
    class Two:
        a: Any = 1.0
        b: Any = 1.0

    positive(Two(), "a", "b")
    with pytest.raises(ValueError, match=r"^Two\.b must be a positive number, got 'x'$"):
        positive(Two(b="x"), "a", "b")
    with pytest.raises(ValueError, match=r"^Two\.a must be a positive number, got 0$"):
        positive(Two(a=0, b="x"), "a", "b")


# --------------------------------------------------------------------------- non_negative, finite
@pytest.mark.parametrize("value", [0, 0.0, -0.0, 3, 2.5, *NUMPY_NUMBERS])
def test_non_negative_accepts_zero_and_positive_numbers(value):
    non_negative(Cfg(value), "x")


@pytest.mark.parametrize("value", [-1, -1e-12, np.int64(-1), *NOT_NUMBERS, *NON_FINITE])
def test_non_negative_refuses_everything_else(value):
    _refused(lambda c: non_negative(c, "x"), value, "a number >= 0")


def test_non_negative_with_none_ok():
    non_negative(Cfg(None), "x", none_ok=True)
    non_negative(Cfg(0.0), "x", none_ok=True)
    for value in [-1.0, math.nan, "0", True]:
        _refused(lambda c: non_negative(c, "x", none_ok=True), value, "None or a number >= 0")

    @dataclass(frozen=True)
    class Two:
        a: Any = None
        b: Any = -1.0

    with pytest.raises(ValueError, match=r"^Two\.b must be None or a number >= 0, got -1\.0$"):
        non_negative(Two(), "a", "b", none_ok=True)  # a field after a None one is checked too


@pytest.mark.parametrize("value", [0, -9.81, 1e300, -(10**300), *NUMPY_NUMBERS])
def test_finite_accepts_any_sign(value):
    finite(Cfg(value), "x")


@pytest.mark.parametrize("value", [*NOT_NUMBERS, *NON_FINITE])
def test_finite_refuses_what_is_not_a_finite_number(value):
    _refused(lambda c: finite(c, "x"), value, "a finite number")


# --------------------------------------------------------------------------- in_range
def test_in_range_closed_and_open_ends():
    def check(c: Cfg) -> None:
        in_range(c, "x", lo=0.0, hi=1.0, lo_open=True)

    for value in [1e-12, 0.5, 1, 1.0, np.float32(0.25), np.int64(1)]:
        check(Cfg(value))
    for value in [0, 0.0, 1.0 + 1e-12, -0.5, *NOT_NUMBERS, *NON_FINITE]:
        _refused(check, value, "a number in (0, 1]")
    in_range(Cfg(0.0), "x", lo=0.0, hi=1.0, hi_open=True)
    for value in [1.0, 2.0, -1e-12]:
        _refused(lambda c: in_range(c, "x", lo=0.0, hi=1.0, hi_open=True), value, "a number in [0, 1)")


def test_in_range_message_bounds_are_exact_and_the_unit_follows():
    _refused(lambda c: in_range(c, "x", lo=0.0, hi=math.pi, unit=" [rad]"), 4.0,
             "a number in [0, 3.141592653589793] [rad]")
    _refused(lambda c: in_range(c, "x", lo=0.01, hi=1e6), 0.0, "a number in [0.01, 1e+06]")
    # a bound whose short form rounds up (0.123457 > 0.1234567) or down is written with every digit
    _refused(lambda c: in_range(c, "x", lo=0.1234567, hi=0.7654321), 0.0, "a number in [0.1234567, 0.7654321]")


# --------------------------------------------------------------------------- integer
@pytest.mark.parametrize("value", [0, 1, 10**30, np.int64(5), np.uint8(3)])
def test_integer_accepts_integers(value):
    integer(Cfg(value), "x", lo=0)


@pytest.mark.parametrize("value", [1.0, 1.5, np.float64(2.0), "1", None, True, False, np.bool_(True), math.nan,
                                   math.inf, [1]])
def test_integer_refuses_what_is_not_an_integer(value):
    _refused(lambda c: integer(c, "x", lo=0), value, "an integer >= 0")
    _refused(lambda c: integer(c, "x"), value, "an integer")


def test_integer_bounds():
    _refused(lambda c: integer(c, "x", lo=1), 0, "an integer >= 1")
    _refused(lambda c: integer(c, "x", lo=1), np.int64(-3), "an integer >= 1")
    integer(Cfg(-5), "x")  # no bound: any integer
    integer(Cfg(1920), "x", lo=160, hi=1920)
    _refused(lambda c: integer(c, "x", lo=160, hi=1920), 1936, "an integer in [160, 1920]")
    _refused(lambda c: integer(c, "x", hi=3), 4, "an integer <= 3")


# --------------------------------------------------------------------------- flag, instance
@pytest.mark.parametrize("value", [True, False, np.bool_(True), np.bool_(False)])
def test_flag_accepts_booleans(value):
    flag(Cfg(value), "x")


@pytest.mark.parametrize("value", [0, 1, 1.0, "True", "yes", None, np.int64(1), [True]])
def test_flag_refuses_everything_else(value):
    _refused(lambda c: flag(c, "x"), value, "True or False")


def test_instance_names_the_class_with_its_article():
    instance(Cfg(EstimatorConfig()), "x", EstimatorConfig)
    _refused(lambda c: instance(c, "x", EstimatorConfig), {}, "an EstimatorConfig")
    _refused(lambda c: instance(c, "x", MapConfig), None, "a MapConfig")


# --------------------------------------------------------------------------- every configuration
REQUIRED: dict[type, dict[str, Any]] = {
    View: {"target": (0.0, 0.0, 0.0), "eye": (1.0, 0.0, 1.0)},
    ArmShape: {"points": np.zeros((4, 3)), "flange": np.zeros(3), "radius": 0.06},
    SensorReading: {"origins": np.zeros((1, 3)), "directions": np.array([[1.0, 0.0, 0.0]]),
                    "ranges": np.array([0.3]), "hit": np.array([True]), "valid": np.array([True]), "max_range": 0.4},
}
"""Arguments of the classes that have required fields."""

CONFIGS = [SensorConfig, SensorReading, View, AnimationConfig, SteeringConfig, FieldPlannerConfig, OpeningConfig,
           EscapeConfig, SearchConfig, ArmShape, PlannerConfig, MapConfig, Repulsion, EstimatorConfig, ScriptedConfig,
           ServoConfig, ControlConfig, CheckConfig, UrdfOptions, TrialConfig]
"""Every dataclass whose ``__post_init__`` checks its fields with :mod:`navstack.validate`."""

OPTIONAL_NUMBERS = {(FieldPlannerConfig, "tight_margin")}
"""Number fields that may also be None."""


def _build(cls: type, **changes: Any) -> Any:
    return cls(**{**REQUIRED.get(cls, {}), **changes})


def _fields(kind: str) -> list[tuple[type, str]]:
    """(class, field) of every field of the configurations whose default (or required value) is a number
    (``kind`` "number") or a bool (``kind`` "flag")."""
    out = []
    for cls in CONFIGS:
        base = _build(cls)
        for f in dataclasses.fields(cls):
            v = getattr(base, f.name)
            if kind == "flag" and isinstance(v, bool):
                out.append((cls, f.name))
            elif kind == "number" and (is_number(v) or (cls, f.name) in OPTIONAL_NUMBERS):
                out.append((cls, f.name))
    return out


NUMBER_FIELDS = _fields("number")
FLAG_FIELDS = _fields("flag")


def test_the_field_lists_cover_the_configurations():
    assert len(NUMBER_FIELDS) > 200 and {cls for cls, _ in NUMBER_FIELDS} == set(CONFIGS)
    assert {f"{cls.__name__}.{name}" for cls, name in FLAG_FIELDS} == {
        "SensorConfig.include_axis", "OpeningConfig.enabled", "SearchConfig.half_curvature",
        "PlannerConfig.gap_centering", "MapConfig.forget_moved", "MapConfig.detect_motion",
        "ServoConfig.gravity_compensation"}


def _unnamed(cls: type, name: str, values: list[Any], words: str) -> list[str]:
    """The ``values`` of field ``name`` that do not give a ValueError ``<Class>.<name> must be <words>``, each
    with what they gave instead."""
    out = []
    for value in values:
        try:
            _build(cls, **{name: value})
            out.append(f"{name}={value!r}: accepted")
        except ValueError as e:
            if not str(e).startswith(f"{cls.__name__}.{name} must be {words}"):
                out.append(f"{name}={value!r}: {e}")
        except Exception as e:  # noqa: BLE001 - what the test is about
            out.append(f"{name}={value!r}: {type(e).__name__}: {e}")
    return out


@pytest.mark.parametrize("cls", CONFIGS, ids=[c.__name__ for c in CONFIGS])
def test_a_value_of_no_number_in_any_number_field_is_a_value_error_naming_the_field(cls):
    """A string, None, a bool or NaN in any number field of any configuration: a ValueError "<Class>.<field> must
    be ..." (before, some were a TypeError from a comparison or a ufunc, and some were accepted)."""
    bad = []
    for c, name in NUMBER_FIELDS:
        if c is cls:
            none = [] if (cls, name) in OPTIONAL_NUMBERS else [None]
            bad += _unnamed(cls, name, ["0.5", "abc", True, math.nan, *none], "")
    assert not bad, bad
    for c, name in OPTIONAL_NUMBERS:
        if c is cls:
            assert getattr(_build(cls, **{name: None}), name) is None


@pytest.mark.parametrize("cls", sorted({c for c, _ in FLAG_FIELDS}, key=lambda c: c.__name__),
                         ids=lambda c: c.__name__)
def test_a_flag_that_is_no_bool_is_refused_naming_the_field(cls):
    bad = []
    for c, name in FLAG_FIELDS:
        if c is cls:
            bad += _unnamed(cls, name, ["yes", 1, None], "True or False, got ")
    assert not bad, bad


@pytest.mark.parametrize("cls", CONFIGS, ids=[c.__name__ for c in CONFIGS])
def test_defaults_are_valid_and_numpy_float64_values_are_kept(cls):
    """A configuration of its defaults builds; the same numbers as numpy float64 (a float subclass, accepted
    before by every configuration) build too and are kept as given."""
    base = _build(cls)
    floats = {name: np.float64(getattr(base, name)) for c, name in NUMBER_FIELDS
              if c is cls and isinstance(getattr(base, name), float)}
    cfg = _build(cls, **floats)
    for name, v in floats.items():
        assert getattr(cfg, name) is v or getattr(cfg, name) == v


def test_numpy_scalars_are_numbers_where_they_were_before():
    """SensorConfig, EstimatorConfig, PlannerConfig, ServoConfig and SensorReading took numpy integer and float
    scalars before; they still do, unchanged."""
    sensor = SensorConfig(cone_rings=np.int64(2), cone_rays_per_ring=np.int32(6), max_range=np.float32(0.4),
                          noise_std=np.float32(0.004), include_axis=np.bool_(True))
    assert sensor.cone_rings == 2 and isinstance(sensor.cone_rings, np.int64)
    est = EstimatorConfig(measurement_std=np.float32(0.004), gate_sigma=np.int64(4), max_coast=np.int64(3))
    assert isinstance(est.max_coast, np.int64) and est.gate_sigma == 4
    planner = PlannerConfig(v_max=np.float32(0.06), max_escapes=np.int64(2), gap_centering=np.bool_(False))
    assert planner.max_escapes == 2
    ServoConfig(physics_hz=np.float32(240.0), control_hz=np.int64(30), position_gain=np.float32(0.5))
    SensorReading(**{**REQUIRED[SensorReading], "max_range": np.float32(0.4)})


@pytest.mark.parametrize(("cls", "changes", "field"), [
    (ServoConfig, {"physics_hz": "240"}, "physics_hz"),  # a ufunc TypeError before
    (ServoConfig, {"position_gain": None}, "position_gain"),
    (ServoConfig, {"control_hz": True}, "control_hz"),  # accepted before
    (ServoConfig, {"gravity": "down"}, "gravity"),  # not checked before
    (ServoConfig, {"solver_iterations": 0}, "solver_iterations"),
    (View, {"fov": "45"}, "fov"),  # a comparison TypeError before
    (SensorReading, {"max_range": "0.4"}, "max_range"),
    (SearchConfig, {"goal_fraction": None}, "goal_fraction"),
    (SearchConfig, {"step": True}, "step"),  # accepted before
    (SearchConfig, {"nav_margin": math.nan}, "nav_margin"),  # not checked before
    (ScriptedConfig, {"speed": True}, "speed"),
    (TrialConfig, {"scripted_speed": True}, "scripted_speed"),
    (TrialConfig, {"servo": None}, "servo"),
    (FieldPlannerConfig, {"path_spacing": 0.0}, "path_spacing"),  # not checked before
    (FieldPlannerConfig, {"map": {}}, "map"),
    (AnimationConfig, {"fov": "wide"}, "fov"),  # accepted before without eye and target
    (SteeringConfig, {"v_max": 10**400}, "v_max"),  # an OverflowError before
    (PlannerConfig, {"lookahead": 10**400}, "lookahead"),
    (UrdfOptions, {"name": 5}, "name"),
])
def test_former_gaps_are_value_errors_naming_the_field(cls, changes, field):
    with pytest.raises(ValueError, match=f"^{cls.__name__}\\.{field} "):
        _build(cls, **changes)


def test_vector_fields_of_no_numbers_are_value_errors_naming_the_field():
    with pytest.raises(ValueError, match=r"^ControlConfig\.wv "):
        ControlConfig(wv=("a",) * 20)  # numpy's own "could not convert" before
    with pytest.raises(ValueError, match=r"^ControlConfig\.posture "):
        ControlConfig(posture=[{}] * 7)
    with pytest.raises(ValueError, match=r"^ControlConfig\.slither "):
        ControlConfig(slither=["full"])  # an unhashable-type TypeError before
    with pytest.raises(ValueError, match="eye and target must be 3 finite numbers"):
        View(target="abc", eye=(1.0, 0.0, 1.0))


def test_cross_field_rules_still_hold():
    with pytest.raises(ValueError, match=r"SteeringConfig\.v_min \(0\.1\) exceeds v_max"):
        SteeringConfig(v_min=0.1, v_max=0.05)
    with pytest.raises(ValueError, match="OpeningConfig.min_clearance must be below ring_radius"):
        OpeningConfig(min_clearance=0.2)
    with pytest.raises(ValueError, match="need gain\\*dt <= 1"):
        ControlConfig(k_tip=1e4)
    with pytest.raises(ValueError, match="whole multiple"):
        ServoConfig(physics_hz=250.0)
    with pytest.raises(ValueError, match="SearchConfig.epsilon must be >= 1"):
        SearchConfig(epsilon=0.9)
    with pytest.raises(ValueError, match="AnimationConfig.width must be a multiple of 16"):
        AnimationConfig(width=300)
    assert EstimatorConfig(lag_sigma=math.inf).lag_sigma == math.inf  # never lagging
    assert FieldPlannerConfig(tight_margin=None).tight_margin is None


def test_in_range_keeps_a_wording_given_for_its_readers():
    _refused(lambda c: in_range(c, "x", lo=0.01, hi=0.5, what="a number from 0.01 to 0.5 m"), 1e300,
             "a number from 0.01 to 0.5 m")
    with pytest.raises(ValueError, match=r"^UrdfOptions\.arm_radius must be a number from 0\.01 to 0\.5 m \(as in"):
        UrdfOptions(arm_radius="0.06")
