"""Assemble ``report.html``: one self-contained page (plotly.js embedded once, PNGs inline).

The page works offline: no file it needs lives outside it. plotly.js is
embedded gzip-compressed and unpacked in the browser with the standard
``DecompressionStream`` (every current browser); ``compress_js=False`` embeds
it as plain text instead (bigger file, also works in very old browsers).
"""

from __future__ import annotations

import base64
import datetime as _dt
import gzip
import html
import json
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..fileio import atomic_open
from ..provenance import machine_info
from .digest import run_digest
from .rundata import RunData, load_run, step_lengths
from .simulation import simulation_section

# --- small formatting helpers ------------------------------------------------------

#: longer lists in summary.json are summarised in the table, not copied into the page
MAX_LIST_IN_TABLE = 1000


def _esc(x: Any) -> str:
    return html.escape(str(x), quote=True)


def fmt_value(v: Any) -> str:
    """A summary value as short text: numbers to 6 significant digits, short lists inline."""
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        if v != 0 and (abs(v) >= 1e6 or abs(v) < 1e-3):
            return f"{v:.4e}"
        return f"{v:.6g}"
    if isinstance(v, (list, tuple)):
        if all(isinstance(x, (int, float, bool)) or x is None for x in v):
            if len(v) <= 12:
                return "[" + ", ".join(fmt_value(x) for x in v) + "]"
            nums = [x for x in v if isinstance(x, (int, float)) and not isinstance(x, bool)]
            head = ", ".join(fmt_value(x) for x in v[:6])
            rng = f"; min {fmt_value(min(nums))}, max {fmt_value(max(nums))}" if nums else ""
            return f"[{head}, …] ({len(v)} values{rng})"
        return json.dumps(v, default=str)[:400]
    return str(v)


def flatten_items(d: Any, prefix: str = "") -> list[tuple[str, Any]]:
    """Every leaf of a nested dict as ``("a.b.c", value)``; lists of dicts are indexed ``a[0].b``."""
    out: list[tuple[str, Any]] = []
    if isinstance(d, dict):
        if not d and prefix:
            out.append((prefix, "{}"))
        for k, v in d.items():
            out.extend(flatten_items(v, f"{prefix}.{k}" if prefix else str(k)))
    elif isinstance(d, (list, tuple)) and d and all(isinstance(x, dict) for x in d):
        for i, x in enumerate(d):
            out.extend(flatten_items(x, f"{prefix}[{i}]"))
    else:
        out.append((prefix, d))
    return out


def _table(items: list[tuple[str, Any]], cls: str = "kv") -> str:
    rows = []
    for k, v in items:
        full = fmt_value(v)
        cell = _esc(full)
        if isinstance(v, (list, tuple)) and 12 < len(v) <= MAX_LIST_IN_TABLE:
            cell = f"<details><summary>{_esc(full)}</summary><code>{_esc(json.dumps(v))}</code></details>"
        elif isinstance(v, (list, tuple)) and len(v) > MAX_LIST_IN_TABLE:
            cell = _esc(full) + ' <span class="note">(every value in summary.json)</span>'

        rows.append(f"<tr><th>{_esc(k)}</th><td>{cell}</td></tr>")
    return f'<table class="{cls}">' + "".join(rows) + "</table>"


def _png_data_uri(path_or_bytes) -> str:
    data = path_or_bytes if isinstance(path_or_bytes, bytes) else Path(path_or_bytes).read_bytes()
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _json_script(id_: str, obj_json: str) -> str:
    safe = obj_json.replace("</", "<\\/").replace("<!--", "<\\!--")
    return f'<script type="application/json" id="{_esc(id_)}">{safe}</script>'


# --- plotly.js embedding -----------------------------------------------------------

