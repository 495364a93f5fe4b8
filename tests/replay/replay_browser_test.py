#!/usr/bin/env python3
"""The viewer in replay mode, in headless Chromium: doppel-replay serving a recording.

Writes a 10 s fixture recording (recording_fixture.h: the robot's trunk falls over while it
moves along x), starts doppel-replay on it (paused, any free port), opens the page and checks:
the timeline shows (a live doppel's page has none: viewer_browser_test.py), the 3D view draws the
robot, a click on the slider at three quarters of its length seeks there (the replay's position
and the drawn trunk follow: its recorded pose at that moment, and the pixel there is no longer
carpet), Play lets the position run on and Pause stops it, the speed selector sets the speed, the
push buttons are disabled, the Bus panel (GET /api/analysis) shows the fixture's 500 Hz cycle and
draws its three plots. Saves a screenshot after scrubbing (OUTPUT_DIR/replay.png) and one of the
Bus panel (OUTPUT_DIR/replay-bus.png).

usage: replay_browser_test.py DOPPEL_REPLAY FIXTURE_TOOL OUTPUT_DIR
Exit 77 (CTest: skipped) only when chromium is not installed.
"""

import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "control"))
from viewer_browser_test import Api, Browser, Failure, browser_test_main, check, tear_down  # noqa: E402

SECONDS = 10.0


