"""Asynchronous serial line settings shared by the RTU driver and the simulated RTU DAQ.

Modbus over serial line (Modbus.org, "MODBUS over Serial Line V1.02", §2.5.1): 11 bits per
character, 8 data bits, even parity by default (odd allowed; no parity then needs 2 stop bits to
keep the 11-bit character, though 1 is widely used and allowed here).

A pseudo-terminal carries bytes, not line bits, so parity means nothing on it; most kernels store
the setting anyway, but some (sandboxed kernels, e.g. this project's CI sandbox) refuse PARENB on a
pty with EINVAL. :func:`line_for_port` then opens a pty without parity and says so.
"""

from __future__ import annotations

import functools
import os
import termios

PARITIES: tuple[str, ...] = ("E", "O", "N")
STOPBITS: tuple[int, ...] = (1, 2)


def bits_per_char(parity: str, stopbits: int) -> int:
    """Bits one byte takes on the line: start + 8 data + parity + stop bits."""
    return 1 + 8 + (parity != "N") + stopbits


def is_pseudo_terminal(port: str) -> bool:
    """True for a Unix98 pseudo-terminal slave (``/dev/pts/N``, or a link to one)."""
    return os.path.realpath(port).startswith("/dev/pts/")


@functools.cache
def pty_accepts_parity() -> bool:
    """Whether this kernel lets a pseudo-terminal store a parity setting (PARENB)."""
    master, slave = os.openpty()
    try:
        attrs = termios.tcgetattr(slave)
        attrs[2] |= termios.PARENB
        termios.tcsetattr(slave, termios.TCSANOW, attrs)
        return True
    except termios.error:
        return False
    finally:
        os.close(master)
        os.close(slave)


def line_for_port(port: str, parity: str) -> tuple[str, str]:
    """(parity to open ``port`` with, note): ``parity`` itself, or "N" on a pseudo-terminal of
    a kernel that refuses parity there (the note says so; empty otherwise)."""
    if parity != "N" and is_pseudo_terminal(port) and not pty_accepts_parity():
        return "N", (f"parity {parity} not applicable: {port} is a pseudo-terminal and this "
                     f"kernel refuses a parity setting on it")
    return parity, ""
