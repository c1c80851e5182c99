"""The run's HTML report: per asset, triangles vs error and ACMR vs LOD plots (inline SVG), a memory
table by encoding, and the failures with their causes. One self-contained file, with no script up to
:data:`INLINE_CURVES` built assets.

Beyond :data:`INLINE_CURVES` built assets the plots are not inline (10,000 assets: 20,000 SVGs, 11 MB for a
browser to lay out on opening): each asset's curve is in a compact table (``<script type=application/json
id=curve-data>``: asset id -> [encoding, triangles, error, LOD, ACMR], the numbers to four significant
digits) and a small inline script draws an asset's two plots, as they are drawn inline, when its name in
the table is clicked. The full figures stay in the manifest (``summary.curve``)."""

from __future__ import annotations

import html
import json
import math
import os
from pathlib import Path

from .worker import atomic_write_bytes

#: the most built assets whose plots the report draws inline (beyond: drawn on demand, see the docstring)
INLINE_CURVES = 500


#: a plot's size and margins (pixels): the axis ends' labels sit in the left and bottom margins
_W, _H, _LEFT, _RIGHT, _TOP, _BOTTOM = 300, 150, 46, 8, 8, 18


def _tick(v: float) -> str:
    """An axis end's label: a whole number as it is, any other to three significant digits."""
    if not math.isfinite(v):
        return "?"
    if v == int(v) and abs(v) < 1e6:
        return str(int(v))
    return f"{v:.3g}"


def _axis_labels(xs: list[float], ys: list[float]) -> list[str]:
    """The labels of a plot's axis ends, ``[x min, x max, y min, y max]``, of the finite figures, in their
    own units (a log plot's too). The on-demand plots get them from the report, not from the script: one
    number format."""
    xs = [v for v in xs if math.isfinite(v)] or [math.nan]
    ys = [v for v in ys if math.isfinite(v)] or [math.nan]
    return [_tick(min(xs)), _tick(max(xs)), _tick(min(ys)), _tick(max(ys))]


def _polyline(
    xs: list[float],
    ys: list[float],
    log_y: bool = False,
    labels: list[str] | None = None,
) -> str:
    if not xs:
        return "<svg></svg>"
    labels = _axis_labels(xs, ys) if labels is None else labels
    if log_y:
        ys = [math.log10(max(y, 1e-12)) for y in ys]
    w, h = _W, _H
    x0, x1 = min(xs), max(xs) or 1
    y0, y1 = min(ys), max(ys)
    sx = (w - _LEFT - _RIGHT) / ((x1 - x0) or 1)
    sy = (h - _TOP - _BOTTOM) / ((y1 - y0) or 1)
    pts = " ".join(
        f"{_LEFT + (x - x0) * sx:.1f},{h - _BOTTOM - (y - y0) * sy:.1f}" for x, y in zip(xs, ys, strict=True)
    )
    xa, xb, ya, yb = labels
    return (
        f'<svg width="{w}" height="{h}" style="background:#fafafa;border:1px solid #ddd">'
        f'<g font-size="10" fill="#555"><text x="{_LEFT - 3}" y="{_TOP + 8}" text-anchor="end">{yb}</text>'
        f'<text x="{_LEFT - 3}" y="{h - _BOTTOM}" text-anchor="end">{ya}</text>'
        f'<text x="{_LEFT}" y="{h - 4}">{xa}</text>'
        f'<text x="{w - _RIGHT}" y="{h - 4}" text-anchor="end">{xb}</text></g>'
        f'<polyline fill="none" stroke="#2a6" stroke-width="2" points="{pts}"/></svg>'
    )


def _held(values: list) -> list:
    """``values`` as the curve table holds them (:func:`_compact`): whole numbers as they are, others to four
    significant digits, one not finite as NaN."""
    return [v if type(v) is int else float(f"{v:.4g}") if math.isfinite(v) else math.nan for v in values]


def _compact(values: list) -> str:
    """Curve figures for the on-demand plots, a JSON array: whole numbers as they are, others to four
    significant digits (a plot is 300 pixels wide), one not finite as null."""
    shown = (str(v) if type(v) is int else f"{v:.4g}" if math.isfinite(v) else "null" for v in values)
    return f"[{','.join(shown)}]"


