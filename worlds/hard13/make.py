"""Own generator, held-out batch 13 (helper acting as an outside user): MESH OBSTACLES AS OTHER PEOPLE EXPORT THEM.
hard5's generator (worlds/hard5/make.py) is imported as a library (importlib, as hard6-12 do): its Path (straight
legs and arcs of radius >= 0.28 m from the start tip P0 heading +x), primitives, exact signed distances and `check`.
Its mesh reader is NOT used: every mesh file here is written by this file's own writers (plain Python / numpy
writing the bytes: OBJ, ASCII and binary PLY, ASCII and binary STL, glTF 2.0 binary), and every mesh's meaning is
kept in memory as a `Part` (its triangles, in the file's own units and frame, GLB node transforms applied by our own
code; the closed components for an inside test). hard5's `sdf` is pointed at these in-memory parts (h5.mesh_of is
replaced), so the reference-path checks and verify_mesh.py measure the geometry the file MEANS, never what a loader
makes of it.
Usage: python make.py [name ...]   (writes <this folder>/<name>.json, parts/*, bad/*; prints each world's checks)"""
import importlib.util, json, math, struct, sys, os
import numpy as np
import warnings
warnings.filterwarnings('ignore', message='Gimbal lock')

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("hard5_make", os.path.join(HERE, '..', 'hard5', 'make.py'))
h5 = sys.modules['hard5_make'] = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(h5)
h5.OUT = OUT = HERE
from hard5_make import (P0, X0, Y0, Z0, Q0, BASE, UP, DOWN, LEFT, RIGHT, EX, unit, Path, S_curve,  # noqa: E402
                        box, cyl, sph, frame_box, plate_hole, seg, check, rnd, R_of)
from geom import MeshDist  # noqa: E402  (hard5's exact point-triangle distance; on sys.path via hard5's make)
from scipy.spatial.transform import Rotation as Rot  # noqa: E402

PARTS_DIR = os.path.join(HERE, 'parts')
EZ = np.array([0, 0, 1.0]); EY = np.array([0, 1.0, 0])


# ======================================================================================================
# in-memory meaning of a mesh file
# ======================================================================================================
class Part:
    """What a mesh file means, in the file's own frame and units: triangles T (n,3,3) with outward winding
    (consistent, whatever the file writes), and `closed`: a list of triangle-index arrays, each a closed
    component (an inside test by its winding number); triangles in no closed component are an open surface."""
    def __init__(self, T, closed):
        self.T = np.asarray(T, float); self.closed = [np.asarray(c, int) for c in closed]


def tris_of(V, polys):
    """correct triangulation of planar polygons (convex: fan; a polygon given as ('ear', idx) is ear-clipped)"""
    V = np.asarray(V, float); out = []
    for p in polys:
        if isinstance(p, tuple) and p[0] == 'ear':
            out += [[V[a], V[b], V[c]] for a, b, c in ear_clip(V, p[1])]
        else:
            for k in range(1, len(p) - 1): out.append([V[p[0]], V[p[k]], V[p[k + 1]]])
    return np.array(out)


def ear_clip(V, idx):
    """ear clipping of a simple planar polygon (indices into V); returns triangles with the polygon's winding"""
    P = np.asarray(V, float)[idx]
    n = np.zeros(3)
    for i in range(len(P)): n += np.cross(P[i], P[(i + 1) % len(P)])
    n = unit(n); a = unit(P[1] - P[0] if np.linalg.norm(np.cross(P[1] - P[0], n)) > 0 else P[2] - P[0]); b = np.cross(n, a)
    Q = [(float(p @ a), float(p @ b)) for p in P]
    rem = list(range(len(idx))); out = []
    cr = lambda o, p, q: (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])
    guard = 0
    while len(rem) > 3 and guard < 10000:
        guard += 1
        for k in range(len(rem)):
            i0, i1, i2 = rem[k - 1], rem[k], rem[(k + 1) % len(rem)]
            if cr(Q[i0], Q[i1], Q[i2]) <= 1e-15: continue
            if any(j not in (i0, i1, i2) and cr(Q[i0], Q[i1], Q[j]) >= 0 and cr(Q[i1], Q[i2], Q[j]) >= 0 and cr(Q[i2], Q[i0], Q[j]) >= 0 for j in rem):
                continue
            out.append((idx[i0], idx[i1], idx[i2])); rem.pop(k); break
    out.append(tuple(idx[i] for i in rem))
    return out


def box_polys(c, h, R=np.eye(3), split=1):
    """closed box: vertices and quads (outward, counter-clockwise seen from outside); split>1 adds collinear
    mid-edge vertices on the x-edges, which turns 4 faces into convex n-gons (as CAD exporters write)"""
    c = np.array(c, float); h = np.array(h, float)
    xs = np.linspace(-1, 1, split + 1)
    V = []; vid = {}
    def v(i, sy, sz):
        key = (i, sy, sz)
        if key not in vid: vid[key] = len(V); V.append(c + R @ (h * [xs[i], sy, sz]))
        return vid[key]
    n = split
    F = [[v(0, -1, -1), v(0, -1, 1), v(0, 1, 1), v(0, 1, -1)],                  # -x
         [v(n, -1, -1), v(n, 1, -1), v(n, 1, 1), v(n, -1, 1)]]                  # +x
    F.append([v(i, -1, -1) for i in range(n + 1)] + [v(n, -1, 1)] + [v(i, -1, 1) for i in range(n - 1, -1, -1)][:-1] + [v(0, -1, 1)])   # -y
    F.append([v(i, 1, -1) for i in range(n, -1, -1)] + [v(0, 1, 1)] + [v(i, 1, 1) for i in range(1, n + 1)])                          # +y
    F.append([v(i, -1, -1) for i in range(n, -1, -1)] + [v(0, 1, -1)] + [v(i, 1, -1) for i in range(1, n + 1)])                       # -z
    F.append([v(i, -1, 1) for i in range(n + 1)] + [v(n, 1, 1)] + [v(i, 1, 1) for i in range(n - 1, -1, -1)][:-1] + [v(0, 1, 1)])     # +z
    # fix: the hand-written n-gons above must be simple loops; rebuild them robustly from their corner sets
    F2 = [F[0], F[1]]
    for face in F[2:]:
        pts = np.array([V[i] for i in dict.fromkeys(face)]); ids = list(dict.fromkeys(face))
        cen = pts.mean(axis=0); nrm = None
        d = cen - c; ax = np.argmax(np.abs(R.T @ d)); nrm = R[:, ax] * np.sign((R.T @ d)[ax])
        a = unit(pts[0] - cen); b = np.cross(nrm, a)
        ang = np.arctan2((pts - cen) @ b, (pts - cen) @ a)
        F2.append([ids[i] for i in np.argsort(ang)])
    return V, F2


def prism_polys(c, r, n, L, R=np.eye(3)):
    """closed n-gon prism, axis local x from -L/2..L/2, radius r (vertices on r): caps are n-gons"""
    V = []
    for sx in (-1, 1):
        for k in range(n):
            a = 2 * math.pi * k / n
            V.append(np.array(c, float) + R @ [sx * L / 2, r * math.cos(a), r * math.sin(a)])
    F = [[k for k in range(n - 1, -1, -1)], [n + k for k in range(n)]]
    for k in range(n):
        F.append([k, (k + 1) % n, n + (k + 1) % n, n + k])
    return V, F


def orient_outward(V, polys):
    """turn each polygon so its normal points away from the centroid of the (convex or star) component"""
    V = np.asarray(V, float); c = V.mean(axis=0); out = []
    for p in polys:
        P = V[p]; nrm = np.zeros(3)
        for i in range(len(P)): nrm += np.cross(P[i], P[(i + 1) % len(P)])
        out.append(list(p) if nrm @ (P.mean(axis=0) - c) > 0 else list(p)[::-1])
    return out


