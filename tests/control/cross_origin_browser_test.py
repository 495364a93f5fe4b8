#!/usr/bin/env python3
"""Another web site in the user's browser cannot drive or read doppel (docs/security.md), in headless
Chromium.

The user has opened doppel's viewer with the link doppel printed (so the browser holds the token's
cookie; the page's scripts cannot read it: HttpOnly). Then a page of another origin, served by this
test from another loopback port (same site as 127.0.0.1, so the browser even sends the cookie:
the worst case), tries what the issue names: a "simple" cross-origin POST /api/pause (text/plain,
no preflight), a JSON POST /api/pause (needs a preflight), and a read of /api/state. A name that
resolves to 127.0.0.1 (DNS rebinding, played with Chromium's --host-resolver-rules) loads
/api/state as its own page. Checked: the page reads nothing, doppel answers 403 to the rebinding
name, and the world is not paused: simulation time runs on.

usage: cross_origin_browser_test.py DOPPEL OUTPUT_DIR
Exit 77 (CTest: skipped) only when chromium is not installed.
"""

import http.server
import json
import os
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from viewer_browser_test import (Browser, Failure, browser_test_main, check, get_state, start_doppel,  # noqa: E402
                                 tear_down)

ATTACK = """<!doctype html><title>a web page</title><script>
window.results = {};
(async () => {
  const doppel = %(doppel)s;
  try {
    await fetch(doppel + 'api/pause', {method: 'POST', mode: 'no-cors', credentials: 'include',
                                      headers: {'Content-Type': 'text/plain'}, body: '{}'});
    window.results.simple_post = 'sent';
  } catch (e) { window.results.simple_post = 'failed: ' + e.message; }
  try {
    const r = await fetch(doppel + 'api/pause', {method: 'POST', credentials: 'include',
                                                 headers: {'Content-Type': 'application/json'}, body: '{}'});
    window.results.json_post = 'answered ' + r.status + ' ' + (await r.text());
  } catch (e) { window.results.json_post = 'refused: ' + e.message; }
  try {
    const r = await fetch(doppel + 'api/state', {credentials: 'include'});
    window.results.read_state = 'read ' + r.status + ' ' + (await r.text());
  } catch (e) { window.results.read_state = 'refused: ' + e.message; }
  try {
    const r = await fetch(doppel + 'api/state', {mode: 'no-cors', credentials: 'include'});
    window.results.opaque_read = r.type + ' ' + (await r.text()).length;
  } catch (e) { window.results.opaque_read = 'refused: ' + e.message; }
  window.results.done = true;
})();
</script>"""


def serve_attack_page(doppel_url):
    """An HTTP server on another loopback port that serves the attacking page; returns it and its URL."""
    body = (ATTACK % {"doppel": json.dumps(doppel_url)}).encode()

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):  # noqa: N802 (the library's name)
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/"


def run(doppel, out_dir, chromium):
    work = tempfile.mkdtemp(prefix="doppel-cross-origin-test-")
    os.makedirs(out_dir, exist_ok=True)
    process, api, page = start_doppel(doppel, work, ("--physics", "none"))  # nothing to render: a light page
    print(f"cross-origin test: doppel serves {page}", flush=True)
    browser = None
    attacker = None
    try:
        port = int(api.url.rstrip("/").rsplit(":", 1)[1])
        profile = os.path.join(work, "chromium")
        os.makedirs(profile)
        browser = Browser(chromium, profile, extra_args=[f"--host-resolver-rules=MAP rebound.example 127.0.0.1"])

        # The user opens the viewer as doppel printed it: the page works, its cookie is not readable.
        browser.open(page)
        browser.wait_for("window.doppelViewer && window.doppelViewer.scene() !== null && window.doppelViewer.sceneUpdates() > 1",
                         "the viewer page to read doppel's scene (with the cookie)")
        check(browser.evaluate("document.cookie") == "", "the token's cookie is readable by the page's scripts")
        check(not get_state(api)["paused"], "doppel is paused before the attack")

        print("cross-origin test: the viewer works", flush=True)
        # Another site's page in the same browser.
        attacker, attack_url = serve_attack_page(api.url)
        browser.call("Page.navigate", {"url": attack_url})
        results = browser.wait_for("window.results && window.results.done && window.results", "the attacking page's requests")
        print(f"cross-origin test: the page got {results}")
        check(results["json_post"].startswith("refused"), f"the JSON POST reached the page: {results['json_post']}")
        check(results["read_state"].startswith("refused"), f"the page read the state: {results['read_state']}")
        check("sim_time_s" not in results["opaque_read"] and results["opaque_read"].endswith(" 0"),
              f"an opaque read gave the page content: {results['opaque_read']}")
        # No request of the page paused the world.
        check(not get_state(api)["paused"], "a cross-origin page paused doppel")

        # DNS rebinding: a name of the attacker's that now resolves to 127.0.0.1, loaded as a page.
        browser.call("Page.navigate", {"url": f"http://rebound.example:{port}/api/state"})
        text = browser.wait_for("document.readyState === 'complete' && location.hostname === 'rebound.example' && "
                                "document.body && document.body.innerText", "the rebound page")
        check("sim_time_s" not in text and "Host header" in text, f"a rebound name read doppel's state: {text[:300]}")
        browser.call("Page.navigate", {"url": f"http://rebound.example:{port}/?token=" + api.token})
        text = browser.wait_for("document.readyState === 'complete' && location.hostname === 'rebound.example' && "
                                "document.body && document.body.innerText", "the rebound viewer page")
        check("Host header" in text, f"a rebound name was served the viewer page: {text[:300]}")
        check(not get_state(api)["paused"], "doppel is paused after the rebinding attempt")
        print("cross-origin test: passed")
    finally:
        if attacker is not None:
            attacker.shutdown()
        tear_down(browser, process, work, out_dir, ("doppel.txt", "chromium/chromium.log"))


def main():
    return browser_test_main("cross-origin test", __doc__, 2, run)


if __name__ == "__main__":
    sys.exit(main())
