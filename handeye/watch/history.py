"""Every calibration version a running cell used: an append-only JSON-lines file, and the current one as JSON.

Each version is one line (``version``, ``time`` (Unix seconds), ``stream_t`` (seconds into the stream),
``reason``, ``T_base_cam`` (4x4, metres), ``sigma`` (6,: rotation rad and position m, camera frame, or null),
``frames`` (the stream's frame indices it came from), ``replaces`` (the version it replaced), ``extra``), written
with one ``write`` and ``fsync``-ed before :meth:`History.append` returns: a version is committed when its line and
newline are on disk. A ``kill -9`` during the write leaves at most a line without its newline at the end;
reading ignores it with a warning, and the next append truncates it first (it was never committed). A
complete line that does not parse is corruption, not a torn write, and raises. Nothing is rewritten:
:meth:`History.rollback` appends a new version equal to an older one.

A :class:`handeye.watch.CellWatcher` commit's ``sigma`` is the registration's per axis (the square roots of its
covariance's diagonal, :attr:`classic.markerless.MarkerlessResult.covariance`): the whole predicted error, the
noise with the repeated error, the model's sampling, the frames' disagreement, the depth-to-colour registration
and the static parts' pull (each bounded term spread evenly over the three axes). Its three rotations and three
positions in quadrature are ``extra["sigma_summary"]`` (``rotation_deg``, ``translation_mm``:
:attr:`classic.markerless.MarkerlessResult.sigma`), the one the event line prints.

The current calibration is a JSON file replaced atomically (:func:`handeye.core.safe_write.write_text_atomic`)
after each append; :meth:`History.publish` rewrites it from the history (after a crash between the two). Beside
the version's fields it has ``stale_since``: null while the watcher holds the version valid, else the stream time
(seconds) from which the watcher knows it is off (:meth:`History.mark_stale`, on a ``moved``), until the next
version replaces it: a consumer must not use a calibration whose ``stale_since`` is not null. A watcher restarted
on the history reads it (:meth:`History.recorded_stale`) and does not call that version valid before it was
re-registered; without ``current_path`` an earlier run's ``moved`` is recorded nowhere it could read.
Appenders take the history's ``flock`` (advisory, released when the process ends however it ends): two
processes appending at once number their versions one after the other. A history path that is not a regular
file (a device, a FIFO, a link to one) is refused, never read from or appended to.
"""

from __future__ import annotations

import fcntl
import json
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.safe_write import check_output_path, write_text_atomic
from handeye.core.validation import check_transforms

__all__ = ["Version", "History", "TornLineWarning"]


class TornLineWarning(UserWarning):
    """The history's last line was cut by a crash during its write: that version was never committed."""