_LOADER = r"""
(async function () {
  const plots = Array.from(document.querySelectorAll('div.plot[data-fig]'));
  function fail(msg) {
    for (const d of plots) { d.innerHTML = '<p class="warn">Interactive view not shown: ' + msg + '</p>'; }
    console.error('polishpath report: ' + msg);
  }
  try {
    if (typeof window.Plotly === 'undefined') {
      const src = document.getElementById('plotly-gz');
      if (!src) { fail('plotly.js is missing from this file'); return; }
      if (typeof DecompressionStream === 'undefined') {
        fail('this browser cannot unpack the embedded plotly.js (needs DecompressionStream; ' +
             'rebuild with write_report(dir, compress_js=False))');
        return;
      }
      const b64 = src.textContent.trim();
      const bin = Uint8Array.from(atob(b64), c => c.charCodeAt(0));
      const text = await new Response(new Blob([bin]).stream()
                     .pipeThrough(new DecompressionStream('gzip'))).text();
      const s = document.createElement('script');
      s.textContent = text;
      document.head.appendChild(s);
    }
    for (const d of plots) {
      const spec = JSON.parse(document.getElementById(d.dataset.fig).textContent);
      await Plotly.newPlot(d, spec.data, spec.layout,
                           {responsive: true, displaylogo: false, scrollZoom: true});
    }
    document.body.dataset.plotsReady = String(plots.length);
  } catch (e) {
    fail(String(e && e.message || e));
  }
})();
"""


def _plotly_js(compress: bool) -> str:
    from plotly.offline import get_plotlyjs

    js = get_plotlyjs()
    if not compress:
        return f"<script>{js}</script>"
    gz = gzip.compress(js.encode("utf-8"), compresslevel=9, mtime=0)
    return ('<script type="application/octet-stream" id="plotly-gz">'
            + base64.b64encode(gz).decode("ascii") + "</script>")


# --- page --------------------------------------------------------------------------

_CSS = """
:root { --fg:#1d232a; --mut:#5b6670; --bg:#fff; --line:#dde3e8; --acc:#2a6f97; }
* { box-sizing: border-box; }
body { font: 14px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color: var(--fg);
       background: var(--bg); margin: 0; }
header { background: #f3f6f8; border-bottom: 1px solid var(--line); padding: 18px 28px 10px; }
header h1 { margin: 0 0 4px; font-size: 22px; }
header .what { font-size: 15px; margin: 0 0 8px; }
.meta { color: var(--mut); font-size: 12.5px; }
.meta span { margin-right: 18px; white-space: nowrap; }
nav { position: sticky; top: 0; background: #fffffff0; border-bottom: 1px solid var(--line);
      padding: 6px 28px; z-index: 10; font-size: 13px; }
nav a { margin-right: 14px; color: var(--acc); text-decoration: none; }
main { padding: 4px 28px 40px; max-width: 1400px; }
section { margin-top: 22px; }
h2 { font-size: 18px; border-bottom: 1px solid var(--line); padding-bottom: 4px; }
h3 { font-size: 15px; margin: 14px 0 6px; }
.cards { display: flex; flex-wrap: wrap; gap: 10px; }
.card { border: 1px solid var(--line); border-radius: 6px; padding: 8px 12px; min-width: 150px; }
.card .v { font-size: 18px; font-weight: 600; }
.card .k { color: var(--mut); font-size: 12px; }
.grid { display: grid; grid-template-columns: repeat(auto-fit, minmax(440px, 1fr)); gap: 14px; }
figure { margin: 0; }
figure img { max-width: 100%; height: auto; border: 1px solid var(--line); }
figcaption { color: var(--mut); font-size: 12.5px; }
.plot { width: 100%; min-height: 420px; border: 1px solid var(--line); }
.note { color: var(--mut); font-size: 12.5px; margin: 4px 0; }
.warn { color: #9a3412; }
table.kv { border-collapse: collapse; font-size: 12.5px; margin: 4px 0 10px; }
table.kv th { text-align: left; font-weight: 500; color: var(--mut); padding: 2px 14px 2px 0;
              vertical-align: top; white-space: nowrap; }
table.kv td { padding: 2px 0; font-family: ui-monospace, Menlo, Consolas, monospace; }
table.kv code { white-space: normal; word-break: break-all; font-size: 11px; }
pre { background: #f6f8fa; padding: 8px; overflow-x: auto; font-size: 12px; }
details > summary { cursor: pointer; }
.tables { columns: 2 520px; column-gap: 28px; }
.tbl { break-inside: avoid; }
footer { color: var(--mut); font-size: 12px; padding: 10px 28px 30px; }
"""


