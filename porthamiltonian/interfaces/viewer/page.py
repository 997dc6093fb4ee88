"""The scene as HTML: an interactive three.js view that works offline, alone or inside a page.

* :func:`assets` — what a page needs once, whatever the number of views: the viewer's styles,
  an import map that carries the vendored three.js (``vendor/three``, its version in
  :data:`THREE_VERSION`) inline as ``data:`` URLs (a page opened from disk may not load module
  files beside it, and nothing is fetched from the network), and the viewer's module script,
  which starts every view of the page;
* :func:`block` — one view: the canvas, its controls, the scene's data (JSON) and, where WebGL
  or scripts are missing, the still image instead;
* :func:`document` / :func:`write_page` — a whole page around one view.

The view: drag to orbit about the up axis, shift-drag (or the right button, or two fingers) to
pan, the wheel or a pinch to zoom, double-click to reset; play/pause, a slider over the frames,
the speed, stepping to the previous/next stride, following the bodies, force arrows on/off.
Keys on the canvas: space, ←/→ (a frame), PageUp/PageDown (a stride), R (reset view).

For tests and for the page's own check, each view writes on its element: ``data-viewer`` —
``ready:F`` (F frames) once drawn, ``no-webgl``, or ``error: ...``; ``data-drawn="k/n"`` — of
the n pixels of its first picture, k differ from the background (read back from WebGL);
``data-probe`` — the world position of each body's first shape at frame 0, as three.js placed it
(JSON), which tests compare with the scene's poses.
"""
from __future__ import annotations

import base64
import functools
import html
import tempfile
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...errors import SceneError
from ...escaping import script_json

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["THREE_VERSION", "assets", "block", "document", "write_page"]

#: the vendored three.js release (npm package ``three``; vendor/three/README.md)
THREE_VERSION = "0.185.1"
_CORE_IMPORT = '"./three.core.min.js"'


@functools.lru_cache(maxsize=1)
def _import_map() -> str:
    """The import map: ``three`` (the module build, its import of the core build pointed at
    ``three/core``) and ``three/core``, both as base64 ``data:`` URLs."""
    base = resources.files(__package__).joinpath("vendor", "three")
    core = base.joinpath("three.core.min.js").read_text(encoding="utf-8")
    module = base.joinpath("three.module.min.js").read_text(encoding="utf-8")
    if _CORE_IMPORT not in module:
        raise SceneError("the viewer's vendor/three/three.module.min.js does not import "
                         f"{_CORE_IMPORT}: the vendored build changed (see its README); "
                         "reinstall porthamiltonian")
    module = module.replace(_CORE_IMPORT, '"three/core"')

    def url(source: str) -> str:
        return "data:text/javascript;base64," + base64.b64encode(source.encode()).decode()
    imports = {"three": url(module), "three/core": url(core)}
    return f'<script type="importmap">{script_json({"imports": imports})}</script>'


_CSS = """.ph-viewer{margin:1em 0 1.6em}
.ph-stage{position:relative}
.ph-viewer canvas{display:none;width:100%;height:420px;border:1px solid #dde1e6;border-radius:6px;
touch-action:none;cursor:grab;outline-offset:2px}
.ph-viewer.ph-live canvas{display:block}.ph-viewer.ph-live .ph-still{display:none}
.ph-still{display:block;max-width:100%;height:auto}
.ph-controls{display:none;flex-wrap:wrap;gap:8px 14px;align-items:center;margin:.5em 0;
font-size:14px}
.ph-viewer.ph-live .ph-controls{display:flex}
.ph-controls input[type=range]{flex:1 1 180px;min-width:0}
.ph-controls button{font:inherit;padding:3px 12px;border:1px solid #dde1e6;border-radius:6px;
background:#f5f6f8;cursor:pointer}
.ph-controls button:disabled{opacity:.45;cursor:default}
.ph-clock{font-variant-numeric:tabular-nums;color:#5d6470}
.ph-viewer figcaption{color:#5d6470;font-size:13.5px;margin-top:.3em;max-width:80ch}"""

