"""scene.png (navstack.render): the outcome and the goal count in the title, links that touched in red,
and the automatic camera that keeps what matters in frame."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from test_animate import straight_world

from navstack import render
from navstack.render import VIEWS, View, auto_view, outcome_line, project
from navstack.trial import run_trial


def contact_red(rgb: np.ndarray) -> int:
    """Pixels of the contact colour (shaded): strong red, little green and blue (the crimson tip path,
    (220, 20, 60), has too much blue to count)."""
    r, g, b = (rgb[..., k].astype(float) for k in range(3))
    return int(((r > 90) & (g < 0.25 * r) & (b < 0.2 * r)).sum())


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """scene.png of a trial whose serpentine goes through a sphere, and of the same trial without it; the
    caption lines each picture was drawn with."""
    out = {}
    for contact in (True, False):
        d = tmp_path_factory.mktemp("contact" if contact else "clear")
        captured = []
        original = render.draw_overlay

        def spy(rgb, _captured=captured, _original=original, **kw):
            _captured.append(kw["lines"])
            return _original(rgb, **kw)

        render.draw_overlay = spy
        try:
            result = run_trial(straight_world(contact), planner="scripted", out_dir=d, render=True)
        finally:
            render.draw_overlay = original
        out[contact] = (result, np.asarray(Image.open(d / "scene.png").convert("RGB")), captured[0])
    return out


def test_scene_title_states_outcome_and_goal_count(scenes):
    for contact, (result, _, lines) in scenes.items():
        text = [t for t, _ in lines]
        assert text[0].startswith("straight: slither / scripted")
        assert text[1] == outcome_line(result.to_dict(), 2)[0]
        if contact:
            assert text[1].startswith("FAILURE: collision, goals 2/2, contact in")
            assert "touched an obstacle" in text[2]
        else:
            assert text[1] == "SUCCESS: reached every goal, goals 2/2"


def test_links_that_touched_are_red(scenes):
    red_contact, red_clear = contact_red(scenes[True][1]), contact_red(scenes[False][1])
    print(f"contact-red pixels: {red_contact} with contact, {red_clear} without")
    assert red_contact > 200 and red_clear == 0


def test_outcome_line_for_every_reason():
    for reason in ("reached", "collision", "timeout", "stalled", "joint_limit", "error"):
        text, colour = outcome_line({"success": reason == "reached", "reason": reason, "goals_reached": 1}, 3)
        assert ("SUCCESS" if reason == "reached" else "FAILURE") in text and "goals 1/3" in text
        assert colour[1] > colour[0] if reason == "reached" else colour[0] > colour[1]
    assert "unknown" in outcome_line(None, 3)[0]


@pytest.mark.parametrize("name", VIEWS)
def test_auto_view_keeps_every_point_in_frame(name):
    rng = np.random.default_rng(len(name))
    for _ in range(20):
        pts = rng.normal(size=(50, 3)) * rng.uniform(0.1, 3.0, size=3) + rng.uniform(-5, 5, size=3)
        view = auto_view(pts, width=768, height=432, name=name, toward=pts[0] + rng.normal(size=3))
        vm, pm = view.matrices(768, 432)
        uv = project(vm, pm, pts, 768, 432)
        assert (uv[:, 0] > 0).all() and (uv[:, 0] < 768).all() and (uv[:, 1] > 0).all() and (uv[:, 1] < 432).all()
        # tight: the points reach the 6 % margin on the left and right or on the top and bottom
        gap_x = min(uv[:, 0].min(), 768 - uv[:, 0].max()) / 768
        gap_y = min(uv[:, 1].min(), 432 - uv[:, 1].max()) / 432
        assert min(gap_x, gap_y) == pytest.approx(0.06, abs=1e-3)


def test_auto_view_looks_from_the_robot_side():
    pts = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, 1.0], [1.0, 0.0, 0.5]])
    for side in (-1.0, 1.0):
        view = auto_view(pts, width=640, height=480, toward=np.array([1.0, side * 3.0, 0.5]))
        assert np.sign(view.eye[1] - view.target[1]) == side


def test_view_checks_its_fields():
    with pytest.raises(ValueError, match="differ"):
        View(target=(0, 0, 0), eye=(0, 0, 0))
    with pytest.raises(ValueError, match="straight down"):
        View(target=(0, 0, 0), eye=(0, 0, 2))
    with pytest.raises(ValueError, match="finite"):
        View(target=(0, 0, np.nan), eye=(1, 0, 0))
    with pytest.raises(ValueError, match="view must be one of"):
        auto_view(np.zeros((2, 3)), width=64, height=64, name="below")
