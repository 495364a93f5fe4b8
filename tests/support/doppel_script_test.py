"""What doppel's Python end-to-end tests share: their failure, its check, JSON requests to doppel's
control API with the run's access token (found as every client finds it:
programs/examples/handshake/doppel_session.py's find_token), stopping the doppel they started (SIGINT as a user's ^C, then SIGKILL after 30 s) and
their main().

A test puts this folder on sys.path and imports it:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import urllib.error
import urllib.parse
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "programs", "examples", "handshake"))
from doppel_session import find_token  # noqa: E402  (the one way to find the token)


class Failure(Exception):
    pass


def check(condition, message):
    if not condition:
        raise Failure(message)


class Api:
    """doppel's control API at `url` (http://127.0.0.1:PORT/) as doppel-ctl uses it: with the access token
    of `link_dir` (doppel --link-dir) for that port. Calling it makes one request."""

    def __init__(self, url, link_dir):
        self.url = url
        self.token = find_token(urllib.parse.urlsplit(url).port or 80, link_dir)

    def __call__(self, path, body=None, method=None):
        """`method` (GET without a body, POST with one) of `url + path` with `body` as JSON: the HTTP
        status and the JSON answer, also for an error status."""
        status, _, data = self.raw(path, body, method)
        return status, json.loads(data)

    def raw(self, path, body=None, method=None, timeout=10):
        """As a call, but the status, Content-Type and the answer's bytes (a camera's still)."""
        headers = {"Content-Type": "application/json"}
        if self.token:
            headers["Authorization"] = "Bearer " + self.token
        request = urllib.request.Request(self.url + path, data=None if body is None else json.dumps(body).encode(),
                                         method=method or ("GET" if body is None else "POST"), headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=timeout) as response:
                return response.status, response.headers["Content-Type"], response.read()
        except urllib.error.HTTPError as error:
            return error.code, error.headers["Content-Type"], error.read()

    def get(self, path):
        """GET `path`'s JSON answer; a Failure unless it is 200."""
        status, answer = self(path)
        check(status == 200, f"GET {path}: {status} {answer}")
        return answer


def stop_doppel(process, work):
    """Stops `process` (a doppel this test started, or None) and removes the test's folder `work`."""
    if process is not None and process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
    shutil.rmtree(work, ignore_errors=True)


def script_test_main(name, doc, argument_count, run):
    """Runs `run(*arguments)` with the command line's `argument_count` arguments: 0 passed, 1 failed
    (a Failure, printed), 2 bad usage (prints `doc`)."""
    if len(sys.argv) != argument_count + 1:
        print(doc)
        return 2
    try:
        run(*sys.argv[1:])
    except Failure as failure:
        print(f"{name}: FAILED: {failure}")
        return 1
    return 0
