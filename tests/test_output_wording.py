"""``handeye calibrate`` says once, in its own words, what each printed figure is, and names the glossary page
that defines every one of them."""

from __future__ import annotations

import re
from pathlib import Path

from handeye.cli import main
from handeye.commands import GLOSSARY, GLOSSARY_WHERE

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "handeye" / "data" / "example_eye_to_hand.csv"
#: The figures the pose path prints, each a bold term of the glossary.
TERMS = ("1-sigma", "Residual RMS per pose", "Noise model", "Max rotation", "Axis diversity", "Angle mismatch")
#: The lines the image path (``calibrate --detections``) adds, each a bold term of the glossary.
IMAGE_TERMS = ("Pixel RMS", "Robot pose error", "Intrinsics")


def glossary_terms(text: str) -> set[str]:
    """The bold terms a glossary page defines (``**Term.**`` or ``**Term, term.**`` at a paragraph's start)."""
    found = set()
    for bold in re.findall(r"^\*\*([^*]+)\.\*\*", text, flags=re.M):
        found.update(t.strip() for t in bold.split(","))
    return found


def test_calibrate_explains_each_figure_once(capsys):
    assert main(["calibrate", str(EXAMPLE), "--setup", "eye-to-hand"]) == 0
    out = capsys.readouterr().out
    assert out.count("1-sigma:") == 2 and out.count("(predicted RMS error of the rotation angle") == 1
    assert out.count("axis diversity:") == 1 and out.count("angle mismatch:") == 1
    assert out.rstrip().splitlines()[-1] == f"  terms: {GLOSSARY_WHERE}"


def test_the_glossary_defines_every_printed_term():
    page = ROOT / GLOSSARY
    assert set(TERMS) | set(IMAGE_TERMS) <= glossary_terms(page.read_text(encoding="utf-8"))


def test_the_term_check_finds_a_missing_term():
    assert glossary_terms("**1-sigma.** the RMS\n\n**Axis diversity, spread.** s2/s1\n") == {
        "1-sigma",
        "Axis diversity",
        "spread",
    }
    assert not set(TERMS) <= glossary_terms("**1-sigma.** the RMS\n")
