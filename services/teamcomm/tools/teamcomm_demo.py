#!/usr/bin/env python3
# The measurement in docs/teamcomm.md: robot 7:1 (port 44001) sends 1000 team messages to a running
# doppel-teamcomm on 127.0.0.1:43737, one every 2 ms; robots 7:2 and 7:3 (44002, 44003) count what
# arrives and how long after it was sent. Loopback only.
import socket, time, statistics
socks = {}
for p in (44001, 44002, 44003):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", p)); s.setblocking(False); socks[p] = s
sent = {}
got = {44002: [], 44003: []}
for i in range(1000):
    sent[i] = time.monotonic()
    socks[44001].sendto(b"%d" % i, ("127.0.0.1", 43737))
    time.sleep(0.002)
    for p in got:
        try:
            while True:
                d = socks[p].recv(100); got[p].append(time.monotonic() - sent[int(d)])
        except BlockingIOError: pass
time.sleep(0.2)
for p in got:
    try:
        while True:
            d = socks[p].recv(100); got[p].append(time.monotonic() - sent[int(d)])
    except BlockingIOError: pass
    print(p, "received", len(got[p]), "of 1000; delay ms min %.1f median %.1f max %.1f" % (min(got[p])*1e3, statistics.median(got[p])*1e3, max(got[p])*1e3))