_JS = r"""
import * as THREE from 'three';
const AXES={z:[[1,0,0],[0,1,0],[0,0,1]],y:[[1,0,0],[0,0,-1],[0,1,0]]};
const BACKGROUND='#eef1f5';
function vec(a,o){o=o||0;return new THREE.Vector3(a[o],a[o+1],a[o+2]);}
function material(c){return new THREE.MeshStandardMaterial({color:c,roughness:0.55,metalness:0.05});}
function mesh(s){
 const m=new THREE.Mesh(undefined,material(s.colour));
 if(s.kind==='sphere'){m.geometry=new THREE.SphereGeometry(s.radius,32,16);m.position.copy(vec(s.center));}
 else if(s.kind==='capsule'||s.kind==='cylinder'){
  const a=vec(s.a),b=vec(s.b),d=b.clone().sub(a),L=d.length();
  m.geometry=s.kind==='capsule'?new THREE.CapsuleGeometry(s.radius,L,8,20):
   new THREE.CylinderGeometry(s.radius,s.radius,L,24);
  m.position.copy(a).add(b).multiplyScalar(0.5);
  if(L>0){m.quaternion.setFromUnitVectors(new THREE.Vector3(0,1,0),d.divideScalar(L));}}
 else if(s.kind==='box'){m.geometry=new THREE.BoxGeometry(s.size[0],s.size[1],s.size[2]);
  m.position.copy(vec(s.center));m.quaternion.set(s.rotation[1],s.rotation[2],s.rotation[3],s.rotation[0]);}
 else if(s.kind==='torus'){m.geometry=new THREE.TorusGeometry(s.radius,s.tube,12,48,s.angle);
  const z=vec(s.axis).normalize(),x=vec(s.mid).normalize().applyAxisAngle(z,-s.angle/2),y=z.clone().cross(x);
  m.quaternion.setFromRotationMatrix(new THREE.Matrix4().makeBasis(x,y,z));m.position.copy(vec(s.center));}
 else{throw new Error('unknown shape '+s.kind);}
 m.castShadow=true;m.receiveShadow=true;return m;}
function start(box){
 const d=JSON.parse(box.querySelector('script.ph-data').textContent);
 const canvas=box.querySelector('canvas'),q=(c)=>box.querySelector(c);
 const F=d.t.length,S=d.size;
 const gl=window.WebGL2RenderingContext&&canvas.getContext('webgl2',{antialias:true,alpha:false,
  stencil:false,depth:true,premultipliedAlpha:true,preserveDrawingBuffer:false});
 if(!gl){box.setAttribute('data-viewer','no-webgl');
  console.warn('3D view: no WebGL 2 in this browser, the still image is shown');return;}
 const renderer=new THREE.WebGLRenderer({canvas:canvas,context:gl,antialias:true});
 box.classList.add('ph-live');
 renderer.setPixelRatio(Math.min(window.devicePixelRatio||1,2));
 renderer.shadowMap.enabled=true;renderer.shadowMap.type=THREE.PCFShadowMap;
 const scene=new THREE.Scene();scene.background=new THREE.Color(BACKGROUND);
 const E=AXES[d.up].map(a=>vec(a));
 const camera=new THREE.PerspectiveCamera(40,1,S*0.005,S*400);camera.up.copy(E[2]);
 const sky=new THREE.HemisphereLight(0xffffff,0x8a8a8a,1.7);sky.position.copy(E[2]);scene.add(sky);
 const sun=new THREE.DirectionalLight(0xffffff,2.1);sun.castShadow=true;sun.shadow.mapSize.set(2048,2048);
 const sc=sun.shadow.camera;sc.left=sc.bottom=-1.5*S;sc.right=sc.top=1.5*S;sc.near=0.05*S;sc.far=12*S;
 sun.shadow.bias=-0.0005;scene.add(sun);scene.add(sun.target);
 const sunDir=E[0].clone().multiplyScalar(0.3).addScaledVector(E[1],-0.5).add(E[2]).normalize();
 if(d.ground){const pos=[];
  for(const g of d.ground.quads){for(const k of [0,1,2,0,2,3]){pos.push(g[3*k],g[3*k+1],g[3*k+2]);}}
  const geo=new THREE.BufferGeometry();geo.setAttribute('position',new THREE.Float32BufferAttribute(pos,3));
  geo.computeVertexNormals();
  const gm=new THREE.Mesh(geo,new THREE.MeshStandardMaterial({color:d.ground.colour,roughness:0.95,
   side:THREE.DoubleSide,polygonOffset:true,polygonOffsetFactor:1,polygonOffsetUnits:1}));
  gm.receiveShadow=true;scene.add(gm);
  const lg=new THREE.BufferGeometry();lg.setAttribute('position',new THREE.Float32BufferAttribute(d.ground.grid,3));
  scene.add(new THREE.LineSegments(lg,new THREE.LineBasicMaterial({color:0x9aa3ad})));}
 const groups=d.bodies.map(b=>{const g=new THREE.Group();g.name=b.name;
  for(const s of b.shapes){g.add(mesh(s));}scene.add(g);return g;});
 const arrows=d.arrows.map(a=>{const h=new THREE.ArrowHelper(new THREE.Vector3(1,0,0),new THREE.Vector3(),1,a.colour);
  h.visible=false;scene.add(h);return h;});
 const play=q('.ph-play'),slider=q('.ph-slider'),clock=q('.ph-clock'),speed=q('.ph-speed');
 const follow=q('.ph-follow'),forces=q('.ph-forces'),prev=q('.ph-prev'),next=q('.ph-next');
 const lo=vec(d.bounds[0]),hi=vec(d.bounds[1]),middle=lo.clone().add(hi).multiplyScalar(0.5);
 const reduce=window.matchMedia&&window.matchMedia('(prefers-reduced-motion: reduce)').matches;
 let i=0,playing=!reduce,clockT=d.t[0],last=null,dirty=true,checked=false;
 let az=-1.2,el=0.32,dist=1,offset=new THREE.Vector3();
 function centre(k){if(!groups.length){return middle.clone();}const c=new THREE.Vector3();
  for(const b of d.bodies){c.add(vec(b.pose,7*k));}return c.divideScalar(groups.length);}
 function resetView(){az=-1.2;el=0.32;offset.set(0,0,0);
  const span=follow&&follow.checked?S:Math.max(S,hi.distanceTo(lo));
  dist=0.75*span/Math.tan(THREE.MathUtils.degToRad(20));view();}
 function view(){const tgt=(follow&&follow.checked?centre(i):middle.clone()).add(offset);
  const dir=E[0].clone().multiplyScalar(Math.cos(el)*Math.cos(az)).addScaledVector(E[1],Math.cos(el)*Math.sin(az)).addScaledVector(E[2],Math.sin(el));
  camera.position.copy(tgt).addScaledVector(dir,dist);camera.lookAt(tgt);
  sun.position.copy(tgt).addScaledVector(sunDir,4*S);sun.target.position.copy(tgt);dirty=true;}
 function strideAt(k){let s=-1;while(s+1<d.strides.length&&d.strides[s+1]<=d.t[k]+1e-12){s++;}return s;}
 function frameOf(time){let k=0;while(k<F-1&&d.t[k]<time-1e-12){k++;}return k;}
 function setFrame(k){i=Math.max(0,Math.min(F-1,k));clockT=d.t[i];
  for(let b=0;b<groups.length;b++){const p=d.bodies[b].pose,o=7*i;
   groups[b].position.set(p[o],p[o+1],p[o+2]);groups[b].quaternion.set(p[o+4],p[o+5],p[o+6],p[o+3]);}
  for(let j=0;j<arrows.length;j++){const a=d.arrows[j],h=arrows[j],v=vec(a.vector,3*i),L=v.length();
   if(forces&&forces.checked&&L>0.01*S){h.position.copy(vec(a.origin,3*i));h.setDirection(v.divideScalar(L));
    h.setLength(L,Math.min(0.3*L,0.08*S),Math.min(0.15*L,0.04*S));h.visible=true;}else{h.visible=false;}}
  slider.value=i;const s=strideAt(i);
  clock.textContent='t = '+d.t[i].toFixed(2)+' '+d.timeUnit+(d.strides.length?' \u00b7 '+
   (s<0?'before the first stride':'stride '+(s+1)+' of '+d.strides.length):'');
  if(prev){prev.disabled=i===0;next.disabled=s>=d.strides.length-1;}view();}
 function setPlaying(p){playing=p;last=null;play.textContent=p?'Pause':'Play';
  play.setAttribute('aria-pressed',p?'true':'false');}
 function toStride(step){const s=strideAt(i);let target;
  if(step>0){target=s+1<d.strides.length?frameOf(d.strides[s+1]):i;}
  else{const here=s>=0?frameOf(d.strides[s]):0;target=i>here?here:(s>0?frameOf(d.strides[s-1]):0);}
  setPlaying(false);setFrame(target);}
 function resize(){const w=canvas.clientWidth||600;
  const h=Math.round(Math.max(240,Math.min(0.62*w,0.7*(window.innerHeight||700))));
  canvas.style.height=h+'px';renderer.setSize(w,h,false);camera.aspect=w/h;
  camera.updateProjectionMatrix();dirty=true;}
 function check(){const gl=renderer.getContext(),w=gl.drawingBufferWidth,h=gl.drawingBufferHeight;
  const px=new Uint8Array(w*h*4);gl.readPixels(0,0,w,h,gl.RGBA,gl.UNSIGNED_BYTE,px);
  const hex=(k)=>parseInt(BACKGROUND.slice(k,k+2),16),br=hex(1),bgg=hex(3),bb=hex(5);
  let n=0;for(let k=0;k<px.length;k+=4){if(Math.abs(px[k]-br)+Math.abs(px[k+1]-bgg)+Math.abs(px[k+2]-bb)>30){n++;}}
  const probe=groups.map(g=>g.children.length?g.children[0].getWorldPosition(new THREE.Vector3()).toArray().map(x=>+x.toFixed(6)):null);
  box.setAttribute('data-drawn',n+'/'+(w*h));box.setAttribute('data-probe',JSON.stringify(probe));
  box.setAttribute('data-viewer','ready:'+F);}
 function loop(ts){
  if(playing&&d.t[F-1]>d.t[0]){if(last!==null){clockT+=(ts-last)/1000*parseFloat(speed.value)/d.timeScale;
    let k=i,wrap=false;if(clockT>d.t[F-1]){clockT=d.t[0];k=0;wrap=true;}
    while(k<F-1&&d.t[k+1]<=clockT){k++;}if(k!==i||wrap){const c=clockT;setFrame(k);clockT=c;}}last=ts;}
  if(dirty){renderer.render(scene,camera);dirty=false;if(!checked){checked=true;check();}}
  window.requestAnimationFrame(loop);}
 play.addEventListener('click',()=>setPlaying(!playing));
 slider.addEventListener('input',()=>{setPlaying(false);setFrame(parseInt(slider.value,10)||0);});
 if(prev){prev.addEventListener('click',()=>toStride(-1));next.addEventListener('click',()=>toStride(1));}
 if(follow){follow.addEventListener('change',()=>{offset.set(0,0,0);resetView();});}
 if(forces){forces.addEventListener('change',()=>setFrame(i));}
 q('.ph-reset').addEventListener('click',resetView);
 const pts=new Map();let pinch=0;
 function spread(){const p=[...pts.values()];return Math.hypot(p[0][0]-p[1][0],p[0][1]-p[1][1])||1;}
 function zoom(f){dist=Math.max(0.05*S,Math.min(200*S,dist*f));view();}
 canvas.addEventListener('pointerdown',e=>{canvas.setPointerCapture(e.pointerId);
  pts.set(e.pointerId,[e.clientX,e.clientY]);pinch=pts.size===2?spread():0;});
 canvas.addEventListener('pointermove',e=>{const p=pts.get(e.pointerId);if(!p){return;}
  const dx=e.clientX-p[0],dy=e.clientY-p[1];p[0]=e.clientX;p[1]=e.clientY;
  if(pts.size===1&&!(e.shiftKey||(e.buttons&6))){az-=0.008*dx;el=Math.max(-1.5,Math.min(1.5,el+0.008*dy));view();}
  else if(pts.size===1||pts.size===2){const k=dist*0.0015,m=camera.matrixWorld.elements;
   offset.addScaledVector(new THREE.Vector3(m[0],m[1],m[2]),-k*dx).addScaledVector(new THREE.Vector3(m[4],m[5],m[6]),k*dy);
   if(pts.size===2){const s=spread();if(pinch>0){zoom(pinch/s);}pinch=s;}view();}});
 const lift=e=>{pts.delete(e.pointerId);pinch=pts.size===2?spread():0;};
 canvas.addEventListener('pointerup',lift);canvas.addEventListener('pointercancel',lift);
 canvas.addEventListener('wheel',e=>{e.preventDefault();zoom(Math.exp(0.0015*e.deltaY));},{passive:false});
 canvas.addEventListener('contextmenu',e=>e.preventDefault());
 canvas.addEventListener('dblclick',resetView);
 canvas.addEventListener('keydown',e=>{const k=e.key;
  if(k===' '){setPlaying(!playing);}else if(k==='ArrowRight'||k==='ArrowLeft'){setPlaying(false);setFrame(i+(k==='ArrowRight'?1:-1));}
  else if(k==='PageDown'||k==='PageUp'){toStride(k==='PageDown'?1:-1);}else if(k==='r'||k==='R'){resetView();}
  else{return;}e.preventDefault();});
 window.addEventListener('resize',resize);
 resize();resetView();setFrame(0);setPlaying(playing);window.requestAnimationFrame(loop);}
for(const box of document.querySelectorAll('.ph-viewer')){
 try{start(box);}catch(e){box.setAttribute('data-viewer','error: '+e.message);throw e;}}
"""


