"""What a tab's page does on its own: count how often it draws its 3D scene, turn keyboard
shortcuts into presses of the side panel's buttons, take a double click on *Add a mirror* as one
click, open the guide in a new tab, and draw its view as a picture to download.

viser's page sends the server no acknowledgement of what it drew and no key presses. Both are
scripts given to the page through viser's message that runs one (as it loads plotly): the draw
rate is kept in the page's localStorage, which the server reads (`draw_rate`); a shortcut clicks the
button in view that does the same (greyed out, it does nothing), so that it acts exactly as the
button does.
"""
from __future__ import annotations

import json
import threading
from typing import Callable

import cv2
import viser

from .guide import DOCS_INDEX, GUIDE, PREFIX, source_root
from .presence import run_js

VIEW_PNG = "mirrorscan-view.png"  # the name of the view saved as a picture
RENDER_TIMEOUT_S = 60.0  # seconds the page may take to draw the view it is asked for
# seconds after a tab is built when its view is framed if the page reported its camera meanwhile:
# by then the page has applied the scene's up direction
LATE_VIEW_S = 2.0
# seconds after which a page that has not reported its camera is no longer waited for
LATE_VIEW_GIVE_UP_S = 30.0
DRAWS_KEY = "mirrorscan-draws"
DRAWS_WINDOW_MS = 2000    # ms: the draw rate counts the frames drawn over this
# A frame counts as drawn when WebGL was asked to draw during it (three.js draws the whole scene
# on the frames it renders, nothing on the others): the draw calls of the scene's canvas (the one
# three.js made) are wrapped, and each animation frame that had one is timed.
DRAWS_JS = """(() => {{
  if (window.__mirrorscanDraws) return;
  window.__mirrorscanDraws = true;
  const key = "viser-user:{key}";
  const frames = [];
  const start = performance.now();
  let drew = false;
  let hooked = null;
  const hook = () => {{
    const canvas = document.querySelector("canvas[data-engine]");
    if (!canvas || canvas === hooked) return;
    const gl = canvas.getContext("webgl2") || canvas.getContext("webgl");
    if (!gl) return;
    hooked = canvas;
    for (const name of ["drawArrays", "drawElements", "drawArraysInstanced",
                        "drawElementsInstanced"]) {{
      const draw = gl[name];
      if (!draw) continue;
      gl[name] = function (...args) {{ drew = true; return draw.apply(this, args); }};
    }}
  }};
  const tick = (now) => {{
    if (drew) frames.push(now);
    drew = false;
    while (frames.length && now - frames[0] > {window}) frames.shift();
    requestAnimationFrame(tick);
  }};
  requestAnimationFrame(tick);
  setInterval(() => {{
    hook();
    const span = Math.min({window}, performance.now() - start);
    localStorage.setItem(key, (frames.length * 1000 / Math.max(span, 1)).toFixed(2));
  }}, 500);
}})();"""

# The shortcuts: (keys as the docs name them, what they do, the button they press).
SHORTCUTS = (
    ("Ctrl+Z", "undo", "Undo"),
    ("Ctrl+Shift+Z, Ctrl+Y", "redo", "Redo"),
    ("Delete, Backspace", "delete the picked marker or corner",
     "Delete marker …, Delete corner …"),
    ("Esc", "cancel the outline being drawn", "Clear boundary, while Close boundary shows"),
    ("1 to 6", "open the steps Mirrors, Object, Measure, Dense, Record, Session", "the step's tab"),
)
# Keys typed into a field of the panel are the field's. A shortcut presses the first button in view
# (not in a closed folder or another step) whose label matches, when it is not greyed out.
KEYS_JS = """(() => {{
  if (window.__mirrorscanKeys) return;
  window.__mirrorscanKeys = true;
  const steps = {steps};
  const typing = (el) => el && (el.isContentEditable
    || ["INPUT", "TEXTAREA", "SELECT"].includes(el.tagName));
  const inView = (el) => el.offsetParent !== null;
  const button = (test) => [...document.querySelectorAll("button")]
    .find((b) => inView(b) && test(b.textContent.trim()));
  const press = (test) => {{
    const found = button(test);
    if (!found || found.disabled) return false;
    found.click();
    return true;
  }};
  const labelled = (name) => (text) => text === name || text.startsWith(name + ": ");
  document.addEventListener("keydown", (event) => {{
    if (typing(event.target) || typing(document.activeElement) || event.altKey) return;
    const key = event.key.toLowerCase();
    const ctrl = event.ctrlKey || event.metaKey;
    let done = false;
    if (ctrl && key === "z" && !event.shiftKey) {{
      done = press(labelled("Undo"));
    }} else if (ctrl && (key === "y" || (key === "z" && event.shiftKey))) {{
      done = press(labelled("Redo"));
    }} else if (ctrl) {{
      return;
    }} else if (key === "delete" || key === "backspace") {{
      done = press((text) => /^Delete (marker|corner) /.test(text));
    }} else if (key === "escape") {{
      if (button((text) => text.startsWith("Close boundary"))) {{
        done = press((text) => text === "Clear boundary");
      }}
    }} else if (/^[1-9]$/.test(key) && Number(key) <= steps.length) {{
      const tab = [...document.querySelectorAll("[role=tab]")]
        .find((t) => inView(t) && t.textContent.trim() === steps[Number(key) - 1]);
      // viser's tabs open on Enter (a click is a drag's start)
      if (tab) {{
        tab.dispatchEvent(new KeyboardEvent("keydown", {{ key: "Enter", bubbles: true }}));
        done = true;
      }}
    }}
    if (done) event.preventDefault();
  }});
}})();"""

