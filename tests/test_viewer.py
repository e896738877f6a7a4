"""``navstack view`` tested as a user would: the viewer serves a run on a local port, real headless Chromium
loads the page, and screenshots show the robot and the structure in their colours; the Play button drives
the replay.  Skipped, with the reason, where the viewer extra, Playwright or Chromium is missing
(``.ci/run`` installs all three).

Set ``NAVSTACK_VIEWER_SCREENSHOT=FILE`` to keep the screenshot (docs/viewer.png was made that way).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from test_animate import synthetic_run

from navstack.jpl import jpl_serpentine
from navstack.rundir import load_run

viser = pytest.importorskip("viser", reason="the viewer extra is not installed (pip install 'navstack[viewer]')")
sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright (test extra) is not installed")

CHROMIUM = os.environ.get("NAVSTACK_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
needs_browser = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed (Debian: apt-get install chromium)")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
VIEWPORT = {"width": 1120, "height": 700}


def _hue_classes(rgb: np.ndarray) -> dict[str, np.ndarray]:
    """Masks of the viewer's colours under shading: arm orange, serpentine green, contact red, structure
    grey-blue (hue from HSV; the structure is the only desaturated blue)."""
    x = rgb.astype(float) / 255.0
    mx, mn = x.max(axis=-1), x.min(axis=-1)
    sat = np.where(mx > 0, (mx - mn) / np.maximum(mx, 1e-9), 0.0)
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    d = np.maximum(mx - mn, 1e-9)
    hue = np.where(mx == r, (g - b) / d % 6, np.where(mx == g, (b - r) / d + 2, (r - g) / d + 4)) * 60.0
    vivid = (sat > 0.45) & (mx > 0.25)
    return {
        "orange": vivid & (hue > 20) & (hue < 50),
        "green": vivid & (hue > 100) & (hue < 160),
        "red": vivid & ((hue < 10) | (hue > 350)),
        "structure": (sat > 0.12) & (sat < 0.45) & (hue > 200) & (hue < 240) & (mx > 0.3),
    }


def _shot(page) -> np.ndarray:
    from io import BytesIO

    from PIL import Image

    return np.asarray(Image.open(BytesIO(page.screenshot())).convert("RGB"))


def _differ(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The pixels that differ between two screenshots (more than 30 in the sum of their RGB differences)."""
    return np.abs(a.astype(int) - b.astype(int)).sum(axis=-1) > 30


def _changed(page, before: np.ndarray, gone: tuple[str, ...] = (),
             timeout: float = 90.0) -> tuple[np.ndarray, np.ndarray]:
    """The screenshot once it has changed from ``before`` and settled with each hue class named in ``gone``
    (names of :func:`_hue_classes`) down to at most half its pixels in ``before``, and the
    mask of the pixels that changed.

    Settled: two screenshots half a second apart agree.  A change of several objects reaches the browser one
    message per object, so the first screenshot that differs may show it half done (in one CI run the arm was
    still drawn after the serpentine had gone, and its pixels were then counted as the structure's; in a
    rehearsal on a loaded machine the serpentine went, the picture held still for half a second, and the arm
    went after that, so a settled picture alone is not enough).  Each class keeps some pixels when its objects
    are hidden (the page's own controls and axes: 6-18 % of the robot's colours), hence the half; the
    structure is one object, hidden in one message, and most of its hue is the ground's, so it names none.  At the
    deadline the last screenshot is returned as it is, and the caller's assertions say what is missing."""
    deadline = time.monotonic() + timeout
    had = {k: int(m.sum()) for k, m in _hue_classes(before).items() if k in gone}
    now = _shot(page)
    while time.monotonic() < deadline:
        time.sleep(0.5)
        later = _shot(page)
        settled = _differ(later, now).sum() <= 20
        now = later
        left = {k: int(m.sum()) for k, m in _hue_classes(now).items() if k in gone}
        if settled and _differ(now, before).sum() > 200 and all(2 * left[k] <= had[k] for k in gone):
            break
    return now, _differ(now, before)


@pytest.fixture(scope="module")
def viewer(tmp_path_factory):
    from navstack.viewer import start_viewer

    run = load_run(synthetic_run(tmp_path_factory.mktemp("run")))
    app = start_viewer(run, host="127.0.0.1", port=0)
    yield app
    app.stop()