def _card(k: str, v: str) -> str:
    return f'<div class="card"><div class="v">{_esc(v)}</div><div class="k">{_esc(k)}</div></div>'


def _num(x: Any) -> float | None:
    return float(x) if isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) else None


def _header(run: RunData, written_at: str, folder: Path) -> tuple[str, str]:
    s = run.summary
    cfg = run.section("config")
    surf = run.section("surface")
    plan = run.section("plan")
    surface_name = surf.get("source") or surf.get("name") or cfg.get("surface") or "unknown surface"
    pattern = plan.get("pattern") or cfg.get("pattern") or "?"
    method = run.section("flattening").get("method") or cfg.get("method") or "?"
    n = plan.get("dwell_points")
    if n is None and run.get("plan_uv") is not None:
        n = len(run.get("plan_uv"))
    spacing = run.spacing
    what = (f"A {pattern} path of {n:,} dwell points" if isinstance(n, int) else f"A {pattern} path")
    if spacing:
        what += f" at {spacing:g} mm spacing"
    what += f" on {surface_name}, flattened with {method}."
    seed = s.get("seed", cfg.get("seed"))
    version = s.get("polishpath_version", "?")
    run_machine = s.get("machine")
    if isinstance(run_machine, dict):
        machine = run_machine.get("node") or run_machine.get("host") or "?"
        proc = run_machine.get("processor") or run_machine.get("machine") or ""
    elif isinstance(run_machine, str) and run_machine:
        machine, proc = run_machine, ""
    else:  # the run did not record it: the machine that writes the report
        here = machine_info()
        machine, proc = here["node"] or "?", here["processor"] or ""
    meta = [
        ("seed", seed), ("polishpath", version), ("machine", f"{machine} ({proc})" if proc else machine),
        ("report written", written_at), ("run folder", folder.resolve()),
    ]
    if s.get("created") or s.get("date"):
        meta.insert(3, ("run date", s.get("created") or s.get("date")))
    meta_html = "".join(f"<span><b>{_esc(k)}</b> {_esc(v)}</span>" for k, v in meta)
    title = f"polishpath report: {pattern} path on {surface_name}"
    head = (f"<header><h1>{_esc(title)}</h1><p class=\"what\">{_esc(what)}</p>"
            f"<div class=\"meta\">{meta_html}</div></header>")
    return title, head


def _overview(run: RunData) -> str:
    plan = run.section("plan")
    surf = run.section("surface")
    cards = []
    uv = run.get("plan_uv")
    n = plan.get("dwell_points", len(uv) if uv is not None else None)
    if n is not None:
        cards.append(_card("dwell points", f"{n:,}" if isinstance(n, int) else str(n)))
    if plan.get("pieces") is not None:
        cards.append(_card("pieces (tool lifts + 1)", str(plan.get("pieces"))))
    if plan.get("unreached") is not None:
        cards.append(_card("unreached grid points", str(plan.get("unreached"))))
    if _num(surf.get("area_mm2")) is not None:
        cards.append(_card("surface area", f"{surf['area_mm2']:.4g} mm²"))
    if _num(plan.get("planar_spacing_mm")) is not None:
        cards.append(_card("planar spacing", f"{plan['planar_spacing_mm']:.4g} mm"))
    xyz = run.get("xyz")
    s = run.spacing
    try:
        st = step_lengths(xyz, run.get("plan_pieces")) if xyz is not None and len(xyz) > 1 else np.zeros(0)
    except Exception:  # malformed array: the 3D view says so; the overview leaves the card out
        st = np.zeros(0)
    if len(st):
        cards.append(_card("3D step mean / max", f"{st.mean():.4g} / {st.max():.4g} mm"))
        if s:
            inside = np.mean((st >= s * (1 - 1e-6)) & (st <= math.sqrt(2) * s * (1 + 1e-6)))
            cards.append(_card(f"steps in [s, √2 s], s = {s:g} mm", f"{100 * inside:.1f}%"))
    try:
        dg = run_digest(run)
    except ValueError:  # malformed arrays: the feed figure says so; the overview leaves the cards out
        dg = None
    if dg is not None and int(dg["feed_bins"][-1]) > 0:
        env, n = dg["feed_envelope"], int(dg["feed_bins"][-1])
        mean = float(np.sum(env[:, 2] * np.diff(dg["feed_bins"])) / n)
        cards.append(_card("feed mean (min..max)", f"{mean:.4g} ({env[:, 0].min():.4g}..{env[:, 1].max():.4g}) mm/min"))
        period = _num(run.section("smooth").get("period_ms"))
        if period:
            t = n * period / 1000.0
            cards.append(_card("machine time", f"{t / 60:.1f} min" if t >= 120 else f"{t:.1f} s"))
    tot = run.summary.get("timings_s")
    if isinstance(tot, dict):
        vals = [_num(v) for v in tot.values()]
        vals = [v for v in vals if v is not None]
        if vals:
            cards.append(_card("planning time", f"{sum(vals):.3g} s"))
    return '<section id="overview"><div class="cards">' + "".join(cards) + "</div></section>"


