"""Checks a screenshot of `cowork experiment --report`'s index.html taken by headless Chromium.

usage: check_report.py REPORT_DIR SCREENSHOT.png DOM.html

- every <img> of index.html names a PNG beside it that decodes, is at least 400x200 px and is
  not one flat colour;
- the DOM Chromium dumped after loading the page says every image loaded (index.html's own
  script writes `data-images-loaded="N/M"` on <body> from `img.complete && naturalWidth > 0`);
- the summary table fits the 1400 px window the DOM was dumped at (the load script writes
  `data-summary-fits="yes|no"` and `data-summary-width="TABLE/WINDOW"` on <body>, measured by the
  browser: the table's scroll width and right edge within the window, no horizontal scrolling);
- every legend entry of every plot has data: each <img> names its legend (`data-legend`, a JSON
  list) and its CSV (`data-csv`, beside the PNG, linked under it); the CSV has a column named
  after each entry with at least one finite number;
- the screenshot is not blank: at least 5 % of its pixels differ from the page background
  (white; the plots themselves are mostly white: a full report measured 13 %, the summary
  table alone with broken images about 3 %), and it shows plot colours (at least 0.3 % of
  saturated pixels: the plots' blue/orange/red/green lines; a full report measured 1.3 %).

Standard library only (the PNG decoder handles what Chromium and plotters write: 8-bit
greyscale / RGB / RGBA / palette, non-interlaced).
"""

import csv
import html as htmllib
import json
import math
import re
import struct
import sys
import zlib
from pathlib import Path


def decode_png(path):
    """(width, height, rows of (r, g, b) tuples)."""
    data = Path(path).read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, palette = 8, b"", None
    width = height = depth = ctype = interlace = None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            width, height, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
        elif kind == b"PLTE":
            palette = [tuple(body[i : i + 3]) for i in range(0, len(body), 3)]
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    if depth != 8 or interlace != 0:
        raise ValueError(f"{path}: bit depth {depth}, interlace {interlace} not handled")
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[ctype]
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev, i = [], bytearray(stride), 0
    for _ in range(height):
        f = raw[i]
        line = bytearray(raw[i + 1 : i + 1 + stride])
        i += 1 + stride
        for x in range(stride):
            a = line[x - channels] if x >= channels else 0
            b = prev[x]
            c = prev[x - channels] if x >= channels else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + ((a + b) >> 1)) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[x] = (line[x] + pred) & 255
        prev = line
        if ctype == 3:
            rows.append([palette[v] for v in line])
        elif ctype in (0, 4):
            rows.append([(line[k], line[k], line[k]) for k in range(0, stride, channels)])
        else:
            rows.append([tuple(line[k : k + 3]) for k in range(0, stride, channels)])
    return width, height, rows


def is_colour(p):
    """A saturated pixel (plot line or fill), not grey text or grid."""
    return max(p) - min(p) >= 60


def finite(cell):
    try:
        return math.isfinite(float(cell))
    except ValueError:
        return False


def check_legends(report, html):
    """Every <img>'s legend entries have at least one finite value in its CSV."""
    tags = re.findall(r"<img\b[^>]*>", html)
    if not tags:
        sys.exit("index.html has no <img>")
    for tag in tags:
        attrs = {k: htmllib.unescape(v) for k, v in re.findall(r'([\w-]+)="([^"]*)"', tag)}
        src = attrs.get("src", "?")
        if "data-legend" not in attrs or "data-csv" not in attrs:
            sys.exit(f"{src}: no data-legend / data-csv: the legend's data cannot be checked")
        legend = json.loads(attrs["data-legend"])
        path = report / attrs["data-csv"]
        if not path.is_file():
            sys.exit(f"{src}: its CSV {path.name} is missing")
        if f'href="{attrs["data-csv"]}"' not in html:
            sys.exit(f"{src}: its CSV {path.name} is not linked on the page")
        with path.open(newline="") as f:
            rows = list(csv.reader(f))
        if not rows or rows[0][:1] != ["t"]:
            sys.exit(f"{path.name}: no header starting with the time column t")
        header = rows[0]
        for name in legend:
            if name not in header:
                sys.exit(f"{src}: legend entry {name!r} has no column in {path.name} ({header})")
            k = header.index(name)
            if not any(len(r) > k and finite(r[k]) for r in rows[1:]):
                sys.exit(f"{src}: legend entry {name!r} has no data in {path.name}")
    print(f"report check: {len(tags)} plots, every legend entry has data in its CSV")


def main():
    report, shot, dom = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    html = (report / "index.html").read_text()
    imgs = re.findall(r'<img src="([^"]+)"', html)
    check_legends(report, html)
    if len(imgs) < 5:
        sys.exit(f"index.html has {len(imgs)} <img> elements, expected the >= 5 plots of a trial")
    for name in imgs:
        w, h, rows = decode_png(report / name)
        if w < 400 or h < 200:
            sys.exit(f"{name}: {w}x{h} px is too small for a plot")
        distinct = {p for row in rows[:: max(1, h // 50)] for p in row[:: max(1, w // 50)]}
        if len(distinct) < 3:
            sys.exit(f"{name}: flat image ({len(distinct)} colours)")
    m = re.search(r'data-images-loaded="(\d+)/(\d+)"', dom.read_text())
    if not m:
        sys.exit("the dumped DOM has no data-images-loaded: the page's load script did not run")
    loaded, total = int(m.group(1)), int(m.group(2))
    if total != len(imgs) or loaded != total:
        sys.exit(f"Chromium loaded {loaded}/{total} images ({len(imgs)} in index.html)")
    dom_text = dom.read_text()
    fits = re.search(r'data-summary-fits="(yes|no)"', dom_text)
    width = re.search(r'data-summary-width="([^"]*)"', dom_text)
    if not fits:
        sys.exit("the dumped DOM has no data-summary-fits: the page does not measure its summary table")
    if fits.group(1) != "yes":
        sys.exit(f"the summary table does not fit a 1400 px window (table/window px: {width.group(1) if width else '?'})")
    w, h, rows = decode_png(shot)
    pixels = [p for row in rows[::2] for p in row[::2]]
    non_white = sum(1 for p in pixels if min(p) < 235) / len(pixels)
    colour = sum(1 for p in pixels if is_colour(p)) / len(pixels)
    print(
        f"report check: {len(imgs)} plots, Chromium loaded {loaded}/{total}; "
        f"screenshot {w}x{h} px, {100 * non_white:.1f} % non-background, {100 * colour:.2f} % plot colour"
    )
    if non_white < 0.05:
        sys.exit(f"screenshot looks blank: {100 * non_white:.1f} % non-background pixels (< 5 %)")
    if colour < 0.003:
        sys.exit(f"screenshot shows no plot colours ({100 * colour:.2f} % saturated pixels)")


if __name__ == "__main__":
    main()
