"""What doppel's Python end-to-end tests share: their failure, its check, a JSON request to doppel's
control API, stopping the doppel they started (SIGINT as a user's ^C, then SIGKILL after 30 s) and
their main().

A test puts this folder on sys.path and imports it:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
"""
import json
import shutil
import signal
import subprocess
import sys
import urllib.error
import urllib.request


class Failure(Exception):
    pass


def check(condition, message):
    if not condition:
        raise Failure(message)


def api(url, path, body=None, method=None):
    """`method` (GET without a body, POST with one) of `url + path` with `body` as JSON: the HTTP status
    and the JSON answer, also for an error status."""
    request = urllib.request.Request(url + path, data=None if body is None else json.dumps(body).encode(),
                                     method=method or ("GET" if body is None else "POST"),
                                     headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            return response.status, json.load(response)
    except urllib.error.HTTPError as error:
        return error.code, json.load(error)


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