def _fig_block(name: str, result: Any, caption: str, png: Path | None, embed: bool) -> str:
    if png is None:
        return (f'<figure id="fig-{_esc(name)}"><p class="note">{_esc(caption)} '
                f'<span class="warn">Not shown: {_esc(result)}.</span></p></figure>')
    if embed:
        img = f'<img alt="{_esc(caption)}" src="{_png_data_uri(png)}">'
    else:
        img = ""
    link = f'<span class="note">PNG: <code>figures/{_esc(png.name)}</code></span>'
    shown = f' <span class="note">{_esc(result)}</span>' if isinstance(result, str) and result else ""
    return f'<figure id="fig-{_esc(name)}">{img}<figcaption>{_esc(caption)}{shown} {link}</figcaption></figure>'


def _interactive_block(key: str, fn, run: RunData, scripts: list[str]) -> tuple[str, bool]:
    """A plotly div + its JSON, or a note. Returns (html, shown)."""
    try:
        fig, notes = fn(run)
    except ImportError as e:
        return f'<p class="note warn">Interactive view not available: {_esc(e)}.</p>', False
    except Exception as e:  # a malformed array must not cost the whole report
        warnings.warn(f"report view {key!r} could not be drawn: {e!r}", RuntimeWarning, stacklevel=2)
        return (f'<p class="note warn">Interactive view could not be drawn from this run\'s arrays '
                f"({_esc(type(e).__name__)}: {_esc(e)}).</p>"), False
    if fig is None:
        return f'<p class="note warn">{_esc(notes)}</p>', False
    import plotly.io as pio

    sid = f"figdata-{key}"
    scripts.append(_json_script(sid, pio.to_json(fig, validate=False, pretty=False)))
    note_html = "".join(f'<p class="note">{_esc(n)}</p>' for n in notes)
    h = int(fig.layout.height or 600)
    return (f'{note_html}<div class="plot" data-fig="{sid}" id="plot-{key}" style="height:{h}px"></div>', True)


