"""Headless Chromium over the DevTools protocol: load a page, read its images, videos and console errors."""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

# After the load event: every <img> decoded (its naturalWidth; 0 if it failed), every <video>'s error code and
# readyState once its metadata is in (or 5 s passed), and where each heading sits on the page.
PROBE = """(async () => {
  const images = await Promise.all(Array.from(document.images).map(
    img => img.decode().then(() => ({alt: img.alt, width: img.naturalWidth}), () => ({alt: img.alt, width: 0}))));
  const videos = await Promise.all(Array.from(document.querySelectorAll('video')).map(v => new Promise(done => {
    const report = () => done({error: v.error ? v.error.code : null, ready: v.readyState});
    if (v.readyState >= 1 || v.error) report();
    else { v.addEventListener('loadedmetadata', report); v.addEventListener('error', report);
           setTimeout(report, 5000); }
  })));
  const headings = Array.from(document.querySelectorAll('h1, h2')).map(
    h => ({text: h.textContent, top: h.getBoundingClientRect().top + window.scrollY}));
  return {images, videos, headings, viewport: [window.innerWidth, window.innerHeight]};
})()"""


def find_browser() -> str | None:
    """The first Chromium or Chrome on PATH, or None."""
    return next((path for name in BROWSERS if (path := shutil.which(name))), None)


def load_page(browser: str, page: Path, screenshot: Path, *, width: int = 1280, height: int = 900,
              timeout: float = 60.0) -> dict:
    """Open ``page`` in a fresh headless ``browser`` at ``width`` x ``height``; returns PROBE's result plus
    ``errors``: the console's errors, uncaught exceptions and failed loads, as text. Saves the first screen
    (the viewport at the top of the page) to ``screenshot``."""
    with tempfile.TemporaryDirectory() as profile, _DevTools(browser, profile, timeout) as tools:
        target = tools.call("Target.createTarget", url="about:blank")["targetId"]
        session = tools.call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        for domain in ("Page", "Runtime", "Log"):
            tools.call(f"{domain}.enable", session)
        tools.call("Emulation.setDeviceMetricsOverride", session, width=width, height=height, deviceScaleFactor=1,
                   mobile=False)
        tools.call("Page.navigate", session, url=Path(page).resolve().as_uri())
        tools.wait_for("Page.loadEventFired")
        result = tools.call("Runtime.evaluate", session, expression=PROBE, awaitPromise=True, returnByValue=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"the page probe failed: {result['exceptionDetails']}")
        shot = tools.call("Page.captureScreenshot", session, format="png")["data"]
        Path(screenshot).write_bytes(base64.b64decode(shot))
        return {**result["result"]["value"], "errors": tools.errors()}


class _DevTools:
    """The browser process and its DevTools pipe (--remote-debugging-pipe: commands in on fd 3, answers and events
    out on fd 4, each message JSON ended by a NUL byte)."""

    def __init__(self, browser: str, profile: str, timeout: float):
        self.deadline = time.monotonic() + timeout
        self.events: list[dict] = []
        self.buffer = b""
        self.next_id = 0
        to_browser, self.to_browser = os.pipe()
        self.from_browser, from_browser = os.pipe()

        def onto_fds_3_and_4():
            # copies first: the pipe ends may themselves sit on fd 3 or 4
            commands, answers = os.dup(to_browser), os.dup(from_browser)
            os.dup2(commands, 3)
            os.dup2(answers, 4)

        self.process = subprocess.Popen(
            [browser, "--headless", "--no-sandbox", "--disable-gpu", "--remote-debugging-pipe", "--no-first-run",
             "--no-default-browser-check", f"--user-data-dir={profile}", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, pass_fds=(3, 4),
            preexec_fn=onto_fds_3_and_4)
        os.close(to_browser)
        os.close(from_browser)

    def __enter__(self) -> "_DevTools":
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self.process.poll() is None:
                self._send({"id": 0, "method": "Browser.close", "params": {}})
                self.process.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            self.process.kill()
            self.process.wait()
        finally:
            os.close(self.to_browser)
            os.close(self.from_browser)
            self.process.stderr.close()

    def _send(self, message: dict) -> None:
        os.write(self.to_browser, json.dumps(message).encode() + b"\0")

    def _receive(self) -> dict:
        while b"\0" not in self.buffer:
            left = self.deadline - time.monotonic()
            if left <= 0 or not select.select([self.from_browser], [], [], left)[0]:
                raise TimeoutError("the browser did not answer in time")
            chunk = os.read(self.from_browser, 1 << 20)
            if not chunk:
                raise RuntimeError("the browser closed its DevTools pipe: "
                                   + self.process.stderr.read().decode(errors="replace")[-2000:])
            self.buffer += chunk
        message, self.buffer = self.buffer.split(b"\0", 1)
        return json.loads(message)

    def call(self, method: str, session: str | None = None, **params) -> dict:
        """Send a command and return its result; events that arrive meanwhile are kept."""
        self.next_id += 1
        self._send({"id": self.next_id, "method": method, "params": params}
                   | ({"sessionId": session} if session else {}))
        while True:
            message = self._receive()
            if message.get("id") == self.next_id:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message["result"]
            self.events.append(message)

    def wait_for(self, event: str) -> None:
        while not any(e.get("method") == event for e in self.events):
            self.events.append(self._receive())

    def errors(self) -> list[str]:
        out = []
        for e in self.events:
            method, params = e.get("method"), e.get("params", {})
            if method == "Runtime.consoleAPICalled" and params["type"] in ("error", "assert"):
                words = (str(a.get("value", a.get("description", ""))) for a in params["args"])
                out.append("console: " + " ".join(words))
            elif method == "Runtime.exceptionThrown":
                details = params["exceptionDetails"]
                out.append("exception: " + details.get("exception", {}).get("description", details["text"]))
            elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
                out.append(f"log: {params['entry']['text']} ({params['entry'].get('url', '')})")
        return out
