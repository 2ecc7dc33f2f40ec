# Checks a Sawyer .glb in Blender: imports it with Blender's own glTF importer and compares the
# boards it finds with what the export says it wrote. Run headless:
#
#   blender -b --factory-startup --python-exit-code 1 --python tools/blender/check_glb.py -- \
#       boards.glb [expect.json]
#
# expect.json (optional): {"log_id": "...", "boards": [{"name": "board 1 (A)",
#   "edges_m": [length, width, thickness]}, ...]}. Prints one line per board and
# "check_glb: OK, N boards" (exit 0) or "check_glb: FAIL: ..." lines (exit 1).
import json
import sys

import bpy
import numpy

# Debian 12's Blender 3.4 glTF importer uses numpy.bool, an alias that Debian's numpy 1.24
# removed (AttributeError on import); it was the builtin bool, so give it back.
if numpy.__dict__.get("bool") is not bool:
    try:
        numpy.bool = bool
    except AttributeError:
        pass

TOL_M = 1e-4  # 0.1 mm: float32 positions in metres are far finer


def args():
    a = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if not a:
        raise SystemExit("usage: blender -b --python check_glb.py -- FILE.glb [expect.json]")
    return a[0], (a[1] if len(a) > 1 else None)


def edges_of(obj):
    """The box's three edge lengths (metres, longest first): its extent along each of its face
    normals (a box has three directions of faces, each pair of faces an edge length apart)."""
    rot = obj.matrix_world.to_3x3()
    pts = [obj.matrix_world @ v.co for v in obj.data.vertices]
    dirs = []
    for poly in obj.data.polygons:
        n = (rot @ poly.normal).normalized()
        if all(abs(n.dot(d)) < 0.999 for d in dirs):
            dirs.append(n)
    ext = [max(p.dot(d) for p in pts) - min(p.dot(d) for p in pts) for d in dirs]
    return sorted(ext, reverse=True)


def textures_of(obj):
    found = {}
    for slot in obj.material_slots:
        mat = slot.material
        if not mat or not mat.use_nodes:
            continue
        for node in mat.node_tree.nodes:
            if node.type == "TEX_IMAGE" and node.image:
                for link in node.outputs["Color"].links:
                    found[link.to_socket.name] = tuple(node.image.size)
                # glTF's metallicRoughness image feeds a Separate RGB node (G: roughness).
                for out in node.outputs:
                    for link in out.links:
                        if link.to_node.type in ("SEPRGB", "SEPARATE_COLOR"):
                            found["Roughness"] = tuple(node.image.size)
                        if link.to_node.type == "NORMAL_MAP":
                            found["Normal"] = tuple(node.image.size)
    return found


def main():
    glb, expect_path = args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=glb)
    boards = {o.name: o for o in bpy.data.objects if o.type == "MESH"}
    failures = []
    for name in sorted(boards):
        o = boards[name]
        tex = textures_of(o)
        e = edges_of(o)
        print("board %r: edges %s m, textures %s" % (name, ["%.4f" % x for x in e], tex))
        for socket in ("Base Color", "Normal", "Roughness"):
            if socket not in tex:
                failures.append("%s: no %s texture" % (name, socket))
    if expect_path:
        with open(expect_path) as f:
            expect = json.load(f)
        want = {b["name"]: b for b in expect["boards"]}
        if sorted(want) != sorted(boards):
            failures.append("boards %s, expected %s" % (sorted(boards), sorted(want)))
        for name, b in want.items():
            if name not in boards:
                continue
            got = edges_of(boards[name])
            exp = sorted(b["edges_m"], reverse=True)
            if len(got) != 3 or any(abs(g - x) > TOL_M for g, x in zip(got, exp)):
                failures.append("%s: edges %s m, expected %s" % (name, got, exp))
        if "log_id" in expect:
            got_id = bpy.context.scene.get("log_id")
            if got_id != expect["log_id"]:
                failures.append("scene log_id %r, expected %r" % (got_id, expect["log_id"]))
    for f in failures:
        print("check_glb: FAIL: " + f)
    if failures:
        sys.exit(1)
    print("check_glb: OK, %d boards" % len(boards))


main()
