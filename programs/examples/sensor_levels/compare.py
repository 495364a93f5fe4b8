#!/usr/bin/python3
"""Sensor levels, a runnable example (docs/multilevel.md, "Sensor levels").

Reads Present Position of one servo over doppel's pty, as a Protocol 1.0 driver does, and the same
servo's decoded and true values from the `sensor_levels` topic that `doppel --sensor-levels HZ`
publishes over UDP, and prints the three levels side by side.

    doppel --no-camera --sensor-levels 50 &
    /usr/bin/python3 programs/examples/sensor_levels/compare.py --id 15

Needs Debian's python3-protobuf, python3-serial and protoc (protobuf-compiler): the message classes
are generated from libs/proto/*.proto into a temporary folder at start.
"""
import argparse
import math
import os
import socket
import subprocess
import sys
import tempfile

import serial

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


def load_messages():
    out = tempfile.mkdtemp(prefix="doppel-levels-")
    proto = os.path.join(ROOT, "libs", "proto")
    subprocess.run(["protoc", "-I", proto, "--python_out", out, os.path.join(proto, "truth.proto"),
                    os.path.join(proto, "sensor_levels.proto")], check=True)
    sys.path.insert(0, out)
    import truth_pb2
    import sensor_levels_pb2
    return truth_pb2, sensor_levels_pb2


def read_present_position(link, baud, servo_id):
    """READ (0x02) of Present Position (36), 2 bytes: FF FF ID 4 0x02 36 2 CKSUM (e-Manual, Protocol 1.0)."""
    body = [servo_id, 4, 0x02, 36, 2]
    packet = bytes([0xFF, 0xFF] + body + [(~sum(body)) & 0xFF])
    with serial.Serial(link, baud, timeout=0.5) as port:
        port.reset_input_buffer()
        port.write(packet)
        reply = port.read(8)
    if len(reply) != 8 or reply[:3] != bytes([0xFF, 0xFF, servo_id]):
        raise SystemExit(f"no status from ID {servo_id} on {link}: {reply.hex()}")
    return reply[5] | (reply[6] << 8)


def main():
    default_link = os.path.join(os.environ.get("XDG_RUNTIME_DIR", "/tmp"), "doppel", "ttyDXL0")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--link", default=default_link, help="the bus' pty link (default %(default)s)")
    parser.add_argument("--baud", type=int, default=1000000)
    parser.add_argument("--id", type=int, default=15, help="the servo's ID")
    parser.add_argument("--robot", type=int, default=0, help="the robot's index")
    parser.add_argument("--udp-port", type=int, default=7600, help="doppel's --truth-udp-port (robot N: + N)")
    parser.add_argument("--timeout", type=float, default=10.0)
    args = parser.parse_args()

    truth_pb2, sensor_levels_pb2 = load_messages()
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", args.udp_port + args.robot))
    receiver.settimeout(args.timeout)
    raw = read_present_position(args.link, args.baud, args.id)
    while True:
        packet = truth_pb2.Packet()
        packet.ParseFromString(receiver.recv(65536))
        if packet.topic != "sensor_levels" or packet.robot != args.robot:
            continue
        levels = sensor_levels_pb2.SensorLevels()
        levels.ParseFromString(packet.payload)
        servo = next((s for s in levels.servos if s.id == args.id), None)
        if servo is None:
            raise SystemExit(f"robot {args.robot} has no servo with ID {args.id}")
        break
    d, t = servo.decoded, servo.truth
    print(f"{servo.name} (ID {servo.id}, {servo.model}) at t = {servo.sim_time_ns * 1e-9:.3f} s of simulation")
    print(f"  bytes    Present Position read over the pty: {raw}")
    print(f"  decoded  Present Position {d.present_position_raw} = {math.degrees(d.present_position_rad):8.3f} deg, "
          f"speed {d.present_speed_rad_s:7.3f} rad/s, load {100 * d.present_load_ratio:6.1f} %, "
          f"{d.present_temperature_c:.0f} C, {d.present_voltage_v:.1f} V")
    print(f"  truth    angle {math.degrees(t.angle_rad):8.3f} deg, velocity {t.velocity_rad_s:7.3f} rad/s, "
          f"torque {t.torque_nm:.4f} N m ({100 * t.load_ratio:.1f} %), {t.temperature_c:.1f} C, {t.voltage_v:.1f} V")


if __name__ == "__main__":
    main()
