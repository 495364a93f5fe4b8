#!/usr/bin/python3
"""A minimal controller for scenario tests: switches every servo of a Protocol 1.0 bus on with one
broadcast WRITE of Torque Enable (address 24, e-Manual RX/AX control table) and holds the port open
until it is stopped, so the robot stands stiff in its initial pose. Usage: stand_stiff.py PORT [BAUD]"""
import sys
import time

import serial

port = serial.Serial(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 1000000, timeout=0.1)
body = [0xFE, 4, 0x03, 24, 1]  # ID broadcast, length, WRITE, address, value
port.write(bytes([0xFF, 0xFF] + body + [(~sum(body)) & 0xFF]))
port.flush()
print("torque on", flush=True)
while True:
    time.sleep(1)
