# Renders a Sawyer .glb in Blender's Cycles (CPU, headless). Two modes:
#
#   face:  one board's top face seen straight on (orthographic), the whole face filling a
#          W x H image, under a uniform white sky: a diffuse surface there shows its base colour
#          (plus a little specular), so the image can be compared with Sawyer's own picture of
#          the face (tests/export_test.cpp does). The board must lie unrotated (rotation 0: its
#          top face looks up, Sawyer's +y, Blender's +z).
#   view:  all boards from above at an angle, lit by a sun and the sky (docs/images).
#   end:   the same light, close to the boards' butt end, looking along them: the end grain and
#          the first metre of their faces with its knots (docs/images).
#
#   blender -b --factory-startup --python-exit-code 1 --python tools/blender/render_boards.py -- \
#       boards.glb out.png face "board 1" W H [samples]
#   blender -b ... -- boards.glb out.png view W H [samples]
#   blender -b ... -- boards.glb out.png end W H [samples]
import math
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


def setup_cycles(w, h, samples):
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = samples
    sc.cycles.use_denoising = False
    sc.render.resolution_x = w
    sc.render.resolution_y = h
    sc.render.resolution_percentage = 100
    sc.render.image_settings.file_format = "PNG"
    sc.render.image_settings.color_mode = "RGB"
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    return sc


def world(strength, color=(1.0, 1.0, 1.0)):
    w = bpy.data.worlds.new("sky")
    w.use_nodes = True
    bg = w.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (*color, 1.0)
    bg.inputs["Strength"].default_value = strength
    bpy.context.scene.world = w


def camera(location, rotation, ortho_scale=None, lens=50.0):
    cam = bpy.data.cameras.new("cam")
    if ortho_scale:
        cam.type = "ORTHO"
        cam.ortho_scale = ortho_scale
    else:
        cam.lens = lens
    cam.clip_end = 1000.0
    obj = bpy.data.objects.new("cam", cam)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    obj.rotation_euler = rotation
    bpy.context.scene.camera = obj
    return obj


def bounds(objs):
    pts = [o.matrix_world @ Vector(c) for o in objs for c in o.bound_box]
    lo = Vector((min(p.x for p in pts), min(p.y for p in pts), min(p.z for p in pts)))
    hi = Vector((max(p.x for p in pts), max(p.y for p in pts), max(p.z for p in pts)))
    return lo, hi


def main():
    a = sys.argv[sys.argv.index("--") + 1:]
    glb, out, mode = a[0], a[1], a[2]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=glb)
    boards = [o for o in bpy.data.objects if o.type == "MESH"]
    if mode == "face":
        name, w, h = a[3], int(a[4]), int(a[5])
        samples = int(a[6]) if len(a) > 6 else 32
        target = [o for o in boards if o.name == name]
        if not target:
            raise SystemExit("render_boards: no board %r in %s" % (name, glb))
        for o in boards:
            o.hide_render = o is not target[0]
        sc = setup_cycles(w, h, samples)
        sc.cycles.filter_width = 0.01  # one texel's colour per pixel, no reconstruction blur
        sc.cycles.max_bounces = 1
        world(1.0)
        lo, hi = bounds(target)
        centre = (lo + hi) / 2
        # glTF +z (Sawyer's z, along the board) is Blender's -y; the face's image runs left to
        # right along Sawyer's z and bottom to top along Sawyer's x (its width): the camera
        # looks down with its right along -y and its up along +x.
        length = hi.y - lo.y
        camera((centre.x, centre.y, hi.z + 1.0), (0.0, 0.0, -math.pi / 2), ortho_scale=length)
    else:
        w, h = int(a[3]), int(a[4])
        samples = int(a[5]) if len(a) > 5 else 32
        sc = setup_cycles(w, h, samples)
        world(0.35, (0.9, 0.93, 1.0))
        sun = bpy.data.lights.new("sun", "SUN")
        sun.energy = 2.5
        sun_obj = bpy.data.objects.new("sun", sun)
        bpy.context.scene.collection.objects.link(sun_obj)
        sun_obj.rotation_euler = (math.radians(40), math.radians(15), math.radians(30))
        lo, hi = bounds(boards)
        centre = (lo + hi) / 2
        size = (hi - lo).length
        if mode == "end":
            # Beyond the butt end (Blender's largest y), above and to the side, looking at a
            # point about 0.6 m along the boards.
            across = max(hi.x - lo.x, hi.z - lo.z)
            target = Vector((centre.x, hi.y - 0.6, centre.z))
            eye = Vector((centre.x + 2.2 * across, hi.y + 0.45, centre.z + 2.0 * across))
            lens = 35.0
        else:
            # From above and to the side of the butt end (Sawyer's z = 0 is Blender's y = 0,
            # the boards run to -y): the top faces, one edge and the butt ends in view.
            target = centre
            eye = centre + Vector((1.0, 0.45, 0.75)).normalized() * size * 1.5
            lens = 50.0
        rot = (target - eye).to_track_quat("-Z", "Y").to_euler()
        camera(eye, rot, lens=lens)
    sc.render.filepath = out
    bpy.ops.render.render(write_still=True)
    print("render_boards: wrote %s (%d x %d, %d samples)" % (out, sc.render.resolution_x,
                                                             sc.render.resolution_y,
                                                             sc.cycles.samples))


main()
