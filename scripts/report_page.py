#!/usr/bin/env python3
"""HTML report pages for the evaluation scripts (ablation.py, synth_fusion.py): their Markdown tables as HTML
tables, grouped bar charts as inline SVG, and links to the `orpe report` page of every run they made.

Like `orpe report` (docs/REPORT.md): one self-contained page, no script, no network, any browser. Python 3
standard library only (no matplotlib: the charts are a few SVG rectangles).

  import report_page
  report_page.write("OUT/report.html", "Ablation", markdown_text,
                    charts=[report_page.bar_chart("ADD-S AUC", ["ALL", "mug"], {"DF": [50, 40], ...}, "AUC")],
                    links=[("scene 0000", "0000/report/index.html")])
  report_page.orpe_reports(orpe, [(run_dir, dataset_args)])   # `orpe report` for each run; returns the links

`python3 scripts/report_page.py --selftest` checks the Markdown conversion and the chart.
"""
import html
import os
import subprocess
import sys

PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
           "#bcbd22", "#17becf"]

STYLE = """body{font-family:sans-serif;margin:1.5em auto;max-width:1400px;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em} th,td{border:1px solid #ccc;padding:.25em .6em}
th{background:#f2f2f2} td.num{text-align:right;font-variant-numeric:tabular-nums}
h2{border-bottom:1px solid #ccc;padding-bottom:.2em} svg{margin:.4em .8em .8em 0}"""


def _inline(text):
    """Markdown inline markup of the scripts' tables: **bold** and `code`, the rest escaped."""
    out, bold, code = [], False, False
    i = 0
    while i < len(text):
        if text.startswith("**", i) and not code:
            out.append("</b>" if bold else "<b>")
            bold = not bold
            i += 2
        elif text[i] == "`":
            out.append("</code>" if code else "<code>")
            code = not code
            i += 1
        else:
            out.append(html.escape(text[i]))
            i += 1
    return "".join(out) + ("</b>" if bold else "") + ("</code>" if code else "")


def _cell(text, header):
    text = text.strip()
    tag = "th" if header else "td"
    numeric = not header and text.replace(".", "", 1).replace("-", "", 1).replace("+", "", 1).replace(
        "/", "").replace(" ", "").replace("(", "").replace(")", "").replace("..", "").isdigit()
    attr = ' class="num"' if numeric else ""
    return f"<{tag}{attr}>{_inline(text)}</{tag}>"


def markdown_to_html(md):
    """Headings (#..), pipe tables and paragraphs, as the scripts write them."""
    out, para, lines = [], [], md.splitlines()
    i = 0

    def flush():
        if para:
            out.append("<p>" + _inline(" ".join(para)) + "</p>")
            para.clear()
    while i < len(lines):
        line = lines[i].rstrip()
        if line.startswith("#"):
            flush()
            level = min(len(line) - len(line.lstrip("#")) + 1, 4)
            out.append(f"<h{level}>{_inline(line.lstrip('#').strip())}</h{level}>")
        elif line.startswith("|"):
            flush()
            rows = []
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c for c in lines[i].strip().strip("|").split("|")])
                i += 1
            body = [r for r in rows[1:] if not all(set(c.strip()) <= set("-:") for c in r)]
            out.append("<table><tr>" + "".join(_cell(c, True) for c in rows[0]) + "</tr>" + "".join(
                "<tr>" + "".join(_cell(c, False) for c in r) + "</tr>" for r in body) + "</table>")
            continue
        elif not line.strip():
            flush()
        else:
            para.append(line.strip())
        i += 1
    flush()
    return "\n".join(out) + "\n"


