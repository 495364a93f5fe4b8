#!/usr/bin/python3
"""A control software's side of doppel's session handshake (docs/handshake.md).

Connects to a running doppel (Unix socket or TCP), asks for a robot with a camera, prints where
its links are, pings a servo on the robot's bus with a Dynamixel Protocol 1.0 PING, disconnects,
comes back to the robot with its token, and removes it (unless --keep).

Needs Debian's python3-protobuf and python3-serial (run it with /usr/bin/python3) and the module
handshake_pb2, which the build generates from libs/proto/handshake.proto into build/python
(PYTHONPATH=build/python, or --python-dir, or $DOPPEL_PYTHON_DIR).

Over TCP it sends doppel's access token, which it reads from LINK_DIR/token-PORT (find_token; other
Python scripts import this module for it).

  /usr/bin/python3 programs/examples/handshake/doppel_session.py --robot op3 --camera head --width 320 --height 240
"""

import argparse
import os
import pwd
import socket
import stat
import struct
import sys
import time

MAX_FRAME = 1 << 20  # the server's default maximum (handshake/framing.h)


def import_messages(python_dir):
    """handshake_pb2 from PYTHONPATH, --python-dir, $DOPPEL_PYTHON_DIR or the source tree's build/python."""
    here = os.path.dirname(os.path.abspath(__file__))
    for path in [python_dir, os.environ.get("DOPPEL_PYTHON_DIR"), os.path.join(here, "..", "..", "..", "build", "python")]:
        if path and path not in sys.path and os.path.isfile(os.path.join(path, "handshake_pb2.py")):
            sys.path.insert(0, path)
            break
    try:
        import handshake_pb2  # noqa: PLC0415 (found at run time)
    except ImportError as e:
        sys.exit("doppel_session: cannot import handshake_pb2 (%s); build doppel (target handshake_python) and "
                 "pass --python-dir BUILD/python" % e)
    return handshake_pb2


def default_link_dir():
    """doppel's default link directory (bus/link_directory.h): $XDG_RUNTIME_DIR/doppel when that is a
    directory of the user's that nobody else can write, else /tmp/doppel-USER."""
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    try:
        st = os.stat(runtime) if runtime else None
    except OSError:
        st = None
    if st is not None and stat.S_ISDIR(st.st_mode) and st.st_uid == os.geteuid() and not st.st_mode & 0o022:
        return os.path.join(runtime, "doppel")
    try:
        user = pwd.getpwuid(os.geteuid()).pw_name
    except KeyError:
        user = str(os.geteuid())
    return "/tmp/doppel-%s" % user


def default_socket(link_dir=None):
    return os.path.join(link_dir or default_link_dir(), "handshake.sock")


def find_token(port, link_dir=None):
    """The access token of the doppel (or doppel-replay) serving TCP port `port` (its control API or
    its handshake; docs/security.md), as doppel-ctl finds it: $DOPPEL_TOKEN when set, else the first
    line of LINK_DIR/token-PORT (doppel writes it there, mode 0600). None when there is neither."""
    if os.environ.get("DOPPEL_TOKEN"):
        return os.environ["DOPPEL_TOKEN"].strip()
    try:
        with open(os.path.join(link_dir or default_link_dir(), "token-%d" % int(port)), encoding="ascii") as f:
            return f.readline().strip() or None
    except (OSError, UnicodeDecodeError):
        return None


class Session:
    """One connection: each request gets exactly one reply, framed as a 4-byte little-endian length
    and the serialized message (libs/proto/handshake.proto)."""

    def __init__(self, pb, unix_path=None, tcp=None, timeout_s=30.0, link_dir=None):
        """Over TCP every request carries the run's access token (find_token with `link_dir`); the
        Unix socket needs none."""
        self.pb = pb
        self.token = None
        try:
            if tcp:
                host, _, port = tcp.rpartition(":")
                self.token = find_token(int(port), link_dir)
                self.sock = socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s)
            else:
                self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                self.sock.settimeout(timeout_s)
                self.sock.connect(unix_path)
        except (OSError, ValueError) as e:
            raise ConnectionError("cannot connect to %s: %s (is doppel running?)" % (tcp or unix_path, e)) from e

    def close(self):
        self.sock.close()

    def _read(self, n):
        data = b""
        while len(data) < n:
            chunk = self.sock.recv(n - len(data))
            if not chunk:
                raise ConnectionError("doppel closed the connection")
            data += chunk
        return data

    def call(self, request):
        if self.token:
            request.access_token = self.token
        payload = request.SerializeToString()
        self.sock.sendall(struct.pack("<I", len(payload)) + payload)
        (length,) = struct.unpack("<I", self._read(4))
        if length > MAX_FRAME:
            raise ConnectionError("reply of %d bytes is larger than any doppel sends" % length)
        reply = self.pb.ServerMessage()
        reply.ParseFromString(self._read(length))
        if reply.WhichOneof("kind") == "error":
            raise RuntimeError("doppel refused: %s: %s" % (reply.error.field or "(request)", reply.error.message))
        return reply


