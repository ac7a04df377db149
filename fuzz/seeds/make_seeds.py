#!/usr/bin/env python3
"""Seed inputs for the fuzz targets: valid messages, so the fuzzer starts past the CRC.

    python3 fuzz/seeds/make_seeds.py
"""
import struct
from pathlib import Path

HERE = Path(__file__).parent


def crc16(b):
    c = 0xFFFF
    for x in b:
        c ^= x << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x1021) & 0xFFFF if c & 0x8000 else (c << 1) & 0xFFFF
    return c


def cobs(b):
    out, block = bytearray(), bytearray()
    for x in b:
        if x == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
        else:
            block.append(x)
            if len(block) == 254:
                out += bytes([255]) + block
                block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out)


def wire(raw):
    raw = raw + struct.pack("<H", crc16(raw))
    return b"\x00" + cobs(raw) + b"\x00"


def forces(seq, t_us, counts):
    return wire(bytes([0x01]) + struct.pack("<IIB", seq, t_us, len(counts)) + struct.pack(f"<{len(counts)}h", *counts))


info = wire(bytes([0x02, 1, 1, 0, 0, 10]) + struct.pack("<HI", 100, 4242))
configure = wire(bytes([0x10]) + struct.pack("<HB", 100, 1))
t = HERE / "tactile_decoder"
(t / "info_then_forces").write_bytes(info + b"".join(forces(k, 10_000 * k, [100 * k + i for i in range(10)]) for k in range(5)))
(t / "configure").write_bytes(configure)
(t / "nine_channels_and_fault").write_bytes(forces(1, 0, [0] * 9) + forces(2, 10_000, [0, 0, 0, -32768] + [0] * 6))
(t / "wrap").write_bytes(forces(0xFFFFFFFF, 0xFFFFFF00, [1] * 10) + forces(0, 0x100, [2] * 10))

# can_decoder: records of tag (high nibble: F condition, E foreign, else frame; low nibble:
# length; 0x10 enable, 0x20 disable, 0x40 transmit), id (u16 le), payload.
def rec(tag, ident, payload=b""):
    return bytes([tag | len(payload)]) + struct.pack("<H", ident) + payload


def fb(node, counts, t, status, seq):
    return rec(0x40, 0x180 + node, struct.pack("<iHBB", counts, t, status, seq))


c = HERE / "can_decoder"
feedback = b"".join(fb(n, 10 * k, 1000 * k, 0, k) for k in range(1, 4) for n in (1, 2, 3))
enabled = b"".join(fb(n, 10 * k, 1000 * k, 1, k) for k in range(4, 8) for n in (1, 2, 3))
(c / "enable").write_bytes(feedback + rec(0x10, 0x000, b"") + enabled)
(c / "bus_off").write_bytes(feedback + rec(0x10, 0) + enabled + rec(0xF0, 0x0001) + enabled)
(c / "slcan_text").write_bytes(b"t1818000000000000010A\rF20\rz\r\x07t7022\r")
(c / "emergency").write_bytes(feedback + rec(0x10, 0) + enabled + rec(0x40, 0x082, struct.pack("<HBB4s", 0x2310, 1, 3, b"\0" * 4)))
