#!/usr/bin/env python3
"""A pymodbus serial server that answers like a Bonfiglioli ACTIVE drive (reference server).

    bonfi_server.py --port PTY --mode rtu|ascii [--addr 1]

pymodbus does the framing (RTU CRC / ASCII LRC, frame detection) and the transport; the request
classes below, registered as custom PDUs, implement the drive's rules from the manual
(bonfiglioli-active-modbus-de.txt):

* FC 3 / 6: 16-bit parameters; register count must be 1 (else exception 2, ch. 6.4.1);
* FC 100 / 101: 32-bit parameters (ch. 6.4.3, 6.4.4);
* start address = data set << 12 | parameter; data sets 5-9 are the RAM copies of 0-4 (ch. 7);
  writing data set 0 sets all four data sets, reading data set 0 fails when they differ
  (exception 4, VABus error 9);
* an unknown parameter answers exception 4 with VABus error 11 (ch. 8.1.3 example 2; see erratum
  E5: ch. 6.6 says 2), a value out of range exception 4 with VABus error 1 (ch. 8.1.2 example 2);
* parameter 11 (VABus SST error register) holds the cause of the last exception 4 and is cleared
  by reading it (ch. 6.6);
* FC 8 sub-functions 0x0A (clear) and 0x0B-0x12 (counters); other sub-functions exception 1,
  data field not 0 exception 3 (ch. 6.4.5). The request being answered is already counted
  (ch. 8.1.5 example 1b: the first read after clearing returns 1).

This lets the interop harness prove its clients (mbpoll, libmodbus, pymodbus) and the drivectl
master against software nobody here wrote, before and besides the simulator of drivectl.
Prints "ready" on stdout once it listens; runs until killed.
"""

from __future__ import annotations

import argparse
import asyncio
import struct
import sys

from pymodbus import FramerType
from pymodbus.pdu import ExceptionResponse, ModbusPDU
from pymodbus.server import ModbusSerialServer
from pymodbus.simulator import SimData, SimDevice

import bonfi_pdu

ILLEGAL_FUNCTION, ILLEGAL_ADDRESS, ILLEGAL_VALUE, DEVICE_FAILURE = 1, 2, 3, 4
# VABus SST error register 11 (ch. 6.6)
VABUS_BAD_VALUE, VABUS_BAD_DATA_SET, VABUS_DATA_SETS_DIFFER, VABUS_WRONG_TYPE = 1, 2, 9, 10
VABUS_UNKNOWN = 11


class Drive:
    """The parameters and counters of one simulated drive."""

    def __init__(self) -> None:
        # parameter -> (bits, minimum, maximum, has four data sets)
        self.table = {
            11: (16, 0, 15, False),  # VABus SST error register, read-only, cleared by reading
            372: (16, 0, 0xFFFF, True),  # rated speed, 1/min
            376: (16, 1, 0xFFFF, True),  # mech. rated power, 0.1 kW (0 is refused, ch. 8.1.2)
            375: (32, 1000, 0x7FFFFFFF, True),  # rated frequency, 0.01 Hz (9.00 Hz refused, ch. 8.1.4)
            481: (32, -99999, 99999, False),  # fixed frequency 2, 0.01 Hz
        }
        # (parameter, data set 0..4) -> value; data set 0 of a data-set parameter is not stored
        self.values: dict[tuple[int, int], int] = {}
        for number, (_, _, _, sets) in self.table.items():
            for ds in (1, 2, 3, 4) if sets else (0,):
                self.values[(number, ds)] = 0
        for ds in (1, 2, 3, 4):
            self.values[(372, ds)] = 1390  # ch. 8.1.1: 1390 1/min
            self.values[(376, ds)] = 22  # 2.2 kW, so that writing 1.5 kW shows
            self.values[(375, ds)] = 5000
        self.values[(481, 0)] = 1000  # ch. 8.1.3: 10.00 Hz
        self.error_register = 0
        self.counters = dict.fromkeys(range(0x0B, 0x13), 0)

    def failure(self, cause: int) -> int:
        self.error_register = cause
        return DEVICE_FAILURE

    def read(self, address: int, bits: int) -> int | tuple[int]:
        """The value, or a 1-tuple with the exception code."""
        number, ds = address & 0x0FFF, (address >> 12) % 5
        if address >> 12 > 9 or number not in self.table:
            return (self.failure(VABUS_UNKNOWN),)
        width, _, _, sets = self.table[number]
        if width != bits:
            return (ILLEGAL_ADDRESS,)
        if number == 11:
            value, self.error_register = self.error_register, 0
            return value
        if not sets:
            return self.values[(number, 0)] if ds == 0 else (self.failure(VABUS_BAD_DATA_SET),)
        if ds == 0:
            four = {self.values[(number, d)] for d in (1, 2, 3, 4)}
            if len(four) != 1:
                return (self.failure(VABUS_DATA_SETS_DIFFER),)
            return four.pop()
        return self.values[(number, ds)]

    def write(self, address: int, bits: int, raw: int) -> int | None:
        """None, or the exception code."""
        number, ds = address & 0x0FFF, (address >> 12) % 5
        if address >> 12 > 9 or number not in self.table:
            return self.failure(VABUS_UNKNOWN)
        width, low, high, sets = self.table[number]
        if width != bits:
            return ILLEGAL_ADDRESS
        if number == 11:
            return self.failure(4)  # VABus error 4: parameter not writable
        value = raw - (1 << 32) if bits == 32 and raw & 0x80000000 else raw
        if not low <= value <= high:
            return self.failure(VABUS_BAD_VALUE)
        if not sets:
            if ds != 0:
                return self.failure(VABUS_BAD_DATA_SET)
            self.values[(number, 0)] = value
        else:
            for d in (1, 2, 3, 4) if ds == 0 else (ds,):
                self.values[(number, d)] = value
        return None

    def count_request(self, dev_id: int) -> None:
        self.counters[0x0B] += 1  # bus messages (every valid frame)
        if dev_id == 0:
            self.counters[0x0F] += 1  # broadcasts ("slave no response")
        else:
            self.counters[0x0E] += 1  # slave messages


