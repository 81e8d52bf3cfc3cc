"""Look at every figure of a geocontact report in a real browser (headless Chromium).

For each ``<img>`` of REPORT.html:

1. its PNG bytes (the embedded ``data:image/png;base64,...``, or the file a relative ``src``
   names) must decode, and the picture must not be blank: more than one colour, and at least
   ``--min-ink`` of its pixels not the background colour (a figure saved before anything was
   drawn on it is one flat colour);
2. in Chromium, the page's image must have decoded (``naturalWidth > 0``, read by a small script
   run in the page, whose result ``--dump-dom`` returns), with the size of its PNG;
3. in a full-page screenshot of the page as the browser paints it, the figure's box must not be
   blank either (what a reader sees, not only what the file holds).

Checks 2 and 3 need ``chromium`` (Debian: ``make chromium``, i.e. ``apt-get install -y
chromium``); without it the script says so and exits 3 after the PNG checks (``--no-browser``
runs the PNG checks alone). Chromium runs headless, sandbox-free (containers), without GPU,
QUIC, first-run, background networking, component updates or sync, from a fresh profile.

    .venv/bin/python scripts/check_report_figures.py out/demo-quick/report.html
        [--screenshot PATH] [--chromium BIN] [--width 1280] [--min-ink 0.002] [--no-browser]
        [--json]

Exit status 0 when every figure passes, 1 when one does not, 2 on bad input, 3 when chromium
is missing. ``make check-figures`` runs the quick demo, then this script on its report.
"""

from __future__ import annotations

import argparse
import base64
import binascii
import html
import io
import json
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import asdict, dataclass, field
from html.parser import HTMLParser
from pathlib import Path

import numpy as np

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "chrome")
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--hide-scrollbars",
                  "--force-device-scale-factor=1", "--mute-audio")
MIN_INK = 0.002  # fraction of a figure's pixels that must differ from its background colour
RESULT_ID = "geocontact-figure-check"
# Run in the page once everything has loaded: each image's decoded size and box, the page size.
PROBE = """<script>
window.addEventListener('load', function () {
  var out = {images: [], width: document.documentElement.scrollWidth,
             height: document.documentElement.scrollHeight};
  var images = document.getElementsByTagName('img');
  for (var i = 0; i < images.length; i++) {
    var r = images[i].getBoundingClientRect();
    out.images.push({complete: images[i].complete, naturalWidth: images[i].naturalWidth,
                     naturalHeight: images[i].naturalHeight, left: r.left + window.scrollX,
                     top: r.top + window.scrollY, width: r.width, height: r.height});
  }
  var pre = document.createElement('pre');
  pre.id = '@RESULT_ID@';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>""".replace("@RESULT_ID@", RESULT_ID)


class BadInput(Exception):
    pass


