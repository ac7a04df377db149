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


# Text targets start from the shipped files and documented lines, past the parser's surface.
ROOT = HERE.parent.parent


def copy_files(target, files):
    d = HERE / target
    d.mkdir(exist_ok=True)
    for f in files:
        (d / f.name).write_bytes(f.read_bytes())


copy_files("config_loader", [ROOT / "config/sim.ron", ROOT / "config/lab.ron"])
copy_files("scene_loader", sorted((ROOT / "config/scenes").glob("*.ron")))
copy_files("fem_model_loader", sorted((ROOT / "config/fem").glob("*.ron")))
# gmsh_reader: the FEM crate's test meshes, ASCII and binary, good and refused.
copy_files("gmsh_reader", sorted((ROOT / "sim-backend/fem/tests/data").glob("*.msh")))

# console_request: one line per file, every verb and argument of docs/console-protocol.md.
console = {
    "status": '{"id":1,"verb":"status"}',
    "enable": '{"id":2,"verb":"enable"}',
    "disable": '{"id":3,"verb":"disable"}',
    "home": '{"id":4,"verb":"home"}',
    "jog": '{"id":5,"verb":"jog","dx_m":0.001,"dz_m":-0.0005}',
    "move": '{"id":7,"verb":"move","x_m":0.012,"z_m":-0.002,"speed_m_s":0.01}',
    "move_null_speed": '{"id":8,"verb":"move","x_m":0,"z_m":0,"speed_m_s":null}',
    "mark": '{"id":9,"verb":"mark"}',
    "track": '{"id":10,"verb":"track","length_m":0.05}',
    "track_open": '{"id":11,"verb":"track"}',
    "pause": '{"id":12,"verb":"pause"}',
    "resume": '{"id":13,"verb":"resume"}',
    "stop": '{"id":14,"verb":"stop"}',
    "estop": '{"id":15,"verb":"estop"}',
    "reset": '{"id":16,"verb":"reset"}',
    "subscribe": '{"id":17,"verb":"subscribe","streams":["state","tactile","detections","faults","trials"],"tactile_every":10}',
    "subscribe_all": '{"id":18,"verb":"subscribe"}',
    "unsubscribe": '{"id":19,"verb":"unsubscribe"}',
    "debug": '{"id":20,"verb":"debug","action":"silence_tactile","duration_s":0.5}',
    "big_id": '{"id":18446744073709551615,"verb":"status"}',
    "exponent": '{"id":21,"verb":"move","x_m":1.2e-2,"z_m":-2E-3}',
    "unicode": '{"id":22,"verb":"st\\u0061tus"}',
}
d = HERE / "console_request"
d.mkdir(exist_ok=True)
for name, line in console.items():
    (d / name).write_bytes(line.encode())

# Scene variants the shipped files do not use: the FEM kernel, hold-down coupling, straight
# and polyline paths.
arc = (ROOT / "config/scenes/seed-arc-145.ron").read_text()
arc_path = "path: Arc(radius_m: 0.145, length_m: 0.26, chord_centre: (x_m: 0.0, z_m: 0.0272), turn: Left),"
assert arc_path in arc
variants = {
    "variant-fem-kernel.ron": arc.replace(
        "wall_m: 0.001,",
        "wall_m: 0.001,\n        kernel: Fem(tissue: (e_pa: 20e3, nu: 0.45), wall: (e_pa: 100e3, nu: 0.49), refine: 0),",
    ),
    "variant-hold-down.ron": arc.replace(
        "wall_m: 0.001,", "wall_m: 0.001,\n        coupling: HoldDown(reference_normal_n: 3.0),"
    ),
    "variant-straight.ron": arc.replace(
        arc_path, "path: Straight(start: (x_m: -0.13, z_m: 0.0), heading_rad: 0.1, length_m: 0.26),"
    ),
    "variant-polyline.ron": arc.replace(
        arc_path,
        "path: Polyline(points: [(x_m: -0.1, z_m: 0.0), (x_m: 0.0, z_m: 0.01), (x_m: 0.1, z_m: 0.0)]),",
    ),
}
for name, text in variants.items():
    assert text != arc, name
    (HERE / "scene_loader" / name).write_text(text)