def assets() -> str:
    """Styles, the import map with three.js and the viewer's module: once per page, after
    the views (:func:`block`) or before them."""
    return (f"<style>{_CSS}</style>\n{_import_map()}\n"
            f'<script type="module">{_JS}</script>')


def _still_png(scene: Scene) -> bytes:
    with tempfile.TemporaryDirectory() as tmp:
        path = scene.to_png(Path(tmp) / "still.png")
        return path.read_bytes()


def block(scene: Scene, *, element_id: str = "viewer", caption: str = "",
          still: bytes | None = None, label: str = "3D view of the motion") -> str:
    """One view of ``scene`` (the page needs :func:`assets` once). ``still``: PNG bytes shown
    where WebGL or scripts are missing. ``caption``: text under the view (escaped here)."""
    data = script_json(scene.to_dict())
    n = len(scene.t)
    speeds = "".join(f'<option value="{s}"{" selected" if s == "1" else ""}>{s}×</option>'
                     for s in ("0.1", "0.25", "0.5", "1", "2"))
    strides = ('<button class="ph-prev" type="button" title="previous stride (PageUp)">◀ stride'
               '</button><button class="ph-next" type="button" title="next stride (PageDown)">'
               "stride ▶</button>" if len(scene.strides) else "")
    arrows = "forces" if all(a.unit == "N" for a in scene.arrows) else "arrows"
    forces = (f'<label><input class="ph-forces" type="checkbox"> {arrows}</label>'
              if scene.arrows else "")
    travel = _travel(scene)
    follow = (f'<label><input class="ph-follow" type="checkbox"{" checked" if travel else ""}>'
              " follow</label>")
    img = ("" if still is None else
           f'<img class="ph-still" src="data:image/png;base64,{base64.b64encode(still).decode()}" '
           f'alt="{html.escape(label)} (still image)">')
    how = ("Drag to orbit, shift-drag or right-drag to pan, wheel or pinch to zoom, double-click "
           "to reset the view; keys on the view: space plays or pauses, ←/→ step a frame"
           + (", PageUp/PageDown a stride" if len(scene.strides) else "") + ".")
    return f"""<figure class="ph-viewer" id="{html.escape(element_id)}" data-viewer="loading">
<div class="ph-stage"><canvas tabindex="0" role="img" aria-label="{html.escape(label)}"></canvas>{img}</div>
<div class="ph-controls"><button class="ph-play" type="button" aria-pressed="true">Pause</button>{strides}
<input class="ph-slider" type="range" min="0" max="{n - 1}" value="0" step="1" aria-label="frame">
<span class="ph-clock"></span><label>speed <select class="ph-speed">{speeds}</select></label>
{follow}{forces}<button class="ph-reset" type="button">reset view</button></div>
<figcaption>{html.escape(caption)}{" " if caption else ""}{html.escape(how)}</figcaption>
<script type="application/json" class="ph-data">{data}</script>
</figure>"""


