"""Following a plan (navstack.planner.steering): speed rules, stopping at the end, slowing, waiting.

Plans are built by hand (a straight line, a circular arc) so positions and tangents are known in closed
form; the speed rules are written out in the tests.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.planner.search import REACHED, Plan
from navstack.planner.steering import PlanFollower, SteeringConfig

CFG = SteeringConfig()
DT = 1.0 / 30.0  # the trial's control period
A_DT = CFG.accel * DT


def _straight(length: float, spacing: float = 0.005) -> Plan:
    n = max(int(math.ceil(length / spacing)), 1) + 1
    s = np.linspace(0.0, length, n)
    return Plan(points=np.column_stack([0.1 + s, np.full(n, 0.2), np.full(n, -0.1)]),
                tangents=np.tile([1.0, 0.0, 0.0], (n, 1)), arc=s, goal_index=np.zeros(n, dtype=np.int64),
                status=REACHED, cost=length, expansions=0)


def _arc(radius: float = 0.25, angle: float = 2.0, spacing: float = 0.005) -> Plan:
    n = int(math.ceil(radius * angle / spacing)) + 1
    phi = np.linspace(0.0, angle, n)
    pts = np.column_stack([radius * np.sin(phi), radius * (1.0 - np.cos(phi)), np.zeros(n)])
    tans = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(n)])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    return Plan(points=pts, tangents=tans, arc=arc, goal_index=np.zeros(n, dtype=np.int64), status=REACHED,
                cost=float(arc[-1]), expansions=0)


def _expected_target(clearance: float, lag: float, remaining: float, cfg: SteeringConfig = CFG) -> float:
    """The documented rules: linear in clearance between stop and slow clearance, the braking bound, the lag."""
    if clearance >= cfg.slow_clearance:
        v = cfg.v_max
    elif clearance <= cfg.stop_clearance:
        v = cfg.v_min
    else:
        v = cfg.v_min + (cfg.v_max - cfg.v_min) * (clearance - cfg.stop_clearance) / (
            cfg.slow_clearance - cfg.stop_clearance)
    adt = cfg.accel * DT  # braking in steps of accel * dt: v^2 + a dt v <= 2 a remaining
    v = min(v, 0.5 * (math.sqrt(adt * adt + 8.0 * cfg.accel * max(remaining, 0.0)) - adt))
    if lag >= cfg.max_lead:
        return 0.0
    if lag > 0.5 * cfg.max_lead:
        v *= (cfg.max_lead - lag) / (0.5 * cfg.max_lead)
    return v


def _run(plan: Plan, steps: int, clearance=lambda k: 1.0, lag=lambda k: 0.0, cfg: SteeringConfig = CFG,
         speed: float = 0.0):
    f = PlanFollower(plan, cfg, speed)
    s, v, pos, vel = [f.s], [f.v], [], []
    for k in range(steps):
        p, u = f.advance(DT, clearance(k), lag(k))
        s.append(f.s)
        v.append(f.v)
        pos.append(p)
        vel.append(u)
    return f, np.array(s), np.array(v), np.array(pos), np.array(vel)


# ---------------------------------------------------------------------------- target speed
@pytest.mark.parametrize("clearance", [-0.01, 0.0, 0.005, 0.01, 0.02, 0.03, 0.049, 0.05, 0.2])
@pytest.mark.parametrize("lag", [0.0, 0.01, 0.015, 0.02, 0.029, 0.03, 0.05])
def test_target_speed_follows_the_documented_rules(clearance, lag):
    f = PlanFollower(_straight(1.0), CFG)
    assert f.target_speed(clearance, lag, DT) == pytest.approx(_expected_target(clearance, lag, 1.0), abs=1e-12)


def test_target_speed_brakes_for_the_end_of_the_plan():
    f = PlanFollower(_straight(1.0), CFG)
    for rem in (0.0, 1e-4, 0.002, 0.01, 0.018, 0.5):
        f.s = 1.0 - rem
        assert f.target_speed(1.0, 0.0, DT) == pytest.approx(_expected_target(1.0, 0.0, rem), abs=1e-12)
        assert f.target_speed(1.0, 0.0, DT) <= math.sqrt(2 * CFG.accel * rem) + 1e-12


# ---------------------------------------------------------------------------- acceleration
def test_speed_changes_by_at_most_accel_dt_per_step_before_the_end():
    """Random clearances and lags on a long plan: every step changes the speed by at most accel * dt
    (steps that land on the plan's end excepted: see the next test)."""
    rng = np.random.default_rng(0)
    cl = rng.uniform(-0.01, 0.08, 400)
    lg = rng.choice([0.0, 0.0, 0.01, 0.02, 0.025, 0.04], 400)
    f, s, v, _, _ = _run(_straight(3.0), 400, lambda k: cl[k], lambda k: lg[k])
    assert s[-1] < 3.0  # never reached the end
    assert np.abs(np.diff(v)).max() <= A_DT + 1e-12
    assert v.max() > CFG.v_min and np.any(v == 0.0)  # it did speed up and stop in between


def test_speed_changes_by_at_most_accel_dt_per_step_up_to_the_stop():
    """Braking in whole steps of accel * dt: only the step that lands on the end may change the speed a
    little more (at most 1.125 accel * dt: the braking curve meets the end between two steps)."""
    for length in (0.5, 0.3011, 0.0123):
        _, s, v, _, _ = _run(_straight(length), 400)
        dv = np.abs(np.diff(v))
        landing = (s[1:] >= length - 1e-12) & (s[:-1] < length - 1e-12)
        assert dv[~landing].max() <= A_DT * (1 + 1e-9), f"plan of {length} m"
        assert dv[landing].max() <= 1.125 * A_DT + 1e-12, f"plan of {length} m"
        assert s[-1] == pytest.approx(length) and v[-1] == 0.0


def test_a_start_speed_is_kept_and_changed_gradually():
    _, _, v, _, _ = _run(_straight(2.0), 5, speed=0.05, clearance=lambda k: 0.0)  # slow down towards v_min
    np.testing.assert_allclose(v, [0.05 - k * A_DT for k in range(6)], atol=1e-12)


# ---------------------------------------------------------------------------- stopping at the end
@pytest.mark.parametrize("plan", [_straight(0.5), _straight(0.0123), _arc()], ids=["straight", "short", "arc"])
def test_the_command_stops_exactly_at_the_end_without_overshoot(plan):
    f, s, v, pos, vel = _run(plan, 600)
    assert np.all(np.diff(s) >= 0) and np.all(s <= plan.length)
    assert s[-1] == plan.length
    np.testing.assert_array_equal(pos[-1], plan.points[-1])
    end = int(np.argmax(s >= plan.length))
    assert np.all(v[end + 1 :] == 0.0) and np.all(pos[end:] == plan.points[-1])  # stays stopped there
    assert f.remaining == 0.0
    # on the way: the speed is the distance covered per period, the velocity along the plan's tangent
    np.testing.assert_allclose(v[1:], np.diff(s) / DT, atol=1e-12)
    for k in range(0, end, 7):
        p, t = plan.state(s[k + 1])
        np.testing.assert_allclose(pos[k], p, atol=1e-12)
        np.testing.assert_allclose(vel[k], v[k + 1] * t, atol=1e-12)
    assert v.max() <= CFG.v_max + 1e-12


def test_the_command_stays_on_the_arc():
    plan = _arc()
    _, _, _, pos, _ = _run(plan, 600)
    r = np.linalg.norm(pos - [0.0, 0.25, 0.0], axis=1)
    sag = 0.005**2 / (8 * 0.25)  # chords of 5 mm on a 0.25 m circle
    assert np.all(r <= 0.25 + 1e-12) and np.all(r >= 0.25 - sag - 1e-12)


# ---------------------------------------------------------------------------- slowing near surfaces
@pytest.mark.parametrize("clearance", [0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.1])
def test_the_speed_settles_at_the_clearance_rule(clearance):
    _, _, v, _, _ = _run(_straight(3.0), 60, clearance=lambda k: clearance)
    assert v[-1] == pytest.approx(_expected_target(clearance, 0.0, 3.0), abs=1e-12)
    assert v.max() <= _expected_target(clearance, 0.0, 3.0) + 1e-12  # it never overshoots it


def test_coming_close_to_a_surface_slows_down_at_accel():
    clearance = lambda k: 1.0 if k < 40 else 0.02  # noqa: E731
    _, _, v, _, _ = _run(_straight(3.0), 80, clearance=clearance)
    assert v[40] == pytest.approx(CFG.v_max)
    slow = _expected_target(0.02, 0.0, 3.0)
    assert slow < CFG.v_max
    np.testing.assert_allclose(np.diff(v[40:50]), -A_DT, atol=1e-12)  # braking as hard as allowed
    assert v[-1] == pytest.approx(slow)


# ---------------------------------------------------------------------------- waiting for the tip
def test_the_command_waits_when_the_tip_lags_by_max_lead():
    lag = lambda k: 0.0 if k < 40 else CFG.max_lead  # noqa: E731
    _, s, v, pos, _ = _run(_straight(3.0), 100, lag=lag)
    assert v[40] == pytest.approx(CFG.v_max)
    np.testing.assert_allclose(np.diff(v[40:58]), -A_DT, atol=1e-12)  # stops as fast as allowed ...
    assert np.all(v[60:] == 0.0)  # ... and waits
    assert np.all(s[60:] == s[60])
    assert s[60] < 3.0


@pytest.mark.parametrize("lag", [0.0, 0.015, 0.02, 0.025, 0.03, 0.04])
def test_a_lagging_tip_scales_the_speed_down(lag):
    _, _, v, _, _ = _run(_straight(3.0), 60, lag=lambda k: lag)
    assert v[-1] == pytest.approx(CFG.v_max * min(max((CFG.max_lead - lag) / (0.5 * CFG.max_lead), 0.0), 1.0),
                                  abs=1e-12)


def test_the_command_resumes_when_the_tip_catches_up():
    lag = lambda k: CFG.max_lead if 20 <= k < 60 else 0.0  # noqa: E731
    _, s, v, _, _ = _run(_straight(3.0), 120, lag=lag)
    assert v[60] == 0.0
    assert v[-1] == pytest.approx(CFG.v_max)
    assert np.abs(np.diff(v)).max() <= A_DT + 1e-12


# ---------------------------------------------------------------------------- configuration
@pytest.mark.parametrize(("kw", "field"), [
    ({"v_max": 0.0}, "v_max"), ({"accel": -1.0}, "accel"), ({"max_lead": np.nan}, "max_lead"),
    ({"v_min": True}, "v_min"), ({"v_min": 0.1, "v_max": 0.05}, "v_min"),
    ({"stop_clearance": 0.05, "slow_clearance": 0.05}, "stop_clearance"),
    ({"accel": 0.0}, "accel"), ({"max_lead": -0.5}, "max_lead"), ({"max_lead": True}, "max_lead"),
    ({"stop_clearance": 0.06, "slow_clearance": 0.05}, "stop_clearance"),
])
def test_steering_config_rejects_bad_values(kw, field):
    with pytest.raises(ValueError, match=field):
        SteeringConfig(**kw)



def test_equal_speed_bounds_are_allowed_and_a_follower_starts_at_rest():
    assert SteeringConfig(v_min=0.05, v_max=0.05).v_min == 0.05
    f = PlanFollower(_straight(0.5), CFG)
    assert (f.s, f.v) == (0.0, 0.0)


def test_a_creeping_speed_below_a_ten_thousandth_of_v_max_is_a_stop():
    """A tip lagging by all but a hair of ``max_lead`` allows a crawl of 0.5e-4 v_max: the command does not
    creep at that, it stops."""
    lag = CFG.max_lead - 0.5 * CFG.max_lead * 0.5e-4
    f = PlanFollower(_straight(0.5), CFG)
    assert 0.0 < f.target_speed(1.0, lag, DT) < 1e-4 * CFG.v_max
    f.advance(DT, 1.0, lag)
    assert (f.s, f.v) == (0.0, 0.0)
