"""The watcher's tests end the threads they start: a test that leaves a :class:`handeye.watch.learner.BackgroundLearner`
worker running fails (its idle thread would outlive the test, and every later one in the process)."""

from __future__ import annotations

import threading

import pytest

#: The name :class:`handeye.watch.learner.BackgroundLearner` gives its worker thread.
LEARNER_THREAD = "handeye-learner"


def learner_threads() -> set[threading.Thread]:
    """The live BackgroundLearner worker threads of this process."""
    return {t for t in threading.enumerate() if t.name == LEARNER_THREAD and t.is_alive()}


@pytest.fixture(autouse=True)
def no_learner_left_running():
    """Fails a test that leaves a learner's worker thread running (close it: ``close()`` or a ``with`` block)."""
    before = learner_threads()
    yield
    left = learner_threads() - before
    if left:
        pytest.fail(
            f"{len(left)} BackgroundLearner worker thread(s) left running by this test: close the learner "
            "(BackgroundLearner.close, or use it in a with block)",
            pytrace=False,
        )