def start_replay(tool, recording, work):
    """doppel-replay on a free port, its token in the test's own link directory: the process, its
    API and the page's link as doppel-replay prints it (with ?token=)."""
    output_path = os.path.join(work, "doppel-replay.txt")
    output = open(output_path, "wb")
    links = os.path.join(work, "links")
    process = subprocess.Popen([tool, recording, "--viewer", "0", "--paused", "--link-dir", links],
                               stdout=output, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        text = open(output_path, encoding="utf-8", errors="replace").read()
        match = re.search(r"viewer on ((http://127\.0\.0\.1:\d+/)\S*)", text)
        if match:
            return process, Api(match.group(2), links), match.group(1)
        if process.poll() is not None:
            raise Failure(f"doppel-replay exited ({process.returncode}) before serving its viewer:\n{text}")
        time.sleep(0.05)
    raise Failure("doppel-replay did not say where its viewer is within 60 s")


def trunk(scene):
    return next(s for s in scene["shapes"] if s["kind"] == "robot")


PIXEL_AT = """((x, y, z) => {
    const v = window.doppelViewer, canvas = document.getElementById('canvas');
    const p = v.pageXY(x, y, z), r = canvas.getBoundingClientRect();
    const copy = document.createElement('canvas');
    copy.width = canvas.width; copy.height = canvas.height;
    const g = copy.getContext('2d');
    g.drawImage(canvas, 0, 0);
    const k = canvas.width / r.width;
    return Array.from(g.getImageData(Math.round((p.x - r.left) * k), Math.round((p.y - r.top) * k), 1, 1).data.slice(0, 3));
})"""


def run(replay_tool, fixture_tool, out_dir, chromium):
    work = tempfile.mkdtemp(prefix="doppel-replay-browser-")
    os.makedirs(out_dir, exist_ok=True)
    recording = os.path.join(work, "fall.mcap")
    subprocess.run([fixture_tool, recording, str(SECONDS), "21", "60", "500", "0"], check=True)
    process, api, page = start_replay(replay_tool, recording, work)
    browser = None
    try:
        profile = os.path.join(work, "chromium")
        os.makedirs(profile)
        browser = Browser(chromium, profile)
        browser.open(page)

        browser.wait_for("window.doppelViewer && window.doppelViewer.timelineShown()", "the replay timeline")
        robots = browser.wait_for("window.doppelViewer.robotCount()", "the robot in the 3D view")
        check(robots == 1, f"the view draws {robots} robots, the recording has 1")
        browser.wait_for("window.doppelViewer.frames() > 5 && window.doppelViewer.sceneUpdates() > 2", "frames drawn")
        replay = api.get("api/replay")
        check(abs(replay["end_s"] - SECONDS) < 1e-9 and not replay["playing"],
              f"/api/replay says {replay}, the recording is {SECONDS} s and doppel-replay started --paused")
        before = trunk(browser.evaluate("window.doppelViewer.scene()"))
        check(abs(before["p"][0]) < 0.01, f"the trunk starts at x {before['p'][0]:.3f}, recorded at 0")

        # Scrub: a click at three quarters of the slider seeks there.
        box = browser.evaluate("(() => { const r = document.getElementById('replay-slider').getBoundingClientRect();"
                               " return {x: r.left, y: r.top + r.height / 2, w: r.width}; })()")
        browser.click(box["x"] + 0.75 * box["w"], box["y"])
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            position = api.get("api/replay")["position_s"]
            if position > 0.6 * SECONDS:
                break
            time.sleep(0.1)
        check(0.65 * SECONDS < position < 0.85 * SECONDS,
              f"a click at three quarters of the slider put the replay at {position:.3f} s of {SECONDS} s")
        # The page draws the trunk where the recording had it then: x = 0.1 t + 0.4 sin(tilt).
        poses_t = math.floor(position / (1 / 30) + 1e-9) * (1 / 30)
        tilt = math.pi / 2 * min(1.0, poses_t / SECONDS)
        want_x = 0.1 * poses_t + 0.4 * math.sin(tilt)
        moved = browser.wait_for(f"(() => {{ const s = window.doppelViewer.scene(); const t = s && s.shapes.find((x) => x.kind === 'robot');"
                                 f" return t && Math.abs(t.p[0] - {want_x}) < 0.02 && t; }})()",
                                 f"the trunk drawn at its recorded x {want_x:.3f} m")
        check(moved["q"][1] > 0.5, f"the trunk is not tilted at {position:.2f} s: q {moved['q']}")
        # Two frames drawn since the page had that scene (one may have begun before it): the canvas shows it.
        drawn = browser.evaluate("window.doppelViewer.frames()")
        browser.wait_for(f"window.doppelViewer.frames() > {drawn + 1}", "a frame drawn of the scrubbed scene")
        where = f"({moved['p'][0]}, {moved['p'][1]}, {moved['p'][2]})"
        inside = browser.evaluate(f"(() => {{ const p = window.doppelViewer.pageXY{where};"
                                  " const r = document.getElementById('canvas').getBoundingClientRect();"
                                  " return p.x > r.left && p.x < r.right && p.y > r.top && p.y < r.bottom; })()")
        check(inside, f"the scrubbed trunk at {where} is outside the 3D view")
        at_trunk = browser.evaluate(PIXEL_AT + where)
        state = api.get("api/state")
        check(state["paused"] and state["robots"][0]["fallen"], f"at {position:.2f} s the state is {state['robots'][0]}")
        shot = os.path.join(out_dir, "replay.png")
        browser.screenshot(shot)
        check(os.path.getsize(shot) > 10000, f"the screenshot {shot} is nearly empty")
        # The same pixel at the start of the recording (the robot stands 0.37 m further back): carpet.
        browser.click_element("#reset")
        browser.wait_for("(() => { const s = window.doppelViewer.scene(); const t = s && s.shapes.find((x) => x.kind === 'robot');"
                         " return t && Math.abs(t.p[0]) < 0.01; })()", "the trunk back at its start")
        drawn = browser.evaluate("window.doppelViewer.frames()")
        browser.wait_for(f"window.doppelViewer.frames() > {drawn + 1}", "a frame drawn of the start")
        at_start = browser.evaluate(PIXEL_AT + where)
        difference = sum(abs(a - b) for a, b in zip(at_trunk, at_start))
        check(difference > 30, f"the pixel at the scrubbed trunk {at_trunk} looks as it does without the robot {at_start}")
        check(at_start[1] > at_start[0] + 20 and at_start[1] > at_start[2] + 20,
              f"without the robot the pixel {at_start} is not carpet green")
        status = browser.evaluate(f"fetch('/api/replay', {{method: 'POST', headers: {{'Content-Type': 'application/json'}}, "
                                  f"body: JSON.stringify({{position_s: {position}}})}}).then((r) => r.status)")
        check(status == 200, f"the page's seek back to {position:.3f} s got {status}")

        # Play runs on, Pause stops.
        browser.click_element("#replay-play")
        browser.wait_for("window.doppelViewer.replay().playing", "the page to show playing")
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and api.get("api/replay")["position_s"] <= position + 0.2:
            time.sleep(0.1)
        later = api.get("api/replay")["position_s"]
        check(later > position + 0.2, f"playing moved the replay only from {position:.3f} s to {later:.3f} s in 10 s")
        browser.click_element("#replay-play")
        browser.wait_for("!window.doppelViewer.replay().playing", "the page to show paused")
        held = api.get("api/replay")["position_s"]
        time.sleep(0.3)
        check(api.get("api/replay")["position_s"] == held, "the replay runs on after Pause")

        # The speed selector.
        browser.evaluate("(() => { const s = document.getElementById('replay-speed'); s.value = '4';"
                         " s.dispatchEvent(new Event('change')); })()")
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and api.get("api/replay")["speed"] != 4:
            time.sleep(0.1)
        check(api.get("api/replay")["speed"] == 4, "the speed selector did not set 4x")
        check(browser.evaluate("document.querySelector('#push-buttons button').disabled"),
              "the push buttons are enabled in a replay")

        # The Bus panel: the analyzer's report of the fixture's traffic, one READ every 2 ms: 500 Hz.
        browser.wait_for("window.doppelViewer.analysisShown()", "the Bus panel")
        cycle = api.get("api/analysis")["reports"][0]["cycle"]
        check(cycle["found"] and abs(cycle["rate_hz"] - 500.0) < 0.01,
              f"/api/analysis finds the cycle {cycle}, the fixture reads every 2 ms (500 Hz)")
        text = browser.evaluate("window.doppelViewer.analysisCycleText()")
        check(len(text) == 1 and "control cycle 500.0 Hz" in text[0] and "P1 READ" in text[0],
              f"the Bus panel says {text}, the fixture's cycle is 500 Hz of P1 READ")
        ink = browser.evaluate("window.doppelViewer.analysisInk()")
        check(len(ink) == 3 and all(i > 500 for i in ink),
              f"the Bus panel's three plots (period, time split, what if) have {ink} pixels of ink")
        browser.evaluate("document.getElementById('analysis').scrollIntoView()")
        time.sleep(0.3)
        bus_shot = os.path.join(out_dir, "replay-bus.png")
        browser.screenshot(bus_shot)
        check(browser.evaluate("window.doppelViewer.error()") == "", f"the page shows an error: {browser.page_error()}")
        print(f"replay browser test: passed; scrubbed to {position:.3f} s; screenshots {shot}, {bus_shot}")
    finally:
        tear_down(browser, process, work, out_dir, ("doppel-replay.txt", "chromium/chromium.log"))


def main():
    return browser_test_main("replay browser test", __doc__, 3, run)


if __name__ == "__main__":
    sys.exit(main())
