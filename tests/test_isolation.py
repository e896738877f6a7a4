"""Structural guarantee: the planner, estimator, sensor model, controller and path
memory never see the world's obstacles.

1. An AST scan of their source files (following their ``navstack`` imports
   transitively) finds no import of pybullet, trimesh, ``navstack.world``,
   ``navstack.sim`` or the modules that build the simulation; a test of the
   scanner itself shows it catches each kind of violation.
2. Their constructors take no world, scene, obstacle or simulator client
   (names, annotations, no ``*args``/``**kwargs`` escape hatch), and passing
   a World where they expect their own inputs is a ``TypeError``.
3. At run time, after a trial's steps, nothing reachable from its planner,
   controller or estimator (attributes, containers, bound methods, closures) is
   a world, an obstacle, the scene, the robot body, a PyBullet client or a
   simulator module: 1 and 2 cannot see an object that ``trial.py`` hands over
   (an audit showed a scene attached to the planner passing them).

The package ``navstack/__init__.py`` re-exports ``run_trial`` and ``load_world``
for users; it is not part of the scanned core (importing a core module runs
it, but the core's own code never reaches into it: a bare ``import navstack``
in a core file is reported).
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import importlib.util
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

PKG = Path(__file__).resolve().parents[1] / "navstack"
CORE = ("planner", "guide", "estimate", "sensing", "control", "path", "retreat", "kinematics")
FORBIDDEN = (
    "pybullet", "pybullet_utils", "pybullet_data", "trimesh",
    "navstack.world", "navstack.sim", "navstack.trial", "navstack.generate", "navstack.truss",
    "navstack.sweep", "navstack.cli", "navstack.render", "navstack.scripted",
)
BAD_NAME = re.compile(r"world|obstacle|scene|client|geometr|mesh|truss|bullet", re.IGNORECASE)
BAD_TYPE = re.compile(r"\b(World|Obstacle|Scene|Cylinder|Box|Sphere|Mesh|BulletClient|RobotBody)\b")


def _is_forbidden(name: str) -> bool:
    return any(name == f or name.startswith(f + ".") for f in FORBIDDEN)


def _module_file(name: str, pkg: Path) -> Path | None:
    """The source file of ``navstack.x.y`` under ``pkg`` (None for the package itself or non-navstack)."""
    parts = name.split(".")
    if parts[0] != "navstack" or len(parts) == 1:
        return None
    base = pkg.joinpath(*parts[1:])
    if base.with_suffix(".py").is_file():
        return base.with_suffix(".py")
    if (base / "__init__.py").is_file():
        return base / "__init__.py"
    return None


def _package_reexport(attr: str, pkg: Path) -> str | None:
    """Where the package ``__init__`` takes a re-exported name from (``from navstack import World``)."""
    init = pkg / "__init__.py"
    if not init.is_file():
        return None
    for node in ast.walk(ast.parse(init.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            for a in node.names:
                if (a.asname or a.name) == attr:
                    return node.module
    return None


def _imports(path: Path, pkg: Path) -> list[tuple[str, int]]:
    """Every module imported anywhere in ``path`` (lazy imports and import_module calls included)."""
    own = "navstack." + ".".join(path.relative_to(pkg).with_suffix("").parts)
    own_pkg = own.rsplit(".", 1)[0] if path.name != "__init__.py" else own
    out: list[tuple[str, int]] = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            for a in node.names:
                out.append((a.name, node.lineno))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = own_pkg.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.append((mod, node.lineno))
            for a in node.names:
                sub = f"{mod}.{a.name}"
                if _module_file(sub, pkg) is not None or _is_forbidden(sub):
                    out.append((sub, node.lineno))
                elif mod == "navstack":
                    src = _package_reexport(a.name, pkg)
                    out.append((src or sub, node.lineno))
        elif isinstance(node, ast.Call):
            f = node.func
            fname = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            literal = bool(node.args) and isinstance(node.args[0], ast.Constant)
            if fname in ("import_module", "__import__") and literal:
                out.append((str(node.args[0].value), node.lineno))
    return out


def scan(files: list[Path], pkg: Path = PKG) -> list[str]:
    """Violations found in ``files`` and, transitively, in the navstack modules they import."""
    problems: list[str] = []
    seen: set[Path] = set()
    todo = [(f, f.name) for f in files]
    while todo:
        path, chain = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        for name, line in _imports(path, pkg):
            where = f"{chain} (line {line})"
            if name == "navstack":
                problems.append(f"{where}: bare 'import navstack' reaches the package's re-exports")
            elif _is_forbidden(name):
                problems.append(f"{where}: imports {name}")
            else:
                sub = _module_file(name, pkg)
                if sub is not None:
                    todo.append((sub, f"{chain} -> {name}"))
    return problems


# ---------------------------------------------------------------------------- 1. imports
@pytest.mark.parametrize("module", CORE)
def test_core_modules_exist(module):
    """A deleted or renamed core module fails here (and in the scans below); it is never skipped."""
    assert _module_file(f"navstack.{module}", PKG) is not None, f"navstack/{module} is missing"
    assert importlib.util.find_spec(f"navstack.{module}") is not None


def test_the_planner_package_keeps_its_parts():
    for name in ("map", "potential", "search", "steering", "escape", "field"):
        assert (PKG / "planner" / f"{name}.py").is_file(), f"planner/{name}"


@pytest.mark.parametrize("module", CORE)
def test_core_module_never_imports_the_simulator_or_the_world(module):
    path = _module_file(f"navstack.{module}", PKG)
    assert path is not None, f"core module navstack.{module} is missing"
    # a package (navstack/control/): every module in it, imported by its __init__ or not
    files = sorted(path.parent.rglob("*.py")) if path.name == "__init__.py" else [path]
    assert scan(files) == []


@pytest.mark.parametrize(
    "source",
    [
        "import pybullet as p\n",
        "from pybullet_utils import bullet_client\n",
        "def f():\n    import navstack.world\n",
        "from navstack.sim.rays import RaySensor\n",
        "from navstack import world\n",
        "from navstack import World\n",
        "from .world import load_world\n",
        "from . import sim\n",
        "import importlib\nm = importlib.import_module('pybullet')\n",
        "import navstack\n",
        "from navstack.helper import thing\n",  # clean itself, but helper imports pybullet
    ],
)
def test_the_scanner_catches_violations(tmp_path, source):
    pkg = tmp_path / "navstack"
    (pkg / "sim").mkdir(parents=True)
    (pkg / "sim" / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("from navstack.world import World\n")
    (pkg / "world.py").write_text("class World: ...\n")
    (pkg / "helper.py").write_text("import pybullet\nthing = 1\n")
    core = pkg / "core.py"
    core.write_text("import numpy as np\n" + source)
    assert scan([core], pkg), source
    core.write_text("import numpy as np\nfrom navstack.kinematics import Chain\nfrom .sensing import x\n")
    assert scan([core], pkg) == []


# ---------------------------------------------------------------------------- 2. constructors
def _classes():
    out = []
    for mod, names in (
        ("navstack.planner.reactive", ("PotentialFieldPlanner", "PointMemory", "PlannerConfig")),
        ("navstack.planner.field", ("FieldPlanner", "FieldPlannerConfig")),
        ("navstack.planner.map", ("SensedMap", "MapConfig")),
        ("navstack.estimate", ("RangeEstimator", "EstimatorConfig")),
        ("navstack.sensing", ("SensorConfig",)),
        ("navstack.control", ("SlitherController", "ControlConfig")),
        ("navstack.control.tasks", ("TipTask", "SlitherTask", "PostureTask", "JointLimitTask")),
        ("navstack.path", ("PathMemory",)),
        ("navstack.retreat", ("Retreat",)),
    ):
        for n in names:
            out.append(pytest.param(mod, n, id=f"{mod.split('.')[-1]}.{n}"))
    return out


@pytest.mark.parametrize(("module", "cls_name"), _classes())
def test_constructors_take_no_world_or_obstacles(module, cls_name):
    cls = getattr(importlib.import_module(module), cls_name, None)
    assert cls is not None, f"{module}.{cls_name} is missing"
    params = list(inspect.signature(cls).parameters.values())
    for prm in params:
        assert prm.kind not in (prm.VAR_POSITIONAL, prm.VAR_KEYWORD), f"{cls_name}(*{prm.name}) is open"
        assert not BAD_NAME.search(prm.name), f"{cls_name} takes a parameter {prm.name!r}"
        assert not BAD_TYPE.search(str(prm.annotation)), f"{cls_name}.{prm.name}: {prm.annotation}"
    if dataclasses.is_dataclass(cls):
        for f in dataclasses.fields(cls):
            assert not BAD_NAME.search(f.name), f"{cls_name} has a field {f.name!r}"
            assert not BAD_TYPE.search(str(f.type)), f"{cls_name}.{f.name}: {f.type}"


@pytest.fixture(scope="module")
def a_world():
    """A real navstack World with an obstacle (if world.py cannot build one, these tests error)."""
    from navstack.world import World, world_from_dict

    world = world_from_dict({
        "format": "navstack-world/1", "name": "isolation", "robot": {},
        "obstacles": [{"type": "sphere", "center": [1.0, 0.0, 1.8], "radius": 0.1}],
        "goals": [{"position": [0.9, 0.0, 1.9]}],
    })
    assert isinstance(world, World) and len(world.obstacles) == 1
    return world


def test_planner_rejects_a_world(a_world):
    from navstack.planner.reactive import PlannerConfig, PotentialFieldPlanner

    with pytest.raises(TypeError):
        PotentialFieldPlanner(a_world)
    with pytest.raises(TypeError):
        PotentialFieldPlanner(PlannerConfig(), a_world, [1.0, 0.0, 0.0])
    with pytest.raises(TypeError):
        PotentialFieldPlanner(start=[0, 0, 0], heading=a_world)
    with pytest.raises(TypeError):
        PotentialFieldPlanner(PlannerConfig(), [0, 0, 0], [1, 0, 0], a_world)
    with pytest.raises(TypeError):
        PotentialFieldPlanner(obstacles=a_world.obstacles)
    with pytest.raises(TypeError):
        PotentialFieldPlanner(world=a_world)
    with pytest.raises((TypeError, ValueError)):
        PlannerConfig(estimator=a_world)
    planner = PotentialFieldPlanner(start=[0, 0, 0], heading=[1, 0, 0])
    with pytest.raises(TypeError):
        planner.step(0.02, np.zeros(3), np.array([1.0, 0, 0]), a_world, np.ones(3), 0.02)


def test_estimator_rejects_a_world(a_world):
    from navstack.estimate import RangeEstimator

    with pytest.raises(TypeError):
        RangeEstimator(a_world)
    with pytest.raises(TypeError):
        RangeEstimator(10, a_world)
    with pytest.raises(TypeError):
        RangeEstimator(10).update(a_world, 0.05)


def test_controller_and_path_memory_reject_a_world(a_world):
    from navstack.control import SlitherController
    from navstack.jpl import jpl_serpentine
    from navstack.path import PathMemory

    with pytest.raises(TypeError, match="config must be a ControlConfig, got World"):
        SlitherController(jpl_serpentine(), a_world)
    with pytest.raises(TypeError, match="World"):
        SlitherController(jpl_serpentine(), None, a_world)  # as the start posture q0
    with pytest.raises(TypeError, match="World"):
        PathMemory(a_world)


def test_controller_rejects_a_world_as_its_chain(a_world):
    from navstack.control import SlitherController

    with pytest.raises(TypeError, match="chain"):
        SlitherController(a_world)


def test_importing_the_core_loads_no_simulator() -> None:
    """At run time too: importing every core module leaves pybullet and trimesh unloaded."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        + "".join(f"import navstack.{m}\n" for m in CORE)
        + "import navstack.planner.field\n"
        + "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('pybullet', 'pybullet_utils', 'trimesh')"
        " or m in ('navstack.world', 'navstack.trial') or m.startswith('navstack.sim'))\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"importing the core loaded: {out.stdout.strip()}"


