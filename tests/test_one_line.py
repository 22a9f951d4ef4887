"""Messages printed on one line: a long path is cut before the diagnosis is."""

from __future__ import annotations

from handeye.core.limits import LONG_WORD_CHARS, MAX_MESSAGE_CHARS, one_line


def test_a_long_path_is_cut_before_the_diagnosis():
    path = "/home/operator/recordings/cell-line-4/2026-12-05-morning-shift/calibration-check/mm32/recording_0.mcap"
    diagnosis = "depth looks like millimetres (median 812 read as 812 m, outside the plausible 0.05-20 m)"
    advice = "pass --depth-unit 0.001 (metres per unit)"
    message = f"handeye import bag: error: {path}, /camera/aligned_depth_to_color/image_raw: {diagnosis}; {advice}"
    assert len(message) > MAX_MESSAGE_CHARS
    line = one_line(message)
    assert len(line) <= MAX_MESSAGE_CHARS
    assert diagnosis in line and advice in line
    assert "recording_0.mcap" in line and path not in line  # the path's end kept, its middle cut


def test_short_messages_and_short_words_are_kept_whole():
    assert one_line("a  b\n\t c") == "a b c"
    words = " ".join(["x" * LONG_WORD_CHARS] * 4)
    assert one_line(words) == words  # under the limit: nothing cut
    long = " ".join(["word"] * 200)
    cut = one_line(long)
    assert len(cut) <= MAX_MESSAGE_CHARS and " ... " in cut  # no long word: the middle is cut