@dataclass(frozen=True)
class Version:
    """One calibration version (module docstring for the fields)."""

    version: int
    time: float
    reason: str
    T_base_cam: np.ndarray
    sigma: np.ndarray | None = None
    frames: tuple = ()
    replaces: int | None = None
    stream_t: float | None = None
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "version": self.version,
            "time": self.time,
            "stream_t": self.stream_t,
            "reason": self.reason,
            "T_base_cam": np.asarray(self.T_base_cam, dtype=float).tolist(),
            "sigma": None if self.sigma is None else np.asarray(self.sigma, dtype=float).tolist(),
            "frames": [int(f) for f in self.frames],
            "replaces": self.replaces,
            "extra": self.extra,
        }

    @classmethod
    def from_dict(cls, d: dict, where: str) -> "Version":
        try:
            T = check_transforms(np.array(d["T_base_cam"], dtype=float), f"{where}: T_base_cam")[0]
            sigma = None if d.get("sigma") is None else np.array(d["sigma"], dtype=float).reshape(6)
            return cls(
                int(d["version"]),
                float(d["time"]),
                str(d["reason"]),
                T,
                sigma,
                tuple(int(f) for f in d.get("frames", ())),
                None if d.get("replaces") is None else int(d["replaces"]),
                None if d.get("stream_t") is None else float(d["stream_t"]),
                dict(d.get("extra") or {}),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise HandEyeInputError(f"{where}: not a calibration version ({exc})") from None


class History:
    """The append-only history at ``path`` (created on the first append), and the current calibration's JSON.

    Parameters
    ----------
    path : str or Path
        The JSON-lines file.
    current_path : str or Path, optional
        Where the current calibration is published (none when omitted).
    """

    def __init__(self, path: str | Path, current_path: str | Path | None = None):
        self.path = Path(path)
        self.current_path = None if current_path is None else Path(current_path)

    def _check_regular(self) -> None:
        """Refuse a path that is there and not a regular file: a FIFO would block the read, a device feed it."""
        if self.path.exists() and not self.path.is_file():
            raise HandEyeInputError(f"{self.path}: not a regular file, so not a history; name a file")

    def _complete_lines(self) -> tuple[list[bytes], int]:
        """The complete lines and the byte length they span (a torn tail after it is left out, with a warning)."""
        self._check_regular()
        try:
            data = self.path.read_bytes()
        except FileNotFoundError:
            return [], 0
        end = data.rfind(b"\n") + 1
        if end < len(data):
            warnings.warn(
                f"{self.path}: the last line ({len(data) - end} bytes) has no end: a write cut by a crash, "
                "ignored (that version was never committed)",
                TornLineWarning,
                stacklevel=3,
            )
        return data[:end].splitlines(), end

    def versions(self) -> list[Version]:
        """Every committed version, oldest first.

        Raises
        ------
        HandEyeInputError
            A complete line that is not a version (naming the line): corruption, not a torn write.
        """
        return [self._parse(line, i) for i, line in enumerate(self._complete_lines()[0], start=1)]

    def _parse(self, line: bytes, number: int) -> Version:
        """One complete line as a version (raises :class:`HandEyeInputError` naming the line)."""
        where = f"{self.path}: line {number}"
        try:
            doc = json.loads(line)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise HandEyeInputError(f"{where}: not JSON ({exc}); the history is corrupt") from None
        if not isinstance(doc, dict):
            raise HandEyeInputError(f"{where}: not a calibration version (a JSON object expected)")
        return Version.from_dict(doc, where)

    def latest(self) -> Version | None:
        """The current version (the last committed), None for an empty history."""
        v = self.versions()
        return v[-1] if v else None

    def get(self, version: int) -> Version:
        """A version by number (raises :class:`HandEyeInputError` naming the versions there are)."""
        versions = self.versions()
        for v in versions:
            if v.version == version:
                return v
        have = f"{versions[0].version}..{versions[-1].version}" if versions else "none"
        raise HandEyeInputError(f"{self.path}: no version {version} (versions: {have})")

    def append(
        self,
        T_base_cam: np.ndarray,
        reason: str,
        sigma: np.ndarray | None = None,
        frames=(),
        stream_t: float | None = None,
        extra: dict | None = None,
    ) -> Version:
        """Commit a new version: its line written and fsynced, then the current JSON replaced.

        Returns
        -------
        Version
            The committed version (numbered after the last, replacing it).
        """
        T = check_transforms(np.asarray(T_base_cam, dtype=float), "T_base_cam")[0]
        self._check_regular()  # before anything is created
        self.path.parent.mkdir(parents=True, exist_ok=True)
        target = check_output_path(self.path)  # no device, FIFO or dangling link appended to
        new = not target.exists()
        fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        try:
            # one appender at a time: the read of the last version, the append and the publication are one step
            fcntl.flock(fd, fcntl.LOCK_EX)
            lines, end = self._complete_lines()
            last = self._parse(lines[-1], len(lines)) if lines else None
            v = Version(
                version=1 if last is None else last.version + 1,
                time=time.time(),
                reason=reason,
                T_base_cam=T,
                sigma=None if sigma is None else np.asarray(sigma, dtype=float).reshape(6),
                frames=tuple(int(f) for f in frames),
                replaces=None if last is None else last.version,
                stream_t=stream_t,
                extra=dict(extra or {}),
            )
            data = (json.dumps(v.to_dict(), separators=(",", ":")) + "\n").encode()
            if os.fstat(fd).st_size > end:  # a torn, never-committed tail: cut it before appending
                os.ftruncate(fd, end)
            written = 0
            while written < len(data):
                written += os.write(fd, data[written:])
            os.fsync(fd)
            if new:
                _fsync_dir(target.parent)
            self._publish(v)
        finally:
            os.close(fd)  # releases the lock
        return v

    def rollback(self, version: int, stream_t: float | None = None) -> Version:
        """Append a new version equal to ``version``, its ``extra`` too (the full sigma, the depth correction it
        was fitted with); nothing is rewritten."""
        old = self.get(version)
        reason = f"rollback to version {version}"
        return self.append(old.T_base_cam, reason, old.sigma, old.frames, stream_t, old.extra)

    def publish(self) -> Version | None:
        """Rewrite the current calibration's JSON from the latest version (after a crash between the two)."""
        v = self.latest()
        if v is not None:
            self._publish(v)
        return v

    def stamp(self) -> tuple | None:
        """``(inode, size, mtime_ns)`` of the file, None while there is none: any append changes it, and a look
        costs one ``stat`` (a running watcher's, per frame: :meth:`handeye.watch.CellWatcher.feed`)."""
        try:
            st = self.path.stat()
        except FileNotFoundError:
            return None
        return (st.st_ino, st.st_size, st.st_mtime_ns)

    def recorded_stale(self) -> float | None:
        """The current JSON's ``stale_since`` when the JSON is about the history's latest version, else None.

        A watcher restarted on this history reads it (:class:`handeye.watch.CellWatcher`): an earlier run's
        ``moved`` is said there only (the history has versions, not states). A JSON about an older version (a
        version appended by a process without ``--current``, or a crash between the append and the JSON) says
        nothing about the latest; none (no ``current_path``, no file) says nothing either.

        Returns
        -------
        float or None
            The earlier run's stream time (seconds) from which the latest version is known to be off.

        Raises
        ------
        HandEyeInputError
            The JSON is there but not a calibration's (unreadable, not an object, ``stale_since`` not a number):
            whether the pose is stale cannot be told, so nothing is assumed.
        """
        if self.current_path is None or not self.current_path.is_file():
            return None
        latest = self.latest()
        try:
            doc = json.loads(self.current_path.read_text())
            if not isinstance(doc, dict):
                raise TypeError("not a JSON object")
            if latest is None or doc["version"] != latest.version:
                return None
            stale = doc.get("stale_since")  # absent from a JSON written before it was recorded: never marked
            return None if stale is None else float(stale)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise HandEyeInputError(
                f"{self.current_path}: not a current calibration ({type(exc).__name__}: {exc}), so whether version "
                f"{None if latest is None else latest.version} is stale cannot be told; remove it (it is rewritten "
                "from the history) if that version is known valid"
            ) from None

    def mark_stale(self, stale_since: float) -> Version | None:
        """Rewrite the current calibration's JSON from the latest version with ``stale_since`` (stream seconds):
        the watcher knows it is off from then (module docstring); the next append clears it."""
        v = self.latest()
        if v is not None:
            self._publish(v, float(stale_since))
        return v

    def _publish(self, v: Version, stale_since: float | None = None) -> None:
        if self.current_path is not None:
            doc = {**v.to_dict(), "stale_since": stale_since}
            write_text_atomic(self.current_path, json.dumps(doc, indent=1) + "\n")


def _fsync_dir(folder: Path) -> None:
    """Make a new file's directory entry durable (POSIX; a no-op where directories cannot be opened)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
