"""Screenshots of the browser tool for docs/browser-tool.md.

Run `.venv/bin/python scripts/screenshots.py`.

Serves the demo (`mirrorscan serve`) on 127.0.0.1 at a free port, opens it in headless Chromium at
1400x900 and 1024x600, visits each step of the side panel (the cloud in its sources' colours, which
tell the views apart) and the depth frame, and writes docs/images/<step>-<width>x<height>.png; then
the live cloud in true colour (live-colour-<size>.png, the colour control in view) and the colour
image on the depth frame's screen (colour-image-<size>.png). The Mirrors step at 1400x900 is also
the README's docs/screenshot.png. Needs the test extras (Playwright, Debian's chromium).
"""
from __future__ import annotations

import argparse
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images"
FRONT = ROOT / "docs" / "screenshot.png"     # the README's picture
SIZES = ((1400, 900), (1024, 600))
STEPS = ("Mirrors", "Object", "Measure", "Dense", "Record", "Session")
CHROMIUM = next((p for p in ("/usr/bin/chromium", "/usr/lib/chromium/chromium")
                 if Path(p).exists()), None)
ARGS = ["--no-sandbox", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
SETTLE_S = 2.0       # the page redraws after a step opens; software WebGL takes a second or two
START_S = 20.0       # the demo calibrates its mirrors and the first cloud reaches the page
# the live cloud in true colour is turned so that the views through the mirrors (the person's
# sides and back) show: a drag across this fraction of the 3D view's width
TURN = 0.125
# the 3D scene's canvas (the largest of the page) on the page, CSS px
SCENE_BOX = """() => {
  const canvas = [...document.querySelectorAll("canvas")]
    .reduce((a, b) => a.clientWidth * a.clientHeight >= b.clientWidth * b.clientHeight ? a : b);
  const r = canvas.getBoundingClientRect();
  return {x: r.x, y: r.y, width: r.width, height: r.height};
}"""
# viser's notice that the browser draws WebGL in software (as headless Chromium does)
CLOSE_WEBGL_NOTICE = """() => {
  for (const el of document.querySelectorAll("div")) {
    const notice = el.textContent.startsWith("Software WebGL rendering detected");
    if (notice && el.querySelector("button")) {
      el.querySelector("button").click();
      return true;
    }
  }
  return false;
}"""


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def wait_until_served(url: str, timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            with urllib.request.urlopen(url, timeout=2):
                return
        except OSError:
            time.sleep(0.5)  # the server is still starting: poll again
    raise SystemExit(f"mirrorscan serve did not answer at {url} within {timeout:.0f} s")


def colour(page, choice: str) -> None:
    """Pick a choice of the header's Colour control (under Playback and view)."""
    folder = page.get_by_text("Playback and view", exact=True)
    control = page.get_by_label("Colour", exact=True)
    if not control.is_visible():
        folder.click()
    control.click()
    page.get_by_role("option", name=choice, exact=True).click()


def turn(page, fraction: float) -> None:
    """Turn the 3D view about what it looks at: a drag across `fraction` of the canvas's width."""
    box = page.evaluate(SCENE_BOX)
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(x + fraction * box["width"] * k / 10, y + 0.02 * box["height"] * k / 10)
        time.sleep(0.05)  # the page takes the drag as a movement, not a jump
    page.mouse.up()


def shoot(url: str, out: Path) -> list[Path]:
    from playwright.sync_api import sync_playwright

    written = []
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        for width, height in SIZES:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.goto(url)
            page.get_by_role("tab", name=STEPS[0], exact=True).wait_for(timeout=60_000)
            time.sleep(START_S)  # the demo's first frames and calibration reach the page
            page.evaluate(CLOSE_WEBGL_NOTICE)
            colour(page, "source")
            page.get_by_text("Playback and view", exact=True).click()
            for step in STEPS:  # a first pass: the view settles and every step has been drawn once
                page.get_by_role("tab", name=step, exact=True).click()
                time.sleep(SETTLE_S / 2)  # the opened step is drawn before the next is clicked
            for step in STEPS:
                page.get_by_role("tab", name=step, exact=True).click()
                time.sleep(SETTLE_S)  # let the software renderer draw the opened step
                written.append(out / f"{step.lower()}-{width}x{height}.png")
                page.screenshot(path=str(written[-1]))
            page.get_by_role("tab", name=STEPS[0], exact=True).click()
            page.get_by_role("button", name="Depth frame", exact=True).click()
            time.sleep(2 * SETTLE_S)  # the camera moves to face the depth frame
            written.append(out / f"depth-frame-{width}x{height}.png")
            page.screenshot(path=str(written[-1]))
            page.get_by_role("button", name="Colour image", exact=True).click()
            time.sleep(2 * SETTLE_S)  # the colour image reaches the page and is drawn
            written.append(out / f"colour-image-{width}x{height}.png")
            page.screenshot(path=str(written[-1]))
            page.get_by_role("button", name="3D scene", exact=True).click()
            colour(page, "true colour")
            page.get_by_role("button", name="Look at the object", exact=True).click()
            time.sleep(SETTLE_S)  # the camera moves to the object
            turn(page, TURN)
            time.sleep(2 * SETTLE_S)  # the cloud comes in true colour and is drawn
            written.append(out / f"live-colour-{width}x{height}.png")
            page.screenshot(path=str(written[-1]))
            page.close()
        browser.close()
    return written


def shoot_plan(url: str, out: Path) -> list[Path]:
    """The plan's page (`mirrorscan plan --serve`) at each size, its figures' details open:
    docs/images/plan-<width>x<height>.png for docs/planning.md."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        written = [_plan_page(browser, url, out / f"plan-{w}x{h}.png", w, h) for w, h in SIZES]
        browser.close()
    return written


def _plan_page(browser, url: str, path: Path, width: int, height: int) -> Path:
    """One screenshot of the plan's page at width x height."""
    page = browser.new_page(viewport={"width": width, "height": height})
    page.goto(url)
    page.get_by_role("button", name="Optimise", exact=True).wait_for(timeout=60_000)
    time.sleep(2 * SETTLE_S)  # the subject's samples and the mirrors reach the page
    page.evaluate(CLOSE_WEBGL_NOTICE)
    page.get_by_text("Details").first.click()
    time.sleep(SETTLE_S)  # let the software renderer draw the opened fold
    page.screenshot(path=str(path))
    page.close()
    return path


def serve_and_shoot(command: list[str], port: int, shooter, out: Path) -> list[Path]:
    """Run a serving command, shoot its page with `shooter`, stop it."""
    server = subprocess.Popen(command + ["--port", str(port)], cwd=ROOT,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        url = f"http://127.0.0.1:{port}/"
        wait_until_served(url)
        return shooter(url, out)
    finally:
        server.terminate()
        server.wait(timeout=30)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT,
                        help="folder of the PNGs (default docs/images)")
    parser.add_argument("--only", choices=("plan",), help="only the plan's screenshots")
    args = parser.parse_args(argv)
    if CHROMIUM is None:
        raise SystemExit("no chromium at /usr/bin/chromium: run scripts/setup.sh --test")
    args.out.mkdir(parents=True, exist_ok=True)
    mirrorscan = str(ROOT / ".venv" / "bin" / "mirrorscan")
    written = []
    if args.only is None:
        written += serve_and_shoot([mirrorscan, "serve"], free_port(), shoot, args.out)
        if args.out == OUT:
            shutil.copyfile(OUT / "mirrors-1400x900.png", FRONT)
            written.append(FRONT)
    with tempfile.TemporaryDirectory() as work:
        plan = [mirrorscan, "plan", "-o", str(Path(work) / "plan"), "--subject", "person:1.75",
                "--mirrors", "2", "--quiet", "--serve"]
        written += serve_and_shoot(plan, free_port(), shoot_plan, args.out)
    for path in written:
        print(path.relative_to(ROOT) if path.is_relative_to(ROOT) else path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