# --- the report's images and the PNG checks (no browser) ---------------------------------------
class _Images(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images: list[dict[str, str]] = []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append({k: v or "" for k, v in attrs})


def report_images(text: str) -> list[dict[str, str]]:
    """The attributes of every <img> of the page, in document order."""
    parser = _Images()
    parser.feed(text)
    return parser.images


def image_bytes(src: str, base: Path) -> bytes:
    """The bytes an image's ``src`` names: a base64 data URI or a file relative to ``base``."""
    if src.startswith("data:"):
        header, _, payload = src.partition(",")
        if not header.endswith(";base64"):
            raise ValueError(f"not a base64 data URI ({header[:40]})")
        try:
            return base64.b64decode(payload, validate=True)
        except (binascii.Error, ValueError) as exc:
            raise ValueError(f"bad base64: {exc}") from None
    path = base / src
    if not path.is_file():
        raise ValueError(f"no such file: {src}")
    return path.read_bytes()


def decode_png(data: bytes) -> np.ndarray:
    """Pixels (height x width x 3, 0..255) of PNG bytes; ValueError if they do not decode."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(data)) as im:
            im.load()
            return np.asarray(im.convert("RGB"))
    except (UnidentifiedImageError, OSError, SyntaxError) as exc:
        raise ValueError(f"does not decode as an image: {exc}") from None


def ink(pixels: np.ndarray) -> tuple[int, float]:
    """(number of colours, fraction of pixels differing from the most common colour)."""
    flat = pixels.reshape(-1, pixels.shape[-1])
    if flat.size == 0:
        return 0, 0.0
    colours, counts = np.unique(flat, axis=0, return_counts=True)
    return int(len(colours)), float(1.0 - counts.max() / flat.shape[0])


def blank_reason(pixels: np.ndarray, min_ink: float = MIN_INK) -> str | None:
    """Why a picture is blank (one colour, all white, almost nothing drawn), or None."""
    if pixels.size == 0 or pixels.shape[0] == 0 or pixels.shape[1] == 0:
        return "empty (no pixels)"
    colours, fraction = ink(pixels)
    if colours == 1:
        flat = pixels.reshape(-1, pixels.shape[-1])[0]
        return "all white" if np.all(flat >= 250) else f"a single colour {tuple(flat)}"
    if fraction < min_ink:
        return f"almost blank ({100 * fraction:.3g} % of pixels drawn, < {100 * min_ink:g} %)"
    return None


@dataclass
class FigureCheck:
    index: int
    alt: str
    source: str  # "embedded PNG" or the file
    width: int = 0
    height: int = 0
    colours: int = 0
    ink: float = 0.0
    problems: list[str] = field(default_factory=list)
    browser: dict | None = None  # naturalWidth, naturalHeight, box, painted ink

    @property
    def ok(self) -> bool:
        return not self.problems


def check_images(report: Path, min_ink: float = MIN_INK) -> list[FigureCheck]:
    """The PNG checks of every <img> of ``report`` (no browser needed)."""
    try:
        text = report.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise BadInput(f"{report}: unreadable ({exc})") from None
    checks = []
    for i, attrs in enumerate(report_images(text)):
        src = attrs.get("src", "")
        check = FigureCheck(i, attrs.get("alt", ""),
                            "embedded PNG" if src.startswith("data:") else src or "(no src)")
        try:
            pixels = decode_png(image_bytes(src, report.parent))
        except ValueError as exc:
            check.problems.append(f"broken: {exc}")
            checks.append(check)
            continue
        check.height, check.width = pixels.shape[:2]
        check.colours, check.ink = ink(pixels)
        reason = blank_reason(pixels, min_ink)
        if reason:
            check.problems.append(f"blank: {reason}")
        checks.append(check)
    return checks


# --- the browser -------------------------------------------------------------------------------
def find_chromium(explicit: str | None = None) -> str | None:
    if explicit:
        return shutil.which(explicit) or (explicit if Path(explicit).is_file() else None)
    return next((p for p in map(shutil.which, CHROMIUM_NAMES) if p), None)


def _chromium(binary: str, profile: Path, *args: str, timeout: float = 120.0) -> str:
    command = [binary, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args]
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise RuntimeError(f"chromium exited {done.returncode}: {tail}")
    return done.stdout


def probe_page(binary: str, report: Path, width: int, work: Path) -> dict:
    """Load a copy of the page with PROBE added (a <base> keeps relative sources resolving)
    and return what PROBE measured."""
    text = report.read_text()
    base = f"<base href='{report.parent.resolve().as_uri()}/'>"
    text = text.replace("<head>", "<head>" + base, 1) if "<head>" in text else base + text
    text = text.replace("</body>", PROBE + "</body>", 1) if "</body>" in text else text + PROBE
    copy = work / "probe.html"
    copy.write_text(text)
    dom = _chromium(binary, work / "profile-probe", f"--window-size={width},900",
                    "--virtual-time-budget=20000", "--dump-dom", copy.as_uri())
    match = re.search(rf"<pre id=\"{RESULT_ID}\">(.*?)</pre>", dom, re.S)
    if not match:
        raise RuntimeError("the probe script did not run (no result in the dumped DOM)")
    return json.loads(html.unescape(match.group(1)))


def screenshot(binary: str, report: Path, width: int, height: int, path: Path,
               work: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    _chromium(binary, work / "profile-shot", f"--window-size={width},{height}",
              "--virtual-time-budget=20000", f"--screenshot={path.resolve()}",
              report.resolve().as_uri())
    if not path.is_file():
        raise RuntimeError(f"chromium wrote no screenshot at {path}")


def check_in_browser(checks: list[FigureCheck], binary: str, report: Path, shot: Path,
                     width: int, min_ink: float) -> dict:
    """Checks 2 and 3: decoded in the page, painted in the full-page screenshot."""
    with tempfile.TemporaryDirectory(prefix="check-figures-") as tmp:
        work = Path(tmp)
        page = probe_page(binary, report, width, work)
        height = int(min(max(page["height"], 100), 60000))
        screenshot(binary, report, width, height, shot, work)
    painted = decode_png(shot.read_bytes())
    if len(page["images"]) != len(checks):
        raise RuntimeError(f"the browser saw {len(page['images'])} images, the HTML has "
                           f"{len(checks)}")
    for check, seen in zip(checks, page["images"], strict=True):
        check.browser = dict(seen)
        if not seen["naturalWidth"]:
            check.problems.append("not decoded by the browser (naturalWidth 0)")
            continue
        if check.width and (seen["naturalWidth"], seen["naturalHeight"]) != (check.width,
                                                                               check.height):
            check.problems.append(f"browser decoded {seen['naturalWidth']}x"
                                  f"{seen['naturalHeight']}, the PNG is {check.width}x"
                                  f"{check.height}")
        top, left = int(round(seen["top"])), int(round(seen["left"]))
        box = painted[top:top + int(seen["height"]), left:left + int(seen["width"])]
        check.browser["painted_box_px"] = [int(box.shape[1]), int(box.shape[0])]
        if box.shape[0] < 0.9 * seen["height"] or box.shape[1] < 0.9 * seen["width"]:
            check.problems.append("outside the screenshot")
            continue
        check.browser["painted_ink"] = ink(box)[1]
        reason = blank_reason(box, min_ink)
        if reason:
            check.problems.append(f"blank on screen: {reason}")
    return {"page_px": [page["width"], page["height"]], "screenshot": str(shot),
            "screenshot_px": [int(painted.shape[1]), int(painted.shape[0])]}


# --- command line ------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("report", type=Path, help="report.html of `geocontact report` or demo")
    ap.add_argument("--screenshot", type=Path, default=None,
                    help="where to write the full-page screenshot (default: "
                         "REPORT_DIR-screenshot.png beside the report's folder)")
    ap.add_argument("--chromium", default=None, help="browser binary (default: on PATH)")
    ap.add_argument("--width", type=int, default=1280, help="window width in pixels")
    ap.add_argument("--min-ink", type=float, default=MIN_INK,
                    help="least fraction of a figure's pixels that are drawn")
    ap.add_argument("--no-browser", action="store_true", help="the PNG checks only")
    ap.add_argument("--json", action="store_true", help="print the result as one JSON document")
    args = ap.parse_args(argv)
    if not args.report.is_file():
        print(f"check_report_figures: report: not a file: {args.report}", file=sys.stderr)
        return 2
    try:
        checks = check_images(args.report, args.min_ink)
    except BadInput as exc:
        print(f"check_report_figures: {exc}", file=sys.stderr)
        return 2
    if not checks:
        print(f"check_report_figures: {args.report} has no <img>", file=sys.stderr)
        return 2
    page: dict = {}
    status = 0
    if not args.no_browser:
        binary = find_chromium(args.chromium)
        if binary is None:
            print("check_report_figures: chromium is missing: install it with `make chromium` "
                  "(apt-get install -y chromium) or name it with --chromium; only the PNG "
                  "checks ran (--no-browser to run them alone)", file=sys.stderr)
            status = 3
        else:
            # beside the report's folder, not in it (a result folder holds only its own files)
            folder = args.report.resolve().parent
            shot = args.screenshot or folder.parent / f"{folder.name}-screenshot.png"
            try:
                page = check_in_browser(checks, binary, args.report, shot, args.width,
                                        args.min_ink)
            except (RuntimeError, subprocess.TimeoutExpired, json.JSONDecodeError) as exc:
                print(f"check_report_figures: browser: {exc}", file=sys.stderr)
                return 2
    failed = [c for c in checks if not c.ok]
    if args.json:
        print(json.dumps({"report": str(args.report), "figures": len(checks),
                          "failed": len(failed), "browser": bool(page), **page,
                          "checks": [asdict(c) for c in checks]}, indent=2))
    else:
        for c in checks:
            seen = ""
            if c.browser:
                seen = (f"; browser {c.browser['naturalWidth']}x{c.browser['naturalHeight']}"
                        + (f", painted ink {100 * c.browser['painted_ink']:.1f} %"
                           if "painted_ink" in c.browser else ""))
            verdict = "ok" if c.ok else "FAIL: " + "; ".join(c.problems)
            print(f"[{c.index:2d}] {c.alt[:60]:60s} {c.width}x{c.height}, {c.colours} colours, "
                  f"ink {100 * c.ink:.1f} %{seen}: {verdict}")
        where = (f"; page {page['page_px'][0]}x{page['page_px'][1]} px, screenshot "
                 f"{page['screenshot']}" if page else "; browser checks not run")
        print(f"{len(checks) - len(failed)} of {len(checks)} figures pass{where}")
    return 1 if failed else status


if __name__ == "__main__":
    sys.exit(main())
