"""The report's simulation section: what ``polishpath simulate`` left in the run folder's ``simulation/``.

Two kinds of simulation can be there (read through
:func:`polishpath.runfolder.read_run`, ``RunData.simulation``):

* the run's own path on its part (``polishpath simulate RUN_DIR``): its table,
  the fair figures of the centre square's residual, the removal and residual
  maps and the PSD with the path's lattice frequencies marked;
* a comparison of path patterns (``polishpath simulate SURFACE -o RUN_DIR``):
  the fair table (mean [min, max] over the seeds), the rankings, the residual
  maps side by side (``residuals.png``) and the PSDs with the lattice peaks
  marked (``psd.png``).
"""

from __future__ import annotations

import html
from typing import Any, Callable

from .rundata import RunData

__all__ = ["simulation_section"]

#: shown first, full width, when present: the two figures of a comparison (issue 18, "seen")
_LEAD_FIGURES = {"residuals.png": "Residual maps side by side (first seed; mean, tilt and power removed; one colour "
                                  "scale)",
                 "psd.png": "Profile PSDs of the residuals (mean over the seeds), each path's own lattice frequencies "
                            "marked (those its lattice peak was read at: 1/h, its harmonics, 1/(2h) of its own "
                            "planar spacing h)"}

_FAIR = (("residual_band_rms_nm", "band RMS (nm)", 1.0), ("lattice_peak_db", "lattice peak (dB)", 1.0),
         ("pvn", "PVn", 1.0), ("suppression_ratio", "paper-style suppression (%)", 100.0))


def _esc(x: Any) -> str:
    return html.escape(str(x), quote=True)


def _num(v, f: float = 1.0) -> str:
    return "—" if v is None else f"{v * f:.3g}"


def _fair_table(rows: list[dict[str, Any]]) -> str:
    head = "".join(f"<th>{_esc(lab)}<br><span class='note'>mean [min, max]</span></th>" for _, lab, _ in _FAIR)
    head += ("<th>lattice peak read at (1/mm)<br><span class='note'>each path's own frequencies</span></th>"
             "<th>time-density peak (dB)<br><span class='note'>machine samples</span></th>")
    body = []
    for r in rows:
        cells = "".join(f"<td>{_num(r.get(k), f)} [{_num(r.get(k + '_min'), f)}, {_num(r.get(k + '_max'), f)}]</td>"
                        for k, _, f in _FAIR)
        freqs = r.get("lattice_frequencies_per_mm")
        cells += f"<td>{', '.join(_num(x) for x in freqs) if freqs else '—'}</td>"
        cells += f"<td>{_num(r.get('time_density_peak_db'))}</td>"
        body.append(f"<tr><th>{_esc(r.get('name'))}</th>{cells}</tr>")
    return f"<table class='kv'><tr><th>path</th>{head}</tr>{''.join(body)}</table>"


def simulation_section(run: RunData, png_data_uri: Callable[[Any], str], kv_table: Callable[[list], str],
                       flatten_items: Callable[[Any], list]) -> str:
    """HTML of the simulation section (``png_data_uri``, ``kv_table``, ``flatten_items``: the page's own helpers)."""
    sim = run.simulation
    if not sim:
        return ('<section id="simulation"><h2>Simulation</h2><p class="note">No simulation in this run folder. '
                "Run <code>polishpath simulate</code> on it to add PSD curves and residual maps here.</p></section>")
    out = ['<section id="simulation"><h2>Simulation (paper Fig. 13, Table 4)</h2>']
    summary = sim.get("summary") or {}
    if sim.get("table"):
        out.append(f"<pre>{_esc(sim['table'])}</pre>")
    rows = summary.get("rows") if isinstance(summary, dict) else None
    if rows:
        out.append("<h3>Fair figures of each path's residual</h3>" + _fair_table(rows))
        for key, rk in (summary.get("rankings") or {}).items():
            own = ", each path at its own lattice frequencies" if key == "lattice_peak_db" else ""
            out.append(f"<p>Ranking by {_esc(key)} (best first{own}; [a ~ b]: not distinguishable, their ranges "
                       f"overlap): <b>{_esc(rk.get('text'))}</b></p>")
    elif isinstance(summary, dict) and summary.get("fair"):
        f = summary["fair"]
        out.append("<h3>Fair figures of the centre square's residual</h3>"
                   + kv_table([("band RMS (nm)", f.get("residual_band_rms_nm")),
                               ("lattice peak over the background (dB)", f.get("lattice_peak_db")),
                               ("PVn (PV / depth)", f.get("pvn")), ("spacing (mm)", f.get("spacing_mm"))]))
    imgs = [p for p in (sim.get("images") or []) if _nonempty(p)]
    captions = _LEAD_FIGURES if rows else {"psd.png": "Profile PSD of the centre square's residual, the run's "
                                                      "lattice frequencies marked"}
    lead = sorted((p for p in imgs if p.name in captions), key=lambda p: list(captions).index(p.name))
    for p in lead:
        out.append(f'<figure><img alt="{_esc(p.stem)}" src="{png_data_uri(p)}" style="max-width:100%">'
                   f"<figcaption>{_esc(p.name)}: {_esc(captions[p.name])}</figcaption></figure>")
    rest = [p for p in imgs if p not in lead]
    if rest:
        out.append('<div class="grid">')
        for p in rest:
            out.append(f'<figure><img alt="{_esc(p.stem)}" src="{png_data_uri(p)}"><figcaption>{_esc(p.name)}'
                       "</figcaption></figure>")
        out.append("</div>")
    if sim.get("summary") is not None:
        out.append("<details><summary>All simulation figures</summary>"
                   + kv_table(flatten_items(sim["summary"])) + "</details>")
    out.append("</section>")
    return "".join(out)


def _nonempty(p) -> bool:
    try:
        return p.stat().st_size > 0
    except OSError:
        return False
