#!/usr/bin/env python3
"""Checks of report.html as headless Chromium showed it (called by report.sh; stdlib only).

    report_check.py dom DOM.html             maps in the order of the tables, 3 per grid
    report_check.py pixels SHOT.png DOM.html the first map is not blank, the legend is shown
    report_check.py netlog NETLOG.json [URL] the page made no request (or made one to URL)

Prints what it checked; exits 1 on the first failure.
"""
import json
import re
import struct
import sys
import zlib

FRAME = (0x0F, 0x1E, 0x2D)  # svg.map's CSS outline colour (report_page.rs STYLE)


def fail(msg):
    print(f"FAIL: {msg}")
    sys.exit(1)


def ok(msg):
    print(f"ok: {msg}")


def read_png(path):
    """(width, height, rows of (r, g, b) tuples) of an 8-bit RGB or RGBA PNG."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        fail(f"{path} is not a PNG")
    pos, idat, w = 8, b"", 0
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or ctype not in (2, 6) or interlace:
                fail(f"unsupported PNG: depth {depth}, colour type {ctype}")
            bpp = 4 if ctype == 6 else 3
        elif kind == b"IDAT":
            idat += body
    raw = zlib.decompress(idat)
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pr) & 255
        rows.append([tuple(line[x * bpp:x * bpp + 3]) for x in range(w)])
        prev = line
    return w, h, rows


def hex_rgb(s):
    return tuple(int(s[i:i + 2], 16) for i in (1, 3, 5))


def near(a, b, tol=3):
    return all(abs(x - y) <= tol for x, y in zip(a, b))


def first_map(dom):
    """The first svg.map element's text."""
    i = dom.find('<svg class="map"')
    if i < 0:
        fail("no <svg class=\"map\"> in the DOM")
    return dom[i:dom.find("</svg>", i)]


def check_dom(path):
    dom = open(path, encoding="utf-8").read()
    if "Content-Security-Policy" not in dom or "default-src 'none'" not in dom:
        fail("no Content-Security-Policy default-src 'none'")
    ok("Content-Security-Policy default-src 'none' in the page")
    table = dom[dom.find('<table id="summary"'):]
    table = table[:table.find("</table>")]
    rows = re.findall(r'<tr data-grid="([^"]*)">.*?href="#(map-\d+)"', table)
    sections = re.findall(r'<section class="grid-maps" id="(map-\d+)" data-grid="([^"]*)"', dom)
    if not rows:
        fail("the summary table has no grid rows")
    if [g for g, _ in rows] != [g for _, g in sections]:
        fail(f"maps {sections} not in the order of the table {rows}")
    for grid, anchor in rows:
        if (anchor, grid) not in sections:
            fail(f"the table's link for {grid} (#{anchor}) is not that grid's maps")
    for anchor, grid in sections:
        part = dom[dom.find(f'id="{anchor}"'):]
        part = part[:part.find("</section>")]
        n_maps = part.count('<svg class="map"')
        if n_maps != 3:
            fail(f"grid {grid}: {n_maps} maps, not 3")
        if part.count('class="swatch"') != 30:
            fail(f"grid {grid}: legends incomplete")
    ok(f"{len(rows)} grid(s) {[g for g, _ in rows]}: maps in the table's order, each row's "
       "link to its own grid's section, 3 maps with 10-class legends each")


def check_pixels(shot, dom_path):
    dom = open(dom_path, encoding="utf-8").read()
    svg = first_map(dom)
    legend = [hex_rgb(c) for c in re.findall(r'class="swatch"[^>]*fill="(#[0-9a-f]{6})"', svg)]
    points = [hex_rgb(c) for c in re.findall(r'class="pt"[^>]*fill="(#[0-9a-f]{6})"', svg)]
    if len(legend) != 10:
        fail(f"first map: {len(legend)} legend swatches in the DOM")
    w, h, px = read_png(shot)
    frame = [(x, y) for y in range(h) for x in range(w) if px[y][x] == FRAME]
    if not frame:
        fail("no map frame (colour #0f1e2d) in the screenshot: the map is not on screen")
    x0, y0 = min(frame, key=lambda p: (p[1], p[0]))
    x1 = x0
    while x1 + 1 < w and px[y0][x1 + 1] == FRAME:
        x1 += 1
    y1 = y0
    while y1 + 1 < h and px[y1 + 1][x0] == FRAME:
        y1 += 1
    if x1 - x0 < 100 or y1 - y0 < 100:
        fail(f"map frame {x0},{y0}–{x1},{y1} too small")
    region = [px[y][x] for y in range(y0 + 1, y1) for x in range(x0 + 1, x1)]
    lum = [0.2126 * r + 0.7152 * g + 0.0722 * b for r, g, b in region]
    mean = sum(lum) / len(lum)
    var = sum((v - mean) ** 2 for v in lum) / len(lum)
    if var < 100.0:
        fail(f"map region variance {var:.1f} (luminance²): blank")
    ok(f"first map at x {x0}–{x1}, y {y0}–{y1} px: luminance variance {var:.0f} "
       "(blank would be ~0)")
    # Legend: every swatch colour on screen as a block (a 28 × 14 swatch is 392 px).
    counts = [sum(1 for p in region if near(p, c)) for c in legend]
    missing = [i for i, n in enumerate(counts) if n < 150]
    if missing:
        fail(f"legend classes {missing} not found in the screenshot (pixels {counts})")
    ok(f"all 10 legend colours drawn in the map box (pixels per colour {counts})")
    # Points: the classes the DOM gives the points are on screen, beyond their swatch.
    used = sorted({legend.index(c) for c in points if c in legend})
    shown = [i for i in used if counts[i] > 392 + 50]
    if len(used) < 2 or shown != used:
        fail(f"point classes {used} in the DOM, on screen beyond the legend {shown}")
    ok(f"point colours of classes {used} on screen, as the DOM says")


def page_requests(path):
    """URLs of the requests the page made (not Chromium's own background ones, whose
    initiator is "not an origin"): URL_REQUEST_START_JOB events of a --log-net-log file."""
    text = open(path, encoding="utf-8").read().rstrip()
    try:
        log = json.loads(text)
    except json.JSONDecodeError:
        # A log cut at exit lacks its closing brackets.
        log = json.loads(text.rstrip(",") + "]}")
    start = log["constants"]["logEventTypes"]["URL_REQUEST_START_JOB"]
    jobs = [e["params"] for e in log["events"]
            if e["type"] == start and "url" in e.get("params", {})]
    page = [p["url"] for p in jobs
            if p.get("initiator") != "not an origin"
            or "file://" in p.get("network_isolation_key", "")]
    return len(jobs), page


def check_netlog(path, expect=None):
    jobs, page = page_requests(path)
    if expect is not None:
        if not any(expect in u for u in page):
            fail(f"control: the log shows no page request to {expect} ({page})")
        ok(f"control: the network log shows the page's request {expect}")
        return
    if page:
        fail(f"requests left the page: {page[:5]}")
    ok(f"network log: the page made no request ({jobs} requests in all, each Chromium's own "
       "background traffic)")


if __name__ == "__main__":
    what = sys.argv[1]
    if what == "dom":
        check_dom(sys.argv[2])
    elif what == "pixels":
        check_pixels(sys.argv[2], sys.argv[3])
    elif what == "netlog":
        check_netlog(sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else None)
    else:
        fail(f"unknown check {what}")
