# Render a sphaptics run folder with Blender (Cycles, CPU) to PNG frames.
#
#   blender -b --factory-startup --python-exit-code 1 -P scripts/render_blender.py -- RUN_DIR [options]
#   (or: scripts/render.sh RUN_DIR [options])
#
# Options (after RUN_DIR):
#   --frames A:B      output frames to render, inclusive, 0-based (default: all)
#   --every N         render every N-th frame (default 1)
#   --resolution WxH  image size in pixels (default 640x360)
#   --samples N       Cycles samples per pixel (default 16)
#   --out DIR         where the PNGs go (default RUN_DIR/render)
#   --volume          render the VDB density sequence (fog) instead of the OBJ surfaces
#   --blend FILE      also save the last frame's scene as a .blend file
#
# What it reads from RUN_DIR: every OBJ sequence NAME_%04d.obj (fluid_<phase>_*, body_<name>_*,
# cloth_<name>_*, soft_<name>_* (soft bodies' surfaces); a fluid surface takes its phase's colour from the OBJ header, or the per-vertex colours
# when the file has them), the VDB sequence NAME_%04d.vdb when --volume is given, and run.json for the domain box
# (camera framing, floor). OBJ files are in simulation coordinates (metres, Z up) and are imported
# with forward_axis='Y', up_axis='Z' so Blender's world matches the simulation's (and the VDB
# files, which Blender imports without axis conversion). Next to the PNGs it writes camera.json
# (the camera's world -> clip matrix, for tests that look at where things land). Debian's Blender has no OpenImageDenoise,
# so denoising is off. Per frame the meshes are imported, rendered and removed again, so memory
# stays flat over long sequences.
import json
import math
import os
import re
import sys
import time

import bpy
from mathutils import Vector


def parse_args(argv):
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    if not args or args[0].startswith("-"):
        raise SystemExit("usage: blender -b -P render_blender.py -- RUN_DIR [--frames A:B] [--every N] "
                         "[--resolution WxH] [--samples N] [--out DIR] [--volume] [--blend FILE]")
    opt = {"run": os.path.abspath(args[0]), "frames": None, "every": 1, "resolution": (640, 360),
           "samples": 16, "out": None, "volume": False, "blend": None}
    i = 1
    while i < len(args):
        a = args[i]
        if a == "--volume":
            opt["volume"] = True
            i += 1
            continue
        if i + 1 >= len(args):
            raise SystemExit("render_blender: %s needs a value" % a)
        v = args[i + 1]
        if a == "--frames":
            lo, _, hi = v.partition(":")
            opt["frames"] = (int(lo), int(hi or lo))
        elif a == "--every":
            opt["every"] = max(1, int(v))
        elif a == "--resolution":
            w, _, h = v.lower().partition("x")
            opt["resolution"] = (int(w), int(h))
        elif a == "--samples":
            opt["samples"] = int(v)
        elif a == "--out":
            opt["out"] = os.path.abspath(v)
        elif a == "--blend":
            opt["blend"] = os.path.abspath(v)
        else:
            raise SystemExit("render_blender: unknown option %s" % a)
        i += 2
    if opt["out"] is None:
        opt["out"] = os.path.join(opt["run"], "render")
    return opt


def sequences(folder, ext):
    """{name: {frame: path}} for every NAME_%04d.EXT in folder."""
    seqs = {}
    pattern = re.compile(r"^(.*)_(\d{4,})\." + ext + "$")
    for f in sorted(os.listdir(folder)):
        m = pattern.match(f)
        if m:
            seqs.setdefault(m.group(1), {})[int(m.group(2))] = os.path.join(folder, f)
    return seqs


def domain_box(run):
    """Domain (min, max) from run.json, or None."""
    try:
        with open(os.path.join(run, "run.json")) as f:
            scene = json.load(f)["scene"]
        return Vector(scene["domain"]["min"]), Vector(scene["domain"]["max"])
    except (OSError, KeyError, TypeError, ValueError):
        return None


