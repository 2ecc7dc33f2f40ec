# Renders a Sawyer .glb in Cycles with the wood of its boards evaluated per shading point by
# shaders/osl/sawyer_wood.osl from the tables of `sawyer export --osl-data DIR`, instead of the
# baked base-colour textures: every surface shows the log's real rings and knots, including
# cuts that Sawyer never baked. Needs a Blender whose Cycles has OSL (Blender's own builds from
# blender.org have it; Debian's blender package does not: _cycles.with_osl is False there, and
# the script stops with that message). Run through scripts/blender_osl_render.sh.
#
#   blender -b --factory-startup --python-exit-code 1 --python scripts/blender_osl_render.py -- \
#       boards.glb DIR out.png [width height samples]
import json
import math
import os
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
from mathutils import Vector


def main():
    a = sys.argv[sys.argv.index("--") + 1:]
    glb, data, out = a[0], os.path.abspath(a[1]), a[2]
    w, h, samples = (int(a[3]), int(a[4]), int(a[5])) if len(a) > 5 else (1200, 800, 64)
    import _cycles
    if not _cycles.with_osl:
        raise SystemExit("blender_osl_render: this Blender's Cycles is built without OSL "
                         "(_cycles.with_osl is False); use a Blender with OSL")
    with open(os.path.join(data, "sawyer_osl.json")) as f:
        meta = json.load(f)
    if meta.get("format") != "sawyer-osl/1":
        raise SystemExit("blender_osl_render: %s is not a sawyer-osl/1 folder" % data)
    shader = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "shaders", "osl",
                          "sawyer_wood.osl")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=glb)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.shading_system = True  # OSL
    sc.cycles.samples = samples
    sc.render.resolution_x, sc.render.resolution_y = w, h
    for mat in bpy.data.materials:
        if not mat.use_nodes:
            continue
        nt = mat.node_tree
        bsdf = next((n for n in nt.nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is None:
            continue
        script = nt.nodes.new("ShaderNodeScript")
        script.mode = "EXTERNAL"
        script.filepath = shader
        # An external script's sockets appear once Blender has compiled it (on assignment of
        # the file path in an OSL build; the node's update() asks again).
        script.update()
        missing = [n for n in ["DataDir"] + list(meta["parameters"]) if n not in script.inputs]
        if missing:
            raise SystemExit("blender_osl_render: %s did not compile (no sockets %s)"
                             % (shader, missing))
        script.inputs["DataDir"].default_value = data
        for name, value in meta["parameters"].items():
            # Colours come as [r, g, b]; a colour socket takes RGBA.
            if isinstance(value, list) and len(value) == 3:
                value = value + [1.0]
            script.inputs[name].default_value = value
        for link in list(bsdf.inputs["Base Color"].links):
            nt.links.remove(link)
        nt.links.new(script.outputs["Color"], bsdf.inputs["Base Color"])
    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.8
    sc.world = world
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(40), math.radians(15), math.radians(30))
    sc.collection.objects.link(sun)
    boards = [o for o in bpy.data.objects if o.type == "MESH"]
    pts = [o.matrix_world @ Vector(c) for o in boards for c in o.bound_box]
    lo = Vector((min(p.x for p in pts), min(p.y for p in pts), min(p.z for p in pts)))
    hi = Vector((max(p.x for p in pts), max(p.y for p in pts), max(p.z for p in pts)))
    centre, size = (lo + hi) / 2, (hi - lo).length
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    sc.collection.objects.link(cam)
    cam.location = centre + Vector((0.55, 0.75, 0.5)).normalized() * size * 0.9
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    sc.camera = cam
    sc.render.filepath = out
    bpy.ops.render.render(write_still=True)
    print("blender_osl_render: wrote %s" % out)


main()
