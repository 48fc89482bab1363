# Blender's Glare compositor node (its non-physical "Ghosts") on an EXR, for issue 17's peer comparison on
# CandleGlass.exr (docs/benchmarks.md). Not run by CI. Usage:
#   blender -b --factory-startup --python bench/flare/blender_glare.py -- IN.exr OUT.exr THRESHOLD QUALITY WxH
# QUALITY: HIGH, MEDIUM or LOW. Prints the compositing time: a render with the Glare node minus the same
# render with it muted (the empty scene's render and the image's load and save are in both).
import sys
import time

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
src, dst = args[0], args[1]
threshold, quality = float(args[2]), args[3]
width, height = (int(v) for v in args[4].split("x"))

scene = bpy.context.scene
image = bpy.data.images.load(src)
scene.render.resolution_x, scene.render.resolution_y = width, height
scene.render.resolution_percentage = 100
scene.render.engine = "CYCLES"
scene.cycles.samples = 1
scene.cycles.device = "CPU"
scene.render.use_compositing = True
scene.render.use_sequencer = False
scene.view_settings.view_transform = "Standard"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "16"
scene.render.image_settings.exr_codec = "PIZ"
for obj in list(scene.objects):
    if obj.type != "CAMERA":
        bpy.data.objects.remove(obj)

scene.use_nodes = True
tree = scene.node_tree
tree.nodes.clear()
source = tree.nodes.new("CompositorNodeImage")
source.image = image
glare = tree.nodes.new("CompositorNodeGlare")
glare.glare_type = "GHOSTS"
glare.quality = quality
glare.iterations = 3
glare.threshold = threshold
glare.mix = 0.0
out = tree.nodes.new("CompositorNodeComposite")
tree.links.new(source.outputs["Image"], glare.inputs["Image"])
tree.links.new(glare.outputs["Image"], out.inputs["Image"])


def render(path):
    scene.render.filepath = path
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return time.perf_counter() - start


with_node = render(dst)
glare.mute = True
without = render(dst + ".muted.exr")
print(f"blender glare ghosts: render {with_node:.2f} s, muted {without:.2f} s, node {with_node - without:.2f} s, "
      f"{width}x{height}, threshold {threshold}, quality {quality}")
