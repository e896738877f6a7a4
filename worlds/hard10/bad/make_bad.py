"""Writes the broken world files of worlds/hard10/bad/ from ../osc_slot.json (a valid world with a mover) and
../goal_in_pipe.json. Each file breaks one thing; none of these edge cases is in worlds/hard5/bad/.
Usage: python make_bad.py"""
import json, os, struct
HERE = os.path.dirname(os.path.abspath(__file__))
base = json.load(open(os.path.join(HERE, '..', 'osc_slot.json')))
mover = next(i for i, o in enumerate(base['obstacles']) if 'motion' in o)


def dump(name, w, edit=None):
    w = dict(w, name=name); txt = json.dumps(w, indent=1)
    if edit: txt = edit(txt)
    open(os.path.join(HERE, name + '.json'), 'w', encoding='utf-8', newline='').write(txt)


def w_with(f):
    w = json.loads(json.dumps(base)); f(w); return w

# 1. a UTF-8 byte order mark before an otherwise valid file
dump('bom', base, lambda t: '\ufeff' + t)
# 2. the bare token Infinity nested in a mover's velocity-free oscillation axis (Python's json accepts it)
dump('inf_nested', w_with(lambda w: w['obstacles'][mover]['motion'].__setitem__('axis', [0.0, 12345.0, 0.0])),
     lambda t: t.replace('12345.0', 'Infinity'))
# 3. a number that overflows a double: 1e309 as an obstacle's radius (not inside extra)
dump('overflow_radius', w_with(lambda w: w['obstacles'][mover].__setitem__('radius', 0.0123456)),
     lambda t: t.replace('0.0123456', '1e309'))
# 4. -0.0 as a box half extent (a flat box of zero thickness, negative zero)
dump('negzero_half', w_with(lambda w: w['obstacles'][0]['half_extents'].__setitem__(0, -0.0)))
# 5. an empty array where a point is expected
dump('empty_point', w_with(lambda w: w['obstacles'][mover].__setitem__('p1', [])))
# 6. -Infinity in the robot's base rpy
dump('base_neginf', w_with(lambda w: w['robot']['base']['rpy'].__setitem__(0, -54321.0)),
     lambda t: t.replace('-54321.0', '-Infinity'))
# 7. a huge count: 50,000 goals, each a valid point 0.1 m ahead of the start tip
def many(w):
    g = w['goals'][0]; p = list(w['extra']['reference_path']['start_tip_world']); p[0] += 0.1
    w['goals'] = [{"position": p, "tolerance": 0.02}] * 50000
dump('goals_50k', w_with(many), lambda t: json.dumps(json.loads(t), separators=(',', ':')))
# 8. a mesh file that is not a mesh: a binary STL header claiming 1,000,000 triangles, holding one
def mesh_obs(path):
    return {"type": "mesh", "path": path, "position": [2.6, 0.6, 1.2], "rpy": [0.0, 0.0, 0.0], "scale": 1.0}
with open(os.path.join(HERE, 'parts', 'short.stl'), 'wb') as f:
    f.write(b'binary stl, truncated'.ljust(80, b' ') + struct.pack('<I', 1000000) + struct.pack('<12fH', *([0.0] * 3 + [0, 0, 0, 0.1, 0, 0, 0, 0.1, 0]), 0))
dump('stl_truncated', w_with(lambda w: w['obstacles'].append(mesh_obs('parts/short.stl'))))
# 9. a mesh path that is a folder
dump('mesh_is_dir', w_with(lambda w: w['obstacles'].append(mesh_obs('parts'))))
# 10. a duplicate top-level key: "goals" twice, the second list empty
dump('dup_goals', base, lambda t: t.replace('\n "time_limit"', '\n "goals": [],\n "time_limit"', 1))
# 11. NaN in the robot's q0 (nested in robot)
dump('q0_nan', w_with(lambda w: w['robot']['q0'].__setitem__(9, 0.987654)), lambda t: t.replace('0.987654', 'NaN'))
# 12. a mesh scale of -0.0 (a valid 20-triangle icosahedron written here)
import trimesh
trimesh.creation.icosahedron().export(os.path.join(HERE, 'parts', 'ico20.stl'))
dump('mesh_scale_negzero', w_with(lambda w: w['obstacles'].append(dict(mesh_obs('parts/ico20.stl'), scale=-0.0))))
