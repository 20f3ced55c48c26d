"""A small Chrome DevTools Protocol client over `--remote-debugging-pipe`, standard library only.

The pipe needs no port, no websocket library and no chromedriver: Chromium reads commands from
its fd 3 and writes replies and events to its fd 4, one JSON message per NUL-terminated chunk.
"""

from __future__ import annotations

import fcntl
import json
import os
import select
import shutil
import subprocess
import tempfile
import time

EXECUTABLES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
# Headless, as root, and quiet: nothing reaches the network on its own.
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-default-apps", "--mute-audio", "--remote-debugging-pipe")


# Windows virtual key codes of the arrows and space (letters use their upper-case code).
KEY_CODES = {"ArrowLeft": 37, "ArrowUp": 38, "ArrowRight": 39, "ArrowDown": 40, " ": 32}


def find_chromium() -> str | None:
    return next((path for name in EXECUTABLES if (path := shutil.which(name))), None)


class Browser:
    """One headless Chromium with a fresh profile; `with Browser(path) as b: b.open(url)`."""

    def __init__(self, executable: str, timeout: float = 30):
        self.timeout = timeout
        self.events: list[dict] = []
        self._profile = tempfile.TemporaryDirectory(prefix="chromium-profile-")
        self._log = tempfile.TemporaryFile()  # noqa: SIM115 - Chromium writes to it until close()
        self._next_id = 0
        self._buffer = b""
        command_read, self._command_write = os.pipe()
        self._reply_read, reply_write = os.pipe()

        def wire_fds():  # runs in the child: its fds 3 and 4 become the two pipe ends
            command_fd = fcntl.fcntl(command_read, fcntl.F_DUPFD, 10)
            reply_fd = fcntl.fcntl(reply_write, fcntl.F_DUPFD, 10)
            os.dup2(command_fd, 3)
            os.dup2(reply_fd, 4)

        self._process = subprocess.Popen(
            [executable, *FLAGS, f"--user-data-dir={self._profile.name}", "about:blank"],
            preexec_fn=wire_fds, pass_fds=(3, 4), stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=self._log)
        os.close(command_read)
        os.close(reply_write)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def log(self) -> str:
        self._log.seek(0)
        return self._log.read().decode(errors="replace")[-2000:]

    def send(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        """Run one command and return its result; events that arrive meanwhile are kept."""
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self._command_write, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + self.timeout
        while True:
            reply = self._receive(deadline)
            if reply.get("id") != self._next_id:
                self.events.append(reply)
            elif "error" in reply:
                raise RuntimeError(f"{method}: {reply['error']}")
            else:
                return reply["result"]

    def _receive(self, deadline: float) -> dict:
        while b"\0" not in self._buffer:
            ready, _, _ = select.select([self._reply_read], [], [], deadline - time.monotonic())
            chunk = os.read(self._reply_read, 1 << 20) if ready else b""
            if not chunk:
                raise RuntimeError(f"Chromium went silent; its log ends with:\n{self.log()}")
            self._buffer += chunk
        message, _, self._buffer = self._buffer.partition(b"\0")
        return json.loads(message)

    def open(self, url: str) -> Page:
        """A new tab showing `url`, with its network requests recorded in `events`."""
        target = self.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True})
        page = Page(self, session["sessionId"], target)
        page.send("Network.enable")
        page.send("Page.navigate", {"url": url})
        return page

    def requested_urls(self) -> list[str]:
        return [e["params"]["request"]["url"] for e in self.events
                if e.get("method") == "Network.requestWillBeSent"]

    def close(self) -> None:
        try:
            if self._process.poll() is None:
                self.send("Browser.close")
                self._process.wait(10)
        except (RuntimeError, OSError, subprocess.TimeoutExpired):
            self._process.kill()
            self._process.wait()
        finally:
            os.close(self._command_write)
            os.close(self._reply_read)
            self._log.close()
            self._profile.cleanup()


class Page:
    def __init__(self, browser: Browser, session: str, target: str):
        self.browser = browser
        self.session = session
        self.target = target

    def send(self, method: str, params: dict | None = None) -> dict:
        return self.browser.send(method, params, self.session)

    def evaluate(self, expression: str):
        """The JSON value of a JavaScript expression in the page."""
        reply = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                               "awaitPromise": True})
        if "exceptionDetails" in reply:
            raise RuntimeError(f"{expression}: {reply['exceptionDetails']}")
        return reply["result"].get("value")

    def press(self, key: str) -> None:
        """One key press (down and up) as a person's keyboard sends it: `key` is a DOM key value
        ("ArrowUp", " ", "x")."""
        code = KEY_CODES.get(key, ord(key.upper()) if len(key) == 1 else 0)
        typed = {"text": key} if len(key) == 1 else {}
        for kind in ("keyDown", "keyUp"):
            self.send("Input.dispatchKeyEvent", {"type": kind, "key": key,
                                                 "windowsVirtualKeyCode": code,
                                                 **(typed if kind == "keyDown" else {})})

    def close(self) -> None:
        """Close the tab, as a person would."""
        self.browser.send("Target.closeTarget", {"targetId": self.target})

    def wait_for(self, expression: str, timeout: float = 10) -> None:
        deadline = time.monotonic() + timeout
        while not self.evaluate(f"Boolean({expression})"):
            if time.monotonic() > deadline:
                raise TimeoutError(f"page never satisfied {expression}")
            time.sleep(0.05)