def build_html(run: RunData, figures: dict[str, tuple[Any, Path | None]], *, compress_js: bool = True,
               written_at: str | None = None, shown_as: str | Path | None = None) -> str:
    """The report page as a string.

    Parameters
    ----------
    run : RunData
    figures : dict of name -> (figure-or-reason, png path or None)
        What :func:`write_report` drew; a None path means "not drawn, for this reason".
    compress_js : bool
        Embed plotly.js gzip-compressed (smaller) or as plain text.
    written_at : str, optional
        Time stamp shown (default: now).
    shown_as : path, optional
        The run folder's name shown (default ``run.folder``).
    """
    from .figures import FIGURES
    from .interactive import plot_planar_2d, plot_surface_3d

    written_at = written_at or _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    title, header = _header(run, written_at, Path(shown_as) if shown_as is not None else run.folder)
    scripts: list[str] = []

    def block(name: str, embed: bool = True) -> str:
        res, png = figures.get(name, ("not drawn", None))
        return _fig_block(name, res, FIGURES[name][1], png, embed)

    parts = [_overview(run)]

    # 1. the path on the part
    inter, shown = _interactive_block("surface_3d", plot_surface_3d, run, scripts)
    parts.append(
        '<section id="surface"><h2>The path on the part</h2>'
        '<p class="note">Drag to rotate, scroll to zoom. The path is coloured by path order '
        "(dark = start, yellow = end). The buttons switch between the dwell-point path and the "
        "smoothed machine curve (NURBS, sampled at the interpolation period).</p>"
        + inter + block("surface_path", embed=not shown) + "</section>")

    # 2. flattening
    flat_note = (f"Method: <b>{_esc(run.section('flattening').get('method') or run.section('config').get('method') or '?')}</b>. "
                 "Angle error: mean over the 3 corners of |planar angle − angle on the part|; area distortion: "
                 "log of (face's share of the planar area / its share of the part's area), 0 = kept.")
    parts.append(
        '<section id="flattening"><h2>Flattening (paper Figs. 2–3)</h2>'
        f'<p class="note">{flat_note}</p>'
        '<div class="grid">' + block("angle_error") + block("area_distortion") + "</div>"
        "<h3>Constraint residuals</h3>" + block("residuals") + "</section>")

    # 3. planar path
    inter2, shown2 = _interactive_block("planar_2d", plot_planar_2d, run, scripts)
    parts.append('<section id="planar"><h2>The planar path (paper Fig. 5b)</h2>'
                 '<p class="note">The pseudo-random walk on the square grid in the flattened region; '
                 "boundary in black, unreached grid points (if any) as red crosses. Drag to zoom, double-click to reset.</p>"
                 + inter2 + block("planar_path", embed=not shown2) + "</section>")

    # 4. path quality
    parts.append('<section id="quality"><h2>Steps, directions, turns</h2><div class="grid">'
                 + block("step_lengths") + block("directions") + block("turn_angles") + "</div></section>")

    # 5. feed
    parts.append('<section id="feed"><h2>Feed rate along the path</h2>' + block("feed_rate") + "</section>")
    if figures.get("tool_axes", ("", None))[1] is not None:  # a 5-axis run only (a 3-axis report as before)
        parts.append('<section id="tool-axes"><h2>Tool axes</h2>' + block("tool_axes") + "</section>")

    # 6. simulation
    parts.append(simulation_section(run, _png_data_uri, _table, flatten_items))

    # 6b. figuring (only for runs whose dwell times were solved from an error map)
    from .figuring import figuring_section

    parts.append(figuring_section(run, _png_data_uri))

    # 7. parameters and every figure
    parts.append(_tables_section(run))

    nav = ("<nav>" + "".join(f'<a href="#{a}">{_esc(t)}</a>' for a, t in [
        ("overview", "Overview"), ("surface", "3D path"), ("flattening", "Flattening"), ("planar", "Planar path"),
        ("quality", "Steps & directions"), ("feed", "Feed"), ("simulation", "Simulation")]
        + ([("figuring", "Figuring")] if run.section("figuring") else []) + [
        ("parameters", "Parameters & figures")]) + "</nav>")
    js = (_plotly_js(compress_js) + "<script>" + _LOADER + "</script>") if scripts else ""
    footer = ("<footer>Written by polishpath from the files of the run folder "
              "(summary.json, run.npz); rebuild with <code>polishpath report DIR</code>. "
              "Interactive views need JavaScript; everything else is plain HTML and inline PNG.</footer>")
    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{_esc(title)}</title><style>{_CSS}</style></head><body>"
            + header + nav + "<main>" + "".join(parts) + "</main>" + footer
            + "".join(scripts) + js + "</body></html>")


