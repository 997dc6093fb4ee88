"""The report's HTML: one self-contained page (styles, scripts, figures and the player's data all
inline; nothing is fetched from the network), readable from a phone to a wide screen.

Building blocks used by :mod:`walker_library.report`: :class:`Html` (text that is already HTML),
:func:`table` (a table in a horizontally scrolling wrapper, numbers right-aligned), :func:`named`
(a readable label whose hover text is the internal name), :func:`number` and
:func:`multiplier_cells` (numbers to the digits they support), :func:`figure`, :func:`player`
(the interactive animation: play/pause, scrub, speed, contact forces) and :func:`page` (which
also carries the 3D view's assets when the body has one).
"""
from __future__ import annotations

import base64
import html
import math
from collections.abc import Iterable, Sequence
from typing import Any

from porthamiltonian.escaping import script_json

__all__ = ["Html", "Note", "figure", "multiplier_cells", "named", "number", "page", "player", "table",
           "text"]


class Html(str):
    """A string that is already HTML (not escaped again)."""


class Note(Html):
    """A table row of one cell across all columns (an explanation under the row above it)."""


def text(value: Any) -> str:
    """Prose for a value: no Python literals (None, True, nan) ever reach the page."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    return str(value)


def number(value: Any, digits: int = 6) -> str:
    """A number to ``digits`` significant digits (``—`` for none/NaN)."""
    if value is None or isinstance(value, bool):
        return text(value)
    try:
        v = float(value)
    except (TypeError, ValueError):
        return text(value)
    if not math.isfinite(v):
        return "—"
    return f"{v:.{digits}g}"


def _cell(value: Any) -> str:
    if isinstance(value, Html):
        return f"<td>{value}</td>"
    if isinstance(value, float) or (isinstance(value, int) and not isinstance(value, bool)):
        return f'<td class="num">{html.escape(number(value))}</td>'
    return f"<td>{html.escape(text(value))}</td>"


def table(head: Sequence[str], rows: Iterable[Sequence[Any]], caption: str = "",
          numeric: Sequence[int] = (), stack: bool = True) -> Html:
    """A table in a scrolling wrapper (a wide table never widens the page). Floats are formatted
    by :func:`number` and right-aligned, as are the columns listed in ``numeric``. ``stack``:
    on a narrow screen each row becomes a block (the first cell as its title, the others as
    "column: value"), so a phone reads it without scrolling sideways."""
    head_html = "".join(f'<th{" class=num" if i in numeric else ""}>{html.escape(h)}</th>'
                        for i, h in enumerate(head))
    body = []
    for row in rows:
        if isinstance(row, Note):
            body.append(f'<tr class="note"><td colspan="{len(head)}">{row}</td></tr>')
            continue
        cells = []
        for i, value in enumerate(row):
            cell = _cell(value)
            if i in numeric and 'class="num"' not in cell:
                cell = cell.replace("<td>", '<td class="num">', 1)
            if stack:
                cell = cell.replace("<td", f'<td data-label="{html.escape(head[i])}"', 1)
            cells.append(cell)
        body.append("<tr>" + "".join(cells) + "</tr>")
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    kind = ' class="stack"' if stack else ""
    return Html(f'<div class="scroll"><table{kind}>{cap}<thead><tr>{head_html}</tr></thead>'
                f'<tbody>{"".join(body)}</tbody></table></div>')


def named(label: str, internal: str) -> Html:
    """A readable label with the internal name on hover (and for screen readers)."""
    if label == internal:
        return Html(html.escape(label))
    return Html(f'<span class="name" title="{html.escape(internal)}">{html.escape(label)}</span>')


def _decimals(error: float) -> int | None:
    """Decimals that an absolute error supports (its first significant digit's place)."""
    if error is None or not math.isfinite(error) or error <= 0:
        return None
    return max(0, -math.floor(math.log10(error)))


def _below(error: float) -> str:
    exponent = math.floor(math.log10(error))
    mantissa = math.ceil(error / 10.0**exponent)
    if mantissa >= 10:
        mantissa, exponent = 1, exponent + 1
    sup = str(exponent).translate(str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻"))
    return f"< {mantissa}×10{sup}"


def multiplier_cells(multipliers: Sequence[complex], error: float) -> tuple[list[list[str]], int]:
    """Rows (λ, |λ|) of the Floquet multipliers to the decimals their error estimate supports,
    conjugate pairs on one row; multipliers smaller than the error are not printed but counted
    (returned second) for one row "< ε". Without an estimate, 3 significant digits."""
    d = _decimals(error)
    small = 0
    rows = []
    seen: list[complex] = []
    for m in sorted((complex(x) for x in multipliers), key=lambda c: (-abs(c), -c.imag)):
        if d is not None and abs(m) < error:
            small += 1
            continue
        if any(abs(m - s.conjugate()) <= 1e-12 * max(1.0, abs(m)) and s.imag != 0 for s in seen):
            continue
        seen.append(m)
        fmt = (lambda v: f"{v:.{d}f}") if d is not None else (lambda v: f"{v:.3g}")
        if m.imag != 0 and (d is None or abs(m.imag) >= error):
            value = f"{fmt(m.real)} ± {fmt(abs(m.imag))}i"
        else:
            value = fmt(m.real)
        rows.append([value, fmt(abs(m))])
    if small:
        rows.append([f"{small} multiplier{'s' if small > 1 else ''}", _below(error)])
    return rows, small


def figure(images: dict[str, tuple[str, bytes]], name: str, alt: str, caption: str = "") -> Html:
    """An embedded image (a data URI) with its caption; empty when the image was not made."""
    if name not in images:
        return Html("")
    mime, data = images[name]
    cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    return Html(f'<figure><img src="data:{mime};base64,{base64.b64encode(data).decode()}" '
                f'alt="{html.escape(alt)}" title="{html.escape(name)}">{cap}</figure>')


_PLAYER_JS = r"""
(function(){'use strict';
var box=document.getElementById('player');if(!box){return;}
var d=JSON.parse(document.getElementById('player-data').textContent);
var cv=document.getElementById('player-canvas'),ctx=cv.getContext('2d');
var slider=document.getElementById('player-slider'),btn=document.getElementById('player-play');
var label=document.getElementById('player-time'),speed=document.getElementById('player-speed');
var forces=document.getElementById('player-forces');
var n=d.t.length,i=0,acc=0,last=null,scale=1,dpr=1,ox=0,oy=0,W=1,H=1;
var reduce=window.matchMedia&&window.matchMedia('(prefers-reduced-motion: reduce)').matches;
var playing=!reduce;
var b=d.bounds,xr=b[1]-b[0],zr=b[3]-b[2];
function X(x){return ox+(x-b[0])*scale;}function Y(z){return oy+(b[3]-z)*scale;}
function size(){W=cv.clientWidth||600;dpr=window.devicePixelRatio||1;
 H=Math.round(Math.min(W*zr/xr,Math.max(220,0.62*window.innerHeight)));
 cv.style.height=H+'px';cv.width=Math.round(W*dpr);cv.height=Math.round(H*dpr);
 scale=Math.min(W/xr,H/zr);ox=(W-xr*scale)/2;oy=(H-zr*scale)/2;draw();}
function line(p,q,c,w){ctx.strokeStyle=c;ctx.lineWidth=w;ctx.beginPath();
 ctx.moveTo(X(p[0]),Y(p[1]));ctx.lineTo(X(q[0]),Y(q[1]));ctx.stroke();}
function draw(){ctx.setTransform(dpr,0,0,dpr,0,0);ctx.clearRect(0,0,W,H);
 var tg=Math.tan(d.slope),xl=b[0]-ox/scale,xh=b[0]+(W-ox)/scale,g=[[xl,-xl*tg],[xh,-xh*tg]];
 ctx.fillStyle='#e6e6e6';ctx.beginPath();ctx.moveTo(X(g[0][0]),Y(g[0][1]));
 ctx.lineTo(X(g[1][0]),Y(g[1][1]));ctx.lineTo(W,H);ctx.lineTo(0,H);
 ctx.closePath();ctx.fill();line(g[0],g[1],'#555',1.5);
 var h=d.hip[i],feet=d.feet[i];ctx.lineCap='round';
 for(var k=0;k<feet.length;k++){var c=feet[k],col=d.colours[d.colour[i][k]%d.colours.length];
  line(h,c,col,3);var r=d.radius[k];
  if(r>0){var a=Math.atan2(c[1]-h[1],c[0]-h[0]);ctx.beginPath();
   ctx.arc(X(c[0]),Y(c[1]),r*scale,-a-d.arcHalfAngle,-a+d.arcHalfAngle);ctx.stroke();}
  else{ctx.fillStyle=col;ctx.beginPath();ctx.arc(X(c[0]),Y(c[1]),3,0,2*Math.PI);ctx.fill();}}
 for(k=0;k<feet.length;k++){
  if(d.force&&forces&&forces.checked){var f=d.force[i][k],p=d.contact[i][k];
   var q=[p[0]+f[0]*d.arrowScale,p[1]+f[1]*d.arrowScale];
   if(Math.hypot(q[0]-p[0],q[1]-p[1])>0.02*d.legLength){line(p,q,'#d62728',2.5);
    var ang=Math.atan2(-(q[1]-p[1]),q[0]-p[0]);ctx.fillStyle='#d62728';ctx.beginPath();
    ctx.moveTo(X(q[0]),Y(q[1]));
    ctx.lineTo(X(q[0])-8*Math.cos(ang-0.4),Y(q[1])-8*Math.sin(ang-0.4));
    ctx.lineTo(X(q[0])-8*Math.cos(ang+0.4),Y(q[1])-8*Math.sin(ang+0.4));ctx.closePath();ctx.fill();}}}
 ctx.fillStyle='#111';ctx.beginPath();ctx.arc(X(h[0]),Y(h[1]),6,0,2*Math.PI);ctx.fill();
 slider.value=i;label.textContent='t = '+d.t[i].toFixed(2)+' '+d.timeUnit+' \u00b7 step '+(d.step[i]+1)+' of '+d.nSteps;}
function frame(ts){if(playing){if(last!==null){acc+=(ts-last)/1000*parseFloat(speed.value);
  var dt=(d.t[n-1]-d.t[0])/(n-1)*d.timeScale;var moved=false;
  while(acc>=dt){acc-=dt;i=(i+1)%n;moved=true;}if(moved){draw();}}last=ts;}
 window.requestAnimationFrame(frame);}
function setPlaying(p){playing=p;last=null;acc=0;btn.textContent=p?'Pause':'Play';
 btn.setAttribute('aria-pressed',p?'true':'false');}
btn.addEventListener('click',function(){setPlaying(!playing);});
slider.addEventListener('input',function(){setPlaying(false);i=parseInt(slider.value,10)||0;draw();});
if(forces){forces.addEventListener('change',draw);}
cv.addEventListener('click',function(){setPlaying(!playing);});
window.addEventListener('resize',size);size();setPlaying(playing);
box.setAttribute('data-player','ready:'+n);window.requestAnimationFrame(frame);})();
"""


def player(data: dict, *, time_unit: str, time_scale: float, caption: str) -> Html:
    """The interactive animation: a canvas drawn from ``data`` (see
    :func:`walker_library.animation.player_data`) with play/pause, a scrub slider, speed and,
    when the data has forces, a contact-force toggle. ``time_scale``: real seconds per unit of
    simulated time at speed 1."""
    payload = script_json({**data, "timeUnit": time_unit, "timeScale": time_scale})
    n = len(data["t"])
    force = ('<label><input id="player-forces" type="checkbox"> contact forces</label>'
             if "force" in data else "")
    speeds = "".join(f'<option value="{s}"{" selected" if s == "1" else ""}>{s}×</option>'
                     for s in ("0.25", "0.5", "1", "2"))
    return Html(f"""<figure id="player" class="player">
<canvas id="player-canvas" role="img" aria-label="animation of the walker"></canvas>
<div class="controls"><button id="player-play" type="button" aria-pressed="true">Pause</button>
<input id="player-slider" type="range" min="0" max="{n - 1}" value="0" step="1" aria-label="time">
<span id="player-time" class="clock"></span>
<label>speed <select id="player-speed">{speeds}</select></label>{force}</div>
<figcaption>{html.escape(caption)}</figcaption>
<script type="application/json" id="player-data">{payload}</script>
</figure>""")


_CSS = """:root{--fg:#1d1f23;--muted:#5d6470;--line:#dde1e6;--soft:#f5f6f8;--accent:#1f5fa8}
*{box-sizing:border-box}
html{-webkit-text-size-adjust:100%}
body{margin:0;padding:0 16px;color:var(--fg);background:#fff;
font:15px/1.5 system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif}
main{max-width:1080px;margin:0 auto;padding:20px 0 48px}
h1{font-size:1.65em;line-height:1.2;margin:.3em 0 .2em}
h2{font-size:1.25em;margin:2em 0 .5em;padding-bottom:.2em;border-bottom:1px solid var(--line)}
h3{font-size:1.05em;margin:1.4em 0 .3em}
p{margin:.5em 0;max-width:80ch}
a{color:var(--accent)}
.lead{color:var(--muted)}
.badges{display:flex;flex-wrap:wrap;gap:6px;margin:.6em 0}
.badge{padding:2px 10px;border-radius:12px;font-size:13px;background:#eef3fb;color:var(--accent)}
.badge.good{background:#e7f5ec;color:#1a7f37}.badge.warn{background:#fdf0e6;color:#a5500c}
.cards{display:grid;grid-template-columns:repeat(auto-fill,minmax(160px,1fr));gap:10px;margin:1em 0}
.card{background:var(--soft);border-radius:8px;padding:8px 12px}
.card .k{font-size:12.5px;color:var(--muted)}.card .v{font-size:1.2em;font-weight:600;
font-variant-numeric:tabular-nums}
nav.toc{display:flex;flex-wrap:wrap;gap:4px 14px;font-size:14px;margin:1em 0}
.scroll{overflow-x:auto;max-width:100%;-webkit-overflow-scrolling:touch}
table{border-collapse:collapse;font-size:13.5px;margin:.3em 0 1em}
caption{text-align:left;font-weight:600;padding:4px 0}
th,td{border-bottom:1px solid var(--line);padding:4px 10px;text-align:left;vertical-align:top}
th{background:var(--soft);font-weight:600;white-space:nowrap}
td.num,th.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
tr.note td{color:var(--muted);font-size:13px;padding:0 10px 8px;white-space:normal;font-weight:400}
tr:has(+ tr.note) td{border-bottom:0}
.where{white-space:nowrap}
.ok{color:#1a7f37;font-weight:600}.bad{color:#b42318;font-weight:600}
.name{text-decoration:underline dotted #999;cursor:help}
figure{margin:1em 0 1.6em}figure img{display:block;max-width:100%;height:auto}
figcaption{color:var(--muted);font-size:13.5px;margin-top:.3em;max-width:80ch}
.grid2{display:grid;grid-template-columns:repeat(auto-fit,minmax(min(100%,420px),1fr));gap:0 24px}
.player canvas{display:block;width:100%;border:1px solid var(--line);border-radius:6px;
background:#fff;cursor:pointer}
.controls{display:flex;flex-wrap:wrap;gap:8px 14px;align-items:center;margin:.5em 0;font-size:14px}
.controls input[type=range]{flex:1 1 180px;min-width:0}
.controls button{font:inherit;padding:3px 14px;border:1px solid var(--line);border-radius:6px;
background:var(--soft);cursor:pointer;min-width:5em}
.clock{font-variant-numeric:tabular-nums;color:var(--muted)}
code{background:var(--soft);padding:1px 4px;border-radius:3px;font-size:.92em;overflow-wrap:anywhere}
@media (max-width:640px){table.stack,table.stack tbody,table.stack tr{display:block}
table.stack thead{display:none}table.stack tr{border-bottom:1px solid var(--line);padding:6px 0}
table.stack td{display:inline;border:0;padding:0 10px 0 0;white-space:normal}
table.stack td.num{text-align:left}table.stack td:first-child{display:block;font-weight:600}
table.stack td:not(:first-child)::before{content:attr(data-label) ": ";color:var(--muted)}
table.stack tr.note td{display:block;padding:2px 0 0;font-weight:400}table.stack tr.note td::before{content:none}
table.stack tr:has(+ tr.note){border-bottom:0}}
details{margin:.5em 0 1em}summary{cursor:pointer;color:var(--accent)}
footer{margin-top:3em;color:var(--muted);font-size:13px}"""

#: the page's own checks, read by the headless-browser tests: images decoded
#: (``data-images-ok="k/n"``) and horizontal overflow in CSS px (``data-overflow-x``); with
#: ``?layout-check`` in the address a 24-px square at the top left shows the overflow in a
#: screenshot (green: none, red: the page is wider than the window)
_CHECK_JS = """window.addEventListener('load',function(){var im=document.images,ok=0;
for(var i=0;i<im.length;i++){if(im[i].complete&&im[i].naturalWidth>0){ok++;}}
var b=document.body,e=document.documentElement,over=Math.max(0,e.scrollWidth-e.clientWidth);
b.setAttribute('data-images-ok',ok+'/'+im.length);b.setAttribute('data-overflow-x',String(over));
if(location.search.indexOf('layout-check')>=0){var m=document.createElement('div');
m.style.cssText='position:fixed;left:0;top:0;width:24px;height:24px;z-index:9;background:'+
(over>0?'#ff0000':'#00ff00');b.appendChild(m);}});"""


def page(title: str, body: str, *, with_player: bool, with_viewer: bool = False) -> str:
    """The whole document around ``body`` (styles and scripts inline). ``with_viewer``: the
    body holds a 3D view (:func:`porthamiltonian.viewer.page.block`): add its styles, three.js
    and its script."""
    script = _CHECK_JS + (_PLAYER_JS if with_player else "")
    if with_viewer:
        from porthamiltonian.interfaces.viewer.page import assets
        script_tags = f"<script>{script}</script>\n{assets()}"
    else:
        script_tags = f"<script>{script}</script>"
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{html.escape(title)}</title>
<style>{_CSS}</style></head>
<body><main>
{body}
</main>
{script_tags}
</body></html>
"""
