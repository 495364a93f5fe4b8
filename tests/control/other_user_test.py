#!/usr/bin/env python3
"""Another user of the machine cannot use the user's doppel (docs/security.md).

Starts doppel (as this user: root in CI) with its control API and its TCP handshake on free
loopback ports, then, as a second, unprivileged user (doppel-test-other, made with useradd when it
does not exist), tries what TCP on loopback allows everyone: read the token file, GET /api/state,
POST /api/pause without a token and with a guessed one, list and add robots over the TCP handshake
without the token, and connect to the handshake's Unix socket. Checked: the token file and the
socket cannot be opened, the API answers 401, the handshake answers an Error for "access_token"
and closes, and nothing changed (not paused, still one robot). Then the user's own doppel-ctl works
with no extra step.

usage: other_user_test.py DOPPEL DOPPEL_CTL
Exit 77 (CTest: skipped) when not run as root or without useradd/runuser: it needs a second user.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from doppel_script_test import Api, check, script_test_main, stop_doppel  # noqa: E402

SKIP = 77
OTHER = "doppel-test-other"

# Run as the other user with `python3 -c`: it cannot read this test's files. Prints one JSON object.
PROBE = r'''
import json, socket, struct, sys, urllib.request, urllib.error
api, hs_port, token_files, unix_socket = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(","), sys.argv[4]
out = {}
for path in token_files:
    try:
        open(path).read()
        out["token_file " + path] = "read"
    except OSError as e:
        out["token_file " + path] = type(e).__name__
def http(method, path, token=None):
    headers = {"Content-Type": "application/json"}
    if token:
        headers["Authorization"] = "Bearer " + token
    request = urllib.request.Request(api + path, data=b"{}" if method == "POST" else None, method=method, headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=10) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code
out["get_state"] = http("GET", "api/state")
out["pause"] = http("POST", "api/pause")
out["pause_guessed"] = http("POST", "api/pause", "0" * 32)
def handshake(payload):
    s = socket.create_connection(("127.0.0.1", hs_port), timeout=10)
    s.sendall(struct.pack("<I", len(payload)) + payload)
    data = b""
    while True:
        chunk = s.recv(65536)
        if not chunk:
            break
        data += chunk
    s.close()
    return data.hex()
out["list_robots"] = handshake(b"\x22\x00")                            # ClientMessage{list_robots {}}
out["add_robot"] = handshake(b"\x0a\x09\x0a\x07mx-test" + b"\x7a\x01x")  # add_robot{robot:"mx-test"}, access_token:"x"
try:
    u = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    u.connect(unix_socket)
    out["unix_socket"] = "connected"
except OSError as e:
    out["unix_socket"] = type(e).__name__
print(json.dumps(out))
'''


def ensure_other_user():
    """The unprivileged user of the test: made once (a system user without a home or a login)."""
    if subprocess.run(["id", "-u", OTHER], capture_output=True).returncode == 0:
        return
    made = subprocess.run(["useradd", "--system", "--no-create-home", "--shell", "/usr/sbin/nologin", OTHER],
                          capture_output=True, text=True)
    if made.returncode not in (0, 9):  # 9: made meanwhile by another run
        raise RuntimeError(f"useradd {OTHER}: {made.stderr.strip()}")


def run(doppel, doppel_ctl):
    work = tempfile.mkdtemp(prefix="doppel-other-user-test-")
    links = os.path.join(work, "links")
    process = None
    try:
        output_path = os.path.join(work, "doppel.txt")
        process = subprocess.Popen([doppel, "--robot", "mx-test", "--physics", "none", "--no-camera", "--timing", "fast",
                                    "--viewer", "0", "--handshake-port", "0", "--link-dir", links,
                                    "--state-dir", os.path.join(work, "state")],
                                   stdout=open(output_path, "wb"), stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 120
        text = ""
        while time.monotonic() < deadline and "running until" not in text:
            text = open(output_path, encoding="utf-8", errors="replace").read()
            check(process.poll() is None, f"doppel exited ({process.returncode}):\n{text}")
            time.sleep(0.05)
        control = re.search(r"simulation control on (http://127\.0\.0\.1:\d+)/", text)
        handshake = re.search(r"tcp 127\.0\.0\.1:(\d+)", text)
        check(control and handshake, f"doppel does not say where its API and TCP handshake are:\n{text}")
        url = control.group(1) + "/"
        api = Api(url, links)
        check(api.token and len(api.token) == 32, f"no access token in {links}: {os.listdir(links)}")
        token_files = [os.path.join(links, f) for f in os.listdir(links) if f.startswith("token-")]
        check(len(token_files) == 2, f"doppel wrote {token_files}, not one token file per TCP listener")
        # The test's folder must be passable for the other user to reach the link directory's door.
        os.chmod(work, 0o711)

        probe = subprocess.run(["runuser", "-u", OTHER, "--", "/usr/bin/python3", "-c", PROBE, url, handshake.group(1),
                                ",".join(token_files), os.path.join(links, "handshake.sock")],
                               capture_output=True, text=True, timeout=120, cwd="/")
        check(probe.returncode == 0, f"the other user's probe failed: {probe.stdout}{probe.stderr}")
        seen = json.loads(probe.stdout)
        print(f"other-user test: {OTHER} got {seen}")
        for path in token_files:
            check(seen["token_file " + path] == "PermissionError", f"{OTHER} could open {path}: {seen['token_file ' + path]}")
        check(seen["get_state"] == 401, f"{OTHER}'s GET /api/state got {seen['get_state']}")
        check(seen["pause"] == 401 and seen["pause_guessed"] == 401, f"{OTHER}'s POST /api/pause got {seen}")
        for what in ("list_robots", "add_robot"):
            reply = bytes.fromhex(seen[what])
            check(len(reply) > 5 and reply[4] == 0x2A and b"access_token" in reply,
                  f"{OTHER}'s {what} over TCP was not refused for its token: {reply!r}")
        check(seen["unix_socket"] == "PermissionError", f"{OTHER} reached the handshake socket: {seen['unix_socket']}")

        # Nothing changed, and the user's own tools work without a word about the token.
        state = api.get("api/state")
        check(not state["paused"] and len(state["robots"]) == 1, f"the other user changed doppel: {state}")
        own = subprocess.run([doppel_ctl, "--url", url.rstrip("/"), "--link-dir", links, "pause"],
                             capture_output=True, text=True, timeout=30)
        check(own.returncode == 0 and json.loads(own.stdout)["paused"], f"the user's doppel-ctl pause: {own.stderr}")
        print("other-user test: passed")
    finally:
        stop_doppel(process, work)


def main():
    if os.geteuid() != 0 or shutil.which("useradd") is None or shutil.which("runuser") is None:
        print("SKIPPED: needs root (to make and become a second user with useradd and runuser)")
        return SKIP
    try:
        ensure_other_user()
    except RuntimeError as e:
        print(f"SKIPPED: {e}")
        return SKIP
    return script_test_main("other-user test", __doc__, 2, run)


if __name__ == "__main__":
    sys.exit(main())
