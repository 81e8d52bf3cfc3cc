"""scripts/check_report_figures.py on a tiny synthetic report: a drawn figure passes; a blank
(all white), a flat-colour and a broken image fail. The PNG checks run everywhere; the browser
part (decoded in Chromium, painted in the screenshot) only where chromium is installed."""

import base64
import importlib.util
import io
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("check_report_figures",
                                               ROOT / "scripts" / "check_report_figures.py")
check = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = check  # dataclasses look their module up while the class is made
_spec.loader.exec_module(check)


def _png(draw=True, colour="white") -> bytes:
    fig, ax = plt.subplots(figsize=(3, 2), facecolor=colour)
    if draw:
        ax.plot([1, 2, 3], [1, 4, 9])
    else:
        ax.set_axis_off()
        ax.set_facecolor(colour)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=50, facecolor=colour)
    plt.close(fig)
    return buffer.getvalue()


def _img(alt: str, data: bytes | str) -> str:
    payload = data if isinstance(data, str) else base64.b64encode(data).decode()
    return f"<figure><img alt='{alt}' src='data:image/png;base64,{payload}'></figure>"


@pytest.fixture
def report(tmp_path):
    (tmp_path / "figures").mkdir()
    (tmp_path / "figures" / "beside.png").write_bytes(_png())
    body = "".join([
        _img("drawn", _png()),
        _img("white", _png(draw=False)),
        _img("grey", _png(draw=False, colour="#808080")),
        _img("broken", base64.b64encode(b"\x89PNG\r\n\x1a\n not a picture").decode()),
        "<figure><img alt='file' src='figures/beside.png'></figure>",
        "<figure><img alt='missing' src='figures/missing.png'></figure>",
    ])
    path = tmp_path / "report.html"
    path.write_text(f"<!doctype html><html><head><meta charset='utf-8'></head><body>{body}"
                    "</body></html>")
    return path


def test_blank_and_broken_images_are_found_without_a_browser(report):
    checks = {c.alt: c for c in check.check_images(report)}
    assert checks["drawn"].ok and checks["file"].ok
    assert checks["drawn"].colours > 1 and checks["drawn"].ink > 0.01
    assert checks["white"].problems == ["blank: all white"]
    assert checks["grey"].problems[0].startswith("blank: a single colour")
    assert checks["broken"].problems[0].startswith("broken: does not decode")
    assert checks["missing"].problems == ["broken: no such file: figures/missing.png"]
    assert check.main([str(report), "--no-browser"]) == 1


def test_blank_reason_on_pixels():
    white = np.full((20, 30, 3), 255, dtype=np.uint8)
    assert check.blank_reason(white) == "all white"
    almost = white.copy()
    almost[0, 0] = 0
    assert check.blank_reason(almost).startswith("almost blank")
    drawn = white.copy()
    drawn[5:10] = 0
    assert check.blank_reason(drawn) is None
    assert check.blank_reason(np.zeros((0, 5, 3), dtype=np.uint8)) == "empty (no pixels)"


def test_a_missing_browser_is_said_clearly(report, capsys):
    assert check.main([str(report), "--chromium", "/nonexistent/chromium"]) == 1
    err = capsys.readouterr().err
    assert "chromium is missing" in err and "make chromium" in err


@pytest.mark.skipif(check.find_chromium() is None, reason="chromium not installed")
def test_the_browser_sees_the_same(report, tmp_path):
    shot = tmp_path / "shot.png"
    checks = check.check_images(report)
    page = check.check_in_browser(checks, check.find_chromium(), report, shot, 800,
                                  check.MIN_INK)
    assert shot.is_file() and page["screenshot_px"][0] == 800
    by_alt = {c.alt: c for c in checks}
    assert by_alt["drawn"].ok and by_alt["file"].ok
    assert by_alt["drawn"].browser["naturalWidth"] == by_alt["drawn"].width
    assert by_alt["drawn"].browser["painted_ink"] > 0.01
    assert "not decoded by the browser (naturalWidth 0)" in by_alt["broken"].problems
    assert "not decoded by the browser (naturalWidth 0)" in by_alt["missing"].problems
    assert any(p.startswith("blank on screen") for p in by_alt["white"].problems)
