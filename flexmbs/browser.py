"""Open a page in headless Chromium with the network cut off, and report what a reader would see.

The browser is driven over the DevTools protocol on a pipe (``--remote-debugging-pipe``: commands on
file descriptor 3, replies and events on 4, each message JSON ended by a NUL byte), so nothing beyond
the standard library and a ``chromium`` executable is needed.  The page is loaded offline in two
ways at once: the protocol's ``Network.emulateNetworkConditions`` (offline) and a proxy on a closed
local port, so a page that fetches anything from the web fails the way it would on a machine without
internet; every request for something other than ``file:``, ``data:``, ``blob:`` or ``about:`` is
recorded.  Used by ``tests/test_view.py`` (the 3D view draws), by ``python -m flexmbs.bench_view``
(load times, docs/benchmarks.md) and by :func:`flexmbs.site.check_site` (``make docs-check``: the documentation
site's pages, one after another in one :class:`Browser`).
"""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

LOCAL_SCHEMES = ("file:", "data:", "blob:", "about:", "chrome:", "devtools:")
"""URL schemes a self-contained page may load: anything else is a network request."""


def chromium() -> str | None:
    """The path of a Chromium (or Chrome) executable, ``$FLEXMBS_CHROMIUM`` first; ``None`` when there is none."""
    names = [os.environ.get("FLEXMBS_CHROMIUM", ""), "chromium", "chromium-browser", "google-chrome", "chrome"]
    return next((found for found in (shutil.which(n) for n in names if n) if found), None)


class BrowserError(RuntimeError):
    """The browser could not be started, or a page did not become ready in time."""


@dataclass
class Page:
    """What the browser saw: ``console`` (level, text) of every console message and uncaught exception,
    ``requests`` the URLs fetched outside :data:`LOCAL_SCHEMES`, ``value`` the ready expression's last value,
    ``load_seconds`` from navigation to the ready expression being true, ``screenshot`` PNG bytes."""

    console: list = field(default_factory=list)
    requests: list = field(default_factory=list)
    value: object = None
    load_seconds: float = float("nan")
    screenshot: bytes = b""

    @property
    def errors(self) -> list:
        """The console's errors and uncaught exceptions, as text."""
        return [text for level, text in self.console if level in ("error", "exception")]


