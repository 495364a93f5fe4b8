"""A pyserial driver that flushes its output after every packet, as pypot-style drivers do.

Sends COUNT Protocol 1.0 SYNC WRITEs of Goal Position (address 30, 2 bytes) to IDs 1, 2 and 3
(shared/reference/dynamixel.md, section 1.7: FF FF FE LEN 83 1E 02 (ID LO HI)... CKSUM), each followed
at once by flushOutput() (tcflush TCOFLUSH) and the next packet, then READs the goal positions back.
Prints "sent N" and "goal ID VALUE" per servo; exit 0 when every read-back equals the last write.
Usage: python3 sync_write_flush.py DEVICE COUNT
"""
import sys
import time

import serial


def packet(ident, instruction, params):
    body = [ident, len(params) + 2, instruction] + params
    return bytes([0xFF, 0xFF] + body + [(~sum(body)) & 0xFF])


def goal(i, servo):
    return 1024 + (i * 7 + servo * 100) % 2048


def main():
    device, count = sys.argv[1], int(sys.argv[2])
    port = serial.Serial(device, 1000000, timeout=0.5)
    port.reset_input_buffer()
    for i in range(count):
        params = [30, 2]
        for servo in (1, 2, 3):
            value = goal(i, servo)
            params += [servo, value & 0xFF, value >> 8]
        port.write(packet(0xFE, 0x83, params))
        port.flushOutput()
    print("sent", count)
    # A USB adapter paces the writes at the line rate; a pty takes them at once and Doppel's wire
    # model serves them at 1 Mbps: let the last packet cross (10 bits per byte) before reading back.
    time.sleep(count * len(packet(0xFE, 0x83, params)) * 10 / 1000000 + 0.1)
    ok = True
    for servo in (1, 2, 3):
        port.reset_input_buffer()
        port.write(packet(servo, 0x02, [30, 2]))
        reply = port.read(8)
        value = reply[5] | (reply[6] << 8) if len(reply) == 8 else -1
        print("goal", servo, value)
        ok = ok and value == goal(count - 1, servo)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