def _tables_section(run: RunData) -> str:
    s = run.summary
    out = ['<section id="parameters"><h2>Parameters and figures</h2>']
    top = [(k, s[k]) for k in ("polishpath_version", "seed") if k in s]
    out.append(_table(top))
    cfg = s.get("config")
    if isinstance(cfg, dict):
        out.append('<div class="tables"><div class="tbl"><h3>Parameters (config; re-run with job.toml)</h3>'
                   + _table(flatten_items(cfg)) + "</div>")
    else:
        out.append('<div class="tables">')
    for key, val in s.items():
        if key in ("config", "polishpath_version", "seed"):
            continue
        items = flatten_items(val, "") if isinstance(val, dict) else [(key, val)]
        out.append(f'<div class="tbl"><h3>{_esc(key)}</h3>' + _table(items) + "</div>")
    out.append("</div></section>")
    return "".join(out)


# --- entry point -------------------------------------------------------------------


def write_report(out_dir: str | Path, *, compress_js: bool = True,
                 shown_as: str | Path | None = None) -> dict[str, Path]:
    """Write ``report.html`` and the PNG figures of a finished run folder.

    Reads only the files of the folder (``summary.json``, ``run.npz`` and, when
    present, ``simulation/``), so it rebuilds the report of any past run.

    Parameters
    ----------
    out_dir : path
        Run folder written by ``polishpath plan SURFACE -o DIR``.
    compress_js : bool, default True
        Embed plotly.js gzip-compressed (about 2 MB instead of 4.8 MB; unpacked by
        the browser's ``DecompressionStream``). False embeds it as plain text.
    shown_as : path, optional
        The run folder's name in the report (default ``out_dir``): the folder
        it will have once a staging folder is renamed into place.

    Returns
    -------
    dict of str -> Path
        ``"report"``: ``out_dir/report.html``; ``"figure_<name>"``: each PNG
        written in ``out_dir/figures/`` (figures whose data the run lacks are
        left out, and the report says why).

    Raises
    ------
    InputError
        ``out_dir`` is not a polishpath run folder (no ``summary.json`` or ``run.npz``).
    """
    from .. import progress
    from .figures import FIGURES, display_note, save_png

    run = load_run(out_dir)
    fig_dir = run.folder / "figures"
    fig_dir.mkdir(exist_ok=True)
    written: dict[str, Path] = {}
    drawn: dict[str, tuple[Any, Path | None]] = {}
    for k, (name, (fn, _caption)) in enumerate(FIGURES.items()):
        progress.update(k, len(FIGURES), "figures")
        try:
            result = fn(run)
        except Exception as e:  # a malformed array must not cost the whole report
            warnings.warn(f"report figure {name!r} could not be drawn: {e!r}", RuntimeWarning, stacklevel=2)
            result = f"could not be drawn from this run's arrays ({type(e).__name__}: {e})"
        if isinstance(result, str):
            drawn[name] = (result, None)
            stale = fig_dir / f"{name}.png"
            if stale.exists():  # from an earlier run of this folder: no longer true
                stale.unlink()
            continue
        png = fig_dir / f"{name}.png"
        save_png(result, png)
        result.clear()
        drawn[name] = (display_note(result), png)
        written[f"figure_{name}"] = png
    page = build_html(run, drawn, compress_js=compress_js, shown_as=shown_as)
    report = run.folder / "report.html"
    with atomic_open(report, "w") as fh:
        fh.write(page)
    return {"report": report, **written}


# --- documents: one list of blocks, written as markdown and as self-contained HTML ---------------
# (used by polishpath.paper; the run report above builds its page directly)

_DOC_CSS = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;line-height:1.45}"
            "table{border-collapse:collapse;margin:0.5em 0;font-size:0.9em}td,th{border:1px solid #bbb;"
            "padding:3px 7px;text-align:right}th{background:#eee}td:first-child,th:first-child{text-align:left}"
            "img{max-width:100%}figure{margin:1em 0}figcaption,.cap{font-size:0.85em;color:#444}"
            "pre{background:#f6f6f6;padding:0.6em;overflow-x:auto;font-size:0.85em}")


