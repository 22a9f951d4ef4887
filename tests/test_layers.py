"""The import picture: layers seen from the folder tree, no arrow running back up.

Layers, bottom to top::

    foundation  handeye/core/           numpy (+ scipy, PIL where a module says so)
    engines     classic/  learned/
    robot       handeye/robot/          the URDF model, its surface, look-at, the sensor profiles
    simulator   sim/
    front       handeye/ (cli, commands, labelling, ...), everything above

Rules (``../shared/DESIGN.md``): the foundation imports no engine and not the front;
``classic`` imports neither the robot, ``sim``, ``learned`` nor the front; ``learned`` imports
neither the robot, ``sim``, ``classic`` nor the front; the robot may use ``classic`` but neither
``sim``, ``learned`` nor the front; ``sim`` may use ``classic`` (ChArUco board, projection) and the
robot but neither ``learned`` nor the front. Every ``import`` statement counts, also those inside
functions: a lazy import is still an arrow.

The robot is not the simulator: the front's modules for real data (every command but ``sim`` and
``demo``, which render) reach neither ``sim`` nor pyrender through any chain of imports
(:func:`test_real_data_commands_never_reach_the_simulator`), and loading a UR with its surface, as
the markerless command does, loads neither (:func:`test_the_robot_and_its_surface_load_without_the_renderer`).

No circles either, between files: a module never imports, directly or through others, a module that
imports it (:func:`import_circles`).

``python -m tests.test_layers`` prints the picture (arrows between layers, with counts) and any circle.
"""

from __future__ import annotations

import ast
from collections import Counter
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("handeye", "classic", "sim", "learned")

# layer -> layers it must never import
FORBIDDEN = {
    "foundation": {"front", "classic", "robot", "sim", "learned"},
    "classic": {"front", "robot", "sim", "learned"},
    "robot": {"front", "sim", "learned"},
    "sim": {"front", "learned"},
    "learned": {"front", "robot", "sim", "classic"},
    "front": set(),
}
#: The front's commands that render (the simulator's own); every other command calibrates real data.
RENDERING_COMMANDS = ("handeye.commands.sim", "handeye.commands.demo")


def layer_of_module(name: str) -> str | None:
    """Layer of a dotted module name inside the project, None for anything else."""
    parts = name.split(".")
    if parts[0] == "handeye":
        return {"core": "foundation", "robot": "robot"}.get(parts[1] if len(parts) >= 2 else "", "front")
    if parts[0] in ("classic", "sim", "learned"):
        return parts[0]
    return None


def module_name(path: Path) -> str:
    rel = path.relative_to(REPO).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imported_modules(path: Path) -> list[tuple[int, str]]:
    """``(line, dotted name)`` of every import in a file, relative imports resolved."""
    own = module_name(path).split(".")
    package = own if path.name == "__init__.py" else own[:-1]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            mod = ".".join(base + ([node.module] if node.module else []))
            # `from handeye import core` imports handeye.core: name the module and the name
            out += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
    return out


def project_files() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (REPO / pkg).rglob("*.py"))


def arrows() -> list[tuple[str, str, str, int, str]]:
    """Every import between project modules: ``(from layer, to layer, file, line, module)``."""
    out = []
    for path in project_files():
        src = layer_of_module(module_name(path))
        for line, name in imported_modules(path):
            dst = layer_of_module(name)
            if dst is not None and dst != src:
                out.append((src, dst, str(path.relative_to(REPO)), line, name))
    return out


def test_every_package_file_has_a_layer():
    files = project_files()
    assert len(files) > 50
    assert all(layer_of_module(module_name(p)) is not None for p in files)
    assert any(module_name(p).startswith("handeye.core.") for p in files)


def test_no_import_runs_against_the_layers():
    bad = [
        f"{file}:{line} ({src}) imports {name} ({dst})"
        for src, dst, file, line, name in arrows()
        if dst in FORBIDDEN[src]
    ]
    assert bad == [], "\n".join(bad)


def test_the_rules_catch_a_backward_arrow(tmp_path):
    """The checker itself: a foundation file importing the front is flagged, with its line."""
    fake = REPO / "handeye" / "core" / "_layer_probe_tmp.py"
    fake.write_text(
        "import numpy\n\ndef f():\n    from handeye.labelling import label_dataset\n    from classic import park\n"
    )
    try:
        found = [(src, dst, line) for src, dst, file, line, _ in arrows() if file.endswith("_layer_probe_tmp.py")]
    finally:
        fake.unlink()
    assert ("foundation", "front", 4) in found and ("foundation", "classic", 5) in found


def test_relative_imports_are_resolved():
    probe = REPO / "learned" / "_layer_probe_tmp.py"
    probe.write_text("from . import model\nfrom .data import load_frames\n")
    try:
        names = [n for _, n in imported_modules(probe)]
    finally:
        probe.unlink()
    assert names == ["learned.model", "learned.data.load_frames"]


def _module_files() -> dict:
    return {module_name(p): p for p in project_files()}


