#!/usr/bin/env python3
"""The web viewer as a person uses it, in headless Chromium (Debian's `chromium`).

Starts doppel with its viewer on a free port, opens the page, and checks: the 3D view draws the
robot (the page's robot count, and the pixel under the robot's trunk is not carpet), the servo
table lists the robot's servos, a click on Pause pauses the simulation (simulation time stands
still), a shift-click on the carpet places the robot there, a click on Step while running shows
the API's refusal, Resume lets simulation time run on; the bus counters count the test's own PINGs,
every IMU and foot-board plot has a line drawn, each camera of the robot has a frustum in the 3D
view and the camera panel shows a still of the camera with carpet in it; then it saves a screenshot.

Chromium is driven through its DevTools protocol over --remote-debugging-pipe (file descriptors
3 and 4, JSON messages ended by NUL), so no websocket library or npm package is needed.
Judged on simulation time and on what the API reports, never on wall-clock pace.

usage: viewer_browser_test.py DOPPEL OUTPUT_DIR
Exit 77 (CTest: skipped) only when chromium is not installed.
"""

import base64
import json
import os
import re
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from doppel_script_test import Api, Failure, check  # noqa: E402  (requests with the run's access token)

SKIP = 77
ROBOT = "fumanoid-2011"  # doppel's default robot


