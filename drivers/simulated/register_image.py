"""One Modbus register table of the simulated DAQ (input or holding): the words it holds and
which addresses its map defines.

Words live in a ``uint16`` array indexed by protocol address, so a 125-register read is one
slice, and "every register of this read is mapped" is one difference of a running count
(issue 33: the per-address dictionary this replaces cost ~60 % of the simulated DAQ's time per
buffer window).
"""

from __future__ import annotations

import numpy as np

#: Protocol addresses are 16-bit (Modbus application protocol v1.1b3 §4.4).
ADDRESSES = 1 << 16


class RegisterImage:
    """Words by 0-based protocol address, and the mapped addresses."""

    def __init__(self) -> None:
        self._words = np.zeros(ADDRESSES, dtype=np.uint16)
        self._mapped = np.zeros(ADDRESSES, dtype=bool)
        self._running = np.zeros(ADDRESSES + 1, dtype=np.int64)   # mapped addresses below i

    def define(self, address: int, words) -> None:
        """Map ``len(words)`` addresses from ``address`` and set them to ``words``."""
        words = np.asarray(words, dtype=np.uint16)
        self._mapped[address:address + len(words)] = True
        self._running[1:] = np.cumsum(self._mapped)
        self._words[address:address + len(words)] = words

    def mapped(self, address: int, count: int) -> bool:
        """Every address of ``address .. address + count - 1`` is in the map."""
        end = address + count
        return 0 <= address and end <= ADDRESSES and count >= 1 and \
            int(self._running[end] - self._running[address]) == count

    def read(self, address: int, count: int) -> np.ndarray:
        """The words at ``address .. address + count - 1`` (a copy)."""
        return self._words[address:address + count].copy()

    def write(self, address: int, words) -> None:
        """Set the words from ``address`` (mapped or not: the caller checked)."""
        words = np.asarray(words, dtype=np.uint16)
        self._words[address:address + len(words)] = words

    def word(self, address: int) -> int:
        return int(self._words[address])

    def copy(self) -> "RegisterImage":
        """An image with the same map and words (a write applied to it can be discarded)."""
        other = RegisterImage.__new__(RegisterImage)
        other._words = self._words.copy()
        other._mapped, other._running = self._mapped, self._running
        return other