class Builder:
    """collects components: each (V, polys, closed) and yields a Part plus per-object lists for the writers"""
    def __init__(self): self.objs = []
    def add(self, name, V, polys, closed=True):
        self.objs.append((name, [np.array(v, float) for v in V], [list(p) if not isinstance(p, tuple) else p for p in polys], closed))
    def part(self):
        T = []; closed = []
        for name, V, polys, cl in self.objs:
            t = tris_of(V, polys)
            if cl: closed.append(np.arange(len(T), len(T) + len(t)))
            T += list(t)
        return Part(np.array(T), closed)


# ======================================================================================================
# writers (our own bytes)
# ======================================================================================================
def fmt(x): return ('%.7f' % x).rstrip('0').rstrip('.') if x != 0 else '0'


def write_obj(name, objs, negative=(), vtvn=True, mtl=False, keyword='o', dup_vertices=False, flip=()):
    """OBJ: several objects (keyword 'o' or 'g', or per object (kw, name)), n-gon faces, vt/vn, negative (relative)
    indices for the objects named in `negative`; polys flipped for indices in flip[(obj, poly)]"""
    L = ['# exported by a CAD tool (hand-written by hard13/make.py)', '# units: as given by the world file scale']
    if mtl:
        L.append('mtllib ' + name.rsplit('.', 1)[0] + '.mtl')
    nv = 0; nt = 0; nn = 0
    for oi, (oname, V, polys, _) in enumerate(objs):
        kw = keyword if not isinstance(keyword, dict) else keyword.get(oname, 'o')
        L.append(f'{kw} {oname}')
        if mtl: L.append('usemtl ' + ('grey' if oi % 2 == 0 else 'blue'))
        base = nv
        if not dup_vertices:
            for v in V: L.append('v ' + ' '.join(fmt(x) for x in v))
            nv += len(V)
        if vtvn:
            L.append('vt 0 0'); L.append('vt 1 0'); L.append('vt 1 1'); nt += 3
        L.append('s off')
        for pi, p in enumerate(polys):
            idx = p[1] if isinstance(p, tuple) else p
            if (oi, pi) in flip: idx = idx[::-1]
            if dup_vertices:
                for i in idx: L.append('v ' + ' '.join(fmt(x) for x in V[i]))
                fidx = list(range(nv + 1, nv + 1 + len(idx))); nv += len(idx)
                rel = [j - (nv + 1) for j in fidx]
            else:
                fidx = [base + i + 1 for i in idx]; rel = [base + i - nv for i in idx]
            ids = rel if oname in negative else fidx
            if vtvn:
                P = np.array([V[i] for i in idx]); nrm = np.zeros(3)
                for i in range(len(P)): nrm += np.cross(P[i], P[(i + 1) % len(P)])
                nrm = unit(nrm); L.append('vn ' + ' '.join(fmt(round(x, 6)) for x in nrm)); nn += 1
                vt = [(-3 + (k % 3)) if oname in negative else (nt - 2 + (k % 3)) for k in range(len(ids))]
                vn = -1 if oname in negative else nn
                L.append('f ' + ' '.join(f'{i}/{t}/{vn}' for i, t in zip(ids, vt)))
            else:
                L.append('f ' + ' '.join(str(i) for i in ids))
    _write_text(name, '\n'.join(L) + '\n')
    if mtl:
        _write_text(name.rsplit('.', 1)[0] + '.mtl', 'newmtl grey\nKd 0.5 0.5 0.5\nnewmtl blue\nKd 0.2 0.3 0.8\n')


WRITE = True


def _write_text(name, s):
    if not WRITE: return
    os.makedirs(PARTS_DIR, exist_ok=True)
    with open(os.path.join(PARTS_DIR, name), 'w', newline='\n') as f: f.write(s)


def _write_bytes(name, b, folder=PARTS_DIR):
    if not WRITE: return
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), 'wb') as f: f.write(b)


def write_ply(name, V, faces, binary=True, double=False, extra_vertex_props=False, comment='exported'):
    """PLY: binary little-endian or ASCII; faces are lists (n-gons allowed)"""
    V = np.asarray(V, float)
    vt = 'double' if double else 'float'
    hdr = ['ply', 'format ' + ('binary_little_endian' if binary else 'ascii') + ' 1.0', 'comment ' + comment,
           f'element vertex {len(V)}', f'property {vt} x', f'property {vt} y', f'property {vt} z']
    if extra_vertex_props:
        hdr += ['property float nx', 'property float ny', 'property float nz', 'property uchar red', 'property uchar green', 'property uchar blue']
    hdr += [f'element face {len(faces)}', 'property list uchar int vertex_indices', 'end_header']
    head = ('\n'.join(hdr) + '\n').encode('ascii')
    if binary:
        vf = '<ddd' if double else '<fff'
        body = b''.join(struct.pack(vf, *v) + (struct.pack('<fffBBB', 0, 0, 1, 128, 128, 128) if extra_vertex_props else b'') for v in V)
        body += b''.join(struct.pack('<B', len(f)) + struct.pack('<%di' % len(f), *f) for f in faces)
        _write_bytes(name, head + body)
    else:
        lines = []
        for v in V:
            s = ' '.join(fmt(x) for x in v)
            if extra_vertex_props: s += ' 0 0 1 128 128 128'
            lines.append(s)
        for f in faces: lines.append(' '.join(str(x) for x in [len(f)] + list(f)))
        _write_bytes(name, head + ('\n'.join(lines) + '\n').encode('ascii'))


def write_stl_ascii(name, solids, zero_normals_every=0):
    """several `solid ... endsolid` blocks; triangles (n,3,3); some facet normals written as 0 0 0"""
    L = []
    for sname, T in solids:
        L.append(f'solid {sname}')
        for k, t in enumerate(T):
            nrm = np.cross(t[1] - t[0], t[2] - t[0]); nrm = nrm / np.linalg.norm(nrm)
            if zero_normals_every and k % zero_normals_every == 0: nrm = np.zeros(3)
            L.append('  facet normal ' + ' '.join('%.6e' % x for x in nrm))
            L.append('    outer loop')
            for p in t: L.append('      vertex ' + ' '.join('%.6e' % x for x in p))
            L.append('    endloop'); L.append('  endfacet')
        L.append(f'endsolid {sname}')
    _write_bytes(name, ('\n'.join(L) + '\n').encode('ascii'))


def write_stl_binary(name, T, header=b'solid part exported by SolidThing 2024 (binary STL, units mm)'):
    T = np.asarray(T, float)
    hdr = header[:80].ljust(80, b' ')
    out = [hdr, struct.pack('<I', len(T))]
    for t in T:
        nrm = np.cross(t[1] - t[0], t[2] - t[0]); nrm = nrm / np.linalg.norm(nrm)
        out.append(struct.pack('<12fH', *nrm, *t[0], *t[1], *t[2], 0))
    _write_bytes(name, b''.join(out))


# ---------------- glTF 2.0 binary ----------------
def quat_xyzw(R):
    return Rot.from_matrix(R).as_quat()          # scipy: (x, y, z, w), glTF's order


