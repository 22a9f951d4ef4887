"""benchmarks/code_measures.py counts what it says on a tree with known contents."""

from __future__ import annotations

import os
import textwrap

from benchmarks.code_measures import measure


def _write(root, rel, text):
    path = root / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text))


def test_each_measure_counts_a_planted_case(tmp_path, monkeypatch):
    monkeypatch.setattr("shutil.which", lambda name: None)  # the duplicates tool: the workplace's, not CI's
    body = "\n".join(f"    x{i} = {i}" for i in range(101))
    _write(tmp_path, "handeye/__init__.py", "")
    _write(tmp_path, "handeye/a.py", f"def long_one():\n{body}\n\n\ndef _hidden():\n    return 1\n")
    _write(
        tmp_path,
        "classic/b.py",
        """
        from handeye.a import _hidden, long_one


        class K:
            def many(self, a, b, c, d, e, f, g, *args, h=1, **kw):
                return a

            def few(self, a, b, c, d, e, f, g):
                return a


        def branchy(x):
            for i in range(x):
                if i == 1 or i == 2:
                    x += 1
                elif i == 3 and x:
                    x -= 1
                elif i == 4:
                    x *= 2
                elif i == 5:
                    x //= 2
                while x > 100:
                    x -= 7
                if x == 9 or x == 11:
                    x = 0
            return x
        """,
    )
    _write(tmp_path, "classic/__init__.py", "from classic.b import branchy\n")
    _write(
        tmp_path,
        "tests/test_x.py",
        """
        import numpy as np
        import pytest
        from tests.tolerances import FLOAT

        def test_a():
            np.testing.assert_allclose(1, 1, atol=1e-9, rtol=FLOAT)
            assert 1 == pytest.approx(1, abs=-0.5)
            np.isclose(1, 1, atol=FLOAT, equal_nan=True)
        """,
    )
    _write(tmp_path, "tests/tolerances.py", "FLOAT = 1e-12\nnp_allclose_kwargs = dict(atol=1e-3)\n")
    m = measure(tmp_path)
    assert m["functions over 100 lines"] == 1
    assert m["functions over 60 lines"] == 1  # long_one's 102; the rest are short
    assert m["lines in handeye/"] == 104  # def + 101 body lines + _hidden's two; blank lines do not count
    packages = ("handeye", "classic", "sim", "learned")
    assert m["lines of Python in the packages"] == sum(m[f"lines in {p}/"] for p in packages)
    assert m["pairs of repeated blocks (6+ lines)"] == "not measured"
    assert m["functions with 8+ parameters"] == 1  # many: a..g, *args, h, **kw = 10; few: 7
    assert m["private imports across modules"] == 1  # _hidden; the package lending branchy does not count
    assert m["private"] == ["classic.b imports handeye.a._hidden"]
    assert m["literal tolerances in tests"] == 2  # atol=1e-9 and abs=-0.5; names and tolerances.py do not count
    assert m["complexity over 10 (radon)"] == 1  # branchy: 1 + for + 4 ifs + while + 1 if + 4 boolean operators
    assert m["longest"][0][1] == "handeye.a.long_one"


def test_repeated_pairs_reads_the_duplicates_tools_count(tmp_path, monkeypatch):
    from benchmarks.code_measures import repeated_pairs

    tool = tmp_path / "bin" / "duplicates"
    _write(tmp_path, "bin/duplicates", "#!/bin/sh\necho '7 pairs of places (2 files read), each sharing ...'\n")
    tool.chmod(0o755)
    _write(tmp_path, "handeye/a.py", "x = 1\n")
    monkeypatch.setenv("PATH", f"{tool.parent}:{os.environ['PATH']}")
    assert repeated_pairs(tmp_path) == 7
    _write(tmp_path, "bin/duplicates", "#!/bin/sh\necho 'no duplicates (2 files read)'\n")
    assert repeated_pairs(tmp_path) == 0