#: draws the plots of an asset (its name clicked in the table) from the curve table, as _polyline does (the
#: axis ends' labels as the table gives them: entries 5 and 6, from :func:`_axis_labels`)
_CURVE_SCRIPT = """<script>
(function(){
var data=JSON.parse(document.getElementById('curve-data').textContent);
function poly(xs,ys,logY,lab){
 var w=300,h=150,L=46,R=8,T=8,B=18;if(!xs.length)return '<svg></svg>';
 if(logY)ys=ys.map(function(y){return Math.log10(Math.max(y,1e-12));});
 var x0=Math.min.apply(null,xs),x1=Math.max.apply(null,xs)||1,y0=Math.min.apply(null,ys),
  y1=Math.max.apply(null,ys),sx=(w-L-R)/((x1-x0)||1),sy=(h-T-B)/((y1-y0)||1);
 var pts=xs.map(function(x,i){return (L+(x-x0)*sx).toFixed(1)+','+(h-B-(ys[i]-y0)*sy).toFixed(1);});
 return '<svg width="'+w+'" height="'+h+'" style="background:#fafafa;border:1px solid #ddd">'+
  '<g font-size="10" fill="#555"><text x="'+(L-3)+'" y="'+(T+8)+'" text-anchor="end">'+lab[3]+'</text>'+
  '<text x="'+(L-3)+'" y="'+(h-B)+'" text-anchor="end">'+lab[2]+'</text>'+
  '<text x="'+L+'" y="'+(h-4)+'">'+lab[0]+'</text>'+
  '<text x="'+(w-R)+'" y="'+(h-4)+'" text-anchor="end">'+lab[1]+'</text></g>'+
  '<polyline fill="none" stroke="#2a6" stroke-width="2" points="'+pts.join(' ')+'"/></svg>';}
function show(aid){
 var c=data[aid];if(!c)return;
 var card=document.createElement('div'),h=document.createElement('h3'),small=document.createElement('small');
 card.className='card';h.textContent=aid+' ';small.textContent=c[0];h.appendChild(small);card.appendChild(h);
 var a=document.createElement('div'),b=document.createElement('div');
 a.innerHTML='triangles (x) vs error (y, log)<br>'+poly(c[1],c[2],true,c[5]);
 b.innerHTML='LOD (x) vs ACMR (y)<br>'+poly(c[3],c[4],false,c[6]);
 card.appendChild(a);card.appendChild(b);
 var box=document.getElementById('curves');box.insertBefore(card,box.firstChild);}
document.getElementById('assets').addEventListener('click',function(e){
 var t=e.target.closest('a.curve');if(t){show(t.textContent);}});
})();
</script>"""


def _auto_table(aid: str, rec: dict) -> str:
    """One asset's ``encoding: auto`` candidates as measured (the chosen one in bold) and the reason."""
    e = html.escape
    cands = rec["auto_candidates"]
    by_error = any("misses_at_error_score" in c for c in cands.values())
    head = "<th>encoding</th><th>ACMR@50%</th>"
    head += "<th>misses at equal error (x fewest)</th>" if by_error else ""
    head += "<th>global B</th><th>instance B</th><th>total B</th><th>LOD change writes</th>"
    body = []
    for enc, c in sorted(cands.items()):
        name = f"<b>{e(enc)}</b>" if enc == rec["encoding"] else e(enc)
        cells = f"<td>{name}</td><td>{c.get('acmr', 0):.3f}</td>"
        if by_error:
            cells += f"<td>{c.get('misses_at_error_score', float('nan')):.2f}</td>"
        cells += (
            f"<td>{c.get('global_bytes')}</td><td>{c.get('instance_bytes')}</td><td>{c.get('total_bytes')}</td>"
            f"<td>{c.get('lod_change_cost', 0):.1f}</td>"
        )
        body.append(f"<tr>{cells}</tr>")
    return f"<h3>{e(aid)}</h3><p>{e(rec.get('why', ''))}</p><table><tr>{head}</tr>{''.join(body)}</table>"