def tear_down(browser, process, work, out_dir, logs):
    """Closes the browser, stops the server `process`, keeps its `logs` (names under `work`) in
    `out_dir` for a failed run to be read, and removes `work`."""
    if browser is not None:
        browser.close()
    process.terminate()
    try:
        process.wait(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
    for name in logs:
        path = os.path.join(work, name)
        if os.path.exists(path):
            shutil.copy(path, os.path.join(out_dir, os.path.basename(name)))
    shutil.rmtree(work, ignore_errors=True)


def browser_test_main(name, doc, argument_count, run):
    """The command line of a browser test: `argument_count` arguments handed to run(..., chromium);
    exit 2 on a bad command line, SKIP without chromium, 1 on a Failure."""
    if len(sys.argv) != argument_count + 1:
        print(doc)
        return 2
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("SKIPPED: chromium is not installed (scripts/setup installs Debian's chromium)")
        return SKIP
    try:
        run(*sys.argv[1:], chromium)
    except Failure as e:
        print(f"{name}: FAILED: {e}")
        return 1
    return 0


class Browser:
    """Headless Chromium and a DevTools session with its one page."""

    def __init__(self, executable, profile, width=1280, height=900, extra_args=()):
        to_browser_read, to_browser_write = os.pipe()
        from_browser_read, from_browser_write = os.pipe()

        def child_fds():  # Chromium reads its commands from fd 3 and writes to fd 4
            read_end, write_end = os.dup(to_browser_read), os.dup(from_browser_write)  # above 4 once 3, 4 are taken
            os.dup2(read_end, 3)
            os.dup2(write_end, 4)

        self.process = subprocess.Popen(
            [executable, "--headless=new", "--remote-debugging-pipe", "--no-sandbox", "--no-first-run",
             "--no-default-browser-check", "--disable-gpu-sandbox", "--use-angle=swiftshader",
             "--enable-unsafe-swiftshader", "--disable-dev-shm-usage", f"--user-data-dir={profile}",
             f"--window-size={width},{height}", *extra_args, "about:blank"],
            pass_fds=(3, 4), preexec_fn=child_fds, start_new_session=True,
            stdout=subprocess.DEVNULL, stderr=open(os.path.join(profile, "chromium.log"), "wb"))
        os.close(to_browser_read)
        os.close(from_browser_write)
        self.out = os.fdopen(to_browser_write, "wb", buffering=0)
        self.inp = os.fdopen(from_browser_read, "rb", buffering=0)
        self.buffer = b""
        self.next_id = 0
        self.session = None
        self.events = []

    def _read_message(self):
        while b"\0" not in self.buffer:
            chunk = self.inp.read(65536)
            if not chunk:
                raise Failure("chromium closed its DevTools pipe (see chromium.log in the output folder)")
            self.buffer += chunk
        message, self.buffer = self.buffer.split(b"\0", 1)
        return json.loads(message)

    def call(self, method, params=None, session=True):
        self.next_id += 1
        request = {"id": self.next_id, "method": method, "params": params or {}}
        if session and self.session is not None:
            request["sessionId"] = self.session
        self.out.write(json.dumps(request).encode() + b"\0")
        while True:
            message = self._read_message()
            if message.get("id") == self.next_id:
                if "error" in message:
                    raise Failure(f"DevTools {method}: {message['error']}")
                return message.get("result", {})
            self.events.append(message)

    def open(self, url):
        targets = self.call("Target.getTargets", session=False)["targetInfos"]
        page = next(t for t in targets if t["type"] == "page")
        self.session = self.call("Target.attachToTarget", {"targetId": page["targetId"], "flatten": True},
                                 session=False)["sessionId"]
        self.call("Page.enable")
        self.call("Runtime.enable")
        self.call("Page.navigate", {"url": url})

    def evaluate(self, expression):
        result = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True, "awaitPromise": True})
        if "exceptionDetails" in result:
            raise Failure(f"page script failed: {expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def wait_for(self, expression, what, timeout_s=60):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                value = self.evaluate(expression)
            except Failure:
                value = None
            if value:
                return value
            time.sleep(0.1)
        raise Failure(f"timed out waiting for {what} ({expression}); page error: {self.page_error()}")

    def page_error(self):
        try:
            return self.evaluate("window.doppelViewer ? window.doppelViewer.error() : 'no viewer script'")
        except Failure as e:
            return str(e)

    def click(self, x, y, shift=False):
        """A left click at page pixel (x, y), as a mouse makes it."""
        modifiers = 8 if shift else 0
        self.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": x, "y": y, "modifiers": modifiers})
        for kind in ("mousePressed", "mouseReleased"):
            self.call("Input.dispatchMouseEvent",
                      {"type": kind, "x": x, "y": y, "button": "left", "buttons": 1 if kind == "mousePressed" else 0,
                       "clickCount": 1, "modifiers": modifiers})

    def click_element(self, selector):
        """A click on the middle of the element `selector` (CSS), scrolled into view first."""
        box = self.evaluate(f"(() => {{ const e = document.querySelector({json.dumps(selector)});"
                            " e.scrollIntoView({block: 'center'}); const r = e.getBoundingClientRect();"
                            " return {x: r.left + r.width / 2, y: r.top + r.height / 2}; })()")
        self.click(box["x"], box["y"])

    def screenshot(self, path):
        data = self.call("Page.captureScreenshot", {"format": "png"})["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))

    def close(self):
        try:
            self.call("Browser.close", session=False)
        except Exception:
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        try:
            os.killpg(self.process.pid, signal.SIGKILL)  # its helper processes, if any outlived it
        except ProcessLookupError:
            pass


def get_state(api):
    return api.get("api/state")


def get_game(api):
    return api.get("api/game")


def get_faults(api):
    return api.get("api/faults")


def wait_sim_time(api, seconds, what, timeout_s=60):
    """Waits until simulation time has advanced by `seconds` (judged on simulation time)."""
    start = get_state(api)["sim_time_s"]
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if get_state(api)["sim_time_s"] >= start + seconds:
            return
        time.sleep(0.05)
    raise Failure(f"simulation time did not advance by {seconds} s ({what})")


def ping(link, servo_id, count):
    """Sends `count` Protocol 1.0 PINGs to `servo_id` on the bus at `link`; returns how many were answered."""
    import termios
    import tty
    fd = os.open(link, os.O_RDWR | os.O_NOCTTY)
    try:
        tty.setraw(fd)
        attributes = termios.tcgetattr(fd)
        attributes[4] = attributes[5] = termios.B1000000
        termios.tcsetattr(fd, termios.TCSANOW, attributes)
        answered = 0
        for _ in range(count):
            packet = bytes([0xFF, 0xFF, servo_id, 2, 0x01])
            os.write(fd, packet + bytes([~(servo_id + 2 + 0x01) & 0xFF]))
            reply = b""
            deadline = time.monotonic() + 5
            while len(reply) < 6 and time.monotonic() < deadline:
                ready, _, _ = select.select([fd], [], [], 0.1)
                if ready:
                    reply += os.read(fd, 6 - len(reply))
            answered += reply[:3] == bytes([0xFF, 0xFF, servo_id]) and len(reply) == 6
        return answered
    finally:
        os.close(fd)


def start_doppel(doppel, work, extra=()):
    """doppel with its viewer on a free port: the process, its API (with the run's token) and the
    page's link as doppel prints it (http://127.0.0.1:PORT/?token=...)."""
    output_path = os.path.join(work, "doppel.txt")
    output = open(output_path, "wb")
    links = os.path.join(work, "links")
    process = subprocess.Popen([doppel, "--viewer", "0", "--no-camera", "--timing", "fast",
                                "--link-dir", links, "--state-dir", os.path.join(work, "state"), *extra],
                               stdout=output, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        text = open(output_path, encoding="utf-8", errors="replace").read()
        match = re.search(r"viewer on ((http://127\.0\.0\.1:\d+/)\S*)", text)
        if match:
            return process, Api(match.group(2), links), match.group(1)
        if process.poll() is not None:
            raise Failure(f"doppel exited ({process.returncode}) before serving its viewer:\n{text}")
        time.sleep(0.05)
    raise Failure("doppel did not say where its viewer is within 120 s")


def run(doppel, out_dir, chromium):
    work = tempfile.mkdtemp(prefix="doppel-viewer-test-")
    os.makedirs(out_dir, exist_ok=True)
    # A robot's GameController listener on a loopback port the system picks; doppel's GameController
    # (off until the page turns it on) sends there and receives return packets on any free port.
    robot = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    robot.bind(("127.0.0.1", 0))
    process, api, page = start_doppel(doppel, work, ("--gc-destination", f"127.0.0.1:{robot.getsockname()[1]}",
                                               "--gc-return", "127.0.0.1:0", "--gc-watch", "off"))
    browser = None
    try:
        profile = os.path.join(work, "chromium")
        os.makedirs(profile)
        browser = Browser(chromium, profile)
        browser.open(page)

        # The robot is drawn: its shapes are in the 3D scene and the frame shows it.
        robots = browser.wait_for("window.doppelViewer && window.doppelViewer.robotCount()", "the robot in the 3D view")
        check(robots == 1, f"the view draws {robots} robots, doppel simulates 1")
        # A live doppel is no replay: no timeline (tests/replay/replay_browser_test.py has it).
        check(not browser.evaluate("window.doppelViewer.timelineShown()"), "a live doppel's page shows the replay timeline")
        check(not browser.evaluate("window.doppelViewer.analysisShown()"), "a live doppel's page shows the Bus panel")
        browser.wait_for("window.doppelViewer.frames() > 5 && window.doppelViewer.sceneUpdates() > 2", "frames drawn")
        # The pixel under the robot's trunk is not the carpet's colour: the robot is drawn there. The
        # page fetches the scene it draws and the state whose pose is looked up here in two requests,
        # so the simulation stands still meanwhile: on a loaded machine the robot had moved between
        # them and the pixel missed it. Paused, the next scene and a frame drawn after it show the
        # state's instant.
        status, answer = api("api/pause", {})
        check(status == 200, f"POST api/pause: {status} {answer}")
        browser.wait_for("window.doppelViewer.state() && window.doppelViewer.state().paused", "the page to show 'paused'")
        updates = browser.evaluate("window.doppelViewer.sceneUpdates()")
        browser.wait_for(f"window.doppelViewer.sceneUpdates() > {updates + 1}", "a scene fetched while paused")
        drawn = browser.evaluate("window.doppelViewer.frames()")
        browser.wait_for(f"window.doppelViewer.frames() > {drawn + 1}", "a frame drawn of it")
        pixel = browser.evaluate("""(() => {
            const v = window.doppelViewer, s = v.state().robots[0].pose;
            const canvas = document.getElementById('canvas');
            const p = v.pageXY(s.x, s.y, s.z + 0.25), r = canvas.getBoundingClientRect();
            const copy = document.createElement('canvas');
            copy.width = canvas.width; copy.height = canvas.height;
            const g = copy.getContext('2d');
            g.drawImage(canvas, 0, 0);
            const k = canvas.width / r.width;
            const robot = g.getImageData(Math.round((p.x - r.left) * k), Math.round((p.y - r.top) * k), 1, 1).data;
            const c = v.pageXY(s.x + 0.6, s.y + 0.6, 0);
            const carpet = g.getImageData(Math.round((c.x - r.left) * k), Math.round((c.y - r.top) * k), 1, 1).data;
            return {robot: Array.from(robot.slice(0, 3)), carpet: Array.from(carpet.slice(0, 3))};
        })()""")
        difference = sum(abs(a - b) for a, b in zip(pixel["robot"], pixel["carpet"]))
        check(difference > 30, f"the pixel at the robot's trunk {pixel['robot']} looks like the carpet {pixel['carpet']}")
        status, answer = api("api/resume", {})
        check(status == 200, f"POST api/resume: {status} {answer}")
        browser.wait_for("!window.doppelViewer.state().paused", "the page to show 'running'")

        # The servo table lists every servo of the robot's bus.
        rows = browser.wait_for("window.doppelViewer.servoRows()", "the servo table")
        buses = browser.evaluate("window.doppelViewer.buses()")
        servos = sum(len(bus["servos"]) for bus in buses)
        check(servos > 0 and rows == servos, f"the servo table shows {rows} rows, the API {servos} servos")
        first = browser.evaluate("document.querySelector('#buses table.servo-table tbody tr').innerText")
        check(str(buses[0]["servos"][0]["id"]) in first and buses[0]["servos"][0]["name"] in first,
              f"the first row '{first}' is not servo {buses[0]['servos'][0]}")

        # Bus counters: the test's own PINGs on the bus are counted, and the page shows them.
        link = buses[0]["link"]
        servo_id = buses[0]["servos"][0]["id"]
        before = browser.evaluate("window.doppelViewer.buses()")[0]["counters"]["packets"]
        pings = ping(link, servo_id, 3)
        check(pings == 3, f"servo {servo_id} on {link} answered {pings} of 3 PINGs")
        shown = browser.wait_for(f"(() => {{ const c = window.doppelViewer.busCounters()[0]; "
                                 f"return c && Number(c.packets) >= {before + 3} && Number(c.replies) >= 3 && c; }})()",
                                 "the bus counters to count the test's PINGs")
        check(shown["bad_checksums"] == "0" and shown["collisions"] == "0",
              f"the bus counters show errors after three good PINGs: {shown}")

        # Sensor plots: one for the IMU's angles, one for its gyro, one per foot board, each with a
        # line drawn (pixels that are not the white background, below the legend).
        state = get_state(api)["robots"][0]
        check(len(state["imus"]) >= 1 and len(state["feet"]) >= 2,
              f"the state lists {len(state['imus'])} IMUs and {len(state['feet'])} foot boards")
        wanted = 2 * len(state["imus"]) + len(state["feet"])
        ink = browser.wait_for(f"(() => {{ const ink = window.doppelViewer.plotInk(); "
                               f"return ink.length === {wanted} && ink.every((n) => n > 100) && ink; }})()",
                               "a line in every sensor plot")
        titles = browser.evaluate("window.doppelViewer.plotTitles()")
        for foot in state["feet"]:
            check(any(t.startswith(foot["name"]) for t in titles), f"no plot for foot board {foot['name']}: {titles}")
        # The held robot stands on its feet: the plotted totals carry its weight (> 0 N).
        check(sum(f["total"] for f in state["feet"]) > 1.0, f"the feet carry nothing: {state['feet']}")
        print(f"viewer test: plots {titles}, ink {ink}")

        # Camera frustums: one per camera of the robot's figure, drawn at the camera's pose.
        cameras = len(state["cameras"])
        check(cameras >= 1, "the robot's figure has no camera in the state")
        frustums = browser.wait_for("window.doppelViewer.frustumCount()", "the camera frustums")
        check(frustums == cameras, f"the view draws {frustums} frustums for {cameras} cameras")

        # The camera panel shows the first camera's still: a PNG of the camera's size with carpet in it.
        image = browser.wait_for("window.doppelViewer.cameraImages() > 0 && window.doppelViewer.cameraImage()",
                                 "the camera image")
        status, content_type, png = api.raw("api/camera/" + state["cameras"][0]["name"], timeout=30)
        check(status == 200 and content_type == "image/png" and png[:8] == b"\x89PNG\r\n\x1a\n",
              f"/api/camera/{state['cameras'][0]['name']} is not a PNG ({status}, {content_type})")
        width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
        check((image["width"], image["height"]) == (width, height),
              f"the page shows a {image['width']}x{image['height']} image, the camera's still is {width}x{height}")
        check(image["green"] > 10, f"the camera image shows no carpet ({image['green']} of 192 samples green)")

        # Step while running: the API refuses it, the page says why.
        browser.click_element("#step")
        message = browser.wait_for("window.doppelViewer.error()", "the refusal of a step while running")
        check("pause first" in message, f"the page shows '{message}' for a step while running")

        # Pause: simulation time stands still.
        browser.click_element("#pause")
        browser.wait_for("window.doppelViewer.state() && window.doppelViewer.state().paused", "the page to show 'paused'")
        check(get_state(api)["paused"], "doppel is not paused after a click on Pause")
        frozen = get_state(api)["sim_time_s"]
        time.sleep(0.3)
        check(get_state(api)["sim_time_s"] == frozen, "simulation time runs on while paused")

        # Shift-click on the carpet places the robot there (paused: it stays where it was put).
        target = (0.5, -0.3)
        where = browser.evaluate(f"window.doppelViewer.pageXY({target[0]}, {target[1]}, 0)")
        browser.click(where["x"], where["y"], shift=True)
        deadline = time.monotonic() + 20
        pose = None
        while time.monotonic() < deadline:
            pose = get_state(api)["robots"][0]["pose"]
            if abs(pose["x"] - target[0]) < 0.03 and abs(pose["y"] - target[1]) < 0.03:
                break
            time.sleep(0.1)
        check(abs(pose["x"] - target[0]) < 0.03 and abs(pose["y"] - target[1]) < 0.03,
              f"a shift-click at {target} placed the robot at ({pose['x']:.3f}, {pose['y']:.3f}); page: {browser.page_error()}")
        # The view follows: the trunk is drawn where the robot now is (scene polled after the place).
        browser.wait_for(f"(() => {{ const s = window.doppelViewer.scene(); return s && s.shapes.some("
                         f"(x) => x.kind === 'robot' && Math.abs(x.p[0] - {target[0]}) < 0.3 && Math.abs(x.p[1] - ({target[1]})) < 0.3); }})()",
                         "the robot's shapes at its new place")

        # A push button sends the push for the selected robot (held by the start-up handler, it
        # does not move; docs/control.md) and the page confirms it.
        browser.click_element('#push-buttons button[data-fx="30"]')
        message = browser.wait_for("document.getElementById('message').textContent.startsWith('pushed robot 0') && "
                                   "document.getElementById('message').textContent", "the push's confirmation")
        check("30 N x" in message, f"the page says '{message}' after a click on +x")
        check(browser.evaluate("window.doppelViewer.error()") == "", f"the push was refused: {browser.page_error()}")

        # The GameController panel: off at start; On, then Ready, and the game is READY through
        # /api/game and in the packets a robot receives (byte 9: state, RoboCupGameControlData.h).
        browser.wait_for("window.doppelViewer.gameShown()", "the GameController panel")
        check(not get_game(api)["on"], "doppel's GameController is on without --gamecontroller")
        browser.click_element("#game-on")
        browser.wait_for("window.doppelViewer.game() && window.doppelViewer.game().on", "the GameController to be on")
        browser.click_element('#game-states button[data-state="ready"]')
        browser.wait_for("window.doppelViewer.game().state === 'ready'", "the page to show READY")
        check(get_game(api)["state"] == "ready", f"/api/game says {get_game(api)['state']} after a click on Ready")
        check(browser.evaluate("window.doppelViewer.error()") == "", f"Ready was refused: {browser.page_error()}")
        robot.settimeout(5)
        states = []
        while 1 not in states:
            data = robot.recv(2048)
            check(len(data) == 688 and data[:4] == b"RGme", f"the robot received {len(data)} bytes {data[:4]!r}")
            states.append(data[9])
            check(len(states) < 20, f"no READY packet among {states}")

        # The Faults panel: a dead servo added from the form stops answering on the bus, its row
        # says active, Clear on its row brings it back; a fault without its servo is refused with
        # the field named (docs/faults.md).
        browser.wait_for("window.doppelViewer.faultsShown() && document.querySelectorAll('#fault-kind option').length > 10",
                         "the Faults panel with its kinds")
        link = os.path.join(work, "links", "ttyDXL0")
        check(ping(link, 1, 1) == 1, "servo 1 does not answer before any fault")
        browser.evaluate("(() => { const k = document.getElementById('fault-kind'); k.value = 'dead';"
                         " k.dispatchEvent(new Event('change')); document.getElementById('fault-bus').value = '0'; })()")
        browser.click_element("#fault-add")
        browser.wait_for("document.getElementById('error').textContent.includes(\"'id'\")",
                         "the page to show that a dead fault needs its servo's id")
        check(get_faults(api)["faults"] == [], f"a refused fault was added: {get_faults(api)['faults']}")
        browser.evaluate("document.getElementById('fault-id').value = '1'")
        browser.click_element("#fault-add")
        browser.wait_for("window.doppelViewer.faultRows().length === 1 && window.doppelViewer.faultRows()[0][5] === 'active'",
                         "the dead servo's row, active")
        listed = get_faults(api)["faults"]
        check(len(listed) == 1 and listed[0]["kind"] == "dead" and listed[0]["id"] == 1 and listed[0]["active"],
              f"/api/faults lists {listed} after Add")
        check(ping(link, 1, 1) == 0, "servo 1 answers while the page made it dead")
        check(ping(link, 2, 1) == 1, "servo 2 does not answer while only servo 1 is dead")
        # A poll that brings the same list leaves the rows as they are, so that a click (press, then
        # release) on Clear cannot straddle a rebuild and be lost.
        browser.evaluate("window.clearButton = document.querySelector('#fault-list button.fault-clear')")
        applied = browser.evaluate("window.doppelViewer.faultListsApplied()")
        browser.wait_for(f"window.doppelViewer.faultListsApplied() >= {applied + 2}", "two more polls of /api/faults")
        check(browser.evaluate("document.querySelector('#fault-list button.fault-clear') === window.clearButton"),
              "a poll that brought the same fault list rebuilt its table")
        browser.click_element("#fault-list button.fault-clear")
        browser.wait_for("window.doppelViewer.faultRows()[0][5] === 'ended'", "the row to say ended after Clear")
        check(ping(link, 1, 1) == 1, "servo 1 does not answer after Clear")

        # Resume: simulation time runs again.
        browser.click_element("#resume")
        wait_sim_time(api, 0.5, "after a click on Resume")
        check(not get_state(api)["paused"], "doppel is still paused after a click on Resume")
        browser.wait_for("!window.doppelViewer.state().paused", "the page to show 'running'")

        shot = os.path.join(out_dir, "viewer.png")
        time.sleep(0.5)  # a few frames with the robot at its new place
        browser.screenshot(shot)
        check(os.path.getsize(shot) > 10000, f"the screenshot {shot} is nearly empty")
        print(f"viewer test: passed; screenshot {shot}")
    finally:
        robot.close()
        tear_down(browser, process, work, out_dir, ("doppel.txt", "chromium/chromium.log"))


def main():
    return browser_test_main("viewer test", __doc__, 2, run)


if __name__ == "__main__":
    sys.exit(main())