def bar_chart(title, groups, series, y_label, width=760, height=320, y_max=None):
    """Grouped bars: one group per entry of `groups`, one bar per series (name -> values, None = no bar)."""
    left, right, top, bottom = 56, 170, 28, 64
    w, h = width - left - right, height - top - bottom
    values = [v for vals in series.values() for v in vals if v is not None]
    vmax = y_max if y_max is not None else max(values + [1e-9]) * 1.05
    step = next(s * 10 ** e for e in range(-3, 6) for s in (1, 2, 5) if vmax / (s * 10 ** e) <= 6)
    y = lambda v: top + h - v / vmax * h
    s = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" '
         f'font-size="11"><rect width="100%" height="100%" fill="white"/>',
         f'<text x="{left + w / 2}" y="18" text-anchor="middle" font-size="13" font-weight="bold">'
         f'{html.escape(title)}</text>']
    t = 0.0
    while t <= vmax + 1e-9:
        s.append(f'<line x1="{left}" y1="{y(t):.1f}" x2="{left + w}" y2="{y(t):.1f}" stroke="#e4e4e4"/>'
                 f'<text x="{left - 5}" y="{y(t) + 4:.1f}" text-anchor="end">{t:g}</text>')
        t += step
    n, gw = len(series), w / max(len(groups), 1)
    bw = gw * 0.8 / max(n, 1)
    for gi, g in enumerate(groups):
        x0 = left + gi * gw + gw * 0.1
        for si, vals in enumerate(series.values()):
            v = vals[gi] if gi < len(vals) else None
            if v is None:
                continue
            s.append(f'<rect x="{x0 + si * bw:.1f}" y="{y(max(v, 0)):.1f}" width="{bw * 0.92:.1f}" '
                     f'height="{abs(y(0) - y(max(v, 0))):.1f}" fill="{PALETTE[si % 10]}"><title>'
                     f'{html.escape(str(g))}: {v:.1f}</title></rect>')
        s.append(f'<text x="{left + gi * gw + gw / 2:.1f}" y="{top + h + 14}" text-anchor="middle">'
                 f'{html.escape(str(g))[:18]}</text>')
    s.append(f'<rect x="{left}" y="{top}" width="{w}" height="{h}" fill="none" stroke="#444"/>')
    s.append(f'<text transform="translate(14 {top + h / 2}) rotate(-90)" text-anchor="middle">'
             f'{html.escape(y_label)}</text>')
    for si, name in enumerate(series):
        ly = top + 12 + 16 * si
        s.append(f'<rect x="{left + w + 10}" y="{ly - 9}" width="12" height="10" fill="{PALETTE[si % 10]}"/>'
                 f'<text x="{left + w + 26}" y="{ly}">{html.escape(name)}</text>')
    return "\n".join(s) + "\n</svg>\n"


def orpe_reports(orpe, runs):
    """`orpe report --run R [args]` for each (run folder, extra args); returns [(label, page)] of those that
    were written (a failure is reported on stderr and skipped: the tables do not depend on it)."""
    links = []
    for label, run_dir, extra in runs:
        cmd = [orpe, "-q", "report", "--run", run_dir] + list(extra)
        res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if res.returncode == 0:
            links.append((label, os.path.join(run_dir, "report", "index.html")))
        else:
            sys.stderr.write(f"warning: {' '.join(cmd)} failed ({res.returncode}):\n{res.stdout}")
    return links


def write(path, title, md, charts=(), links=()):
    """Writes the page atomically; links are (label, target) with targets made relative to the page."""
    base = os.path.dirname(os.path.abspath(path))
    parts = [f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{html.escape(title)}"
             f"</title><style>{STYLE}</style></head><body>", markdown_to_html(md)]
    if charts:
        parts.append("<h2>Charts</h2>\n" + "".join(charts))
    if links:
        parts.append("<h2>Runs (orpe report)</h2>\n<ul>" + "".join(
            f'<li><a href="{html.escape(os.path.relpath(os.path.abspath(t), base))}">{html.escape(l)}</a></li>'
            for l, t in links) + "</ul>")
    parts.append("</body></html>\n")
    with open(path + ".tmp", "w") as f:
        f.write("\n".join(parts))
    os.replace(path + ".tmp", path)


def _selftest():
    md = "### Title\n\ntext with `code`\n\n| a | b |\n| --- | ---: |\n| **ALL** | 12.5 |\n"
    h = markdown_to_html(md)
    assert "<h4>Title</h4>" in h, h
    assert "<code>code</code>" in h, h
    assert "<td><b>ALL</b></td><td class=\"num\">12.5</td>" in h, h
    assert "---" not in h, h
    svg = bar_chart("t", ["x", "y"], {"A": [1, 2], "B": [3, None]}, "v")
    assert svg.count("<rect") == 2 + 3 + 2, svg  # background, frame, 3 bars, 2 legend swatches
    print("report_page selftest: ok")


if __name__ == "__main__":
    if sys.argv[1:] == ["--selftest"]:
        _selftest()
    else:
        sys.exit(__doc__)