# Buttons whose second click of a double click is dropped in the page (event.detail counts the
# clicks of one double click however late the busy page dispatches them): each click adds one.
ONCE_BUTTONS = ("Add a mirror",)
ONCE_JS = """(() => {{
  if (window.__mirrorscanOnce) return;
  window.__mirrorscanOnce = true;
  const once = {labels};
  window.addEventListener("click", (event) => {{
    const b = event.target.closest && event.target.closest("button");
    if (b && event.detail > 1 && once.includes(b.textContent.trim())) {{
      event.stopPropagation();
      event.preventDefault();
    }}
  }}, true);
}})();"""

# viser's Markdown links open in the tool's own tab: a link to the guide opens in a new one instead,
# leaving the tool's page (and its connection) as it is. The new tab carries the token's cookie
# (SameSite=Strict lets a same-site navigation send it).
LINKS_JS = """(() => {{
  if (window.__mirrorscanLinks) return;
  window.__mirrorscanLinks = true;
  window.addEventListener("click", (event) => {{
    const a = event.target.closest && event.target.closest("a[href]");
    if (!a || event.button !== 0) return;
    const url = new URL(a.getAttribute("href"), location.href);
    if (url.origin !== location.origin || !url.pathname.startsWith({prefix})) return;
    event.preventDefault();
    event.stopPropagation();
    window.open(url.href, "_blank", "noopener");
  }}, true);
}})();"""


def start_page(client: viser.ClientHandle, steps: tuple[str, ...]) -> None:
    """Give the tab's page its draw counter, its keyboard shortcuts, its once-only buttons and its
    links to the guide that open in a new tab.

    Parameters
    ----------
    client : viser.ClientHandle
    steps : tuple of str
        The titles of the side panel's steps, in order (keys 1 to 9 open them).
    """
    run_js(client, DRAWS_JS.format(key=f"{DRAWS_KEY}-{client.client_id}",
                                   window=DRAWS_WINDOW_MS))
    run_js(client, KEYS_JS.format(steps=json.dumps(list(steps))))
    run_js(client, ONCE_JS.format(labels=json.dumps(list(ONCE_BUTTONS))))
    run_js(client, LINKS_JS.format(prefix=json.dumps(PREFIX)))


def draw_rate(client: viser.ClientHandle, timeout: float = 2.0) -> float | None:
    """How many frames a second the tab's page drew its 3D scene over the last DRAWS_WINDOW_MS.

    Parameters
    ----------
    client : viser.ClientHandle
    timeout : float, optional
        Seconds to wait for the page's answer.

    Returns
    -------
    float or None
        None before the page has counted, or when it does not answer in time.
    """
    try:
        value = client.local_storage.get_item(f"{DRAWS_KEY}-{client.client_id}",
                                              timeout=timeout)
    except (TimeoutError, RuntimeError):
        return None
    try:
        return float(value) if value else None
    except ValueError:
        return None


def keys_help() -> str:
    """The keyboard shortcuts and the guide, as Markdown (the header's folder).

    Returns
    -------
    str
        The guide as links to it served beside the page (guide.py), or as its path in
        mirrorscan's source when the install has no docs.
    """
    keys = " · ".join(f"**{keys}** {what}" for keys, what, _ in SHORTCUTS)
    if source_root() is None:
        return f"Keys: {keys}. The guide: `{GUIDE}` in mirrorscan's source."
    return (f"Keys: {keys}.\n\n[Open the guide]({PREFIX}{GUIDE}) · "
            f"[all the docs]({PREFIX}{DOCS_INDEX}) (in a new tab)")


def save_view(client: viser.ClientHandle, act: Callable[[Callable[[], object]], None]) -> None:
    """Download what the tab's 3D view shows now as a PNG (VIEW_PNG), at the canvas's size.

    The page draws it on request (viser's get_render), on a thread of its own, so that the
    button's callback returns at once.

    Parameters
    ----------
    client : viser.ClientHandle
    act : callable
        Runs the work as the tab's action (a failure becomes a notification).
    """
    camera = client.camera
    width, height = int(camera.image_width), int(camera.image_height)

    def render() -> None:
        image = client.get_render(height, width, transport_format="png", timeout=RENDER_TIMEOUT_S)
        ok, data = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGBA2BGRA))
        if ok:
            client.send_file_download(VIEW_PNG, data.tobytes(), save_immediately=True)

    threading.Thread(target=lambda: act(render), name="mirrorscan-render", daemon=True).start()


def frame_late(client: viser.ClientHandle, first_view: Callable[[None], None]) -> None:
    """Call first_view(None) once the page has reported its camera, from LATE_VIEW_S on.

    A page may report its camera while its tab is still being built, before the tab listens to
    the reports; no other report follows until the camera moves. A page still loading reports it
    later: it is asked again every LATE_VIEW_S, for at most LATE_VIEW_GIVE_UP_S. `first_view`
    frames the view once (later calls do nothing).

    Parameters
    ----------
    client : viser.ClientHandle
    first_view : callable
    """
    def late(waited: float) -> None:
        try:
            client.camera.wxyz  # noqa: B018 (viser asserts until the page has reported it)
        except AssertionError:
            if waited < LATE_VIEW_GIVE_UP_S:
                _after(LATE_VIEW_S, late, waited + LATE_VIEW_S)
            return
        first_view(None)

    _after(LATE_VIEW_S, late, LATE_VIEW_S)


def _after(seconds: float, call: Callable, *args) -> None:
    """Call `call(*args)` on a daemon timer `seconds` from now."""
    timer = threading.Timer(seconds, call, args)
    timer.daemon = True
    timer.start()