# ---- 3. what the pipeline objects can reach at run time


def _reachable(root, limit: int = 500_000):
    """Every object reachable from ``root`` by references (``gc.get_referents``), functions through their
    closures and defaults (not their module globals, which reach everything), navstack's classes through their
    attributes, modules and other classes not entered; an AssertionError past ``limit`` objects."""
    import gc
    import types

    seen, todo = set(), [root]
    while todo:
        assert len(seen) < limit, f"more than {limit} objects reachable: the walk would stop short"
        o = todo.pop()
        if id(o) in seen or isinstance(o, (str, bytes, int, float, bool, types.BuiltinFunctionType)):
            continue
        if isinstance(o, type) and not o.__module__.startswith("navstack"):
            continue  # (a navstack class is walked: its class attributes are reachable too)
        seen.add(id(o))
        yield o
        if isinstance(o, types.ModuleType) or (isinstance(o, np.ndarray) and o.dtype != object):
            continue
        if isinstance(o, types.FunctionType):
            todo.extend(c.cell_contents for c in (o.__closure__ or ()) if c.cell_contents is not None)
            todo.extend(o.__defaults__ or ())
            todo.extend((o.__kwdefaults__ or {}).values())
            continue
        todo.extend(gc.get_referents(o))


def _leaks(sim) -> list[str]:
    import types

    from navstack.sim.scene import Scene
    from navstack.world import Box, Cylinder, Mesh, Sphere, World

    bad = (World, Cylinder, Box, Sphere, Mesh, Scene, type(sim.client), type(sim.body))
    found = []
    for name in ("planner", "controller", "estimator"):
        root = getattr(sim, name)
        if root is None:
            continue
        for o in _reachable(root):
            if isinstance(o, bad) or (isinstance(o, types.ModuleType) and o.__name__.startswith(
                    ("pybullet", "navstack.sim", "navstack.world", "navstack.trial"))):
                found.append(f"{name} reaches a {type(o).__name__}")
                break
    return found


@pytest.mark.parametrize("planner", ["field", "reactive", "scripted"])
def test_nothing_of_the_simulation_is_reachable_from_the_pipeline_after_a_trial(planner):
    from navstack.trial import TrialConfig, _Simulation
    from navstack.world import load_world, world_from_dict

    data = load_world(PKG.parent / "worlds" / "truss_clutter.json").to_dict()
    data["time_limit"] = 1.0  # 30 control steps: the pipeline objects hold their state of a running trial
    sim = _Simulation(world_from_dict(data), "slither", planner, 0, TrialConfig())
    try:
        sim.run()
        assert _leaks(sim) == []
        sim.planner.hint = lambda: sim.scene.world  # the check itself: a closure over the simulation is seen
        leaks = _leaks(sim)
        assert leaks and leaks[0].startswith("planner reaches a "), leaks
    finally:
        sim.close()