class _Pipe:
    """The DevTools protocol over Chromium's pipe: numbered commands, events kept in order."""

    def __init__(self, proc: subprocess.Popen, write_fd: int, read_fd: int):
        self.proc, self.write_fd, self.read_fd = proc, write_fd, read_fd
        self.buffer, self.events, self.next_id = b"", [], 0

    def _messages(self, timeout: float) -> list:
        """The messages that arrive within ``timeout`` seconds (every complete one of the chunk read: a reply
        may come with events behind it)."""
        ready, _, _ = select.select([self.read_fd], [], [], max(timeout, 0.0))
        if not ready:
            return []
        chunk = os.read(self.read_fd, 1 << 20)
        if not chunk:
            raise BrowserError(f"chromium closed its pipe (exit status {self.proc.poll()})")
        self.buffer += chunk
        *done, self.buffer = self.buffer.split(b"\0")
        return [json.loads(message) for message in done]

    def send(self, method: str, params: dict | None = None, session: str | None = None, timeout: float = 30.0):
        """Send one command and wait for its reply's ``result``."""
        self.next_id += 1
        command = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            command["sessionId"] = session
        os.write(self.write_fd, json.dumps(command).encode() + b"\0")
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            reply = None
            for message in self._messages(end - time.monotonic()):
                if message.get("id") == self.next_id:
                    reply = message
                else:
                    self.events.append(message)
            if reply is not None:
                if "error" in reply:
                    raise BrowserError(f"{method}: {reply['error'].get('message')}")
                return reply.get("result", {})
        raise BrowserError(f"{method}: no reply in {timeout:g} s")

    def pump(self, seconds: float) -> None:
        """Collect events for ``seconds``."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.events.extend(self._messages(end - time.monotonic()))


def _launch(executable: str, profile: str, width: int, height: int) -> tuple[subprocess.Popen, int, int]:
    to_browser_r, to_browser_w = os.pipe()
    from_browser_r, from_browser_w = os.pipe()
    high = [os.dup(fd) for fd in (to_browser_r, from_browser_w)]  # above 4, so that the dup2 below cannot clash;
    # os.dup2 makes 3 and 4 inheritable in the child, every other descriptor here is not (close_fds=False keeps them)

    def child_fds():
        os.dup2(high[0], 3)
        os.dup2(high[1], 4)

    flags = ["--headless", "--remote-debugging-pipe", "--no-first-run", "--no-default-browser-check",
             "--disable-extensions", "--disable-background-networking", "--disable-component-update",
             "--disable-sync", "--mute-audio", "--no-sandbox", "--disable-dev-shm-usage",
             "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--ignore-gpu-blocklist",
             "--proxy-server=http://127.0.0.1:9", "--proxy-bypass-list=<-loopback>", "--hide-scrollbars",
             f"--window-size={width},{height}", f"--user-data-dir={profile}", "about:blank"]
    proc = subprocess.Popen([executable, *flags], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, preexec_fn=child_fds, close_fds=False)
    for fd in (to_browser_r, from_browser_w, *high):
        os.close(fd)
    return proc, to_browser_w, from_browser_r


class Browser:
    """One headless Chromium, offline, that opens pages one after another (:meth:`open`); a context manager
    (leaving it, or :meth:`close`, ends the browser).

    Parameters
    ----------
    width, height : int
        Window size [px] (the screenshots').
    executable : str, optional
        The browser; :func:`chromium` by default.
    """

    def __init__(self, width: int = 1000, height: int = 700, executable: str | None = None):
        executable = executable or chromium()
        if executable is None:
            raise BrowserError("no chromium executable (install one, e.g. apt-get install chromium)")
        self._profile = tempfile.TemporaryDirectory(prefix="flexmbs-chromium-", ignore_cleanup_errors=True)
        self.proc, self._write, self._read = _launch(executable, self._profile.name, width, height)
        self.pipe = _Pipe(self.proc, self._write, self._read)
        try:
            targets = self.pipe.send("Target.getTargets")["targetInfos"]
            target = next(t["targetId"] for t in targets if t["type"] == "page")
            self.session = self.pipe.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
            for domain in ("Runtime", "Log", "Network", "Page"):
                self.pipe.send(f"{domain}.enable", session=self.session)
            self.pipe.send("Network.emulateNetworkConditions", {"offline": True, "latency": 0,
                                                                "downloadThroughput": -1, "uploadThroughput": -1},
                           session=self.session)
        except BaseException:
            self.close()
            raise

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """End the browser and remove its profile."""
        for fd in (self._write, self._read):
            os.close(fd)
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self._profile.cleanup()

    def open(self, path, ready: str = "true", timeout: float = 60.0, settle: float = 0.5, screenshot: bool = True,
             fragment: str = "") -> Page:
        """Load the file ``path`` (at its anchor ``fragment``, if given) and wait until the JavaScript expression
        ``ready`` is truthy; see :func:`open_page`.  ``ready`` may be a promise: its value is awaited."""
        url = Path(path).resolve().as_uri() + (f"#{fragment}" if fragment else "")
        pipe, session = self.pipe, self.session
        pipe.send("Runtime.evaluate", {"expression": "window.flexmbsLeaving = true"}, session=session)
        pipe.events.clear()
        page = Page()
        t0 = time.monotonic()
        navigated = pipe.send("Page.navigate", {"url": url}, session=session)
        if navigated.get("errorText"):
            raise BrowserError(f"{url}: {navigated['errorText']}")
        if "loaderId" not in navigated:  # the same document, at another anchor
            pipe.send("Runtime.evaluate", {"expression": "delete window.flexmbsLeaving"}, session=session)
        # until the new document is current, the old one (marked leaving) answers the ready expression
        expression = ("(async function(){try{if (window.flexmbsLeaving) return [false, null]; "
                      f"var v = await ({ready}); return [!!v, v];}}catch(e){{return [false, null];}}}})()")
        while True:
            try:
                result = pipe.send("Runtime.evaluate", {"expression": expression, "awaitPromise": True,
                                                        "returnByValue": True}, session=session,
                                   timeout=max(timeout - (time.monotonic() - t0), 1.0))  # a busy page answers late
            except BrowserError:
                if time.monotonic() - t0 <= timeout:
                    raise
                result = {}  # a promise that never settled
            truthy, value = result.get("result", {}).get("value") or (False, None)
            if truthy:
                page.load_seconds, page.value = time.monotonic() - t0, value
                break
            if time.monotonic() - t0 > timeout:
                _collect(pipe.events, page)
                raise BrowserError(f"{url}: not ready after {timeout:g} s ({' '.join(ready.split())[:100]}); "
                                  f"console: {page.console[:5]}")
            pipe.pump(0.05)
        pipe.pump(settle)
        if screenshot:
            page.screenshot = base64.b64decode(pipe.send("Page.captureScreenshot", {"format": "png"},
                                                         session=session, timeout=timeout)["data"])
        _collect(pipe.events, page)
        return page


def open_page(path, ready: str = "true", timeout: float = 60.0, settle: float = 0.5, width: int = 1000,
              height: int = 700, screenshot: bool = True, executable: str | None = None) -> Page:
    """Load the file ``path`` offline in a fresh browser and wait until the JavaScript expression ``ready`` is
    truthy (:class:`Browser` opens several pages in one browser).

    Parameters
    ----------
    path : path
        An HTML file.
    ready : str
        Evaluated in the page every 50 ms after navigation; its first truthy value ends the wait and is
        returned as :attr:`Page.value` (e.g. ``"window.flexmbsView && window.flexmbsView.drawn"``).
    timeout : float
        Seconds to wait for ``ready`` [s]; past it, :class:`BrowserError`.
    settle : float
        Seconds to keep collecting console messages after ready [s].
    width, height : int
        Window size [px] (the screenshot's).
    """
    with Browser(width, height, executable) as browser:
        return browser.open(path, ready, timeout, settle, screenshot)


def _collect(events: list, page: Page) -> None:
    """Console messages, uncaught exceptions and non-local requests out of the protocol's events."""
    for event in events:
        method, params = event.get("method"), event.get("params", {})
        if method == "Runtime.consoleAPICalled":
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in params.get("args", []))
            page.console.append(("error" if params.get("type") in ("error", "assert") else params.get("type"), text))
        elif method == "Runtime.exceptionThrown":
            details = params.get("exceptionDetails", {})
            page.console.append(("exception", details.get("exception", {}).get("description", details.get("text"))))
        elif method == "Log.entryAdded":
            entry = params.get("entry", {})
            page.console.append((entry.get("level"), f"{entry.get('text')} {entry.get('url', '')}".strip()))
        elif method == "Network.requestWillBeSent":
            url = params.get("request", {}).get("url", "")
            if not url.startswith(LOCAL_SCHEMES):
                page.requests.append(url)
