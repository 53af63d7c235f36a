"""Bonfiglioli ACTIVE / ACTIVE Cube Modbus PDUs for pymodbus (function codes 100 and 101).

Function codes 100 and 101 are not in the Modbus specification; the Bonfiglioli manual
(bonfiglioli-active-modbus-de.txt, ch. 6.4.3 and 6.4.4) defines them:

* FC 100 (0x64) request:  start address (2 bytes)                 -> response: value (4 bytes)
* FC 101 (0x65) request:  start address (2 bytes), value (4 bytes) -> response: echo of the request
* exceptions: 0xE4 / 0xE5 + exception code (pymodbus decodes any function code with bit 7 set as
  an ExceptionResponse)

Start address = data set (bits 12-15) << 12 | parameter number (bits 0-11). Every field is
big-endian (ch. 6.4, "zuerst das höchstwertige Byte").

pymodbus registers one class per function code for both directions of a decoder, and sizes RTU
frames by that class, so the request and the response of FC 100 (6 and 8 bytes with address and
CRC) need different classes: a client registers the *Response classes, a server the *Request
classes (see bonfi_server.py).
"""

from __future__ import annotations

import struct

from pymodbus.pdu import ModbusPDU

READ32 = 100
WRITE32 = 101


def start_address(parameter: int, data_set: int) -> int:
    """The register address of a parameter in a data set (ch. 6.4.1: 372 in data set 2 = 0x2174)."""
    return (data_set << 12) | parameter


class Read32Request(ModbusPDU):
    """FC 100 request: read one 32-bit parameter."""

    function_code = READ32
    rtu_frame_size = 6  # address, FC, start address (2), CRC (2)

    def __init__(self, address: int = 0, dev_id: int = 1, transaction_id: int = 0) -> None:
        super().__init__(dev_id=dev_id, transaction_id=transaction_id, address=address)

    def encode(self) -> bytes:
        return struct.pack(">H", self.address)

    def decode(self, data: bytes) -> None:
        (self.address,) = struct.unpack(">H", data[:2])


class Read32Response(ModbusPDU):
    """FC 100 response: the 32-bit value."""

    function_code = READ32
    rtu_frame_size = 8  # address, FC, value (4), CRC (2)

    def __init__(self, value: int = 0, dev_id: int = 1, transaction_id: int = 0) -> None:
        super().__init__(dev_id=dev_id, transaction_id=transaction_id)
        self.value = value

    def encode(self) -> bytes:
        return struct.pack(">I", self.value & 0xFFFFFFFF)

    def decode(self, data: bytes) -> None:
        (self.value,) = struct.unpack(">I", data[:4])


class Write32Request(ModbusPDU):
    """FC 101 request: write one 32-bit parameter."""

    function_code = WRITE32
    rtu_frame_size = 10  # address, FC, start address (2), value (4), CRC (2)

    def __init__(
        self, address: int = 0, value: int = 0, dev_id: int = 1, transaction_id: int = 0
    ) -> None:
        super().__init__(dev_id=dev_id, transaction_id=transaction_id, address=address)
        self.value = value

    def encode(self) -> bytes:
        return struct.pack(">HI", self.address, self.value & 0xFFFFFFFF)

    def decode(self, data: bytes) -> None:
        self.address, self.value = struct.unpack(">HI", data[:6])


class Write32Response(Write32Request):
    """FC 101 response: the echo of the request (same layout and size)."""
