#!/usr/bin/env python3
"""Writes the seed corpora of the protocol fuzzers: one file per instruction, each a valid packet
framed from /work/shared/reference/dynamixel.md (P1 checksum §1.1, P2 CRC-16/BUYPASS §2.2 and byte
stuffing §2.3), not with Doppel's encoder. Every input starts with the two bytes the fuzz targets
read first (fuzz_support.h: line-rate selector, feedback driver).

Usage: fuzz/make_corpus.py [fuzz/corpus]   (rewrites protocol1_parser_fuzz/ and protocol2_parser_fuzz/)
"""
import os
import sys

PREFIX = bytes([0, 128])  # first line rate of each target, feedback at mid scale


def p1(ident, inst, params=()):
    body = [ident, len(params) + 2, inst, *params]
    return bytes([0xFF, 0xFF, *body, (~sum(body)) & 0xFF])


def crc16(data):
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def stuff(region):
    out = bytearray()
    for byte in region:
        out.append(byte)
        if out[-3:] == b"\xff\xff\xfd":
            out.append(0xFD)
    return bytes(out)


def p2(ident, inst, params=()):
    region = stuff(bytes([inst, *params]))
    length = len(region) + 2
    packet = bytes([0xFF, 0xFF, 0xFD, 0x00, ident, length & 0xFF, length >> 8]) + region
    crc = crc16(packet)
    return packet + bytes([crc & 0xFF, crc >> 8])


def le16(value):
    return [value & 0xFF, value >> 8]


assert crc16(b"123456789") == 0xFEE8  # reference §2.2 check value
assert p2(1, 0x01) == bytes.fromhex("FFFFFD0001030001194E")  # reference §2.2 PING ID 1

# mx-style Protocol 1.0 bus of protocol1_parser_fuzz: servos 1..4, IMU 100, foot board 101.
P1 = {
    "ping": p1(1, 0x01),
    "ping_broadcast": p1(0xFE, 0x01),
    "read_position": p1(1, 0x02, [36, 2]),
    "read_imu": p1(100, 0x02, [0, 8]),
    "write_goal": p1(3, 0x03, [30, 0x00, 0x02]),
    "write_torque_enable": p1(2, 0x03, [24, 1]),
    "reg_write": p1(4, 0x04, [30, 0xFF, 0x01]),
    "action": p1(0xFE, 0x05),
    "reset": p1(1, 0x06),
    "sync_write": p1(0xFE, 0x83, [30, 2, 1, 0x00, 0x02, 2, 0x10, 0x01, 3, 0xFF, 0x03]),
    "bulk_read": p1(0xFE, 0x92, [0x00, 2, 3, 36, 2, 4, 36, 1, 101, 0]),
    "reg_write_then_action": p1(4, 0x04, [30, 0xFF, 0x01]) + p1(0xFE, 0x05),
}

# Protocol 2.0 bus of protocol2_parser_fuzz: XM430 1, 2, XL430 3, IMU 241, BitFoot 101, CORE 42.
XDL = [0x44, 0x58, 0x4C, 0x22]
P2 = {
    "ping": p2(1, 0x01),
    "ping_broadcast": p2(0xFE, 0x01),
    "read_present_position": p2(1, 0x02, [*le16(132), *le16(4)]),
    "write_goal_position": p2(2, 0x03, [*le16(116), 0x00, 0x08, 0x00, 0x00]),
    "write_torque_enable": p2(1, 0x03, [*le16(64), 1]),
    "reg_write": p2(3, 0x04, [*le16(116), 0xFF, 0x07, 0x00, 0x00]),
    "action": p2(0xFE, 0x05),
    "factory_reset": p2(2, 0x06, [0x02]),
    "reboot": p2(1, 0x08),
    "clear_multi_turn": p2(1, 0x10, [0x01, *XDL]),
    "clear_errors": p2(1, 0x10, [0x02, 0x45, 0x52, 0x43, 0x4C]),
    "control_table_backup": p2(1, 0x20, [0x01, 0x43, 0x54, 0x52, 0x4C]),
    "sync_read": p2(0xFE, 0x82, [*le16(132), *le16(4), 1, 2, 3]),
    "sync_write": p2(0xFE, 0x83, [*le16(116), *le16(4), 1, 0, 8, 0, 0, 2, 0xFF, 0xFF, 0xFD, 0]),
    "fast_sync_read": p2(0xFE, 0x8A, [*le16(132), *le16(4), 1, 2, 3]),
    "bulk_read": p2(0xFE, 0x92, [1, *le16(132), *le16(4), 241, *le16(0), *le16(8)]),
    "bulk_write": p2(0xFE, 0x93, [1, *le16(64), *le16(1), 1, 2, *le16(116), *le16(4), 0, 8, 0, 0]),
    "fast_bulk_read": p2(0xFE, 0x9A, [1, *le16(132), *le16(4), 2, *le16(132), *le16(4)]),
    "protocol1_on_the_same_bus": p1(1, 0x02, [36, 2]),
}


def write(directory, packets):
    os.makedirs(directory, exist_ok=True)
    for name in os.listdir(directory):
        os.remove(os.path.join(directory, name))
    for name, packet in packets.items():
        with open(os.path.join(directory, name), "wb") as out:
            out.write(PREFIX + packet)


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "corpus")
    write(os.path.join(root, "protocol1_parser_fuzz"), P1)
    write(os.path.join(root, "protocol2_parser_fuzz"), P2)


if __name__ == "__main__":
    main()
