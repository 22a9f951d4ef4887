"""The documentation's bash blocks (``docs/**/*.md``), every one executed as written or parsed.

Every ```bash block of the documentation is classified in :data:`BLOCKS` (a block added without a
classification fails ``test_every_docs_bash_block_is_classified``):

``a``
    Runs here as written, in seconds: :func:`test_docs_bash_block_runs` writes stand-ins of the files the
    block names into a fresh folder, runs the block there with ``bash -euo pipefail -c`` (the environment's
    ``bin`` first on ``PATH``, ``HOME`` a fresh folder beside it, so ``~/ws/src`` and ``~/.ros2/...`` are the
    stand-ins'), asserts exit 0 and that every file or folder the block names as an output (``-o``,
    ``--out``, ``--report``, ``--export-*``, ``--board-out``) exists.
``b``
    Runs as written for minutes to hours at full size (it renders a paper preset, trains with the ``cpu``
    preset, or is a benchmark): executed the same way, as written, in a smoke run
    (``HANDEYE_SMOKE_TEST=1``, :mod:`handeye.core.smoke`: every preset and benchmark size cut to seconds,
    the same commands, code paths and files).
Parsed, not run (``Block.parsed``, a block of kind a or b whose code other tests of CI's run already run, which
names them): each command parsed by its own argument parser and stopped there (:func:`_parse_check`), so that a
renamed command or option fails here as it would for a reader; chosen where running it repeated minutes of CI's
run (a render, a bag round trip, two labellings) that those tests make.
``c``
    A fresh virtual environment (``docs/getting-started.md``'s core install and its tests line, which the
    README prints too): the tests line is ``.ci/run``'s own, whose fresh install CI makes;
    :func:`test_the_install_blocks_agree_with_ci` checks that the core install and the demo's installs make
    the same environment with fewer extras (the demo itself runs as a block of kind b).
``p``
    A printed example, or the ``python -c`` step that writes its inputs (``docs/make_examples.py``'s
    ``EXAMPLE`` and ``SETUP``, on a page of its ``FILES``): ``tests/test_docs.py``'s
    ``test_printed_examples_print_what_is_shown`` runs the page's steps as written, in order, in one folder (in
    a smoke run where the page renders), compares what each prints with the page and checks the outputs it
    names exist; not run a second time here.

The commands are the documentation's, unchanged. Two kinds of line are left out of the executed text and
checked instead: ``pip install -e ".[extras]"`` or ``pip install torch==2.13.0 ...`` (every requirement of
those extras, or the one named, is installed in this environment).

The stand-ins are smaller than what the documentation describes, so that the commands run as written on
less data:

- ``images/``, ``robot.csv``, ``camera.json``: ten rendered eye-in-hand views of the 7x5 ChArUco board the
  images guide prints (:func:`classic.vision.synthetic.make_image_dataset`); ``detections.json`` detected
  from them; ``camera_info.yaml`` the same camera as ROS writes it;
- ``data/paper-sim`` (and ``data/paper-sim-noisy`` where a block reads that without rendering it): 16
  camera placements (2 regions of 7 train + 1 test), 4 configurations each, at the ``small`` preset's image
  sizes, labelled (the real preset has 108 placements of 50 configurations); ``runs/sim/reservoir``: a
  model trained on it with the ``tiny`` learned preset (seconds, not the ``cpu`` preset's minutes);
- ``data/my-cell`` and the bags ``data_0/ cal_0/ ...``: two placements rendered as a D435 reports depth
  and written as ROS 2 bags by :mod:`sim.bag_export` (``placement_0/``: the same as frame folders);
  ``my_arm.urdf``: the UR5's URDF, its meshes under ``~/ws/src``; ``guess.json``: the first placement's
  truth 2 cm and 2 degrees off;
- ``kuka_poses.csv``, ``my_eob_calib.samples``, ``recording/``: pose files and a bag written from
  synthetic problems (the builders of ``test_posefile_controllers``, ``test_cli_ros``, ``test_ros_bag``);
- ``benchmarks/``: the repository's scripts, linked, beside an empty ``results/`` (a benchmark's ``--out``
  lands in the test's folder); for ``calibrate_identity.py``, which adds a git worktree of an earlier
  revision, the folder is a git clone of the repository (its committed tree) instead;
- a running Ray cluster (``ray start --head``, stopped after the blocks) for the blocks that join one;
- for a block that reads what the block before it on its page wrote (``Block.after``: a guide's label step after
  its render, its render on a cluster completing the part an earlier step rendered), that block's output: the
  blocks run in order in one folder, in one test (``page#2+5+6``);
- for reproduce-paper's two blocks, which start with the same render, that render made once (a smoke run) and
  copied: the command, run again as written, keeps the complete placements (:func:`_render_shared`).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from handeye.core.ray_pool import LOCAL_WORKER_NICENESS
from handeye.core.smoke import ENV as SMOKE_ENV
from handeye.core.smoke import NOTICE as SMOKE_NOTICE
from tests.shared_renders import shared_build
from tests.test_docs import DOCS, README, ROOT, code_blocks, d435_cell_build, printed_steps
from tests.test_docs import command_lines as _commands
from tests.test_docs import written_paths as _outputs
from tests.tiers import hold_ray_lock

#: Left out of the executed text (checked instead): no network here.
DROPPED = ("pip install",)


@dataclasses.dataclass(frozen=True)
class Block:
    """One bash block: how its first command (after any ``pip install``) starts, its kind (a, b, c), why b
    and c take too long at full size, and for a and b the function that writes its stand-ins into the folder
    it runs in."""

    first: str
    kind: str
    why: str = ""
    prepare: Callable | None = None
    #: A block of kind a that takes long enough at full size to leave to CI's run (``--full``).
    slow: bool = False
    #: The index of the page's block whose output this one reads, as a reader runs the page: it runs right after
    #: that one, in its folder, in the same test (``page#3+4``), instead of from stand-ins that repeat that
    #: block's work (:func:`_after_previous`; or :func:`_ray_head`, the cluster it joins, and nothing else).
    after: int | None = None
    #: A block of kind b whose commands are parsed, not run (:func:`_parse_check`): the tests that run the same
    #: code in CI's run, which a smoke run of the block would repeat.
    parsed: str = ""


# --------------------------------------------------------------------------- stand-ins, built once a session


def _have(*modules: str) -> None:
    for m in modules:
        pytest.importorskip(m)


@pytest.fixture(scope="session")
def image_recording(tmp_path_factory):
    """Ten eye-in-hand views of the 7x5 ChArUco board (images/, robot.csv, board.json, camera.json) and
    detections.json detected from them with those intrinsics, as ``test_cli_vision`` renders them."""
    _have("cv2")
    from classic.vision.synthetic import make_image_dataset
    from handeye.cli import main

    folder = tmp_path_factory.mktemp("images")
    make_image_dataset(folder, 10, "eye_in_hand", rng=np.random.default_rng(7), noise_gray=2.0)
    argv = ["detect", str(folder / "images"), "--board", str(folder / "board.json")]
    assert main([*argv, "--intrinsics", str(folder / "camera.json"), "-o", str(folder / "detections.json")]) == 0
    return folder


@pytest.fixture(scope="session")
def paper_sim_standin(tmp_path_factory):
    """data/paper-sim at 16 placements of 4 configurations (the ``small`` preset's sizes), labelled, and a
    reservoir model trained on it with the ``tiny`` learned preset."""
    _have("pyrender", "pinocchio", "torch")
    from handeye.cli import main
    from handeye.core.engine_protocol import EngineOptions
    from handeye.labelling import label_dataset
    from sim.cameras import PRESETS
    from sim.generate import Recipe, generate

    # 16 placements: the block names cameras 14 and 15; 4 configurations: with 3, the registration refuses 7 of
    # the 16 placements and the block's 'handeye markerless data/paper-sim --write-labels' exits 1
    preset = dataclasses.replace(
        PRESETS["small"], name="paper-sim-standin", train_per_region=(7, 7), test_per_region=(1, 1), configurations=4
    )

    def build(root):
        generate(root / "data", Recipe(preset, seed=0), options=EngineOptions(workers=2, progress=False))
        label_dataset(root / "data", workers=2, progress=False)
        argv = ["learned", "run", "--data", str(root / "data"), "--preset", "tiny", "--strategies", "reservoir"]
        assert main([*argv, "--out", str(root / "runs"), "--quiet"]) == 0

    root, _ = shared_build(tmp_path_factory, "paper-sim-standin", build)  # one for the blocks on every worker
    return root / "data", root / "runs" / "reservoir"


@pytest.fixture(scope="session")
def d435_cell(tmp_path_factory):
    """Two placements as a D435 reports depth (the markerless guide's printed cell, ``docs/make_examples.py``'s
    ``render_cell``: colour and board views both 480x480, so that a frame folder's one intrinsics file serves
    both), written as ROS 2 bags, the board file, and the bags imported (``data/my-cell``): the same build
    ``test_printed_examples_print_what_is_shown`` runs the guide's steps on."""
    _have("pyrender", "pinocchio", "rosbags")
    from handeye.core.dataset import Dataset

    root, bags = shared_build(tmp_path_factory, "d435-cell", d435_cell_build)  # one for every worker
    return Dataset.open(root / "sim"), bags, root / "board.json", root / "my-cell"


@pytest.fixture(scope="session")
def mpl_config(tmp_path_factory):
    """One matplotlib cache for every block (each runs with a fresh HOME)."""
    return tmp_path_factory.mktemp("mpl")


def _my_arm(folder: Path, home: Path) -> None:
    """my_arm.urdf: the UR5's URDF, its package:// meshes under ~/ws/src (``--package-dir ~/ws/src``)."""
    _have("example_robot_data")
    import example_robot_data as erd

    loader = erd.robots_loader.UR5Loader()
    shutil.copy(loader.df_path, folder / "my_arm.urdf")
    share = Path(loader.model_path).resolve().parents[1]  # holds example-robot-data/, the package
    (home / "ws" / "src").mkdir(parents=True)
    (home / "ws" / "src" / "example-robot-data").symlink_to(share / "example-robot-data")


def _guess(folder: Path, ds) -> None:
    """guess.json: the first placement's true T_base_cam, 2 cm and 2 degrees off (a rough guess)."""
    import json

    from handeye.core.se3 import make_transform, so3_exp

    T = make_transform(so3_exp(np.radians([2.0, 0.0, 0.0])), [0.02, 0.0, 0.0]) @ ds.truth()[0]
    (folder / "guess.json").write_text(json.dumps({"T_base_cam": T.tolist()}))


def _copy(src: Path, dst: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    (shutil.copytree if src.is_dir() else shutil.copy)(src, dst)


# --------------------------------------------------------------------------- per-block stand-ins


def _board_of(block: str, kind: str | None, scratch: Path):
    """The board a block's ``handeye board`` line (of ``--kind kind``) prints, written in a scratch folder."""
    from classic.vision.board import BoardSpec
    from handeye.cli import main

    line = next(
        ln.split(" #")[0]
        for ln in block.splitlines()
        if ln.startswith("handeye board") and (kind is None or f"--kind {kind}" in ln)
    )
    argv = shlex.split(line)[1:]
    out = argv.index("-o") + 1
    scratch.mkdir()
    argv[out] = str(scratch / argv[out])
    assert main(argv) == 0
    return BoardSpec.load((scratch / argv[out]).with_suffix(".json"))


def _images_guide_1(folder, home, block, request):
    """camera.json, and images/ of the ArUco grid the block prints (four views)."""
    rec = request.getfixturevalue("image_recording")
    from classic.vision.camera import CameraIntrinsics
    from classic.vision.synthetic import make_image_dataset

    spec = _board_of(block, "aruco-grid", home.parent / "board")
    make_image_dataset(
        home.parent / "grid",
        4,
        spec=spec,
        intr=CameraIntrinsics.load(rec / "camera.json"),
        rng=np.random.default_rng(3),
    )
    _copy(home.parent / "grid" / "images", folder / "images")
    _copy(rec / "camera.json", folder / "camera.json")


def _markerless_guide_0(folder, home, block, request):
    data, model = request.getfixturevalue("paper_sim_standin")
    ds, _, _, my_cell = request.getfixturevalue("d435_cell")
    _copy(data, folder / "data" / "paper-sim")
    _copy(model, folder / "runs" / "sim" / "reservoir")
    _copy(my_cell, folder / "data" / "my-cell")
    _guess(folder, ds)
    _my_arm(folder, home)


def _markerless_guide_3(folder, home, block, request):
    """placement_0/, placement_1/: frame folders (data frames as test_import_recording writes them, PNG and
    NPY depth) with calibration/ (the board views and their joints), and board.json."""
    from PIL import Image

    from tests.test_import_recording import _write_folder

    ds, _, board, _ = request.getfixturevalue("d435_cell")
    for c in range(2):
        placement = folder / f"placement_{c}"
        _write_folder(ds, c, placement, npy=bool(c))
        rows = ds.select(c, "calibration")
        (placement / "calibration" / "rgb").mkdir(parents=True)
        names = [str(n) for n in ds.meta["joint_names"]]
        lines = ["frame," + ",".join(names)]
        for k, (rgb, q) in enumerate(zip(rows["rgb"], ds.joints(rows))):
            lines.append(f"b{k:03d}," + ",".join(repr(float(v)) for v in q))
            Image.fromarray(ds.rgb(c, rgb)).save(placement / "calibration" / "rgb" / f"b{k:03d}.png")
        (placement / "calibration" / "joints.csv").write_text("\n".join(lines) + "\n")
    _copy(board, folder / "board.json")


def _real_cell_3(folder, home, block, request):
    """recording/: a ROS 2 bag of tf and marker poses (test_ros_bag's)."""
    _have("rosbags")
    from tests.test_ros_bag import write_exact_bag

    write_exact_bag(folder / "recording", "sqlite3")


def _demo(folder, home, block, request):
    """Nothing: the demo renders its own cell (the simulator and torch installed)."""
    _have("pyrender", "pinocchio", "torch")


def _nothing(folder, home, block, request):
    """The block makes its own inputs."""
    if "handeye sim" in block:
        _have("pyrender", "pinocchio")


def _benchmarks(folder, home, block, request):
    """benchmarks/: the repository's scripts, linked, beside an empty results/ (the --out lands here)."""
    _nothing(folder, home, block, request)
    (folder / "benchmarks" / "results").mkdir(parents=True)
    for script in (ROOT / "benchmarks").glob("*.py"):
        (folder / "benchmarks" / script.name).symlink_to(script)


def _render_shared(then: Callable) -> Callable:
    """A block's stand-ins (``then``'s) and the render its first command makes (a smoke run), made once for every
    block that starts with the same command (reproduce-paper's two blocks render the same preset) and copied into
    its folder: the command, run again as written, finds every placement complete and keeps them (``kept N
    complete``), and the rest of the block reads them."""

    def prepare(folder, home, block, request):
        then(folder, home, block, request)
        first = _commands(block)[0].split("&&")[0].strip()
        out = shlex.split(first)[shlex.split(first).index("--out") + 1]

        def build(root):
            (root / "home").mkdir()
            env = _block_env(root / "home", request.getfixturevalue("mpl_config"), smoke=True)
            run = subprocess.run(["bash", "-c", first], cwd=root, env=env, capture_output=True, text=True, timeout=900)
            assert run.returncode == 0, f"{first!r} failed (exit {run.returncode}):\n{run.stderr[-3000:]}"

        key = "render-" + re.sub(r"[^A-Za-z0-9]+", "-", first)
        root, _ = shared_build(request.getfixturevalue("tmp_path_factory"), key, build)
        _copy(root / out, folder / out)

    return prepare


def _git_clone(dest: Path) -> None:
    """``dest`` a clone of the repository's committed tree (its objects shared, nothing written to its .git);
    skips where the repository is not a git checkout."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("the repository is not a git checkout")
    subprocess.run(["git", "clone", "-q", "--shared", str(ROOT), str(dest)], check=True)


def _clone(folder, home, block, request):
    """The folder a git clone of the repository (:func:`_git_clone`), holding the revision ``--against``
    names: the benchmark adds a worktree of it to the clone, not to the repository under test."""
    revision = re.search(r"--against (\S+)", block)[1]
    _git_clone(folder)
    if subprocess.run(["git", "-C", str(folder), "cat-file", "-e", f"{revision}^{{commit}}"]).returncode:
        pytest.skip(f"this checkout's history lacks {revision} (a shallow clone)")


def _paper_sim(folder, home, block, request):
    """data/paper-sim, or data/paper-sim-noisy when the block reads that: the labelled stand-in."""
    data, _ = request.getfixturevalue("paper_sim_standin")
    name = "paper-sim-noisy" if "data/paper-sim-noisy" in block else "paper-sim"
    _copy(data, folder / "data" / name)


def _after_previous(folder, home, block, request):
    """Nothing: the block reads what the block before it (``Block.after``) wrote into the same folder."""


def _ray_head(folder, home, block, request):
    """A running Ray cluster of 2 CPUs on this machine (``ray start --head``), stopped after the block."""
    _nothing(folder, home, block, request)
    _have("ray")  # the Ray lock is held by the test: the block says --engine ray
    ray = str(Path(sys.executable).parent / "ray")
    start = [ray, "start", "--head", "--num-cpus", "2", "--object-store-memory", str(256 * 2**20)]
    start += ["--include-dashboard", "false", "--disable-usage-stats"]
    request.addfinalizer(lambda: subprocess.run([ray, "stop", "--force"], capture_output=True, timeout=120))
    env = dict(os.environ, HOME=str(home))
    env.setdefault(*LOCAL_WORKER_NICENESS)  # the workers at the tests' priority, as RayEngine's own cluster's
    run = subprocess.run(start, capture_output=True, text=True, timeout=300, env=env)
    assert run.returncode == 0, f"ray start --head failed:\n{run.stdout[-1500:]}\n{run.stderr[-1500:]}"


_EYE_IN_HAND = "handeye calibrate handeye/data/example_eye_in_hand.csv"
_PAPER_PRESET = "renders the paper-sim preset (108 placements, 7,020 frames: 5 minutes on 2 cores) and labels it"
_CPU_TRAINING = "trains the four strategies with the cpu learned preset on paper-sim: 38 minutes on 2 cores"

#: Every bash block of docs/**/*.md, by file and index among the file's bash blocks.
BLOCKS: dict[tuple[str, int], Block] = {
    ("docs/benchmarks/classic.md", 0): Block(
        "python benchmarks/calibrate_identity.py",
        "b",
        "a benchmark: the workload 50 times in each of two trees, about a minute",
        _clone,
    ),
    ("docs/benchmarks/markerless.md", 0): Block(
        "python benchmarks/markerless_sensors.py",
        "b",
        "a benchmark: renders paper-real and paper-sim placements at three distances per sensor profile (40 min)",
        _benchmarks,
    ),
    ("docs/benchmarks/markerless.md", 1): Block(
        "python benchmarks/imported_bag.py",
        "b",
        "a benchmark: renders 12 placements at three distances, writes them as bags, imports and registers them",
        _benchmarks,
    ),
    ("docs/getting-started.md", 0): Block(
        "python3 -m venv .venv", "c", "creates a virtual environment and installs the project from the network"
    ),
    ("docs/getting-started.md", 1): Block("handeye calibrate handeye/data/example_eye_to_hand.csv", "p"),
    ("docs/getting-started.md", 2): Block(_EYE_IN_HAND, "p"),
    ("docs/getting-started.md", 3): Block(
        "handeye demo", "b", "installs torch and the simulator from the network, then the demo (minutes)", _demo
    ),
    ("docs/getting-started.md", 4): Block(
        "python3 -m venv .venv",
        "c",
        "creates a virtual environment, installs torch and the project with the test extras from the network, "
        "runs the whole test suite",
    ),
    ("docs/guides/beyond-one-machine.md", 0): Block(
        "handeye sim generate --preset small --out data/small --engine ray",
        "b",
        "starts a local Ray cluster and renders the small preset on it",
        _nothing,
        parsed="the small preset rendered on a local Ray cluster with a worker killed, its shards byte-identical to "
        "the process pool's: tests/test_ray_engine.py; a local cluster started by the engine and stopped with its "
        "driver: tests/test_processes.py; the command line's --engine ray: step 6's render (a third cluster here "
        "repeated two to three minutes of CI's run)",
    ),
    # step 6 completes the part step 3 rendered (run after it: step 3's 10 placements kept, the other 20 of the
    # smoke cut rendered on the cluster); step 4 labels the paper-sim stand-in, which only the slow tier builds, and
    # step 5 (torchrun, parsed) reads what it wrote; steps 1, 2 and 7 (rendering and labelling on Ray) are parsed:
    # tests/test_ray_engine.py renders and labels on a cluster
    ("docs/guides/beyond-one-machine.md", 1): Block(
        "handeye label data/small --engine ray",
        "a",
        "",
        _nothing,
        parsed="the small preset labelled on a local Ray cluster, its cameras.csv byte-identical to the process "
        "pool's: tests/test_ray_engine.py (a second cluster here repeated a minute of CI's run)",
    ),
    ("docs/guides/beyond-one-machine.md", 2): Block(
        "handeye sim generate --preset dense-sim --out data/dense-sim --cameras 0:10",
        "b",
        "renders 10 placements of dense-sim (650 frames: minutes on 2 cores)",
        _nothing,
    ),
    ("docs/guides/beyond-one-machine.md", 3): Block(
        "handeye label data/paper-sim --method tsai", "a", "", _paper_sim, slow=True
    ),
    ("docs/guides/beyond-one-machine.md", 4): Block(
        "torchrun --nproc-per-node 2 -m handeye learned run",
        "b",
        "trains the paper learned preset with torchrun: hours on CPUs",
        _after_previous,
        after=3,
        parsed="torchrun --nproc-per-node 2 -m handeye learned run on the tiny preset, its results against one "
        "process's and only rank 0 writing: tests/learned/test_distributed.py (the smoke run here repeated it, "
        "40-60 s of CI's run)",
    ),
    ("docs/guides/beyond-one-machine.md", 5): Block(
        "handeye sim generate --preset dense-sim --out data/dense-sim --engine ray --address auto",
        "b",
        "renders the 1,000 placements of dense-sim on a running Ray cluster: 3.2 core-hours",
        _ray_head,
        after=2,
    ),
    ("docs/guides/beyond-one-machine.md", 6): Block(
        "handeye label data/dense-sim --engine ray --address auto",
        "a",
        "",
        _nothing,
        parsed="labelling on Ray: tests/test_ray_engine.py; joining a running cluster with --address auto: step 6's "
        "render, run here on a cluster started for it",
    ),
    ("docs/guides/images.md", 0): Block("python -c", "p"),
    ("docs/guides/images.md", 1): Block("handeye board --squares 7x5", "p"),
    ("docs/guides/images.md", 2): Block("handeye intrinsics images/", "p"),
    ("docs/guides/images.md", 3): Block("handeye detect images/", "p"),
    ("docs/guides/images.md", 4): Block("handeye calibrate --detections", "p"),
    ("docs/guides/images.md", 5): Block("handeye board --kind checkerboard", "a", "", _images_guide_1),
    # steps 1 to 3: printed examples, run after simulate-label's steps on the data they wrote (a smoke run)
    ("docs/guides/learned.md", 0): Block("handeye learned run --data data/paper-sim --preset cpu", "p", _CPU_TRAINING),
    ("docs/guides/learned.md", 1): Block("handeye learned report runs/sim", "p"),
    ("docs/guides/learned.md", 2): Block("handeye compare data/paper-sim --model", "p"),
    ("docs/guides/learned.md", 3): Block(
        "handeye learned run",
        "b",
        "trains the keypoint family with the cpu learned preset: more than 7 minutes even on the small preset",
        _paper_sim,
        parsed="the keypoint family trained, reported and compared (hybrid and classic columns) from the command "
        "line on the tiny preset: tests/learned/test_end_to_end.py (the smoke run here repeated it, 35 s of CI's "
        "run)",
    ),
    ("docs/guides/markerless.md", 0): Block("handeye import bag data_0/ data_1/", "p"),
    # the D435 cell's render (29 s of the default run): the slow tier's, as the guide's printed steps that read it
    ("docs/guides/markerless.md", 1): Block(
        "handeye import folder placement_0/", "a", "", _markerless_guide_3, slow=True
    ),
    ("docs/guides/markerless.md", 2): Block("handeye label data/my-cell", "p"),
    ("docs/guides/markerless.md", 3): Block("handeye markerless data/my-cell --start", "p"),
    ("docs/guides/markerless.md", 4): Block("handeye compare data/my-cell", "p"),
    ("docs/guides/markerless.md", 5): Block(
        "handeye sim generate --preset small",
        "a",
        "",
        _nothing,
        parsed="a render with the D435 profile, its bags written and imported: the guide's printed example "
        "(tests/test_docs.py, docs/make_examples.py's render_cell), tests/test_import_recording.py",
    ),
    ("docs/guides/markerless.md", 6): Block(
        "handeye markerless data/paper-sim --camera 14 15",
        "a",
        "",
        _markerless_guide_0,
        slow=True,  # 62 s on a quiet 2-core machine (76 s with block 7's two commands)
    ),
    ("docs/guides/markerless.md", 7): Block(
        "handeye markerless data/paper-sim --write-labels",
        "a",
        "",
        _nothing,
        parsed="markerless labels written: the next block's first command (CI's run), "
        "tests/test_import_recording.py; the comparison with its hybrid column: the learned guide's printed "
        "example (tests/test_docs.py)",
    ),
    ("docs/guides/markerless.md", 8): Block(
        "handeye markerless data/paper-sim-noisy",
        "b",
        "trains twice with the cpu learned preset: 1 min 30 s each for the reservoir strategy even on 8 frames",
        _paper_sim,
    ),
    ("docs/guides/markerless.md", 9): Block(
        "handeye sim generate --preset paper-real",
        "b",
        "renders paper-real with the D435 profile (2,400 data frames: minutes), then two markerless passes over "
        "24 placements",
        _nothing,
        parsed="a D435 render labelled and registered with --sensor d435: the guide's printed example "
        "(tests/test_docs.py); --depth-model fixed: tests/classic/test_markerless_depth.py",
    ),
    ("docs/guides/poses.md", 0): Block("handeye calibrate handeye/data/example_eye_to_hand.csv", "p"),
    ("docs/guides/poses.md", 1): Block("handeye calibrate handeye/data/example_eye_to_hand.csv", "p"),
    ("docs/guides/poses.md", 2): Block("python -c", "p"),
    ("docs/guides/poses.md", 3): Block("handeye calibrate bumped.csv", "p"),
    ("docs/guides/poses.md", 4): Block("python -c", "p"),
    ("docs/guides/poses.md", 5): Block("handeye calibrate --robot-poses robot.txt", "p"),
    ("docs/guides/real-cell.md", 0): Block("python -c", "p"),
    ("docs/guides/real-cell.md", 1): Block("handeye calibrate kuka_poses.csv", "p"),
    ("docs/guides/real-cell.md", 2): Block("python -c", "p"),
    ("docs/guides/real-cell.md", 3): Block("handeye calibrate my_eob_calib.samples", "p"),
    ("docs/guides/real-cell.md", 4): Block("handeye calibrate my_eob_calib.samples", "p"),
    ("docs/guides/real-cell.md", 5): Block("python -c", "p"),
    ("docs/guides/real-cell.md", 6): Block("handeye detect images/", "p"),
    ("docs/guides/real-cell.md", 7): Block("handeye bag-poses recording/", "a", "", _real_cell_3),
    ("docs/guides/real-cell.md", 8): Block("handeye calibrate handeye/data/example_eye_to_hand.csv", "p"),
    ("docs/guides/real-cell.md", 9): Block("handeye plan", "p"),
    ("docs/guides/real-cell.md", 10): Block(
        "handeye sim stream --preset bumps",
        "b",
        "renders three minutes of a running cell (900 frames), then replays it through the watcher; the last line "
        "needs rclpy and live topics",
        _nothing,
        parsed="the smoke stream rendered and watched end to end, a bump detected and committed: "
        "tests/watch/test_cli_watch.py; a rollback from the command line: the same file; live ROS 2 topics: "
        "tests/watch/test_ros2.py",
    ),
    ("docs/guides/your-robot.md", 0): Block("handeye board --squares 7x5", "p"),
    ("docs/guides/your-robot.md", 1): Block("handeye plan --setup eye-in-hand", "p"),
    # steps 4 to 6: the shipped eye-in-hand example calibrated, then with a report, then exported
    **{("docs/guides/your-robot.md", k): Block(_EYE_IN_HAND, "p") for k in (2, 3, 4)},
    ("docs/guides/simulate-label.md", 0): Block(
        "handeye sim generate --preset paper-sim",
        "p",
        "renders the paper-sim preset (108 placements, 7,020 frames: 5 minutes on 2 cores)",
    ),
    ("docs/guides/simulate-label.md", 1): Block("handeye label data/paper-sim", "p"),
    ("docs/guides/simulate-label.md", 2): Block("handeye show data/paper-sim --camera 14", "p"),
    ("docs/reproduce-paper.md", 0): Block(
        "handeye sim generate --preset paper-sim",
        "b",
        _PAPER_PRESET + "; then the paper protocol's training, ablation and thresholds (10 to 30 minutes each)",
        _render_shared(_nothing),
    ),
    ("docs/reproduce-paper.md", 1): Block(
        "handeye sim generate --preset paper-sim",
        "b",
        _PAPER_PRESET + "; then paper-real and two protocol benchmarks",
        _render_shared(_benchmarks),
    ),
    ("docs/reproduce-paper.md", 2): Block(
        "handeye sim generate --preset small",
        "a",
        "",
        _nothing,
        parsed="the small preset rendered and labelled by Park and by Tsai with repeats: conftest's small_dataset, "
        "tests/test_paper_labels.py, tests/test_ray_engine.py (rendered on Ray)",
    ),
}


# --------------------------------------------------------------------------- the blocks as the docs print them


def docs_bash_blocks() -> dict[tuple[str, int], str]:
    """Every ```bash block of docs/**/*.md, by (file, index in the file)."""
    return {
        (p.relative_to(ROOT).as_posix(), i): b
        for p in sorted(DOCS.rglob("*.md"))
        for i, b in enumerate(code_blocks(p, "bash"))
    }


def executed_text(block: str) -> tuple[str, list[str]]:
    """The block without its ``pip install`` lines, and those lines."""
    kept, dropped = [], []
    for line in block.splitlines():
        (dropped if line.startswith(DROPPED) else kept).append(line)
    return "\n".join(kept) + "\n", [ln.split(" #")[0].strip() for ln in dropped]


def test_every_docs_bash_block_is_classified():
    """Each bash block of the documentation has a row in BLOCKS (a new one fails here until it is run or
    said why not), each row a block, each row's first command the block's."""
    blocks = docs_bash_blocks()
    assert set(blocks) - set(BLOCKS) == set(), "bash blocks without a classification in BLOCKS"
    assert set(BLOCKS) - set(blocks) == set(), "rows of BLOCKS without a bash block (moved or removed?)"
    for key, block in BLOCKS.items():
        assert block.kind in "abcp" and len(block.kind) == 1, key
        first = next(c for c in _commands(blocks[key]) if not c.startswith("pip install"))
        assert first.startswith(block.first), f"{key}: its first command is {first!r}"
        assert (block.kind in "ab") == (block.prepare is not None), key
        assert block.kind in "ap" or block.why, f"{key}: say why it does not run at full size"
    printed = {k for k, b in BLOCKS.items() if b.kind == "p"}
    assert printed == printed_steps() & set(blocks), "kind p is for the blocks make_examples runs, and only those"


def test_the_documentation_states_the_count():
    """The page on how the documentation is tested gives the figures of BLOCKS: how many run, and a row per
    block that does not, with its kind."""
    kinds = [b.kind for b in BLOCKS.values()]
    text = (DOCS / "benchmarks" / "index.md").read_text()
    stated = (
        f"all {len(kinds)} bash blocks run as written: {kinds.count('a')} at full size, {kinds.count('b')} in a "
        f"smoke run, {kinds.count('p')} as printed examples (their output compared) and {kinds.count('c')} in a "
        "fresh virtual environment"
    )
    assert stated.lower() in " ".join(text.split()).lower(), f"docs/benchmarks/index.md should say '{stated}'"
    rows = re.findall(r"^\| `([^`]+)` \| ([abcp]) \|", text, flags=re.M)
    expected = [(f"{path.removeprefix('docs/')}#{index}", b.kind) for (path, index), b in BLOCKS.items() if b.why]
    assert sorted(rows) == sorted(expected), "docs/benchmarks/index.md: the table of blocks not run"


def _extras_installed(line: str) -> None:
    """Every requirement of the extras a ``pip install -e ".[...]"`` line names is installed here, or the
    requirements a ``pip install NAME==VERSION [--index-url URL]`` line names (a local build such as
    ``+cpu`` meets ``==VERSION``, as pip takes it)."""
    import tomllib

    from packaging.requirements import Requirement

    what, _ = _install_step(line)
    extras = re.search(r'-e "\.\[([^\]]+)\]"', line)
    named = [w for w in what.split()[2:] if not w.startswith("-")]
    assert extras or (named and "-e" not in what.split()), f"{line!r}: not an install this test can check"
    defined = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    specs = [spec for extra in extras[1].split(",") for spec in defined[extra.strip()]] if extras else named
    for spec in specs:
        req = Requirement(spec)
        if req.marker is not None and not req.marker.evaluate():
            continue
        try:
            version = importlib.metadata.version(req.name)
        except importlib.metadata.PackageNotFoundError:
            pytest.fail(f"{line!r}: {req.name} is not installed")
        assert req.specifier.contains(version, prereleases=True), f"{req.name} {version} not {req.specifier}"


def _marks(keys: list[tuple[str, int]]) -> list:
    """A smoke run (b), or a block marked slow, is the slow tier's (a block on Ray holds the Ray lock)."""
    slow = any((BLOCKS[k].kind == "b" and not BLOCKS[k].parsed) or BLOCKS[k].slow for k in keys)
    return [pytest.mark.slow] if slow else []


def runs() -> list[list[tuple[str, int]]]:
    """The blocks of kinds a and b as the tests run them: each alone, or after the block it reads
    (``Block.after``), in order."""
    order = [key for key, b in BLOCKS.items() if b.kind in "ab"]
    out = {key: [key] for key in order if BLOCKS[key].after is None}
    for key in order:  # a block follows one before it on its page
        if BLOCKS[key].after is not None:
            head = next(run for run in out.values() if run[-1] == (key[0], BLOCKS[key].after))
            head.append(key)
    return list(out.values())


def _executed() -> list:
    blocks = docs_bash_blocks()
    return [
        pytest.param(
            keys,
            [blocks[k] for k in keys],
            id=f"{keys[0][0].removeprefix('docs/')}#{'+'.join(str(k[1]) for k in keys)}",
            marks=_marks(keys),
        )
        for keys in runs()
        if all(k in blocks for k in keys)
    ]


def test_a_block_run_after_another_follows_it_on_its_page():
    """A block that reads another's output (``Block.after``) comes after it on the same page, and is run right
    after it: every block of kinds a and b runs once."""
    for key, b in BLOCKS.items():
        assert b.after is None or (b.after < key[1] and (key[0], b.after) in BLOCKS), key
        assert b.after is None or b.prepare in (_after_previous, _ray_head), key
    ran = [k for run in runs() for k in run]
    assert sorted(ran) == sorted(k for k, b in BLOCKS.items() if b.kind in "ab")
    assert [("docs/guides/beyond-one-machine.md", 2), ("docs/guides/beyond-one-machine.md", 5)] in runs()


@pytest.mark.parametrize("keys,blocks", _executed())
def test_docs_bash_block_runs(keys, blocks, tmp_path, request, mpl_config):
    """The block, as written, from a folder of stand-ins (a b block in a smoke run): exit 0 and every output
    it names written; a block that reads another's output (``Block.after``) right after that one, in its
    folder."""
    folder, home = tmp_path / "cwd", tmp_path / "home"
    folder.mkdir()
    home.mkdir()
    ran = [b for k, b in zip(keys, blocks) if not BLOCKS[k].parsed]
    if any("--engine ray" in b for b in ran):  # a local cluster, or the one the setup starts: one at a time
        hold_ray_lock(request)
    for key, block in zip(keys, blocks):
        _run_block(key, block, folder, home, request, mpl_config)


def _run_block(key, block, folder: Path, home: Path, request, mpl_config) -> None:
    """One block of :func:`test_docs_bash_block_runs`: its stand-ins, then the block as written, and its checks;
    a block whose code other tests run (``Block.parsed``): its commands parsed (:func:`_parse_check`)."""
    if BLOCKS[key].parsed:
        _parse_check(block, folder, _block_env(home, mpl_config, smoke=True))
        return
    BLOCKS[key].prepare(folder, home, block, request)
    text, dropped = executed_text(block)
    env = _block_env(home, mpl_config, smoke=BLOCKS[key].kind == "b")
    run = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", text], cwd=folder, env=env, capture_output=True, text=True, timeout=900
    )
    assert run.returncode == 0, f"{key} failed (exit {run.returncode}):\n{run.stdout[-2000:]}\n{run.stderr[-3000:]}"
    if BLOCKS[key].kind == "b":  # the run said it is a smoke run (the CLI on stderr, a benchmark in its header)
        assert SMOKE_NOTICE in run.stdout + run.stderr, f"{key}: the smoke run did not say so"
    for out in _outputs(text):
        target = home / out[2:] if out.startswith("~/") else folder / out
        assert target.exists(), f"{key}: {out} was not written"
    for line in dropped:
        _extras_installed(line)


#: Each command's argument parser run on its words, then stopped (:class:`_Parsed`): ``handeye`` through
#: :func:`handeye.cli.main`, ``python benchmarks/X.py`` through the script run as ``__main__``.
_PARSE_CHECK = r"""
import argparse, json, runpy, sys


class _Parsed(BaseException):
    pass


_parse_args = argparse.ArgumentParser.parse_args


def _parse_then_stop(self, args=None, namespace=None):
    _parse_args(self, args, namespace)
    raise _Parsed


argparse.ArgumentParser.parse_args = _parse_then_stop
for words in json.loads(sys.argv[1]):
    if words[0] == "torchrun":  # torchrun's own options, then the module's: -m handeye ...
        from torch.distributed.run import get_args_parser

        try:
            get_args_parser().parse_args(words[1:])
        except _Parsed:
            words = words[words.index("-m") + 1 :]
    try:
        if words[0] == "handeye":
            from handeye.cli import main

            main(words[1:])
        else:
            sys.argv = words[1:]
            runpy.run_path(words[1], run_name="__main__")
    except _Parsed:
        continue
    sys.exit(f"{' '.join(words)}: went past its argument parser (not parsed with argparse's parse_args)")
"""


def _parsable(words: list[str]) -> bool:
    """``handeye ...``, ``torchrun ... -m handeye ...`` or ``python benchmarks/X.py ...``."""
    if words[0] == "torchrun":
        return "-m" in words and words[words.index("-m") + 1 :][:1] == ["handeye"]
    return words[0] == "handeye" or (words[0] == "python" and words[1].startswith("benchmarks/"))


def _parse_check(block: str, folder: Path, env: dict) -> None:
    """Every command of ``block`` (``handeye ...``, ``torchrun ... -m handeye ...`` or ``python benchmarks/X.py
    ...``, split at ``&&``) parsed by
    its own argument parser and stopped there: a renamed subcommand or option, a value outside its choices, fails;
    nothing runs (so a value the command checks only when it runs, a preset's name, is not checked). The
    benchmarks' scripts are the repository's (``benchmarks/`` linked into ``folder``); a ``pip install`` line is
    checked as a run block's is (:func:`_extras_installed`)."""
    lines = _commands(block)
    for line in lines:
        if line.startswith("pip install"):
            _extras_installed(line)
    words = [shlex.split(part) for line in lines if not line.startswith("pip install") for part in line.split("&&")]
    assert all(_parsable(w) for w in words), words
    if not (folder / "benchmarks").exists():
        (folder / "benchmarks").symlink_to(ROOT / "benchmarks")
    run = subprocess.run(
        [sys.executable, "-c", _PARSE_CHECK, json.dumps(words)],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, f"a command did not parse (exit {run.returncode}):\n{run.stderr[-3000:]}"


def _block_env(home: Path, mpl_config: Path, smoke: bool) -> dict:
    """The environment a block runs in: this interpreter's ``bin`` first on ``PATH``, ``HOME`` the fresh
    ``home``, one matplotlib cache, and a smoke run (:data:`SMOKE_ENV`) only where ``smoke``."""
    path = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
    env = dict(
        os.environ,
        PYOPENGL_PLATFORM="egl",
        PYTHONPATH=str(ROOT),
        PATH=path,
        HOME=str(home),
        MPLCONFIGDIR=str(mpl_config),
    )
    env.pop(SMOKE_ENV, None)
    if smoke:
        env[SMOKE_ENV] = "1"
    return env


def _install_step(step: str) -> tuple[str, frozenset]:
    """A ``pip install`` step as (what it installs, its extras): ``-q`` and ``--index-url URL`` dropped (the
    CPU build's index serves the same version), ``-e ".[a,b]"`` as ``-e .`` and ``{a, b}``."""
    words = re.sub(r"--index-url \S+", "", step).split()
    words = [w for w in words if w != "-q"]
    extras: frozenset = frozenset()
    for i, w in enumerate(words):
        m = re.fullmatch(r'"?\.\[([a-z,]+)\]"?', w)
        if m:
            words[i], extras = ".", frozenset(m.group(1).split(","))
    return " ".join(words), extras


def _steps(block: str) -> list[str]:
    """The block's steps: its commands split at ``&&``."""
    return [step.strip() for command in _commands(block) for step in command.split("&&")]


def test_the_install_blocks_agree_with_ci():
    """The getting-started page's installs (the core, the demo's, the tests line): the README prints the same
    steps; the tests line is ``.ci/run``'s own, so CI's fresh install is that block's; every install the core
    and the demo make is one CI makes with at least those extras (torch pinned alike), every other step one
    CI runs, but the demo itself (run as a block of kind b). A second fresh environment would only repeat CI's
    install and downloads."""
    blocks = docs_bash_blocks()
    core, demo, tests = (blocks[("docs/getting-started.md", k)] for k in (0, 3, 4))
    readme = [b for b in code_blocks(README, "bash") if "pip install" in b]
    assert [_steps(b) for b in readme] == [_steps(core), _steps(demo), _steps(tests)], (
        "the README and getting-started print different installs"
    )
    assert (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1] == _commands(tests)[0], (
        ".ci/run runs another command"
    )
    ci = _steps(tests)
    ci_installs = [_install_step(s) for s in ci if s.startswith("pip install")]
    for step in _steps(core) + _steps(demo):
        if step.startswith("pip install"):
            what, extras = _install_step(step)
            assert any(what == w and extras <= e for w, e in ci_installs), f"CI does not install what {step!r} does"
        else:
            assert step in ci or step == "handeye demo", f"{step!r} is not a step of CI's"
    assert _steps(demo)[-1] == "handeye demo", f"the demo block ends with {_steps(demo)[-1]!r}"


@pytest.mark.parametrize(
    "block",
    [
        "handeye sim generate --preset small --out data/small --no-such-option\n",
        "handeye sim generate --preset small --engine no-such-engine --out data/small\n",
        "handeye label data/small && handeye no-such-command data/small\n",
        "python benchmarks/imported_bag.py --no-such-option\n",
    ],
)
def test_the_parse_check_fails_on_what_no_longer_parses(block, tmp_path, mpl_config):
    """A parsed block (``Block.parsed``) fails on an option, a choice or a command its parser does not know, in
    either kind of command: the check can fail."""
    (tmp_path / "home").mkdir()
    env = _block_env(tmp_path / "home", mpl_config, smoke=True)
    _parse_check("handeye sim generate --preset small --out data/small\n", tmp_path, env)  # parses
    with pytest.raises(AssertionError, match="did not parse"):
        _parse_check(block, tmp_path, env)
