# A pyserial controller (written from pyserial's API and the Protocol 1.0 PING of the Dynamixel
# e-Manual): 200 times PING ID 1, read its 6-byte status (select() with a timeout inside pyserial),
# sleep 5 ms (time.sleep: clock_nanosleep). Prints how many answered and the time.monotonic() span.
import sys
import time

import serial

port = serial.Serial(sys.argv[1], 1000000, timeout=0.01)
start = time.monotonic()
answered = 0
for _ in range(200):
    port.write(bytes([0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB]))
    answered += len(port.read(6)) == 6
    time.sleep(0.005)
print("answered=%d elapsed_s=%.6f" % (answered, time.monotonic() - start))