DRIVE = Drive()


class Answer(ModbusPDU):
    """A response built from its function code and data bytes."""

    def __init__(self, function_code: int, data: bytes, dev_id: int, transaction_id: int) -> None:
        super().__init__(dev_id=dev_id, transaction_id=transaction_id)
        self.function_code = function_code
        self.data = data

    def encode(self) -> bytes:
        return self.data


class DriveRequest(ModbusPDU):
    """Common part: count the request, answer with data or an exception."""

    def answer(self, data: bytes) -> ModbusPDU:
        return Answer(self.function_code, data, self.dev_id, self.transaction_id)

    def exception(self, code: int) -> ModbusPDU:
        DRIVE.counters[0x0D] += 1
        return ExceptionResponse(self.function_code, code, self.dev_id, self.transaction_id)

    async def datastore_update(self, context, device_id: int) -> ModbusPDU:
        _ = context, device_id
        DRIVE.count_request(self.dev_id)
        return self.handle()

    def handle(self) -> ModbusPDU:
        raise NotImplementedError


class Read16(DriveRequest):
    function_code = 3
    rtu_frame_size = 8

    def decode(self, data: bytes) -> None:
        self.address, self.count = struct.unpack(">HH", data[:4])

    def handle(self) -> ModbusPDU:
        if self.count != 1:
            return self.exception(ILLEGAL_ADDRESS)  # ch. 8.1.1 example 2
        value = DRIVE.read(self.address, 16)
        if isinstance(value, tuple):
            return self.exception(value[0])
        return self.answer(struct.pack(">BH", 2, value & 0xFFFF))


class Write16(DriveRequest):
    function_code = 6
    rtu_frame_size = 8

    def decode(self, data: bytes) -> None:
        self.address, self.value = struct.unpack(">HH", data[:4])

    def handle(self) -> ModbusPDU:
        if (code := DRIVE.write(self.address, 16, self.value)) is not None:
            return self.exception(code)
        return self.answer(struct.pack(">HH", self.address, self.value))


class Read32(DriveRequest):
    function_code = bonfi_pdu.READ32
    rtu_frame_size = 6

    def decode(self, data: bytes) -> None:
        (self.address,) = struct.unpack(">H", data[:2])

    def handle(self) -> ModbusPDU:
        value = DRIVE.read(self.address, 32)
        if isinstance(value, tuple):
            return self.exception(value[0])
        return self.answer(struct.pack(">I", value & 0xFFFFFFFF))


class Write32(DriveRequest):
    function_code = bonfi_pdu.WRITE32
    rtu_frame_size = 10

    def decode(self, data: bytes) -> None:
        self.address, self.value = struct.unpack(">HI", data[:6])

    def handle(self) -> ModbusPDU:
        if (code := DRIVE.write(self.address, 32, self.value)) is not None:
            return self.exception(code)
        return self.answer(struct.pack(">HI", self.address, self.value))


class Diagnostics(DriveRequest):
    function_code = 8
    rtu_frame_size = 8

    def decode(self, data: bytes) -> None:
        self.sub, self.value = struct.unpack(">HH", data[:4])

    def handle(self) -> ModbusPDU:
        if self.sub != 0x0A and self.sub not in DRIVE.counters:
            return self.exception(ILLEGAL_FUNCTION)  # ch. 8.1.5 example 2
        if self.value != 0:
            return self.exception(ILLEGAL_VALUE)
        if self.sub == 0x0A:
            DRIVE.counters = dict.fromkeys(DRIVE.counters, 0)
            return self.answer(struct.pack(">HH", 0x0A, 0))
        return self.answer(struct.pack(">HH", self.sub, DRIVE.counters[self.sub] & 0xFFFF))


async def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", required=True)
    parser.add_argument("--mode", choices=("rtu", "ascii"), required=True)
    parser.add_argument("--addr", type=int, default=1)
    args = parser.parse_args()
    server = ModbusSerialServer(
        SimDevice(args.addr, simdata=[SimData(0)]),
        framer=FramerType.RTU if args.mode == "rtu" else FramerType.ASCII,
        port=args.port,
        baudrate=19200,
        parity="N",
        stopbits=1,
        # A pty refuses 7 data bits (tcsetattr: EINVAL); ASCII characters fit in 8 all the same.
        bytesize=8,
        custom_pdu=[Read16, Write16, Read32, Write32, Diagnostics],
    )
    await server.serve_forever(background=True)
    print("ready", flush=True)
    await asyncio.Event().wait()
    return 0


if __name__ == "__main__":
    sys.exit(asyncio.run(main()))
