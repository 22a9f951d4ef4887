"""The benchmarks' report header: the command it repeats is one a shell takes back as it was given."""

from __future__ import annotations

import shlex

from benchmarks._report import Report


def test_the_header_repeats_the_command_quoted(capsys):
    argv = ["--bands", "1.2 m", "--sensors", "d435-sgbm", "d435"]
    rep = Report("t", "benchmarks/imported_bag.py", argv, "numpy")
    command = next(line for line in rep.lines if line.startswith("command: "))
    assert shlex.split(command.removeprefix("command: ")) == ["python", "benchmarks/imported_bag.py", *argv]


def test_a_report_is_written_only_where_out_names_a_file(tmp_path, capsys):
    page = tmp_path / "kept.md"
    Report("t", "benchmarks/x.py", ["--trials", "500"], "numpy").write(page)
    kept = page.read_text()
    assert "command: python benchmarks/x.py --trials 500" in kept
    assert Report("t", "benchmarks/x.py", ["--trials", "1"], "numpy").write(None) == 0
    assert page.read_text() == kept and sorted(tmp_path.iterdir()) == [page]


def test_a_second_run_with_other_arguments_leaves_the_kept_page(monkeypatch, tmp_path, capsys):
    """real_recordings.py once defaulted --out to benchmarks/results/real_recordings.md: a run cut short (a smoke
    run, --max-poses) replaced the page the documentation quotes. Now a run without --out prints only."""
    from benchmarks.real_recordings import main
    from handeye.core.smoke import ENV

    monkeypatch.setenv(ENV, "1")
    monkeypatch.chdir(tmp_path)
    page = tmp_path / "benchmarks" / "results" / "real_recordings.md"
    page.parent.mkdir(parents=True)
    assert main(["--out", str(page)]) == 0
    kept = page.read_text()
    assert main(["--max-poses", "8", "--splits", "2", "--halves", "2"]) == 0
    assert "command: python benchmarks/real_recordings.py --max-poses 8" in capsys.readouterr().out
    assert page.read_text() == kept
    assert [p.name for p in page.parent.iterdir()] == [page.name]


def test_no_benchmark_defaults_its_report_to_a_kept_page():
    """Every benchmark's output option defaults to None (printed only): no ``default=`` into benchmarks/results."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "benchmarks"
    found = []
    for path in sorted(root.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument":
                for kw in node.keywords:
                    if kw.arg == "default" and "benchmarks/results" in ast.unparse(kw.value):
                        found.append(f"{path.name}: {ast.unparse(node)}")
    assert len(list(root.glob("*.py"))) > 10 and not found, found