@pytest.fixture(scope="module")
def page(viewer):
    with sync_api.sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(tempfile.mkdtemp(prefix="navstack-chromium-"),
                                                    executable_path=CHROMIUM, args=ARGS, headless=True,
                                                    viewport=VIEWPORT)
        try:
            pg = ctx.new_page()
            pg.goto(viewer.url)
            pg.wait_for_selector("canvas", timeout=60_000)
            yield pg
        finally:
            ctx.close()


@needs_browser
def test_robot_and_structure_are_drawn(viewer, page):
    viewer.seek(viewer.run.duration)  # the last sample: the serpentine's front links are in the sphere
    deadline = time.monotonic() + 90
    while True:  # software WebGL takes a few seconds for the first picture
        full = _shot(page)
        cls = _hue_classes(full)
        if (cls["orange"].sum() > 500 and cls["structure"].sum() > 500) or time.monotonic() > deadline:
            break
        time.sleep(0.5)
    keep = os.environ.get("NAVSTACK_VIEWER_SCREENSHOT")
    if keep:
        from PIL import Image

        Image.fromarray(full).save(keep)
    assert full.std() > 20, "blank page"

    for handle in viewer.links.values():  # hide the robot: the pixels that change are the robot's
        handle.visible = False
    no_robot, robot = _changed(page, full, gone=("orange", "green", "red"))
    cls = {k: (m & robot).sum() for k, m in _hue_classes(full).items()}
    print(f"robot pixels {robot.sum()}: {cls}")
    assert cls["orange"] > 1000 and cls["green"] > 300 and cls["red"] > 50  # arm, serpentine, links in contact

    viewer.obstacles.visible = False  # hide the structure: its pixels are grey-blue
    _, structure = _changed(page, no_robot)
    cls = {k: (m & structure).sum() for k, m in _hue_classes(no_robot).items()}
    print(f"structure pixels {structure.sum()}: {cls}")
    assert cls["structure"] > 0.5 * structure.sum() and structure.sum() > 1000
    viewer.obstacles.visible = True
    for handle in viewer.links.values():
        handle.visible = True


@needs_browser
def test_play_button_and_slider_drive_the_replay(viewer, page):
    viewer.seek(0.0)
    viewer.speed = 0.2  # the 2 s run replays in 10 s: time to press Pause before it ends
    assert viewer.index == 0 and viewer.slider.value == 0.0
    page.get_by_role("button", name="Play").click()
    deadline = time.monotonic() + 30
    while viewer.index == 0 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert 0 < viewer.index < len(viewer.run.t) - 1 and viewer.playing
    page.get_by_role("button", name="Pause").click()
    deadline = time.monotonic() + 30
    while viewer.playing and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not viewer.playing
    time.sleep(0.5)
    assert viewer.slider.value == pytest.approx(viewer.run.t[viewer.index])  # the slider follows the replay
    viewer.seek(1.0)  # the robot's link poses follow frames(q) of the chosen sample
    i = viewer.index
    assert viewer.run.t[i] <= 1.0 < viewer.run.t[min(i + 1, len(viewer.run.t) - 1)] + 1e-9
    T0 = viewer.run.world.robot.base.transform()
    F = T0 @ jpl_serpentine().frames(viewer.run.q[i])
    for k, handle in viewer.links.items():
        np.testing.assert_allclose(handle.position, F[k, :3, 3], atol=1e-9)


def test_cli_view_without_a_run_folder_is_bad_input(tmp_path, capsys):
    from navstack.cli import main

    assert main(["view", str(tmp_path / "missing")]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_view_prints_its_address(tmp_path):
    """``navstack view`` as a process: it prints the address to open, and that address serves the page."""
    import subprocess
    import sys
    import urllib.request

    run_dir = synthetic_run(tmp_path / "run", n=5)
    proc = subprocess.Popen([sys.executable, "-m", "navstack.cli", "view", str(run_dir), "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        url = None
        deadline = time.monotonic() + 120
        while url is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            if "open http://" in line:
                url = line.split("open ", 1)[1].split()[0]
        assert url is not None and url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(url, timeout=30) as response:
            assert response.status == 200 and b"<html" in response.read().lower()
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    assert Path(run_dir).is_dir()