def inline_html(text: str) -> str:
    """Markdown inline marks (``**bold**``, ```code```, ``*italic*``) of ``text`` as escaped HTML."""
    import re

    t = html.escape(str(text), quote=False)
    t = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", t)
    t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
    return re.sub(r"(?<![\w*])\*([^*\n]+?)\*(?![\w*])", r"<i>\1</i>", t)


def markdown_table(header: list, rows: list, caption: str = "") -> str:
    """A pipe table (a ``|`` inside a cell becomes ``/``), the caption in italics below it."""
    lines = ["| " + " | ".join(str(c) for c in header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c).replace("|", "/") for c in r) + " |" for r in rows]
    return "\n".join(lines) + (f"\n\n*{caption}*" if caption else "")


def html_table(header: list, rows: list, caption: str = "") -> str:
    """The same table as HTML, cells with their inline marks, the caption as a ``p.cap`` below it."""
    t = "<table><thead><tr>" + "".join(f"<th>{inline_html(c)}</th>" for c in header) + "</tr></thead><tbody>"
    t += "".join("<tr>" + "".join(f"<td>{inline_html(c)}</td>" for c in r) + "</tr>" for r in rows)
    return t + "</tbody></table>" + (f"<p class='cap'>{inline_html(caption)}</p>" if caption else "")


class Document:
    """Headings, paragraphs, lists, tables, figures and preformatted text, in order.

    :meth:`markdown` links the figures relatively; :meth:`html` embeds them
    (PNG data URIs), so the page needs no other file and fetches nothing.
    """

    def __init__(self) -> None:
        self.blocks: list[tuple] = []

    def h(self, level: int, text: str) -> None:
        self.blocks.append(("h", level, text))

    def p(self, text: str) -> None:
        self.blocks.append(("p", text))

    def ul(self, items) -> None:
        self.blocks.append(("ul", list(items)))

    def table(self, header, rows, caption: str = "") -> None:
        self.blocks.append(("table", list(header), [list(r) for r in rows], caption))

    def fig(self, rel: str, caption: str) -> None:
        """A PNG at ``rel``, a path relative to the folder the document is written to."""
        self.blocks.append(("fig", rel, caption))

    def pre(self, text: str) -> None:
        self.blocks.append(("pre", text))

    def markdown(self) -> str:
        """The document as markdown (figures as relative image links)."""
        out = []
        for b in self.blocks:
            kind = b[0]
            if kind == "h":
                out.append("#" * b[1] + " " + b[2])
            elif kind == "p":
                out.append(b[1])
            elif kind == "ul":
                out.append("\n".join(f"* {it}" for it in b[1]))
            elif kind == "table":
                out.append(markdown_table(b[1], b[2], b[3]))
            elif kind == "fig":
                out.append(f"![{b[2]}]({b[1]})\n\n*{b[2]}*")
            elif kind == "pre":
                out.append("```\n" + b[1].rstrip("\n") + "\n```")
        return "\n\n".join(out) + "\n"

    def html(self, root: str | Path, title: str) -> str:
        """The document as one self-contained HTML page; ``root`` is the folder the figure paths are relative to."""
        body = []
        for b in self.blocks:
            kind = b[0]
            if kind == "h":
                body.append(f"<h{b[1]}>{inline_html(b[2])}</h{b[1]}>")
            elif kind == "p":
                body.append(f"<p>{inline_html(b[1])}</p>")
            elif kind == "ul":
                body.append("<ul>" + "".join(f"<li>{inline_html(i)}</li>" for i in b[1]) + "</ul>")
            elif kind == "table":
                body.append(html_table(b[1], b[2], b[3]))
            elif kind == "fig":
                body.append(f"<figure><img alt='{_esc(b[2])}' src='{_png_data_uri(Path(root) / b[1])}'>"
                            f"<figcaption>{inline_html(b[2])}</figcaption></figure>")
            elif kind == "pre":
                body.append(f"<pre>{html.escape(b[1])}</pre>")
        return (f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
                f"<style>{_DOC_CSS}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")


__all__ = ["Document", "build_html", "flatten_items", "fmt_value", "html_table", "inline_html", "markdown_table",
           "write_report"]