def config_named(out_dir: Path, config: object) -> str | None:
    """The config file a manifest's ``config`` names, as an absolute path: it is relative to ``out_dir``'s
    real folder (:func:`.manifest._config_ref`: output.dir a link to a folder elsewhere is that folder), or
    absolute (an older version's). None for a value that is no path."""
    if not isinstance(config, str) or "\0" in config:
        return None
    return os.path.normpath(os.path.join(os.path.realpath(out_dir), config))


def config_shown(path: Path, config: object) -> str:
    """The manifest's ``config`` as the report ``path`` shows it: absolute (:func:`config_named`)."""
    named = config_named(path.parent, config)
    return str(config) if named is None else named


def _code(failure: dict) -> str:
    """A failure's stable code (:mod:`swpm_usd.codes`) as the report shows it before its message; "" for a
    record without one (written by an earlier version)."""
    code = failure.get("code")
    return f"<code>{html.escape(code)}</code>" if isinstance(code, str) else ""


def _layout(rec: dict) -> str:
    """The layout of an asset's .swpm as its record holds it (:func:`.worker.swpm_layout`): its index and
    offset widths in bytes, and whether it is the legacy one (a reader before 0.9.0's); "-" without a .swpm,
    "?" for a record without them (an older version's)."""
    swpm = (rec.get("outputs") or {}).get("swpm")
    if not isinstance(swpm, dict):
        return "-"
    if "index_width" not in swpm or "offset_width" not in swpm:
        return "?"
    legacy = " legacy" if swpm.get("legacy_layout") else ""
    return f"W{swpm['index_width']} O{swpm['offset_width']}{legacy}"


