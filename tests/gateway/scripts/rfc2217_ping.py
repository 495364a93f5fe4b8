"""PINGs a Protocol 1.0 servo through pyserial's rfc2217:// client, which asks the server for the
line rate (RFC 2217 SET-BAUDRATE). Written from shared/reference/dynamixel.md section 1.

usage: rfc2217_ping.py URL BAUD ID COUNT   (prints "ok N/COUNT"; exit 0 when every PING was answered)
"""
import sys

import serial


def packet(dxl_id, instruction, params=b""):
    body = bytes([dxl_id, len(params) + 2, instruction]) + params
    return b"\xff\xff" + body + bytes([~sum(body) & 0xFF])


def main():
    url, baud, dxl_id, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    # 2 s for each status: on a loaded machine an answer through pyserial, ser2net, the pty and
    # doppel can take far longer than the wire, and one read that gave up too early would pair every
    # later PING with the status before it.
    port = serial.serial_for_url(url, baudrate=baud, timeout=2)
    answered = 0
    for _ in range(count):
        port.write(packet(dxl_id, 0x01))
        answered += port.read(6) == packet(dxl_id, 0x00)  # status: ERR 0 in place of INST
    port.close()
    print("ok %d/%d" % (answered, count))
    return 0 if answered == count else 1


if __name__ == "__main__":
    sys.exit(main())
