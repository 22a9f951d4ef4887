"""``import classic`` needs numpy and scipy only: it works where torch, pinocchio and pyrender cannot load."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

from tests.tolerances import SIGMA_BOUND

REPO = Path(__file__).resolve().parents[1]
HEAVY = ["torch", "pinocchio", "pin", "pyrender", "trimesh"]

SCRIPT = textwrap.dedent(
    """
    import json, sys

    BLOCKED = {blocked!r}

    class Block:
        # a meta-path finder that refuses the heavy packages, as on a machine without them
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in BLOCKED:
                raise ImportError(f"blocked for the test: {{name}}")
            return None

    sys.meta_path.insert(0, Block())
    for name in list(sys.modules):
        if name.split(".")[0] in BLOCKED:
            del sys.modules[name]

    # the blocker works
    for name in BLOCKED:
        try:
            __import__(name)
        except ImportError:
            pass
        else:
            raise SystemExit(f"blocker failed for {{name}}")

    import numpy as np
    import classic
    after_import = sorted(m for m in ("torch", "pinocchio", "pin", "pyrender", "trimesh", "cv2") if m in sys.modules)

    from handeye.core.synthetic import make_problem
    out = {{"after_import": after_import, "errors": []}}
    for setup in ("eye_to_hand", "eye_in_hand"):
        p = make_problem(12, setup, np.random.default_rng(0), camera_noise=(0.1, 0.5))
        res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup)
        from handeye.core.metrics import pose_error
        rot, trans = pose_error(res.X, p.X_true)
        out["errors"].append([float(rot), float(trans), res.sigma["X_rotation_deg"], res.sigma["X_translation_mm"]])
    heavy = ("torch", "pinocchio", "pin", "pyrender", "trimesh", "cv2")
    out["after_calibrate"] = sorted(m for m in heavy if m in sys.modules)
    print(json.dumps(out))
    """
)


def _run(blocked):
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT.format(blocked=sorted(blocked))],
        check=False,
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_classic_imports_and_calibrates_without_heavy_dependencies():
    out = _run(HEAVY)
    assert out["after_import"] == []
    assert out["after_calibrate"] == []
    for rot_deg, trans_mm, sigma_rot, sigma_trans in out["errors"]:
        # a real calibration, not just an import: within a few predicted sigma of the truth
        assert rot_deg <= SIGMA_BOUND * sigma_rot
        assert trans_mm <= SIGMA_BOUND * sigma_trans


def test_classic_does_not_import_opencv():
    # cv2 is installed here (a test dependency) but classic must not pull it in
    out = _run([])
    assert "cv2" not in out["after_import"]
    assert "cv2" not in out["after_calibrate"]


def test_learned_loads_without_sim_or_classic():
    """DESIGN: learned reads datasets and labels; loading it pulls in neither the simulator nor the solvers
    (the static rule is in tests/test_layers.py)."""
    code = (
        "import sys, learned.experiment, learned.calibrator, learned.report; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('sim', 'classic', 'pinocchio', 'pyrender')))"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
