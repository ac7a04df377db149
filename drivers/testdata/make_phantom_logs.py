#!/usr/bin/env python3
"""Writes the candump-format (`candump -L`) logs the CAN driver's replay tests use.

Deterministic; rerun after changing the protocol (docs/protocols/phantom-can.md):
    python3 drivers/testdata/make_phantom_logs.py
The amplifiers are nodes 1, 2, 3; feedback at 1 kHz; times start at T0.
"""
import struct
from pathlib import Path

T0 = 1_763_000_000_000_000  # µs
HERE = Path(__file__).parent
ENABLED, FAULT, ESTOP = 0x01, 0x02, 0x04


def line(t_us, ident, data, iface="can0"):
    t = T0 + t_us
    return f"({t // 1_000_000}.{t % 1_000_000:06d}) {iface} {ident}#{data.hex().upper()}"


def feedback(node, counts, amp_us, status, seq):
    return f"{0x180 + node:03X}", struct.pack("<iHBB", counts, amp_us & 0xFFFF, status, seq & 0xFF)


def heartbeat(node, state):
    return f"{0x700 + node:03X}", bytes([state, 0])


def error_frame(class_bits, data1=0):
    # 8-hex-digit id with CAN_ERR_FLAG (0x20000000): an error frame, class bits in the id.
    return f"{0x20000000 | class_bits:08X}", bytes([0, data1, 0, 0, 0, 0, 0, 0])


def stream(ms, status_at, counts_at=lambda j, ms: 0, silent=lambda j, ms: False):
    """Feedback from the three nodes for each millisecond in `ms`."""
    out = []
    for m in ms:
        t = m * 1000
        if m % 100 == 0:
            for node in (1, 2, 3):
                st = 2 if status_at(m) & ENABLED else 1
                out.append(line(t, *heartbeat(node, st)))
        for j, node in enumerate((1, 2, 3)):
            if not silent(j, m):
                out.append(line(t + 100 * j, *feedback(node, counts_at(j, m), t, status_at(m), m)))
    return out


def enabled_after(ms_enable):
    return lambda m: ENABLED if m >= ms_enable else 0


def moving(j, m):
    return 2 * m if j == 0 else (-m if j == 1 else 500)


def write(name, lines):
    (HERE / name).write_text("\n".join(lines) + "\n")


# Amplifiers report enabled from 10 ms (the test enables at 5 ms); joint 0 turns at 2
# counts/ms, joint 1 at -1 count/ms, joint 2 stands at 500 counts.
write("phantom-enable.log", stream(range(0, 40), enabled_after(10), moving))

# Bus-off at 30.5 ms, the controller restarts at 35.5 ms; feedback goes on.
lines = stream(range(0, 30), enabled_after(10), moving)
lines.append(line(30_500, *error_frame(0x40)))  # CAN_ERR_BUSOFF
lines += stream(range(31, 35), enabled_after(10), moving)
lines.append(line(35_500, *error_frame(0x100)))  # CAN_ERR_RESTARTED
lines += stream(range(36, 40), lambda m: 0, moving)
write("phantom-busoff.log", lines)

# Error counters climb: warning at 20.5 ms, error-passive at 25.5 ms.
lines = stream(range(0, 20), enabled_after(10), moving)
lines.append(line(20_500, *error_frame(0x04, 0x0C)))  # CAN_ERR_CRTL, RX+TX warning
lines += stream(range(21, 25), enabled_after(10), moving)
lines.append(line(25_500, *error_frame(0x04, 0x30)))  # CAN_ERR_CRTL, RX+TX passive
lines += stream(range(26, 30), enabled_after(10), moving)
write("phantom-error-passive.log", lines)

# E-stop pressed at 25 ms: the amplifiers drop out of enabled, flag it, and send an
# emergency; it is released at 32 ms.
estop = lambda m: ENABLED if 10 <= m < 25 else (ESTOP if 25 <= m < 32 else 0)
lines = stream(range(0, 25), estop, moving)
lines.append(line(25_000, "081", struct.pack("<HBB4s", 0x5441, 0x01, 3, b"\0\0\0\0")))
lines += stream(range(25, 40), estop, moving)
write("phantom-estop.log", lines)

# Joint 1's amplifier goes silent at 20 ms.
write("phantom-silent.log", stream(range(0, 30), enabled_after(10), moving, lambda j, m: j == 1 and m >= 20))

# A clean stream with everything that should be ignored or counted mixed in.
junk = [
    line(19_300, "00000181", bytes(8)),  # extended id: foreign
    line(19_310, "181", b"") .replace("#", "#R", 1),  # remote frame: foreign
    line(19_320, "181#", bytes(8)).replace("181##", "181##0", 1),  # CAN FD: foreign
    line(19_330, "182", bytes([1, 2])),  # feedback with 2 bytes: malformed
    line(19_340, "703", bytes([9, 0])),  # heartbeat with an undefined state: malformed
    line(19_350, "183", bytes([0, 0, 0, 0, 0, 0, 0xE0, 0])),  # undefined status bits: malformed
    line(19_360, "4A1", bytes([0x11])),  # not in the protocol: foreign
    line(19_370, *feedback(9, 0, 0, 0, 0)),  # a node that is not ours: foreign
    "(garbage) can0 181#0000000000000000",  # bad timestamp
    line(19_380, "XYZ", b"\x00"),  # bad id
    line(19_390, "800", b"\x01"),  # 3 digits but not an 11-bit id
    "(1763000000.019400) can0",  # truncated record
]
lines = stream(range(0, 20), enabled_after(10), moving) + junk + stream(range(20, 25), enabled_after(10), moving)
write("phantom-garbage.log", lines)