def ping(port_path, servo_id, baud):
    """Dynamixel Protocol 1.0 PING (e-Manual, Protocol 1.0: FF FF ID 02 01 CHKSUM); returns the status
    packet's error byte, or raises when no valid status arrives."""
    import serial  # python3-serial

    checksum = (~(servo_id + 2 + 1)) & 0xFF
    with serial.Serial(port_path, baudrate=baud, timeout=0.5) as port:
        port.reset_input_buffer()
        port.write(bytes([0xFF, 0xFF, servo_id, 0x02, 0x01, checksum]))
        status = b""
        deadline = time.monotonic() + 2.0
        while len(status) < 6 and time.monotonic() < deadline:
            status += port.read(6 - len(status))
    if len(status) < 6 or status[0:2] != b"\xff\xff" or status[2] != servo_id or status[3] != 2:
        raise RuntimeError("no status packet from ID %d on %s (got %s)" % (servo_id, port_path, status.hex(" ")))
    if status[5] != (~(status[2] + status[3] + status[4])) & 0xFF:
        raise RuntimeError("status packet with a bad checksum: " + status.hex(" "))
    return status[4]


def print_robot(title, robot):
    print("%s: robot %d (%s)" % (title, robot.robot, robot.name))
    for link in robot.link:
        print("  %-14s %-12s %s" % (link.kind, link.name, link.location))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--unix", metavar="PATH", help="doppel's handshake socket (default: LINK_DIR/handshake.sock)")
    where.add_argument("--tcp", metavar="HOST:PORT", help="doppel's TCP handshake, e.g. 127.0.0.1:7590")
    parser.add_argument("--link-dir", metavar="DIR",
                        help="doppel's link directory (doppel --link-dir): its handshake socket and access token")
    what = parser.add_mutually_exclusive_group()
    what.add_argument("--robot", default=None, help="robot name or file as doppel --robot takes it (default fumanoid-2011)")
    what.add_argument("--description", metavar="FILE", help="send this Robot Description File's text instead")
    parser.add_argument("--camera", metavar="NAME", help="the camera mount to ask for (default: all of the file's)")
    parser.add_argument("--width", type=int, help="camera width in pixels")
    parser.add_argument("--height", type=int, help="camera height in pixels")
    parser.add_argument("--format", help="camera pixel format (rgb24, yuyv, uyvy, bayer_rggb, ...)")
    parser.add_argument("--fps", type=float, help="camera frames per second")
    parser.add_argument("--no-camera", action="store_true", help="ask for no camera")
    parser.add_argument("--world-model", action="store_true", help="ask for the world-model sensor (docs/multilevel.md)")
    parser.add_argument("--world-model-fov", type=float, metavar="DEG", help="its field of view, below 180 (0 = all around)")
    parser.add_argument("--world-model-sigma", type=float, metavar="M", help="its position noise (standard deviation)")
    parser.add_argument("--sensor-levels", action="store_true", help="ask for decoded and true sensor values")
    parser.add_argument("--x", type=float, help="where the robot stands, x in m (field frame)")
    parser.add_argument("--y", type=float, help="where the robot stands, y in m")
    parser.add_argument("--id", type=int, default=1, help="servo ID to ping (default 1)")
    parser.add_argument("--baud", type=int, default=1000000, help="the bus' baud rate (default 1000000)")
    parser.add_argument("--keep", action="store_true", help="leave the robot running (do not remove it)")
    parser.add_argument("--python-dir", help="where handshake_pb2.py is (the build's python folder)")
    args = parser.parse_args()
    pb = import_messages(args.python_dir)

    request = pb.ClientMessage()
    add = request.add_robot
    if args.description:
        with open(args.description, encoding="utf-8") as f:
            add.description = f.read()
    else:
        add.robot = args.robot or "fumanoid-2011"
    if args.x is not None:
        add.x_m = args.x
    if args.y is not None:
        add.y_m = args.y
    if args.no_camera:
        add.cameras_off = True
    elif args.camera:
        camera = add.camera.add(name=args.camera)
        for field, value in (("width_px", args.width), ("height_px", args.height), ("format", args.format),
                             ("fps", args.fps)):
            if value is not None:
                setattr(camera, field, value)

    if args.world_model or args.world_model_fov is not None or args.world_model_sigma is not None:
        add.world_model.SetInParent()  # present = the robot gets one
        if args.world_model_fov is not None:
            add.world_model.fov_deg = args.world_model_fov
        if args.world_model_sigma is not None:
            add.world_model.position_sigma_m = args.world_model_sigma
    add.sensor_levels = args.sensor_levels

    endpoint = {"tcp": args.tcp, "link_dir": args.link_dir} if args.tcp else {"unix_path": args.unix or default_socket(args.link_dir)}
    try:
        session = Session(pb, **endpoint)
        added = session.call(request).robot_added
        print_robot("added", added)
        buses = [link.location for link in added.link if link.kind == "bus"]
        if buses:
            error = ping(buses[0], args.id, args.baud)
            print("PING id %d on %s: answered, error byte 0x%02x" % (args.id, buses[0], error))
        else:
            print("no bus link to ping")
        session.close()  # the robot stays; its token brings us back

        session = Session(pb, **endpoint)
        again = pb.ClientMessage()
        again.reattach.token = added.token
        back = session.call(again).reattached
        if back.robot != added.robot or list(back.link) != list(added.link):
            raise RuntimeError("reattached to robot %d with other links than robot %d had" % (back.robot, added.robot))
        print_robot("reattached", back)
        if not args.keep:
            remove = pb.ClientMessage()
            remove.remove_robot.robot = added.robot
            session.call(remove)
            print("removed: robot %d" % added.robot)
        session.close()
    except (OSError, RuntimeError, ConnectionError) as e:
        sys.exit("doppel_session: %s" % e)


if __name__ == "__main__":
    main()
