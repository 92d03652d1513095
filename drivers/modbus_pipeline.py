"""Several Modbus TCP read requests in flight on one connection (pipelined transaction ids).

Modbus TCP (Modbus Messaging on TCP/IP Implementation Guide V1.0b, §3.1.2/§4.1) lets a client
send a request before the previous answer arrives; the MBAP transaction identifier pairs each
answer with its request. pymodbus's clients send one request at a time, so a capture buffer read
over a 2 ms link would cost one round trip per 125 registers; this module keeps up to ``depth``
function-code-4 requests outstanding on an already connected socket and returns the answers in
request order. It raises :class:`ExceptionAnswer` (the server's exception code and which request),
``TimeoutError`` (no complete answer in time), :class:`UnexpectedAnswer` (a ``ConnectionError``:
an answer that does not match any outstanding request, or is malformed) or another
``ConnectionError``/``OSError`` (closed or reset by the server); the caller owns the socket and
closes it on error.
"""

from __future__ import annotations

import select
import socket
import struct
import time

import numpy as np

READ_INPUT_REGISTERS = 4
_MBAP = struct.Struct(">HHHB")          # transaction id, protocol id (0), length, unit id


class UnexpectedAnswer(ConnectionError):
    """An answer that matches no outstanding request, or is empty or malformed: the stream of
    answers cannot be trusted any more (the connection is still there)."""


class ExceptionAnswer(Exception):
    """The server answered request ``index`` with Modbus exception ``code``."""

    def __init__(self, index: int, code: int) -> None:
        super().__init__(f"request {index}: Modbus exception {code}")
        self.index = index
        self.code = code


def read_input_registers_pipelined(sock: socket.socket, unit_id: int, address: int,
                                   counts: list[int], *, depth: int, timeout_s: float,
                                   first_tid: int = 1) -> list[np.ndarray]:
    """Read ``counts[i]`` input registers from ``address`` for every i, ``depth`` in flight;
    each answer's words as a ``uint16`` array.

    Each request is answered in full before its words are used; the server must answer in
    request order only as far as the *data* it returns depends on order (an auto-increment
    buffer window does): the caller checks the data (the DAQ's sample counter does). The
    requests that fit in the window are sent together, in one write (each its own ADU).
    """
    if depth < 1:
        raise ValueError(f"depth={depth} must be >= 1")
    answers: list[np.ndarray | None] = [None] * len(counts)
    outstanding: dict[int, int] = {}            # transaction id -> request index
    buffer = bytearray()
    sent = 0
    deadline = time.monotonic() + timeout_s
    sock.setblocking(False)
    while sent < len(counts) or outstanding:
        requests = []
        while sent < len(counts) and len(outstanding) < depth:
            tid = (first_tid + sent) & 0xFFFF
            pdu = struct.pack(">BHH", READ_INPUT_REGISTERS, address, counts[sent])
            requests.append(_MBAP.pack(tid, 0, len(pdu) + 1, unit_id) + pdu)
            outstanding[tid] = sent
            sent += 1
        if requests:
            _send_all(sock, b"".join(requests), deadline)
        buffer += _receive_some(sock, deadline)
        while len(buffer) >= _MBAP.size:
            tid, protocol, length, unit = _MBAP.unpack_from(buffer)
            if len(buffer) < 6 + length:
                break
            pdu = bytes(buffer[_MBAP.size:6 + length])
            del buffer[:6 + length]
            index = outstanding.pop(tid, None)
            if index is None or protocol != 0 or unit != unit_id:
                raise UnexpectedAnswer(f"answer with transaction id {tid}, protocol {protocol}, "
                                      f"unit {unit} matches no outstanding request")
            answers[index] = _decode_read_answer(index, pdu, counts[index])
            deadline = time.monotonic() + timeout_s     # ``timeout_s`` per answer
    return answers  # type: ignore[return-value]


def _decode_read_answer(index: int, pdu: bytes, count: int) -> np.ndarray:
    if not pdu:
        raise UnexpectedAnswer(f"request {index}: empty answer")
    if pdu[0] == READ_INPUT_REGISTERS | 0x80:
        raise ExceptionAnswer(index, pdu[1] if len(pdu) > 1 else 0)
    if pdu[0] != READ_INPUT_REGISTERS or len(pdu) < 2 or pdu[1] != 2 * count \
            or len(pdu) != 2 + 2 * count:
        raise UnexpectedAnswer(f"request {index}: malformed answer {pdu[:8].hex()}… "
                              f"({len(pdu)} bytes for {count} registers)")
    return np.frombuffer(pdu, dtype=">u2", offset=2).astype(np.uint16)


def _send_all(sock: socket.socket, data: bytes, deadline: float) -> None:
    view = memoryview(data)
    while view:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError("request not sent in time")
        _, writable, _ = select.select([], [sock], [], remaining)
        if writable:
            view = view[sock.send(view):]


def _receive_some(sock: socket.socket, deadline: float) -> bytes:
    remaining = deadline - time.monotonic()
    if remaining <= 0:
        raise TimeoutError("no complete answer in time")
    readable, _, _ = select.select([sock], [], [], remaining)
    if not readable:
        raise TimeoutError("no complete answer in time")
    data = sock.recv(65536)
    if not data:
        raise ConnectionError("connection closed by the server")
    return data
