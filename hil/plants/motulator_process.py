"""motulator in a worker process: :class:`hil.plants.motulator_drive.MotulatorDrive` served over
a pipe, so that its tens of seconds of computation per capture never hold this process's GIL.

Found on the foreign bench (issue 30): with motulator computing in a thread of the instruments'
process, a loaded 2-core machine left the Modbus server's thread without the GIL for more than
the DAQ driver's 1 s reply timeout (``daq: write control=2: no answer within 1.0 s``). Here the
instruments' threads only wait on the pipe (reading it releases the GIL). The worker is
started as a subprocess of the same Python; it ends when its pipe closes.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys


class RunCancelled(RuntimeError):
    """The worker was ended by :meth:`DriveProcess.cancel` while a call waited on it."""


class DriveProcess:
    """``MotulatorDrive`` in a worker process (``start``, then ``configure`` / ``run``).

    The worker is ``python -m hil.plants.motulator_process`` with this Python; requests and
    replies are pickles on its standard input and output (its own prints go to standard
    error). It ends when its standard input closes, i.e. with this process at the latest."""

    def __init__(self) -> None:
        self._cancelled: str | None = None
        self._process = subprocess.Popen(
            [sys.executable, "-m", "hil.plants.motulator_process"], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE)

    def start(self, motor, t0_s: float) -> None:
        """Build ``MotulatorDrive(motor, t0_s)`` in the worker (seconds: motulator's imports)."""
        self._call("start", motor, t0_s)

    @property
    def cancelled(self) -> bool:
        return self._cancelled is not None

    def configure(self, applied, **commands) -> None:
        self._call("configure", applied, **commands)

    def run(self, t_plant_s: float, duration_s: float):
        return self._call("run", t_plant_s, duration_s)

    def cancel(self, reason: str) -> None:
        """End the worker now, from any thread: a call waiting on it raises
        :class:`RunCancelled` with ``reason`` (the drive was disabled, the bench closed)."""
        self._cancelled = reason
        self._process.kill()

    def close(self) -> None:
        try:
            self._process.stdin.close()
            self._process.wait(timeout=5.0)
        except (OSError, subprocess.TimeoutExpired):
            self._process.kill()

    def _call(self, name: str, *args, **kwargs):
        if self._cancelled is not None:
            raise RunCancelled(f"motulator {name}() abandoned: {self._cancelled}")
        if self._process.poll() is not None:
            raise RuntimeError(f"the motulator worker process has exited "
                               f"(code {self._process.returncode})")
        try:
            pickle.dump((name, args, kwargs), self._process.stdin)
            self._process.stdin.flush()
            ok, value = pickle.load(self._process.stdout)
        except (EOFError, OSError, pickle.UnpicklingError) as exc:
            if self._cancelled is not None:
                raise RunCancelled(f"motulator {name}() abandoned: {self._cancelled}") from None
            raise RuntimeError(f"the motulator worker process ended during {name}(): "
                               f"{exc}") from None
        if not ok:
            raise RuntimeError(f"motulator worker: {value}")
        return value


def serve(requests, replies) -> None:
    """The worker's loop: (name, args, kwargs) pickles in, (ok, value) pickles out."""
    drive = None
    while True:
        try:
            name, args, kwargs = pickle.load(requests)
        except EOFError:
            return
        try:
            if name == "start":
                from hil.plants.motulator_drive import MotulatorDrive

                drive, value = MotulatorDrive(*args, **kwargs), None
            else:
                value = getattr(drive, name)(*args, **kwargs)
            reply = (True, value)
        except Exception as exc:  # noqa: BLE001 - reported to the plant, which raises it
            reply = (False, f"{type(exc).__name__}: {exc}")
        pickle.dump(reply, replies)
        replies.flush()


if __name__ == "__main__":
    replies = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)                  # anything printed goes to standard error, not the pipe
    serve(sys.stdin.buffer, replies)