def material(name, colour, kind):
    """A Principled BSDF material for one OBJ sequence. Water (a fluid surface without vertex
    colours) is clear, tinted glass: IOR 1.33 and transmission 0.9, its base colour the phase colour
    lightened halfway to white (light passes the tint twice, in and out, which would otherwise
    darken it to near black), so the bodies and cloth under the surface show through. Bodies, cloth
    and soft bodies are opaque."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    bsdf = nt.nodes["Principled BSDF"]
    if kind == "fluid":
        tint = tuple(0.5 * c + 0.5 for c in colour)
        bsdf.inputs["Base Color"].default_value = (*tint, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.05
        bsdf.inputs["Transmission"].default_value = 0.9
        bsdf.inputs["IOR"].default_value = 1.33
    else:
        bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.5
    # Per-vertex colours (OBJ "v x y z r g b": bodies, cloth, soft bodies, and fluid surfaces with
    # the isosurface option vertex_colours) drive the colour once a mesh brings them (import_obj).
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "GEOMETRY"
    attr.attribute_name = "Color"
    mat["kind"] = kind
    return mat, attr, bsdf


# Colours when neither the OBJ header nor its vertices give one, by the sequence's prefix:
# fluid_<phase>, body_<name>, cloth_<name>, soft_<name> (soft bodies: the same format as cloth).
COLOURS = {"fluid": (0.25, 0.5, 0.9), "body": (0.8, 0.6, 0.3), "cloth": (0.8, 0.2, 0.25),
           "soft": (0.85, 0.55, 0.5)}


def header_colour(path):
    """The '# colour: r g b' line sphaptics writes at the top of a surface OBJ (the phase's colour)."""
    try:
        with open(path) as f:
            for line in f:
                if not line.startswith("#"):
                    break
                if line.startswith("# colour:"):
                    r, g, b = (float(v) for v in line.split(":", 1)[1].split()[:3])
                    return (r, g, b)
    except (OSError, ValueError):
        pass
    return None


def kind_of(name):
    for k in COLOURS:
        if name.startswith(k):
            return k
    return "body"


def import_obj(path, name, mat, attr, bsdf):
    bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z")
    objs = list(bpy.context.selected_objects)
    for ob in objs:
        ob.name = name
        mesh = ob.data
        mesh.polygons.foreach_set("use_smooth", [True] * len(mesh.polygons))
        mesh.materials.clear()
        mesh.materials.append(mat)
        has_colour = len(getattr(mesh, "color_attributes", [])) > 0
        links = mat.node_tree.links
        if has_colour and not bsdf.inputs["Base Color"].is_linked:
            attr.attribute_name = mesh.color_attributes[0].name
            links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
            if mat["kind"] == "fluid":
                # Coloured fluid (paint that mixes): opaque, so that the colours read as they are.
                bsdf.inputs["Transmission"].default_value = 0.0
                bsdf.inputs["Roughness"].default_value = 0.3
    return objs


def setup_scene(opt, box):
    scene = bpy.context.scene
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = opt["samples"]
    scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    r = scene.render
    r.resolution_x, r.resolution_y = opt["resolution"]
    r.resolution_percentage = 100
    r.image_settings.file_format = "PNG"
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.8, 0.85, 0.9, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6

    lo, hi = box
    centre = (lo + hi) / 2
    size = hi - lo
    diag = size.length
    # Camera: in front (-y), to the side and above, looking at the domain centre.
    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens = 35
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    direction = Vector((0.6 * size.x + 0.3 * diag, -1.3 * diag, 0.7 * diag))
    cam.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    cam_data.clip_end = 100 * diag
    scene.camera = cam
    # Distance: move in along that direction until the box's corners fill the picture (each within
    # 90 % of the half-width and half-height), so a flat or low scene is not a speck in the middle.
    corners = [Vector((x, y, z)) for x in (lo.x, hi.x) for y in (lo.y, hi.y) for z in (lo.z, hi.z)]
    scale = 1.0
    for _ in range(40):
        cam.location = centre + direction * scale
        bpy.context.view_layer.update()
        m = cam.calc_matrix_camera(bpy.context.evaluated_depsgraph_get(), x=r.resolution_x,
                                        y=r.resolution_y) @ cam.matrix_world.inverted()
        reach = 0.0
        for c in corners:
            p = m @ c.to_4d()
            reach = max(reach, abs(p.x / p.w), abs(p.y / p.w)) if p.w > 0 else 2.0 + reach
        if reach > 0.9:
            scale /= 0.95  # one step back: the last distance that fitted
            break
        scale *= 0.95
    cam.location = centre + direction * scale
    bpy.context.view_layer.update()
    sun_data = bpy.data.lights.new("sun", "SUN")
    sun_data.energy = 3.0
    sun = bpy.data.objects.new("sun", sun_data)
    sun.rotation_euler = (math.radians(40), math.radians(15), math.radians(30))
    scene.collection.objects.link(sun)
    # Floor: the domain's bottom, a little larger than the box.
    bpy.ops.mesh.primitive_plane_add(size=1, location=(centre.x, centre.y, lo.z))
    floor = bpy.context.active_object
    floor.name = "floor"
    floor.scale = (size.x * 1.6, size.y * 1.6, 1)
    fm = bpy.data.materials.new("floor")
    fm.use_nodes = True
    fm.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.55, 0.55, 0.55, 1)
    floor.data.materials.append(fm)
    return scene


def bounding_box(objs):
    lo = Vector((math.inf,) * 3)
    hi = Vector((-math.inf,) * 3)
    for ob in objs:
        for c in ob.bound_box:
            w = ob.matrix_world @ Vector(c)
            lo = Vector(map(min, lo, w))
            hi = Vector(map(max, hi, w))
    return (lo, hi) if lo.x <= hi.x else None


