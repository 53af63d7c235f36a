#!/usr/bin/env python3
"""pymodbus client checks for `cargo xtask interop`: 32-bit parameters (FC 100/101, custom PDUs)
and the FC 8 diagnostic counters of a Bonfiglioli ACTIVE drive, in RTU or ASCII mode.

    pymodbus_client.py --port PTY --mode rtu|ascii [--addr 1]

Prints one line per check, "PASS pymodbus-<mode>: <what> (<compared>)" or "FAIL ...", and exits
1 when any check failed, 2 when the port cannot be opened. FC 8 goes through pymodbus's own
diagnostic requests (sub-functions 0x0A, 0x0D, 0x0E); FC 100/101 through bonfi_pdu.py.
"""

from __future__ import annotations

import argparse
import sys

from pymodbus import FramerType
from pymodbus.client import ModbusSerialClient
from pymodbus.exceptions import ModbusException
from pymodbus.pdu import ModbusPDU
from pymodbus.pdu.diag_message import DiagnosticBase

import bonfi_pdu
from bonfi_pdu import Read32Request, Read32Response, Write32Request, Write32Response, start_address

FAILURES = 0
TAG = "pymodbus"


def report(ok: bool, what: str, compared: str) -> None:
    global FAILURES
    print(f"{'PASS' if ok else 'FAIL'} {TAG}: {what} ({compared})", flush=True)
    FAILURES += not ok


def execute(client: ModbusSerialClient, request: ModbusPDU) -> ModbusPDU | str:
    try:
        return client.execute(False, request)
    except ModbusException as exc:
        return f"no answer: {exc}"


def shown(response: ModbusPDU | str) -> str:
    if isinstance(response, str):
        return response
    if response.isError():
        return f"exception {response.exception_code} (function code 0x{response.function_code:02X})"
    return str(getattr(response, "value", response))


def read32(client, addr, parameter, data_set, expected, what) -> None:
    a = start_address(parameter, data_set)
    r = execute(client, Read32Request(a, dev_id=addr))
    ok = isinstance(r, Read32Response) and r.value == expected
    report(ok, what, f"FC 100 0x{a:04X}: expected {expected}, got {shown(r)}")


def write32(client, addr, parameter, data_set, value, what) -> None:
    a = start_address(parameter, data_set)
    r = execute(client, Write32Request(a, value, dev_id=addr))
    ok = isinstance(r, Write32Response) and (r.address, r.value) == (a, value)
    got = f"echo 0x{r.address:04X} = {r.value}" if isinstance(r, Write32Response) else shown(r)
    report(ok, what, f"FC 101 0x{a:04X} = {value}: expected the echo, got {got}")


def expect_exception(client, request, code, what) -> None:
    r = execute(client, request)
    ok = not isinstance(r, str) and r.isError() and r.exception_code == code
    want = f"0x{request.function_code | 0x80:02X} exception {code}"
    report(ok, what, f"FC {request.function_code} 0x{request.address:04X}: expected {want}, got {shown(r)}")


def counter(client, addr, read, sub: int, expected: int, what: str) -> None:
    try:
        r = read(device_id=addr)
        got = shown(r) if r.isError() else str(r.message)
        ok = not r.isError() and r.message == expected
    except ModbusException as exc:
        got, ok = f"no answer: {exc}", False
    report(ok, what, f"FC 8 sub-function 0x{sub:02X}: expected {expected}, got {got}")


class UnknownDiagnostic(DiagnosticBase):
    """FC 8 with sub-function 0x13, which the drive does not support (ch. 8.1.5 example 2)."""

    sub_function_code = 0x13


def main() -> int:
    global TAG
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", required=True)
    parser.add_argument("--mode", choices=("rtu", "ascii"), required=True)
    parser.add_argument("--addr", type=int, default=1)
    args = parser.parse_args()
    TAG = f"pymodbus-{args.mode}"
    client = ModbusSerialClient(
        args.port,
        framer=FramerType.RTU if args.mode == "rtu" else FramerType.ASCII,
        baudrate=19200,
        parity="N",
        stopbits=1,
        # A pty refuses 7 data bits (tcsetattr: EINVAL); ASCII characters fit in 8 all the same.
        bytesize=8,
        timeout=1,
        retries=0,
    )
    client.register(Read32Response)
    client.register(Write32Response)
    if not client.connect():
        print(f"{TAG}: cannot open {args.port}", file=sys.stderr)
        return 2
    a = args.addr

    # ch. 8.1.3 example 1: fixed frequency 2 (481) in data set 0, 1000 = 10.00 Hz
    write32(client, a, 481, 0, 1000, "write fixed frequency 2 (481) = 10.00 Hz")
    read32(client, a, 481, 0, 1000, "read 481 (ch. 8.1.3: 1000 = 10.00 Hz)")
    write32(client, a, 481, 0, 2575, "write 481 = 25.75 Hz")
    read32(client, a, 481, 0, 2575, "read back 481")
    write32(client, a, 481, 5, 1000, "write 481 data set 5 (RAM copy of data set 0) = 10.00 Hz")
    read32(client, a, 481, 0, 1000, "read 481 after the RAM write")
    # ch. 8.1.4: rated frequency 375 in data set 2; 9.00 Hz is refused with exception 4
    write32(client, a, 375, 2, 1000, "write rated frequency 375 data set 2 = 10.00 Hz (ch. 8.1.4)")
    read32(client, a, 375, 2, 1000, "read back 375 data set 2")
    expect_exception(
        client, Write32Request(start_address(375, 2), 900, dev_id=a), 4,
        "write 9.00 Hz to 375 refused (ch. 8.1.4 example 2)",
    )
    # ch. 8.1.3 example 2: unknown parameter 1600 in data set 2
    expect_exception(
        client, Read32Request(start_address(1600, 2), dev_id=a), 4,
        "read unknown parameter 1600 refused (ch. 8.1.3 example 2)",
    )

    # FC 8 (ch. 8.1.5): clear, then the slave message counter counts the request itself
    try:
        r = client.diag_clear_counters(device_id=a)
        got = shown(r) if r.isError() else f"sub-function 0x{r.sub_function_code:02X}"
        ok = not r.isError() and r.sub_function_code == 0x0A
    except ModbusException as exc:
        got, ok = f"no answer: {exc}", False
    report(ok, "clear the diagnostic counters", f"FC 8 sub-function 0x0A: expected the echo, got {got}")
    counter(client, a, client.diag_read_device_message_count, 0x0E, 1, "slave message counter after clearing (ch. 8.1.5 example 1b)")
    counter(client, a, client.diag_read_device_message_count, 0x0E, 2, "slave message counter after one more request")
    counter(client, a, client.diag_read_bus_exception_error_count, 0x0D, 0, "exception counter after clearing")
    expect_exception(client, Read32Request(start_address(1600, 0), dev_id=a), 4, "read unknown parameter 1600 refused")
    counter(client, a, client.diag_read_bus_exception_error_count, 0x0D, 1, "exception counter after one exception")
    counter(client, a, client.diag_read_bus_message_count, 0x0B, 6, "bus message counter (six requests since clearing)")
    r = execute(client, UnknownDiagnostic(0, dev_id=a))
    ok = not isinstance(r, str) and r.isError() and r.exception_code == 1
    report(ok, "unknown sub-function 0x13 refused (ch. 8.1.5 example 2)", f"FC 8 sub-function 0x13: expected 0x88 exception 1, got {shown(r)}")

    client.close()
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
