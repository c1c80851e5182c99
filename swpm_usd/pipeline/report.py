"""The run's HTML report: per asset, triangles vs error and ACMR vs LOD plots (inline SVG), a memory
table by encoding, and the failures with their causes. One self-contained file, no scripts."""

from __future__ import annotations

import html
from pathlib import Path

from .worker import atomic_write_bytes


def _polyline(xs: list[float], ys: list[float], w: int = 260, h: int = 140, log_y: bool = False) -> str:
    import math

    if not xs:
        return "<svg></svg>"
    if log_y:
        ys = [math.log10(max(y, 1e-12)) for y in ys]
    x0, x1 = min(xs), max(xs) or 1
    y0, y1 = min(ys), max(ys)
    sx = (w - 20) / ((x1 - x0) or 1)
    sy = (h - 20) / ((y1 - y0) or 1)
    pts = " ".join(
        f"{10 + (x - x0) * sx:.1f},{h - 10 - (y - y0) * sy:.1f}" for x, y in zip(xs, ys, strict=True)
    )
    return (
        f'<svg width="{w}" height="{h}" style="background:#fafafa;border:1px solid #ddd">'
        f'<polyline fill="none" stroke="#2a6" stroke-width="2" points="{pts}"/></svg>'
    )


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


def write_report(path: Path, manifest: dict) -> None:
    assets = manifest.get("assets", {})
    rows, failures, plots, autos = [], [], [], []
    kept = 0
    by_encoding: dict[str, list[dict]] = {}
    for aid, rec in sorted(assets.items()):
        e = html.escape
        if rec.get("status") != "built":
            failures.append(f"<tr><td>{e(aid)}</td><td><pre>{e(rec.get('error', '?'))}</pre></td></tr>")
            continue
        if "last_failure" in rec:  # a failed rebuild: the previous build is kept, and listed below
            kept += 1
            failures.append(
                f"<tr><td>{e(aid)}</td><td><pre>{e(rec['last_failure'].get('error', '?'))}</pre>"
                "rebuild failed; the previous build (below) is kept</td></tr>"
            )
        s = rec.get("summary", {})
        by_encoding.setdefault(rec["encoding"], []).append(s)
        rows.append(
            f"<tr><td>{e(aid)}</td><td>{e(str(rec.get('rule')))}</td><td>{e(rec['encoding'])}</td>"
            f"<td>{s.get('triangles')}</td><td>{s.get('lod_count')}</td><td>{s.get('lambda', 0):.2f}</td>"
            f"<td>{s.get('acmr', 0):.3f}</td><td>{s.get('global_bytes')}</td>"
            f"<td>{s.get('instance_bytes')}</td>"
            f"<td>{rec.get('instances')}</td><td>{rec.get('seconds', 0):.2f}</td>"
            f"<td title='{e(rec.get('why', ''))}'>why</td></tr>"
        )
        if rec.get("auto_candidates"):
            autos.append(_auto_table(aid, rec))
        curve = s.get("curve", [])
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
    doc = f"""<!doctype html><html><head><meta charset="utf-8"><title>swpm-usd run report</title>
<style>body{{font-family:sans-serif;margin:2em}} table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}} td:first-child{{text-align:left}}
.card{{display:inline-block;margin:8px;padding:8px;border:1px solid #ddd;vertical-align:top}}
.card div{{display:inline-block;margin:4px}}</style></head><body>
<h1>swpm-usd run report</h1><p>tool {html.escape(str(manifest.get("tool_version")))}, config
{html.escape(str(manifest.get("config")))}: {len(rows)} built, {len(failures)} failed{kept_note}.</p>
<h2>Failures</h2><table><tr><th>asset</th><th>cause</th></tr>
{"".join(failures) or "<tr><td>none</td></tr>"}</table>
<h2>Memory by encoding</h2><table><tr><th>encoding</th><th>assets</th><th>global bytes</th>
<th>instance bytes (one instance each)</th></tr>{mem}</table>
<h2>Assets</h2><table><tr><th>asset</th><th>rule</th><th>encoding</th><th>triangles</th><th>LODs</th>
<th>lambda</th><th>ACMR@50%</th><th>global B</th><th>instance B</th><th>instances</th><th>s</th><th></th></tr>
{"".join(rows)}</table>
<h2>Encodings compared by <code>auto</code></h2>{"".join(autos) or "<p>none</p>"}
<h2>Curves</h2>{"".join(plots)}
</body></html>
"""
    atomic_write_bytes(path, doc.encode())