def _travel(scene: Scene) -> bool:
    """Whether the bodies travel further than the scene's size (then the view follows them)."""
    if not scene.bodies:
        return False
    c = np.mean([b.position for b in scene.bodies], axis=0)
    return bool(np.linalg.norm(c.max(axis=0) - c.min(axis=0)) > scene.size())


def document(scene: Scene, *, title: str | None = None, caption: str = "",
             still: bool = True) -> str:
    """A whole page with one view of ``scene`` (everything inline)."""
    name = title if title is not None else (scene.title or "3D view")
    view = block(scene, caption=caption, still=_still_png(scene) if still else None,
                 label=f"3D view: {name}")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{html.escape(name)}</title>
<style>body{{margin:0;padding:0 16px;font:15px/1.5 system-ui,sans-serif;color:#1d1f23}}
main{{max-width:1080px;margin:0 auto;padding:16px 0 32px}}h1{{font-size:1.4em}}</style></head>
<body><main><h1>{html.escape(name)}</h1>
{view}
</main>
{assets()}
</body></html>
"""


def write_page(scene: Scene, path: Path, *, title: str | None = None, caption: str = "",
               still: bool = True) -> Path:
    """Write :func:`document` to ``path`` (UTF-8) and return the path."""
    path.write_text(document(scene, title=title, caption=caption, still=still), encoding="utf-8")
    return path
