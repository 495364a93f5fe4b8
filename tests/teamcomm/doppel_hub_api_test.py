#!/usr/bin/python3
"""The team-communication hub inside doppel (--teamcomm), robots registered while it runs.

Two robots' software (loopback sockets on ports the system picks) are registered through
POST /api/teamcomm/robots and doppel-ctl teamcomm add; a team message one sends to the hub reaches
the other, byte for byte, and not the sender; GET /api/teamcomm counts the relay on its link;
after DELETE the removed robot hears nothing; a bad registration names its field. Loopback only.

usage: doppel_hub_api_test.py DOPPEL DOPPEL_CTL
"""
import json
import os
import re
import socket
import subprocess
import sys
import tempfile
import time


sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from doppel_script_test import Api, Failure, check, script_test_main, stop_doppel  # noqa: E402


def receive(sock, timeout):
    sock.settimeout(timeout)
    try:
        return sock.recv(65536)
    except socket.timeout:
        return None


def run(doppel, doppel_ctl):
    work = tempfile.mkdtemp(prefix="doppel-hub-test-")
    a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    a.bind(("127.0.0.1", 0))
    b.bind(("127.0.0.1", 0))
    process = None
    try:
        output_path = os.path.join(work, "doppel.txt")
        process = subprocess.Popen([doppel, "--physics", "none", "--no-camera", "--timing", "fast", "--viewer", "0",
                                    "--link-dir", os.path.join(work, "links"), "--state-dir", os.path.join(work, "state"),
                                    "--teamcomm", "127.0.0.1:0"], stdout=open(output_path, "wb"), stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 120
        url = None
        while url is None and time.monotonic() < deadline:
            text = open(output_path, encoding="utf-8", errors="replace").read()
            match = re.search(r"simulation control on (http://127\.0\.0\.1:\d+)/", text)
            if match:
                url = match.group(1) + "/"
            elif process.poll() is not None:
                raise Failure(f"doppel exited ({process.returncode}):\n{text}")
            else:
                time.sleep(0.05)
        check(url is not None, "doppel did not start serving within 120 s")
        api = Api(url, os.path.join(work, "links"))
        hub_match = re.search(r"team communication hub on 127\.0\.0\.1:(\d+), 0 robots", text)
        check(hub_match, f"doppel does not say where its hub listens:\n{text}")
        hub = ("127.0.0.1", int(hub_match.group(1)))

        # Registration: a through the API, b through doppel-ctl.
        status, answer = api("api/teamcomm/robots", {"team": 7, "player": 1, "port": a.getsockname()[1]})
        check(status == 200, f"POST /api/teamcomm/robots: {status} {answer}")
        done = subprocess.run([doppel_ctl, "--url", url.rstrip("/"), "--link-dir", os.path.join(work, "links"), "teamcomm", "add", "7", "2", str(b.getsockname()[1])],
                              capture_output=True, text=True, timeout=30)
        check(done.returncode == 0, f"doppel-ctl teamcomm add: {done.returncode} {done.stderr}")
        _, robots = api("api/teamcomm/robots")
        check(sorted((r["team"], r["player"]) for r in robots) == [(7, 1), (7, 2)], f"registered: {robots}")

        message = bytes(range(256)) * 3
        a.sendto(message, hub)
        check(receive(b, 5) == message, "robot 7:2 did not receive 7:1's message byte for byte")
        check(receive(a, 0.3) is None, "the sender received its own message back")
        b.sendto(b"from 7:2", hub)
        check(receive(a, 5) == b"from 7:2", "robot 7:1 did not receive 7:2's message")
        # The hub counts a relay after its send: the receiver may have the message first.
        deadline = time.monotonic() + 5
        while True:
            _, status_now = api("api/teamcomm")
            links = {(l["from"]["player"], l["to"]["player"]): l for l in status_now["links"]}
            if (links[(1, 2)]["relayed"] == 1 and links[(2, 1)]["relayed"] == 1) or time.monotonic() > deadline:
                break
            time.sleep(0.01)
        check(links[(1, 2)]["relayed"] == 1 and links[(2, 1)]["relayed"] == 1, f"link counters: {status_now['links']}")
        check(status_now["received"] == 2, f"received {status_now['received']}, 2 were sent")

        # A bad registration names its field and changes nothing; a second 7:2 is refused.
        status, error = api("api/teamcomm/robots", {"team": 7, "player": 3, "port": 0})
        check(status == 400 and "'port'" in error["error"], f"port 0: {status} {error}")
        status, error = api("api/teamcomm/robots", {"team": 7, "player": 2, "port": 40999})
        check(status == 409 and "7:2 is registered twice" in error["error"], f"7:2 again: {status} {error}")
        done = subprocess.run([doppel_ctl, "--url", url.rstrip("/"), "--link-dir", os.path.join(work, "links"), "teamcomm", "add", "7", "3", "0"],
                              capture_output=True, text=True, timeout=30)
        check(done.returncode != 0, "doppel-ctl teamcomm add with port 0 succeeded")

        # Removed (7:2 through the API, a third one through doppel-ctl), 7:2 hears nothing more.
        status, answer = api("api/teamcomm/robots/7/2", method="DELETE")
        check(status == 200 and len(answer["robots"]) == 1, f"DELETE 7/2: {status} {answer}")
        api("api/teamcomm/robots", {"team": 8, "player": 1, "port": 40998})
        done = subprocess.run([doppel_ctl, "--url", url.rstrip("/"), "--link-dir", os.path.join(work, "links"), "teamcomm", "remove", "8", "1"],
                              capture_output=True, text=True, timeout=30)
        check(done.returncode == 0 and [r["team"] for r in json.loads(done.stdout)["robots"]] == [7],
              f"doppel-ctl teamcomm remove: {done.returncode} {done.stdout} {done.stderr}")
        status, error = api("api/teamcomm/robots/7/2", method="DELETE")
        check(status == 404 and "7:2" in error["error"], f"DELETE 7/2 again: {status} {error}")
        a.sendto(b"after", hub)
        check(receive(b, 0.5) is None, "a removed robot still receives its team's messages")
        print("doppel hub API test: passed")
    finally:
        a.close()
        b.close()
        stop_doppel(process, work)


if __name__ == "__main__":
    sys.exit(script_test_main("doppel hub API test", __doc__, 2, run))
