"""What a reader of a report sees, measured from the outputs a PDF reader extracts (poppler's ``pdftotext`` and
``pdfimages``): the text in each table cell's region, and the pixels of each design's colour inside a figure's axes;
and the headless Chromium the browser tests lay pages out in.

Used by tests/test_report_browser.py (the demo reports), tests/test_report_layout.py (small cases) and
tests/test_explore.py (the interactive page).
"""

from __future__ import annotations

import html
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

WORD_RE = re.compile(r'<word xMin="([\d.]+)" yMin="([\d.]+)" xMax="([\d.]+)" yMax="([\d.]+)">(.*?)</word>')
COLOR_TOLERANCE = 40
"""Largest difference per RGB channel [0-255] of a pixel counted as a design's colour (anti-aliased edges)."""
MIN_PIXELS = 60
"""Pixels of its colour a design's curve must have inside a figure's axes to count as visible."""
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def chromium() -> str | None:
    """The first Chromium-like browser on the PATH, or None."""
    return next((p for p in map(shutil.which, BROWSERS) if p), None)


BROWSER = chromium()


def run_browser(args: list[str], profile: Path) -> subprocess.CompletedProcess:
    """Headless :data:`BROWSER` with ``args`` and its own profile folder."""
    cmd = [BROWSER, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run",
           f"--user-data-dir={profile}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)


def have_poppler() -> bool:
    """True when ``pdftotext`` and ``pdfimages`` (Debian: poppler-utils) are on the PATH."""
    return all(shutil.which(t) for t in ("pdftotext", "pdfimages"))


def pdf_words(pdf: Path) -> list[list[tuple[float, float, float, float, str]]]:
    """Per page, every word the PDF's text holds with its box ``(x0, y0, x1, y1, text)`` [pt from the page's top
    left], as ``pdftotext -bbox-layout`` extracts it."""
    out = subprocess.run(["pdftotext", "-bbox-layout", str(pdf), "-"], capture_output=True, text=True, check=True)
    return [[(float(m[1]), float(m[2]), float(m[3]), float(m[4]), html.unescape(m[5])) for m in WORD_RE.finditer(page)]
            for page in re.findall(r"<page [^>]*>(.*?)</page>", out.stdout, re.S)]


def split_in(words: list[str], text: str) -> str | None:
    """Why ``words`` (a cell's extracted words in reading order) are not ``text`` broken only at spaces or after
    ``_`` and ``/``; None when they are. A word split across lines ("0.0268", "8"; "dampin", "g") fails."""
    text = " ".join(text.split())
    pos = 0
    for k, w in enumerate(words):
        spaces = 0
        while pos < len(text) and text[pos] == " ":
            pos, spaces = pos + 1, spaces + 1
        if not text.startswith(w, pos):
            return f"{w!r} is not the text at {pos} of {text!r}"
        if k and not spaces and text[pos - 1] not in "_/":
            return f"{text!r} split before {w!r}"
        pos += len(w)
    return None if pos == len(text) else f"only {pos} of {len(text)} characters of {text!r} found"


def cell_problems(cells: list[dict], pages: list) -> list[str]:
    """Every laid-out table cell (``pdf.layout_pages(..., cells=...)``) whose region in the PDF does not hold its text
    unsplit, or whose words reach outside it."""
    problems = []
    for c in cells:
        x0, y0, x1, y1 = (v * 72.0 for v in c["box_in"])
        words = [w for w in pages[c["page"]]
                 if x0 - 3 <= (w[0] + w[2]) / 2 <= x1 + 3 and y0 - 1.5 <= (w[1] + w[3]) / 2 <= y1 - 0.5]
        words.sort(key=lambda w: (round((w[1] + w[3]) / 2), w[0]))
        why = split_in([w[4] for w in words], c["text"]) if c["text"].strip() else None
        if why:
            problems.append(f"page {c['page'] + 1}: {why}")
        over = [w[4] for w in words if w[0] < x0 - 0.5 or w[2] > x1 + 0.5]
        if over:
            problems.append(f"page {c['page'] + 1}: {over} outside the cell of {c['text']!r}")
    return problems


def pdf_images(pdf: Path, folder: Path) -> list[Path]:
    """The images embedded in the PDF, in page order, as PNG files (``pdfimages -png``)."""
    folder.mkdir(parents=True, exist_ok=True)
    subprocess.run(["pdfimages", "-png", str(pdf), str(folder / "img")], check=True, capture_output=True)
    return sorted(folder.glob("img-*.png"))


def axes_mask(fig, shape: tuple[int, int]) -> np.ndarray:
    """Pixels inside the axes of a matplotlib figure (its legend band and labels left out) on an image of ``shape``."""
    h, w = shape
    mask = np.zeros((h, w), bool)
    for ax in fig.axes:
        p = ax.get_position()
        mask[int(h * (1 - p.y1)) + 1:int(h * (1 - p.y0)) - 1, int(w * p.x0) + 1:int(w * p.x1) - 1] = True
    return mask


def colour_pixels(rgb: np.ndarray, mask: np.ndarray, color: str) -> int:
    """Pixels of ``rgb`` (h, w, 3) inside ``mask`` within :data:`COLOR_TOLERANCE` of ``color`` (``#rrggbb``)."""
    target = np.array([int(color[i:i + 2], 16) for i in (1, 3, 5)])
    return int(((np.abs(rgb.astype(int) - target).max(axis=2) <= COLOR_TOLERANCE) & mask).sum())
