"""A scripted instrument on a pty for the manual-example tests: fixed answers, nothing simulated.

Each command line received (CR or LF terminated) is looked up in ``answers``; the answer bytes are
written back verbatim (a missing command is answered by nothing, as a Magtrol unit does). So the
driver under test reads exactly the bytes a manual prints, independent of the project's simulator.
"""

from __future__ import annotations

import os
import select
import threading
import tty


class ScriptedInstrument:
    """A pty answering each command with fixed bytes; ``received`` lists the commands seen."""

    def __init__(self, answers: dict[str, bytes]) -> None:
        self.answers = dict(answers)
        self.received: list[str] = []
        self._master, self._slave = os.openpty()
        tty.setraw(self._master)
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._stop_r, self._stop_w = os.pipe()
        self._thread = threading.Thread(target=self._run, daemon=True, name="scripted-pty")

    def __enter__(self) -> "ScriptedInstrument":
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        os.write(self._stop_w, b"x")
        self._thread.join(5.0)
        for fd in (self._master, self._slave, self._stop_r, self._stop_w):
            os.close(fd)

    def _run(self) -> None:
        pending = bytearray()
        while True:
            ready, _, _ = select.select([self._master, self._stop_r], [], [], 1.0)
            if self._stop_r in ready:
                return
            if self._master not in ready:
                continue
            try:
                pending += os.read(self._master, 4096)
            except OSError:
                continue
            while (cut := min((i for i in (pending.find(b"\r"), pending.find(b"\n")) if i >= 0),
                              default=-1)) >= 0:
                command = pending[:cut].decode("ascii").strip()
                del pending[:cut + 1]
                if command:
                    self.received.append(command)
                    if command in self.answers:
                        os.write(self._master, self.answers[command])