def trs_matrix(node):
    if 'matrix' in node:
        return np.array(node['matrix'], float).reshape(4, 4).T      # glTF matrices are column-major
    M = np.eye(4)
    t = np.array(node.get('translation', [0, 0, 0]), float)
    q = node.get('rotation', [0, 0, 0, 1]); s = np.array(node.get('scale', [1, 1, 1]), float)
    x, y, z, w = q                                 # our own quaternion -> matrix (not scipy's) for independence
    Rq = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                   [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                   [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    M[:3, :3] = Rq @ np.diag(s); M[:3, 3] = t      # T * R * S
    return M


def write_glb(name, meshes, nodes, scene_roots, folder=PARTS_DIR):
    """meshes: list of (V float32 (n,3), I uint (m,3)); nodes: list of glTF node dicts (mesh, children,
    translation/rotation/scale or matrix); returns nothing. Buffer: per mesh POSITION then indices (uint16)."""
    bin_ = b''; views = []; accs = []; gmeshes = []
    for V, I in meshes:
        V = np.asarray(V, np.float32); I = np.asarray(I, np.uint16)
        off = len(bin_); vb = V.tobytes(); bin_ += vb
        views.append({"buffer": 0, "byteOffset": off, "byteLength": len(vb), "target": 34962})
        accs.append({"bufferView": len(views) - 1, "componentType": 5126, "count": int(len(V)), "type": "VEC3",
                     "min": [float(x) for x in V.min(axis=0)], "max": [float(x) for x in V.max(axis=0)]})
        pos_acc = len(accs) - 1
        off = len(bin_); ib = I.reshape(-1).tobytes(); bin_ += ib
        while len(bin_) % 4: bin_ += b'\x00'
        views.append({"buffer": 0, "byteOffset": off, "byteLength": len(ib), "target": 34963})
        accs.append({"bufferView": len(views) - 1, "componentType": 5123, "count": int(I.size), "type": "SCALAR"})
        gmeshes.append({"primitives": [{"attributes": {"POSITION": pos_acc}, "indices": len(accs) - 1, "mode": 4}]})
    js = {"asset": {"version": "2.0", "generator": "hard13/make.py (hand-written glTF)"}, "scene": 0,
          "scenes": [{"nodes": scene_roots}], "nodes": nodes, "meshes": gmeshes, "accessors": accs,
          "bufferViews": views, "buffers": [{"byteLength": len(bin_)}]}
    jb = json.dumps(js, separators=(',', ':'), sort_keys=True).encode('utf-8')
    while len(jb) % 4: jb += b' '
    while len(bin_) % 4: bin_ += b'\x00'
    total = 12 + 8 + len(jb) + 8 + len(bin_)
    data = struct.pack('<III', 0x46546C67, 2, total) + struct.pack('<II', len(jb), 0x4E4F534A) + jb + struct.pack('<II', len(bin_), 0x004E4942) + bin_
    _write_bytes(name, data, folder)


def glb_meaning(meshes, nodes, roots):
    """the triangles the glTF scene means: every node's mesh through the product of its ancestors' matrices
    (our own composition), in the file's coordinate frame (no axis conversion)"""
    out = []; closed = []
    def walk(i, M):
        n = nodes[i]; M2 = M @ trs_matrix(n)
        if 'mesh' in n:
            V, I = meshes[n['mesh']]; V = np.asarray(V, np.float32).astype(float)
            W = V @ M2[:3, :3].T + M2[:3, 3]
            t = W[np.asarray(I)]
            if np.linalg.det(M2[:3, :3]) < 0: t = t[:, ::-1]
            closed.append(np.arange(len(out), len(out) + len(t))); out.extend(list(t))
        for c in n.get('children', []): walk(c, M2)
    for r in roots: walk(r, np.eye(4))
    return Part(np.array(out), closed)


# ======================================================================================================
# obstacles in the world: an in-memory registry for hard5's sdf
# ======================================================================================================
PARTS = {}           # path -> Part (what the file means)
_MD = {}


class SignedPartDist:
    """exact distance of world points to a placed Part; negative inside its closed components
    (generalised winding number of the component, points within 0.05 m of the surface only: every part here is
    thinner than 2 x 12 mm, so no point deeper than that is inside)"""
    def __init__(self, part, position, rpy, scale):
        Rm = R_of(rpy); self.T = (part.T * scale) @ Rm.T + np.array(position, float)
        self.md = MeshDist(self.T.reshape(-1, 3), np.arange(len(self.T) * 3).reshape(-1, 3))
        self.closed = [self.T[c] for c in part.closed]

    def winding(self, P, T):
        a = T[None, :, 0, :] - P[:, None, :]; b = T[None, :, 1, :] - P[:, None, :]; c = T[None, :, 2, :] - P[:, None, :]
        la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
        det = np.einsum('ijk,ijk->ij', a, np.cross(b, c))
        den = la * lb * lc + np.einsum('ijk,ijk->ij', a, b) * lc + np.einsum('ijk,ijk->ij', b, c) * la + np.einsum('ijk,ijk->ij', c, a) * lb
        return (2 * np.arctan2(det, den)).sum(axis=1) / (4 * math.pi)

    def __call__(self, P, cap=None):
        P = np.atleast_2d(np.asarray(P, float))
        d = self.md(P, cap=cap)
        near = np.where(d < 0.05)[0]
        if len(near) and self.closed:
            ins = np.zeros(len(near), bool)
            for T in self.closed:
                for a in range(0, len(near), 2000):
                    sl = near[a:a + 2000]
                    ins[a:a + len(sl)] |= np.abs(self.winding(P[sl], T)) > 0.5
            d[near[ins]] *= -1
        return d


def mesh_dist_of(o):
    key = (o['path'], tuple(o['position']), tuple(o['rpy']), o.get('scale', 1.0))
    if key not in _MD:
        _MD[key] = SignedPartDist(PARTS[o['path']], o['position'], o['rpy'], o.get('scale', 1.0))
    return _MD[key]


h5.mesh_of = mesh_dist_of     # hard5's sdf now measures the in-memory meaning


def mesh(path, position, rpy=(0, 0, 0), scale=1.0):
    return {"type": "mesh", "path": path, "position": [float(v) for v in position], "rpy": [float(v) for v in rpy], "scale": float(scale)}


def rpy_of(Rm): return [float(x) for x in Rot.from_matrix(Rm).as_euler('xyz')]


def plate(x0, x1, y0, y1, z0, z1):
    return box([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2], [(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2])


def end_wall(e, d=0.12, half=0.35):
    return plate(e[0] + d, e[0] + d + 0.012, Y0 - half, Y0 + half, Z0 - half, Z0 + half)


def s_bend(off, R=0.3):
    o = np.array([0.0, off[0], off[1]]); d = unit(o); th = S_curve(R, float(np.linalg.norm(o)))
    return [('A', R, th, tuple(d)), ('A', R, th, tuple(-d))], 2 * R * math.sin(math.radians(th)), 2 * R * math.radians(th)


W = {}
def world(fn): W[fn.__name__] = fn; return fn


# ======================================================================================================
# worlds
# ======================================================================================================
@world
def obj_window():
    return _window('window.obj', ('right_jamb', 'post'))


@world
def obj_window_abs():
    """CONTROL for obj_window: the same wall, the same OBJ but every index absolute (positive)"""
    d, obs, g, p, opt = _window('window_abs.obj', ())
    return ("CONTROL for obj_window: the same geometry and OBJ layout, every index written absolute (positive) "
            "instead of relative. " + d), obs, g, p, opt


def _window(fname, negative):
    """OBJ exported as a CAD tool does: a wall of four closed boxes round a window (o/o/g/g objects), quads and
    convex n-gons (collinear mid-edge vertices), vt/vn on every face, negative indices in two objects, a material
    library; an octagonal post (n-gon caps) behind the wall"""
    bend, dx, sl = s_bend((0.10, 0.0))
    path = Path([('S', 0.08)] + bend + [('S', 0.35)])
    e, _ = path.end()
    xw = X0 + 0.5; hy, hz = 0.045, 0.06; t = 0.006; half = 0.45
    # local frame: origin at the window's centre (so the OBJ's coordinates are about the window)
    B = Builder()
    # jambs: from the window edges out to the wall's edge (the wall spans y in Y0 +- 0.45, i.e. local -0.55..0.35)
    pieces = [('left_jamb', [0, (hy + (half - 0.1)) / 2, 0], [t, ((half - 0.1) - hy) / 2, half]),
              ('right_jamb', [0, -(hy + (half + 0.1)) / 2, 0], [t, ((half + 0.1) - hy) / 2, half]),
              ('head', [0, 0, (hz + half) / 2], [t, hy, (half - hz) / 2]),
              ('sill', [0, 0, -(hz + half) / 2], [t, hy, (half - hz) / 2])]
    for i, (nm, c, h) in enumerate(pieces):
        V, F = box_polys(c, h, split=3 if i % 2 == 0 else 1)
        B.add(nm, V, F)
    # octagonal post, vertical, right of the way 0.12 m behind the wall (n-gon caps)
    r8 = 0.03; yp = -(0.025 + 0.016 + r8)
    V, F = prism_polys([0.12, yp, 0.0], r8, 8, 0.5, R=np.array([[0, 0, 1.0], [0, 1.0, 0], [-1.0, 0, 0]]))
    B.add('post', V, orient_outward(V, F))
    write_obj(fname, B.objs, negative=negative, vtvn=True, mtl=True,
              keyword={'left_jamb': 'o', 'right_jamb': 'o', 'head': 'g', 'sill': 'g', 'post': 'o'})
    PARTS['parts/' + fname] = B.part()
    obs = [mesh('parts/' + fname, [xw, Y0 + 0.10, Z0]), end_wall(e, 0.12)]
    return ("A 12 mm wall 0.5 m ahead (0.9 m wide, 0.9 m tall) built as an OBJ of four closed boxes round a window "
            "0.09 m wide and 0.12 m tall centred 0.1 m left of the start line (objects `o left_jamb`, `o right_jamb`, "
            "`g head`, `g sill`; faces are quads and convex hexagons/octagons with collinear vertices; vt/vn on every "
            "face; negative indices in two objects; a .mtl), an octagonal post (n-gon caps) 0.12 m behind it on the "
            "right of the way. Way: 0.1 m left, straight through the window (20 mm each side), on to the goal."), obs, [e], path, {}


@world
def obj_concave_slot():
    return _slot('slot.obj', True)


@world
def obj_slot_tris():
    """CONTROL for obj_concave_slot: the same plate, its 8-gon faces written as triangles (ear clipping)"""
    d, obs, g, p, opt = _slot('slot_tris.obj', False)
    return ("CONTROL for obj_concave_slot: the same plate, its two concave 8-gons written as 6 triangles each "
            "(ear clipping, no new vertices). " + d), obs, g, p, opt


def _slot(fname, ngon):
    """ONE concave n-gon face (a plate with a slot cut down from its top edge), front and back, closed by side
    quads: the slot is the only way. A fan triangulation of the n-gon from its first vertex covers the slot."""
    path = Path([('S', 0.75)])
    e, _ = path.end()
    xw = X0 + 0.45; t = 0.005; H = 0.45; sw = 0.045; sb = -0.08
    # polygon in (y, z), counter-clockwise seen from +x, starting at the bottom-left corner
    poly = [(-H, -H), (H, -H), (H, H), (sw, H), (sw, sb), (-sw, sb), (-sw, H), (-H, H)]
    V = [[t, y, z] for y, z in poly] + [[-t, y, z] for y, z in poly]
    n = len(poly)
    front = ('ear', list(range(n)))                       # +x face: counter-clockwise seen from +x
    back = ('ear', list(range(2 * n - 1, n - 1, -1)))     # -x face, reversed
    sides = [[k, n + k, n + (k + 1) % n, (k + 1) % n] for k in range(n)]
    sides = orient_sides(V, sides)
    if not ngon:
        front = [list(t) for t in ear_clip(V, front[1])]; back = [list(t) for t in ear_clip(V, back[1])]
        B = Builder(); B.add('slotted_plate', V, front + back + sides)
    else:
        B = Builder(); B.add('slotted_plate', V, [front, back] + sides)
    PARTS['parts/' + fname] = B.part()
    write_obj(fname, B.objs, negative=(), vtvn=False, keyword='o')
    obs = [mesh('parts/' + fname, [xw, Y0, Z0]), end_wall(e, 0.12, 0.4)]
    return ("A 10 mm plate 0.45 m ahead, 0.9 m square, with a slot 0.09 m wide cut from its top edge down to 80 mm "
            "below the start line; written as an OBJ whose front and back faces are ONE concave 8-gon each "
            "(Blender and CAD tools export such n-gons), closed by side quads. The slot is the way: straight on "
            "(20 mm each side). Meaning: the polygon; a loader fanning the 8-gon from its first vertex closes the "
            "slot (and the start line) with triangles the file does not have."), obs, [e], path, {}


def orient_sides(V, sides):
    """side quads of an extruded polygon (front z = +t first half): make them point outward of the polygon"""
    V = np.asarray(V, float); out = []
    n = len(sides)
    P2 = V[:n, 1:]
    area = sum(P2[k, 0] * P2[(k + 1) % n, 1] - P2[(k + 1) % n, 0] * P2[k, 1] for k in range(n))
    for k, q in enumerate(sides):
        a, b = V[k, 1:], V[(k + 1) % n, 1:]
        out_dir = np.array([0, b[1] - a[1], -(b[0] - a[0])]) * (1 if area > 0 else -1)   # outward in (y,z)
        P = V[q]; nrm = np.cross(P[1] - P[0], P[2] - P[0])
        out.append(q if nrm @ out_dir > 0 else q[::-1])
    return out


@world
def ply_bin_duct():
    """binary little-endian PLY: an OPEN square duct (no end caps, zero-thickness walls), duplicate vertices per
    quad, a third of the quads wound the other way; placed with position and rpy (rolled 30 deg about its axis)
    on an oblique leg; a bulkhead round its mouth makes it the only way"""
    ang = 25.0; d = unit([0, 0.6, 0.8])
    path = Path([('S', 0.1), ('A', 0.3, ang, tuple(d)), ('S', 0.55)])
    s0 = 0.1 + 0.3 * math.radians(ang)
    p_mouth, h = path.at(s0 + 0.06); e, _ = path.end()
    u0 = unit(np.cross(h, EZ) * -1); v0 = np.cross(h, u0)           # u0 left-ish, v0 up-ish
    roll = math.radians(30); u = math.cos(roll) * u0 + math.sin(roll) * v0; v = np.cross(h, u)
    Rm = np.column_stack([h, u, v])
    a = 0.043; Ld = 0.36; x0l = 0.1                        # local duct from x = 0.1 to 0.46; origin 0.1 m before the mouth
    V = []; F = []; rng = np.random.default_rng(13)
    nseg = 6
    corners = [(-a, -a), (a, -a), (a, a), (-a, a)]
    for k in range(4):
        (y1, z1), (y2, z2) = corners[k], corners[(k + 1) % 4]
        for j in range(nseg):
            xa, xb = x0l + Ld * j / nseg, x0l + Ld * (j + 1) / nseg
            q = [len(V), len(V) + 1, len(V) + 2, len(V) + 3]
            V += [[xa, y1, z1], [xa, y2, z2], [xb, y2, z2], [xb, y1, z1]]   # own vertices per quad (duplicates)
            F.append(q if rng.random() > 1 / 3 else q[::-1])
    write_ply('duct.ply', V, F, binary=True, comment='exported by ScanTool, open duct, no caps')
    PARTS['parts/duct.ply'] = Part(tris_of(V, F), [])
    pos = p_mouth - h * x0l
    obs = [mesh('parts/duct.ply', pos, rpy_of(Rm))]
    obs += plate_hole(p_mouth - h * 0.006, u, v, h, 0.45, 0.45, (0.0, 0.0), (a, a), 0.006)
    obs.append(frame_box(e + h * 0.12, u, v, 0.3, 0.3, 0.006))
    return ("An open square duct (0.086 m inside, 0.36 m long, zero-thickness walls, no end caps) in a binary "
            "little-endian PLY: 24 quads, each with its own four vertices, 8 of them wound the other way. It lies "
            "on a leg 25 deg left-up of the start heading, rolled 30 deg about its axis (mesh rpy and position both "
            "non-trivial; the file's origin is 0.1 m before the mouth). A 12 mm bulkhead fits round its mouth; the "
            "goal 0.13 m past its exit. Way: 0.1 m on, 25 deg left-up, straight through (18 mm each side)."), obs, [e], path, {}


@world
def ply_ascii_grating():
    """ASCII PLY with vertex normals and colours: a grating of closed bars (quads) in a frame, gaps 40 mm (less
    than the 50 mm body) except one of 0.09 m, 0.12 m right of the line; the grating yawed 15 deg"""
    bend, dx, sl = s_bend((-0.12, 0.0))
    path = Path([('S', 0.05)] + bend + [('S', 0.3)] + bend_back((-0.12, 0.0)) + [('S', 0.1)])
    s_gap = 0.05 + sl + 0.15
    pg, _ = path.at(s_gap); e, _ = path.end()
    yaw = math.radians(15)
    bw = 0.008; bt = 0.005; gap = 0.040; wide = 0.09
    # local: plate plane x = 0, bars along z; wide gap centred at local y = 0
    ys = []; y = wide / 2 + bw
    while y < 0.6: ys.append(y); y += 2 * bw + gap
    y = -(wide / 2 + bw)
    while y > -0.35: ys.append(y); y -= 2 * bw + gap
    V = []; F = []
    def addbox(c, h):
        Vb, Fb = box_polys(c, h); o = len(V); V.extend(Vb); F.extend([[o + i for i in f] for f in Fb])
    for yb in sorted(ys): addbox([0, yb, 0], [bt, bw, 0.35])
    ylo, yhi = min(ys) - bw, max(ys) + bw
    addbox([0, (ylo + yhi) / 2, 0.35 + 0.01], [bt, (yhi - ylo) / 2 + 0.02, 0.01])
    addbox([0, (ylo + yhi) / 2, -0.35 - 0.01], [bt, (yhi - ylo) / 2 + 0.02, 0.01])
    write_ply('grating.ply', V, F, binary=False, extra_vertex_props=True, comment='exported by MeshLab-like tool')
    closed = [np.arange(12 * k, 12 * k + 12) for k in range(len(F) // 6)]
    PARTS['parts/grating.ply'] = Part(tris_of(V, F), closed)
    obs = [mesh('parts/grating.ply', pg, [0.0, 0.0, yaw])]
    obs.append(end_wall(e, 0.12, 0.4))
    return (f"A grating of {len(ys)} vertical bars (16 x 10 mm, 0.7 m tall) with top and bottom rails, as an ASCII PLY "
            "(vertex normals and colours, closed box bars as quads), 0.6 m ahead and yawed 15 deg; the gaps are 40 mm "
            "(the body is 50 mm) except one of 0.09 m whose middle is 0.12 m right of the start line. Way: 0.12 m "
            "right, straight through the wide gap, back onto the line; goal 0.12 m before an end wall."), obs, [e], path, {}


def bend_back(off):
    return s_bend((-off[0], -off[1]))[0]


@world
def stl_ascii_tee():
    """ASCII STL with two `solid` blocks (a pipe tee: the run and the branch, open tubes), some facet normals
    written as 0 0 0; the file's branch is along its +y (exported Y-up), the obstacle's rpy turns it to world +z;
    the way passes between the run and a ceiling, 20 mm from each"""
    path = Path([('S', 0.85)])
    e, _ = path.end()
    r1, r2, n = 0.05, 0.04, 24
    def tube(p0, p1, r, n):
        ax = unit(np.array(p1) - p0); ref = EZ if abs(ax[2]) < 0.9 else EX
        a = unit(np.cross(ax, ref)); b = np.cross(ax, a); T = []
        for k in range(n):
            t0, t1 = 2 * math.pi * k / n, 2 * math.pi * (k + 1) / n
            c0 = r * (math.cos(t0) * a + math.sin(t0) * b); c1 = r * (math.cos(t1) * a + math.sin(t1) * b)
            A, Bq, C, D = p0 + c0, p0 + c1, p1 + c1, p1 + c0
            T += [[A, C, Bq], [A, D, C]]
        return np.array(T)
    # local: run along x from -0.4 to 0.4, branch from the run's axis up (+y) to 0.39, at x = 0.16
    run = tube(np.array([-0.4, 0, 0]), np.array([0.4, 0, 0]), r1, n)
    branch = tube(np.array([0.16, 0, 0]), np.array([0.16, 0.39, 0]), r2, n)
    write_stl_ascii('tee.stl', [('run', run), ('branch', branch)], zero_normals_every=5)
    PARTS['parts/tee.stl'] = Part(np.concatenate([run, branch]), [])
    Rm = np.column_stack([EY, EZ, EX])           # local x -> world y, local y -> world z
    apo = r1 * math.cos(math.pi / n)
    zc = Z0 - 0.025 - 0.02 - apo
    obs = [mesh('parts/tee.stl', [X0 + 0.5, Y0, zc], rpy_of(Rm)),
           plate(X0 + 0.36, X0 + 0.64, Y0 - 0.3, Y0 + 0.3, Z0 + 0.045, Z0 + 0.057),
           end_wall(e, 0.12, 0.4)]
    return ("A pipe tee (open tubes, 24 sides: run r 50 mm, branch r 40 mm) as an ASCII STL of two `solid` blocks, "
            "every fifth facet normal written as 0 0 0; in the file the run is along x and the branch along +y (a "
            "Y-up export); the obstacle's rpy maps file x to world y and file y to world up. The run lies across the "
            "way 0.5 m ahead just below it (its top 20 mm under the body), the branch rises 0.16 m to the left, a "
            "ceiling plate 20 mm over the body: the way is the 90 mm gap. Goal 0.85 m ahead on the line."), obs, [e], path, {}


@world
def stl_bin_mm_hatch():
    """binary STL (80-byte header starting `solid`) in MILLIMETRES with scale 0.001: a 10 mm plate with a round
    hole (32-gon, 37.8 mm apothem) off the plate's centre; plate tilted (rpy with roll, pitch and yaw) and the way
    threads the hole along its axis"""
    ang = 30.0; d = unit([0, -0.5, 0.866])
    path = Path([('S', 0.1), ('A', 0.3, ang, tuple(d)), ('S', 0.5)])
    s0 = 0.1 + 0.3 * math.radians(ang)
    ph, h = path.at(s0 + 0.22); e, _ = path.end()
    u0 = unit(np.cross(EZ, h)); v0 = np.cross(h, u0); roll = math.radians(-50)
    u = math.cos(roll) * u0 + math.sin(roll) * v0; v = np.cross(h, u)
    Rm = np.column_stack([u, v, h])                        # local x, y in the plate, local z along the way
    n = 32; rh = 38.0; th = 5.0; hc = np.array([120.0, -80.0]); Hs = 300.0
    ang_k = [2 * math.pi * k / n for k in range(n)]
    hole = [hc + rh * np.array([math.cos(a), math.sin(a)]) for a in ang_k]
    def ray_to_square(a):
        dvec = np.array([math.cos(a), math.sin(a)])
        tmax = min(((Hs if dvec[i] > 0 else -Hs) - hc[i]) / dvec[i] for i in range(2) if abs(dvec[i]) > 1e-12)
        return hc + tmax * dvec
    outer = [ray_to_square(a) for a in ang_k]
    T = []
    for z, s in ((th, 1), (-th, -1)):
        for k in range(n):
            k2 = (k + 1) % n
            A = [*hole[k], z]; Bq = [*hole[k2], z]; C = [*outer[k2], z]; D = [*outer[k], z]
            tr = [[A, D, C], [A, C, Bq]] if s > 0 else [[A, C, D], [A, Bq, C]]
            T += tr
    for k in range(n):
        k2 = (k + 1) % n
        for ring, sgn in ((hole, -1), (outer, 1)):
            A = [*ring[k], -th]; Bq = [*ring[k2], -th]; C = [*ring[k2], th]; D = [*ring[k], th]
            T += [[A, Bq, C], [A, C, D]] if sgn > 0 else [[A, C, Bq], [A, D, C]]
    T = np.array(T, float)
    write_stl_binary('hatch_mm.stl', T)
    PARTS['parts/hatch_mm.stl'] = Part(T, [np.arange(len(T))])
    pos = ph - Rm @ np.array([hc[0], hc[1], 0.0]) * 0.001
    obs = [mesh('parts/hatch_mm.stl', pos, rpy_of(Rm), 0.001), frame_box(e + h * 0.12, u, v, 0.3, 0.3, 0.006)]
    return ("A 10 mm plate (0.6 m square, corners cut) with a round hole (a 32-gon of radius 38 mm: 37.8 mm to its "
            "flats) 120 mm / -80 mm off the plate's middle, as a binary STL in millimetres whose 80-byte header "
            "begins with `solid` (as SolidWorks-style exporters write), scale 0.001, rpy with all three angles "
            "non-zero, position the plate's origin (not the hole). The hole's axis lies on a leg 30 deg right-up of "
            "the start heading; way: 0.1 m on, 30 deg right-up, straight through the hole (12.8 mm round the body), "
            "goal 0.28 m past the plate."), obs, [e], path, {}


GLB = {}


def glb_frame_scene():
    """unit cube (+-0.5) instanced by nodes: a parent (rotation +90 deg about glTF y, a translation, uniform scale
    2) holding four bars (non-uniform scale per node) round a window, one bar given by a column-major `matrix`"""
    cube = np.array([[x, y, z] for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)], np.float32)
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
                      [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], np.uint16)
    # in the parent's frame (before its scale 2): the wall is in the x-y plane (glTF's "front" is +z), window
    # centre at (wx, wy); half sizes (hx, hy) of the opening; bars 6 mm thick in z (3 mm after... no: scaled x2)
    wx, wy = 0.02, -0.015; hx, hy = 0.0225, 0.03; half = 0.2; tz = 0.003
    # parent scale 2 -> the window is 0.09 x 0.12 m, the wall 0.8 m, thickness 12 mm
    bars = [((wx + hx + (half - wx - hx) / 2, 0.0), ((half - wx - hx), 2 * half)),        # +x side
            ((wx - hx - (half + wx - hx) / 2, 0.0), ((half + wx - hx), 2 * half)),        # -x side
            ((wx, wy + hy + (half - wy - hy) / 2), (2 * hx, half - wy - hy)),            # +y (top in glTF)
            ((wx, wy - hy - (half + wy - hy) / 2), (2 * hx, half + wy - hy))]            # -y
    nodes = [{"name": "frame", "translation": [0.1, -0.05, 0.03],
              "rotation": [float(x) for x in Rot.from_euler('y', 90, degrees=True).as_quat()], "scale": [2.0, 2.0, 2.0],
              "children": [1, 2, 3, 4]}]
    for i, ((cx, cy), (sx, sy)) in enumerate(bars):
        nd = {"name": f"bar{i}", "mesh": 0}
        if i == 2:
            M = np.eye(4); M[:3, :3] = np.diag([sx, sy, 2 * tz]); M[:3, 3] = [cx, cy, 0]
            nd["matrix"] = [float(x) for x in M.T.reshape(-1)]             # column-major
        else:
            nd.update({"translation": [cx, cy, 0.0], "scale": [sx, sy, 2 * tz]})
            if i == 3:       # a bar given a rotation of 180 deg about its own long axis (x): same box, tests rotation
                nd["rotation"] = [1.0, 0.0, 0.0, 0.0]
        nodes.append(nd)
    meshes = [(cube, faces)]
    return meshes, nodes, [0], (wx, wy, hx, hy)


@world
def glb_nodes():
    """GLB: one cube mesh placed four times by nodes (translation/rotation/scale, one `matrix`) under a rotated,
    translated, scaled parent; the window it leaves is the only way: reachable only if the node transforms are
    applied as glTF means (T*R*S, parent x child; no Y-up conversion, as for every other format)"""
    meshes, nodes, roots, (wx, wy, hx, hy) = glb_frame_scene()
    write_glb('frame.glb', meshes, nodes, roots)
    part = glb_meaning(meshes, nodes, roots); PARTS['parts/frame.glb'] = part
    # window centre in the file's frame: parent matrix applied to (wx, wy, 0)
    Mp = trs_matrix(nodes[0]); wc = Mp[:3, :3] @ [wx, wy, 0] + Mp[:3, 3]
    # file frame: wall normal = parent's z -> Ry(90) z = +x; so rpy 0 keeps the wall square to world x
    target = np.array([X0 + 0.5, Y0 - 0.1, Z0 - 0.06])
    off = (-0.1, -0.06)
    bend, dx, sl = s_bend(off)
    path = Path([('S', 0.06)] + bend + [('S', 0.3)])
    e, _ = path.end()
    obs = [mesh('parts/frame.glb', target - wc), end_wall(e, 0.12, 0.4)]
    return ("A wall 0.8 m square and 12 mm thick 0.5 m ahead, as a GLB (glTF 2.0 binary, hand-written): one unit cube "
            "mesh used by four bar nodes (translation + non-uniform scale; one with a rotation of 180 deg about x; one "
            "given as a column-major `matrix`) under a parent node rotated +90 deg about glTF's y, translated and "
            "scaled x2. The bars leave a window 0.12 m (world y) x 0.09 m (world z) whose centre is 0.1 m right of "
            "and 0.06 m below the start line. Meaning: node matrices composed parent x child, each T*R*S, in the "
            "file's axes (no Y-up to Z-up turn, as trimesh reads GLB and as every other format is read). Way: S-bend "
            "0.1 m right and 0.06 m down, straight through (20 mm above and below, 35 mm at the sides), goal 0.21 m behind the wall."), obs, [e], path, {}


@world
def obj_thin_sleeve():
    """thin-walled closed parts in one OBJ written as a triangle soup (every face its own vertices, `g` groups,
    several faces wound the other way): the body STARTS inside a 3 mm-walled square sleeve and then passes
    through a 3 mm-walled U hood over a floor"""
    e_path = Path([('S', 0.78)]); e, _ = e_path.end()
    a = 0.044; t = 0.003
    def ring_walls(x0, x1, sides):
        """thin walls round the axis: a list of closed boxes (one per side), corners overlapping -> one union;
        written as a single closed surface per side box (overlapping boxes: a union of closed solids)"""
        out = []
        for s in sides:
            if s in ('top', 'bottom'):
                z = (a + t) * (1 if s == 'top' else -1)
                out.append(([(x0 + x1) / 2, 0, z], [(x1 - x0) / 2, a + 2 * t, t]))
            else:
                y = (a + t) * (1 if s == 'left' else -1)
                out.append(([(x0 + x1) / 2, y, 0], [(x1 - x0) / 2, t, a + 2 * t]))
        return out
    B = Builder()
    for i, (c, h) in enumerate(ring_walls(-0.22, 0.06, ('top', 'bottom', 'left', 'right'))):
        V, F = box_polys(c, h); B.add(f'sleeve_{i}', V, [f for f in F])
    for i, (c, h) in enumerate(ring_walls(0.25, 0.55, ('top', 'left', 'right'))):
        V, F = box_polys(c, h); B.add(f'hood_{i}', V, [f for f in F])
    flips = {(0, 1), (2, 4), (4, 0), (5, 5), (6, 2)}
    write_obj('thin.obj', B.objs, dup_vertices=True, vtvn=False, keyword='g', flip=flips)
    PARTS['parts/thin.obj'] = B.part()
    obs = [mesh('parts/thin.obj', [X0, Y0, Z0]),
           plate(X0 + 0.2, X0 + 0.6, Y0 - 0.3, Y0 + 0.3, Z0 - a - 0.012, Z0 - a),     # floor under the hood
           end_wall(e, 0.12, 0.4)]
    return ("Thin-walled parts (3 mm walls) in one OBJ written as a triangle soup (every face its own vertices, `g` "
            "groups, some faces wound the other way): a square sleeve 0.088 m inside round the start (from 0.22 m "
            "behind to 0.06 m ahead of the tip: the body starts inside it, 19 mm from its walls) and a U hood "
            "(top and sides, 0.25-0.55 m ahead) over a 12 mm floor plate: a tunnel 0.088 m square. Each wall is a "
            "closed box, overlapping its neighbours at the corners. Way: straight on 0.78 m to the goal."), obs, [e], e_path, {}


@world
def ply_collide_ring(mixed=False):
    """BUILT TO COLLIDE: a tube (open, binary PLY, double coordinates) capped at its far end, with an internal
    annular baffle whose opening (32-gon, 22.4 mm to its flats) is 2.6 mm narrower than the body's radius; the goal
    lies 0.15 m past the baffle inside the tube: any trial that reaches it must touch"""
    path = Path([('S', 0.6)])
    e, _ = path.end()
    n = 32; R = 0.065; ri = 0.0225; x0, x1, xb = 0.15, 0.75, 0.45
    V = []; F = []
    ring = lambda x, r: [[x, r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)] for k in range(n)]
    base = len(V); V += ring(x0, R) + ring(x1, R)
    for k in range(n):
        k2 = (k + 1) % n; F.append([base + k, base + k2, base + n + k2, base + n + k])
    cap = len(V); V += ring(x1, R)                              # the cap repeats the end ring's vertices (duplicates)
    capf = list(range(cap + n - 1, cap - 1, -1))
    if mixed:
        F.append(capf)                                           # one 32-gon cap (trimesh cannot read this in binary PLY)
    else:
        F += [[capf[0], capf[k], capf[k + 1], capf[k + 2]] for k in range(1, n - 2, 2)]   # the cap as 15 quads
    bo = len(V); V += ring(xb, R) + ring(xb, ri)
    rng = np.random.default_rng(5)
    for k in range(n):
        k2 = (k + 1) % n; q = [bo + k, bo + n + k, bo + n + k2, bo + k2]
        F.append(q if rng.random() > 0.5 else q[::-1])          # baffle quads with mixed winding
    if mixed:
        return V, F
    write_ply('baffle.ply', V, F, binary=True, double=True, comment='exported by PipeCAD; baffle inside')
    PARTS['parts/baffle.ply'] = Part(tris_of(V, F), [])
    obs = [mesh('parts/baffle.ply', [X0, Y0, Z0]), end_wall(e, 0.3, 0.4)]
    return ("A tube 0.13 m across (open shell, 32 sides) from 0.15 to 0.75 m ahead on the start line, capped at its far "
            "end, with a zero-thickness annular baffle 0.45 m ahead whose opening is a 32-gon of radius "
            "22.5 mm (22.4 mm to its flats); binary PLY with double coordinates, the cap's ring repeated, the baffle's "
            "quads of mixed winding, the cap's 32-gon written as 15 quads (every face a quad: trimesh 5.2 refuses a binary PLY whose faces have mixed sizes, see bad/). The goal is on the axis 0.15 m past the baffle: the 25 mm body cannot pass the "
            "baffle without touching it (2.6 mm deep at least): BUILT TO COLLIDE, any success is wrong."), obs, [e], path, \
        {"collide": True}


@world
def glb_mm_rpy():
    """the same GLB scene written in millimetres (vertices x1000), placed with scale 0.001 and an rpy with three
    non-zero angles so that its window faces a leg 20 deg left of the start heading"""
    meshes, nodes, roots, (wx, wy, hx, hy) = glb_frame_scene()
    meshes = [(np.asarray(meshes[0][0], np.float32) * 1000.0, meshes[0][1])]
    nodes = json.loads(json.dumps(nodes))
    nodes[0]['translation'] = [x * 1000.0 for x in nodes[0]['translation']]
    for nd in nodes[1:]:
        if 'matrix' in nd:
            M = np.array(nd['matrix']).reshape(4, 4).T; M[:3, 3] *= 1000.0; nd['matrix'] = [float(x) for x in M.T.reshape(-1)]
        else:
            nd['translation'] = [x * 1000.0 for x in nd['translation']]
    # keep the per-node scale as it was (the cube mesh is now 1000 mm): parts are the same size in mm
    write_glb('frame_mm.glb', meshes, nodes, roots)
    part = glb_meaning(meshes, nodes, roots); PARTS['parts/frame_mm.glb'] = part
    Mp = trs_matrix(nodes[0]); wc = (Mp[:3, :3] @ [wx * 1000, wy * 1000, 0] + Mp[:3, 3]) * 0.001
    path = Path([('S', 0.1), ('A', 0.3, 20.0, tuple(unit([0, 1, 0.35]))), ('S', 0.5)])
    s0 = 0.1 + 0.3 * math.radians(20)
    pw, h = path.at(s0 + 0.25); e, _ = path.end()
    # the file's wall normal is +x; window long side along file z (parent Ry(90) maps y->y, so the 0.12 m side
    # is file y... compute: bars' y extent is the window's 0.12 m side -> file y).  Place: file x -> h, file y ->
    # rolled 'up' direction, file z completes.
    up = unit(EZ - (EZ @ h) * h); roll = math.radians(35)
    side = np.cross(h, up); fy = math.cos(roll) * up + math.sin(roll) * side; fz = np.cross(h, fy)
    Rm = np.column_stack([h, fy, fz])
    obs = [mesh('parts/frame_mm.glb', pw - Rm @ wc, rpy_of(Rm), 0.001), frame_box(e + h * 0.12, fy, fz, 0.35, 0.35, 0.006)]
    return ("The GLB window wall of glb_nodes written in millimetres (vertices and translations x1000, node scales "
            "unchanged), placed with scale 0.001 and rpy with three non-zero angles: the wall square to a leg 20 deg "
            "left and a little up of the start heading, rolled 35 deg about it; the window's centre on that leg 0.25 m along it. Way: "
            "0.1 m on, 20 deg left-up, straight through the window (20 mm round the body), goal 0.25 m past the wall."), obs, [e], path, {}


@world
def mixed_slalom():
    """three formats in one world, re-used in other placements: the ASCII-STL tee with its run vertical, the GLB
    wall on edge beside the way, the binary-PLY duct lying across under it; a slalom 12-15 mm from each"""
    bend1, dx1, sl1 = s_bend((0.09, 0.0)); bend2, dx2, sl2 = s_bend((-0.09, 0.0))
    path = Path([('S', 0.05)] + bend1 + [('S', 0.08)] + bend2 + [('S', 0.35)])
    e, _ = path.end()
    apo = 0.05 * math.cos(math.pi / 24)
    pA, _ = path.at(0.05 + sl1 + 0.04)            # middle of the straight between the bends (0.09 m left)
    Rm_tee = np.column_stack([EZ, -EX, -EY])      # file x (run) -> world z, file y (branch) -> world -x
    obs = [mesh('parts/tee.stl', [pA[0], pA[1] - 0.025 - 0.021 - apo, Z0], rpy_of(Rm_tee))]
    pB, _ = path.at(path.L - 0.35 + 0.08); pB = pB + EX * 0.4      # the wall (0.8 m long) from 0.08 m into the last leg
    Rm_g = np.column_stack([-EY, EX, EZ])         # file x (the wall's normal) -> world -y, file y -> world x
    Vw = PARTS['parts/frame.glb'].T.reshape(-1, 3); cf = (Vw.min(axis=0) + Vw.max(axis=0)) / 2
    obs.append(mesh('parts/frame.glb', np.array([pB[0], pB[1] + 0.025 + 0.013 + 0.006, Z0]) - Rm_g @ cf, rpy_of(Rm_g)))
    Rm_d = np.column_stack([EY, EX, -EZ])         # file x (the duct's axis) -> world y
    obs.append(mesh('parts/duct.ply', [e[0] - 0.12, Y0 - 0.28, Z0 - 0.025 - 0.015 - 0.043], rpy_of(Rm_d)))
    obs.append(end_wall(e, 0.12, 0.4))
    return ("Meshes of three formats re-used in other placements: the ASCII-STL tee with its run vertical (file x -> "
            "world z, file y -> world -x) on the start line, right of the straight between two S-bends, 14 mm from the body "
            "(the way goes 0.09 m left round it and back); the GLB wall turned on "
            "edge along the way, 13 mm left of the body over the last 0.35 m; the binary-PLY open duct lying across "
            "under the last leg, 15 mm below the body. Goal 0.12 m before an end wall."), obs, [e], path, {}


# ======================================================================================================
# deliberately bad files (bad/, not run)
# ======================================================================================================
def write_bad():
    bad = os.path.join(HERE, 'bad'); os.makedirs(bad, exist_ok=True)
    # 1: a GLB whose index accessor names vertex 99 of an 8-vertex POSITION accessor
    cube = np.array([[x, y, z] for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)], np.float32) * 0.1
    faces = np.array([[0, 1, 3], [0, 3, 99], [4, 6, 7]], np.uint16)
    write_glb('bad_index.glb', [(cube, faces)], [{"mesh": 0}], [0], folder=bad)
    # 2: an OBJ whose face names vertex 9 of 4
    with open(os.path.join(bad, 'bad_index.obj'), 'w', newline='\n') as f:
        f.write('o quad\nv 0 0 0\nv 0 0.1 0\nv 0 0.1 0.1\nv 0 0 0.1\nf 1 2 3 9\n')
    # 3: a binary STL whose triangle count says 1000 but holds 2 triangles
    T = np.array([[[0, 0, 0], [0, .1, 0], [0, .1, .1]], [[0, 0, 0], [0, .1, .1], [0, 0, .1]]], float)
    data = b'solid truncated'.ljust(80, b' ') + struct.pack('<I', 1000) + b''.join(struct.pack('<12fH', 1, 0, 0, *t[0], *t[1], *t[2], 0) for t in T)
    _write_bytes('bad_count.stl', data, bad)
    # 4: a VALID binary PLY (the baffle tube with its cap as one 32-gon: faces of mixed sizes, 4 and 32)
    V, F = ply_collide_ring(mixed=True)
    head = b'ply\nformat binary_little_endian 1.0\ncomment valid file, faces of 4 and 32 vertices\nelement vertex %d\nproperty double x\nproperty double y\nproperty double z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n' % (len(V), len(F))
    body = b''.join(struct.pack('<ddd', *v) for v in V) + b''.join(struct.pack('<B', len(f)) + struct.pack('<%di' % len(f), *f) for f in F)
    _write_bytes('valid_mixed_faces.ply', head + body, bad)
    for nm, fn in (('bad_glb_index', 'bad_index.glb'), ('bad_obj_index', 'bad_index.obj'), ('bad_stl_count', 'bad_count.stl'),
                   ('valid_ply_mixed_faces', 'valid_mixed_faces.ply')):
        w = {"format": "navstack-world/1", "name": nm, "description": "deliberately bad mesh file: " + fn,
             "robot": {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06},
             "obstacles": [mesh(fn, [X0 + 0.5, Y0 + 0.3, Z0])],
             "goals": [{"position": [round(X0 + 0.3, 6), round(Y0, 6), round(Z0, 6)], "tolerance": 0.02}], "time_limit": 60.0}
        with open(os.path.join(bad, nm + '.json'), 'w') as f: json.dump(rnd(w), f, indent=1)


# ======================================================================================================
def build_all(names, write=True):
    results = {}
    for name in names:
        desc, obs, goals, path, opt = W[name]()
        goals = [np.array(g, float) for g in goals]
        ck = check(obs, path, goals)
        results[name] = (ck, opt)
        if not write: continue
        robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06}
        ref_pts = path.P[::25].tolist() + [path.P[-1].tolist()]
        w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h13-" + name.split('_')[0],
             "robot": robot, "obstacles": obs,
             "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": 0.02} for g in goals],
             "time_limit": 60.0}
        w['extra'] = {"reference_path": {"commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [float(x) for x in c[3]]] for c in path.cmds],
                                         "note": "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points every 5 cm",
                                         "start_tip_world": [round(float(v), 6) for v in path.start],
                                         "points": [[round(float(v), 4) for v in p] for p in ref_pts]},
                      "checks": ck, "expected": "collision or not a success (built to collide)" if opt.get('collide') else "reached",
                      "generator": "worlds/hard13/make.py (batch 13 helper; meshes written by its own writers)"}
        with open(os.path.join(HERE, name + '.json'), 'w') as f: json.dump(rnd(w), f, indent=1)
    return results


def define_parts():
    """build every Part in memory (and write the mesh files), in the fixed order (mixed_slalom needs earlier parts)"""
    for n in W:
        if n != 'mixed_slalom': W[n]()


if __name__ == '__main__':
    names = sys.argv[1:] or list(W)
    if 'mixed_slalom' in names and len(names) < len(W):
        WRITE = False; define_parts(); WRITE = True
    res = build_all(names)
    write_bad()
    for n, (ck, opt) in res.items():
        ok = ck['body_clearance'] >= (-0.004 if opt.get('collide') else 0.008) and ck['arm_clearance'] >= 0.03 and ck['lathe_travel'] <= 2.0
        print(('OK  ' if ok else 'BAD ') + n, json.dumps({k: ck[k] for k in ('tip_clearance', 'body_clearance', 'body_worst_at_s', 'arm_clearance', 'lathe_travel', 'straight_leg_clearance_static')}), flush=True)