def file_graph() -> dict:
    """Module to the project modules it imports (a name resolved to its module: ``a.b.f`` -> ``a.b``).

    A package's ``__init__`` re-exporting its modules is not an arrow back: its edges to the modules inside it
    are left out, as are edges from a module to its own package (``import classic`` inside ``classic.x``
    reaches names the package lends, not a module that imports it back).
    """
    modules = _module_files()
    graph = {}
    for name, path in modules.items():
        targets = set()
        for _, imported in imported_modules(path):
            parts = imported.split(".")
            while parts and ".".join(parts) not in modules:
                parts = parts[:-1]
            target = ".".join(parts)
            if not target or target == name:
                continue
            if path.name == "__init__.py" and target.startswith(name + "."):
                continue
            if modules[target].name == "__init__.py" and name.startswith(target + "."):
                continue
            targets.add(target)
        graph[name] = targets
    return graph


def import_circles() -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan's algorithm, iterative)."""
    graph = file_graph()
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter[0]
                    counter[0] += 1
                    stack.append(child)
                    on.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                group = []
                while True:
                    member = stack.pop()
                    on.discard(member)
                    group.append(member)
                    if member == node:
                        break
                if len(group) > 1:
                    out.append(sorted(group))
    return out


def test_no_import_circles():
    """No two files import each other, directly or round a longer circle (a lazy import counts)."""
    assert import_circles() == []


def test_the_circle_check_finds_a_circle():
    a, b = REPO / "handeye" / "_circle_probe_a.py", REPO / "handeye" / "_circle_probe_b.py"
    a.write_text("def f():\n    from handeye._circle_probe_b import g\n")
    b.write_text("from handeye._circle_probe_a import f\n")
    try:
        circles = import_circles()
    finally:
        a.unlink()
        b.unlink()
    assert ["handeye._circle_probe_a", "handeye._circle_probe_b"] in circles


def reached(graph: dict, start: str) -> set:
    """Every project module ``start`` imports, directly or through others (lazy imports included)."""
    seen, todo = set(), [start]
    while todo:
        for target in graph.get(todo.pop(), ()):
            if target not in seen:
                seen.add(target)
                todo.append(target)
    return seen


def real_data_modules() -> list[str]:
    """The front's command modules that calibrate real data: all but :data:`RENDERING_COMMANDS`."""
    return sorted(
        name
        for name in file_graph()
        if name.startswith("handeye.commands.") and name not in RENDERING_COMMANDS and not name.endswith("__init__")
    )


def test_real_data_commands_never_reach_the_simulator():
    graph, files = file_graph(), _module_files()
    commands = real_data_modules()
    assert {"handeye.commands.calibrate", "handeye.commands.markerless", "handeye.commands.import_recording"} <= set(
        commands
    )
    bad = []
    for command in commands:
        chain = reached(graph, command) | {command}
        bad += [f"{command} reaches {m}" for m in sorted(chain) if m.split(".")[0] == "sim"]
        bad += [
            f"{command} reaches pyrender through {m}"
            for m in sorted(chain)
            if any(name.split(".")[0] == "pyrender" for _, name in imported_modules(files[m]))
        ]
    assert bad == [], "\n".join(bad)


def test_the_reach_check_sees_a_lazy_import_of_the_simulator():
    """The check itself: a command importing ``sim`` inside a function is flagged."""
    probe = REPO / "handeye" / "commands" / "_sim_probe_tmp.py"
    probe.write_text("def run(args):\n    from handeye.planning import plan\n    from sim.generate import generate\n")
    try:
        assert "handeye.commands._sim_probe_tmp" in real_data_modules()
        assert "sim.generate" in reached(file_graph(), "handeye.commands._sim_probe_tmp")
    finally:
        probe.unlink()


def test_the_robot_and_its_surface_load_without_the_renderer():
    """What ``handeye markerless`` does with a real recording's robot: a UR, its surface posed; no sim, no pyrender."""
    import subprocess
    import sys

    import pytest

    pytest.importorskip("pinocchio")
    pytest.importorskip("trimesh")
    code = (
        "import sys, numpy as np\n"
        "import handeye.commands.markerless, handeye.commands.import_recording, handeye.commands.plan\n"
        "from handeye.robot.model import load_robot\n"
        "from handeye.robot.surface import RobotSurface\n"
        "robot = load_robot('ur5')\n"
        "posed = RobotSurface(robot, spacing_m=0.03).posed(np.zeros((2, robot.nq)))\n"
        "assert len(posed.points_base) > 100, len(posed.points_base)\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'sim', 'pyrender', 'OpenGL'}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "[]"


def picture() -> str:
    counts = Counter((src, dst) for src, dst, *_ in arrows())
    lines = ["| from | to | imports | allowed |", "|---|---|---|---|"]
    for (src, dst), n in sorted(counts.items()):
        lines.append(f"| {src} | {dst} | {n} | {'no' if dst in FORBIDDEN[src] else 'yes'} |")
    return "\n".join(lines)


if __name__ == "__main__":
    print(picture())
    for circle in import_circles():
        print("circle:", " <-> ".join(circle))
