# Blender's Defocus compositor node (Z-buffer mode) on an EXR with R, G, B and Z, for bench/dof's peer
# comparison (docs/dof.md). Not run by CI. Usage:
#   blender -b --factory-startup --python bench/dof/blender_defocus.py -- IN.exr OUT.exr FSTOP FOCAL_MM FOCUS_M MAX_BLUR_PX WxH
# Prints the compositing time: a render with the Defocus node minus the same render with it muted (the
# empty scene's render and the image's load and save are in both).
import os
import sys

import bpy

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from blender_peer import compositing_scene, node_seconds  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
src, dst = args[0], args[1]
fstop, focal_mm, focus_m = float(args[2]), float(args[3]), float(args[4])
max_blur = float(args[5])

width, height = (int(v) for v in args[6].split("x"))  # Blender reads R, G, B, Z as a multilayer image: no size
scene = compositing_scene(width, height, "32", "ZIP")
image = bpy.data.images.load(src)

camera = bpy.data.cameras.new("lens")
camera.lens = focal_mm
camera.sensor_fit = "HORIZONTAL"
camera.sensor_width = 36.0
camera.dof.use_dof = True
camera.dof.focus_distance = focus_m
camera.dof.aperture_fstop = fstop
camera_object = bpy.data.objects.new("lens", camera)
scene.collection.objects.link(camera_object)
scene.camera = camera_object

tree = scene.node_tree
source = tree.nodes.new("CompositorNodeImage")
source.image = image
print("image outputs:", [o.name for o in source.outputs if o.enabled])
depth = next(o for o in source.outputs if o.name in ("Depth", "Z") and o.enabled)
defocus = tree.nodes.new("CompositorNodeDefocus")
defocus.scene = scene
defocus.use_zbuffer = True
defocus.z_scale = 1.0
defocus.f_stop = fstop
defocus.blur_max = max_blur
defocus.threshold = 0.0
defocus.use_preview = False
defocus.use_gamma_correction = False
defocus.bokeh = "CIRCLE"
out = tree.nodes.new("CompositorNodeComposite")
colour = next(o for o in source.outputs if o.name in ("Image", "Combined") and o.enabled)
tree.links.new(colour, defocus.inputs["Image"])
tree.links.new(depth, defocus.inputs["Z"])
tree.links.new(defocus.outputs["Image"], out.inputs["Image"])

with_node, without = node_seconds(scene, defocus, dst)
print(f"blender defocus: render {with_node:.2f} s, muted {without:.2f} s, node {with_node - without:.2f} s, "
      f"{width}x{height}, f/{fstop} {focal_mm} mm focus {focus_m} m")