def write_report(path: Path, manifest: dict, because: dict[str, list[dict]] | None = None) -> None:
    """Write the report of ``manifest`` at ``path``; ``because``: why the run that writes it built each of
    the assets it built (asset id -> :func:`.reasons.build_reasons`' reasons), shown beside them."""
    from .reasons import shown as reasons_shown

    because = because or {}
    assets = manifest.get("assets", {})
    rows, failures, plots, autos, warned = [], [], [], [], []
    kept = 0
    by_encoding: dict[str, list[dict]] = {}
    inline = sum(rec.get("status") == "built" for rec in assets.values()) <= INLINE_CURVES
    curves: list[str] = []  # (beyond INLINE_CURVES) each asset's plots' figures, a JSON object's member
    for aid, rec in sorted(assets.items()):
        e = html.escape
        # (a loader's warning kept by the record: an attribute dropped, a prim not drawn)
        warned.extend(f"<tr><td>{e(aid)}</td><td>{e(w)}</td></tr>" for w in rec.get("warnings", []))
        if rec.get("status") != "built":
            failures.append(
                f"<tr><td>{e(aid)}</td><td>{_code(rec)}<pre>{e(rec.get('error', '?'))}</pre></td></tr>"
            )
            continue
        if "last_failure" in rec:  # a failed rebuild: the previous build is kept, and listed below
            kept += 1
            failures.append(
                f"<tr><td>{e(aid)}</td><td>{_code(rec['last_failure'])}"
                f"<pre>{e(rec['last_failure'].get('error', '?'))}</pre>"
                "rebuild failed; the previous build (below) is kept</td></tr>"
            )
        s = rec.get("summary", {})
        by_encoding.setdefault(rec["encoding"], []).append(s)
        # (the script looks the name up as the link's text: a carriage return, which a browser's parser
        # reads as a line feed, written as a character reference, read as itself)
        link = e(aid).replace("\r", "&#13;")
        name = e(aid) if inline else f"<a class=curve href='#curves'>{link}</a>"
        rule = "(defaults)" if rec.get("rule") is None else str(rec["rule"])  # (no rule matched: was "None")
        rows.append(
            f"<tr><td>{name}</td><td>{e(rule)}</td><td>{e(rec['encoding'])}</td>"
            f"<td>{s.get('triangles')}</td><td>{s.get('lod_count')}</td><td>{s.get('lambda', 0):.2f}</td>"
            f"<td>{s.get('acmr', 0):.3f}</td><td>{s.get('global_bytes')}</td>"
            f"<td>{s.get('instance_bytes')}</td>"
            f"<td>{rec.get('instances')}</td><td>{rec.get('seconds', 0):.2f}</td>"
            f"<td>{e(_layout(rec))}</td><td>{e(reasons_shown(because.get(aid, [])))}</td>"
            f"<td title='{e(rec.get('why', ''))}'>why</td></tr>"
        )
        if rec.get("auto_candidates"):
            autos.append(_auto_table(aid, rec))
        curve = s.get("curve", [])
        if not inline:
            figures = [[c[k] for c in curve] for k in ("triangles", "error", "lod", "acmr")]
            # (the labels of the figures as the table holds them, four significant digits, as drawn)
            held = [_held(f) for f in figures]
            labels = [_axis_labels(held[0], held[1]), _axis_labels(held[2], held[3])]
            shown = ",".join(
                [json.dumps(rec["encoding"]), *(_compact(f) for f in figures), *map(json.dumps, labels)]
            )
            curves.append(f"{json.dumps(aid)}:[{shown}]")
            continue
        tri = [c["triangles"] for c in curve]
        plots.append(
            f"<div class=card><h3>{e(aid)} <small>{e(rec['encoding'])}</small></h3>"
            "<div>triangles (x) vs error (y, log)<br>"
            f"{_polyline(tri, [c['error'] for c in curve], log_y=True)}</div>"
            "<div>LOD (x) vs ACMR (y)<br>"
            f"{_polyline([c['lod'] for c in curve], [c['acmr'] for c in curve])}</div>"
            "</div>"
        )
    mem = "".join(
        f"<tr><td>{html.escape(enc)}</td><td>{len(v)}</td><td>{sum(x['global_bytes'] for x in v)}</td>"
        f"<td>{sum(x['instance_bytes'] for x in v)}</td></tr>"
        for enc, v in sorted(by_encoding.items())
    )
    kept_note = f" ({kept} of them keeping their previous build)" if kept else ""
    if inline:
        curve_section = "".join(plots)
    else:  # ("<" escaped: no "</script>" in an asset id ends the table)
        table = ("{" + ",".join(curves) + "}").replace("<", "\\u003c")
        curve_section = (
            f"<p>{len(curves)} assets: click an asset's name in the table above to draw its curves here "
            f"(drawn inline for up to {INLINE_CURVES} assets; every figure is in the manifest, each "
            "record's <code>summary.curve</code>).</p><noscript><p>(Drawing them needs JavaScript.)</p>"
            f"</noscript><div id=curves></div><script type=application/json id=curve-data>{table}</script>"
            + _CURVE_SCRIPT
        )
    config = config_shown(path, manifest.get("config"))
    doc = f"""<!doctype html><html><head><meta charset="utf-8"><title>swpm-usd run report</title>
<style>body{{font-family:sans-serif;margin:2em}} table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}} td:first-child{{text-align:left}}
.card{{display:inline-block;margin:8px;padding:8px;border:1px solid #ddd;vertical-align:top}}
.card div{{display:inline-block;margin:4px}}</style></head><body>
<h1>swpm-usd run report</h1><p>tool {html.escape(str(manifest.get("tool_version")))}, config
{html.escape(config)}: {len(rows)} built, {len(failures)} failed{kept_note}.</p>
<h2>Failures</h2><table><tr><th>asset</th><th>cause</th></tr>
{"".join(failures) or "<tr><td>none</td></tr>"}</table>
<h2>Warnings</h2><table><tr><th>asset</th><th>warning of its last build</th></tr>
{"".join(warned) or "<tr><td>none</td></tr>"}</table>
<h2>Memory by encoding</h2><table><tr><th>encoding</th><th>assets</th><th>global bytes</th>
<th>instance bytes (one instance each)</th></tr>{mem}</table>
<h2>Assets</h2><table id=assets><tr><th>asset</th><th>rule</th><th>encoding</th><th>triangles</th>
<th>LODs</th><th>lambda</th><th>ACMR@50%</th><th>global B</th><th>instance B</th><th>instances</th><th>s</th>
<th title="the .swpm's index width W and offset width O in bytes; legacy: the layout a reader before 0.9.0
reads">.swpm layout</th><th>built by this report's run because</th><th></th></tr>
{"".join(rows)}</table>
<h2>Encodings compared by <code>auto</code></h2>{"".join(autos) or "<p>none</p>"}
<h2>Curves</h2>{curve_section}
</body></html>
"""
    atomic_write_bytes(path, doc.encode())