def volume_object(scene, name, files):
    folder = os.path.dirname(files[0])
    bpy.ops.object.volume_import(filepath=files[0], directory=folder,
                                 files=[{"name": os.path.basename(f)} for f in files],
                                 use_sequence_detection=True, align="WORLD", location=(0, 0, 0))
    ob = bpy.context.active_object
    ob.name = name
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    pv.inputs["Density"].default_value = 20.0
    pv.inputs["Density Attribute"].default_value = "density"
    pv.inputs["Color"].default_value = (*COLOURS["fluid"], 1.0)
    nt.links.new(pv.outputs["Volume"], out.inputs["Volume"])
    ob.data.materials.append(mat)
    return ob


def write_camera(scene, path):
    """The camera as a world -> pixel projection, for tests that check where things land in the
    picture: pixel (x right, y down) = ((ndc_x + 1) / 2 * W, (1 - ndc_y) / 2 * H), with
    ndc = (M @ (x, y, z, 1)) divided by its w."""
    r = scene.render
    w, h = r.resolution_x, r.resolution_y
    cam = scene.camera
    proj = cam.calc_matrix_camera(bpy.context.evaluated_depsgraph_get(), x=w, y=h)
    m = proj @ cam.matrix_world.inverted()
    with open(path, "w") as f:
        json.dump({"resolution": [w, h], "world_to_clip": [list(row) for row in m]}, f, indent=1)


def main():
    opt = parse_args(sys.argv)
    run = opt["run"]
    if not os.path.isdir(run):
        raise SystemExit("render_blender: no such run folder: %s" % run)
    objs = sequences(run, "obj")
    vdbs = sequences(run, "vdb") if opt["volume"] else {}
    if opt["volume"] and not vdbs:
        raise SystemExit("render_blender: --volume given but %s holds no NAME_%%04d.vdb files" % run)
    if not objs and not vdbs:
        raise SystemExit("render_blender: %s holds no NAME_%%04d.obj files (was output.isosurface on?)" % run)
    frames = sorted({f for s in objs.values() for f in s} | {f for s in vdbs.values() for f in s})
    if opt["frames"]:
        frames = [f for f in frames if opt["frames"][0] <= f <= opt["frames"][1]]
    frames = frames[::opt["every"]]
    if not frames:
        raise SystemExit("render_blender: no frames in the requested range")

    box = domain_box(run)
    if box is None:  # no run.json: frame the first frame's meshes
        tmp = []
        for name, seq in objs.items():
            if frames[0] in seq:
                bpy.ops.wm.obj_import(filepath=seq[frames[0]], forward_axis="Y", up_axis="Z")
                tmp += list(bpy.context.selected_objects)
        box = bounding_box(tmp) or (Vector((-1, -1, 0)), Vector((1, 1, 1)))
    scene = setup_scene(opt, box)
    os.makedirs(opt["out"], exist_ok=True)

    materials = {}
    for name, seq in objs.items():
        if not opt["volume"] or not name.startswith("fluid"):
            colour = header_colour(seq[min(seq)]) or COLOURS[kind_of(name)]
            materials[name] = material(name, colour, kind_of(name))
    volumes = {}
    for name, seq in vdbs.items():
        volumes[name] = volume_object(scene, name, [seq[f] for f in sorted(seq)])
        volumes[name]["first_frame"] = min(seq)

    write_camera(scene, os.path.join(opt["out"], "camera.json"))
    rendered = 0
    started = time.monotonic()
    for f in frames:
        t0 = time.monotonic()
        current = []
        for name, seq in objs.items():
            if name in materials and f in seq:
                current += import_obj(seq[f], "%s_%04d" % (name, f), *materials[name])
        # Volume sequences: frame_offset maps Blender frame 1 to the first file (clients.md pitfall 9).
        scene.frame_set(f - (min(min(s) for s in vdbs.values()) if vdbs else 0) + 1)
        scene.render.filepath = os.path.join(opt["out"], "frame_%04d.png" % f)
        bpy.ops.render.render(write_still=True)
        rendered += 1
        print("render_blender: frame %d -> %s (%.2f s)" % (f, scene.render.filepath, time.monotonic() - t0), flush=True)
        if opt["blend"] and f == frames[-1]:
            bpy.ops.wm.save_as_mainfile(filepath=opt["blend"])
        for ob in current:
            mesh = ob.data
            bpy.data.objects.remove(ob, do_unlink=True)
            if mesh is not None and mesh.users == 0:
                bpy.data.meshes.remove(mesh)
    print("render_blender: %d frames in %s (%.2f s per frame)"
          % (rendered, opt["out"], (time.monotonic() - started) / max(rendered, 1)))


main()
