# Blender's Glare compositor node (its non-physical "Ghosts") on an EXR, for issue 17's peer comparison on
# CandleGlass.exr (docs/benchmarks.md). Not run by CI. Usage:
#   blender -b --factory-startup --python bench/flare/blender_glare.py -- IN.exr OUT.exr THRESHOLD QUALITY WxH
# QUALITY: HIGH, MEDIUM or LOW. Prints the compositing time: a render with the Glare node minus the same
# render with it muted (the empty scene's render and the image's load and save are in both).
import os
import sys

import bpy

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from blender_peer import compositing_scene, node_seconds  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
src, dst = args[0], args[1]
threshold, quality = float(args[2]), args[3]
width, height = (int(v) for v in args[4].split("x"))

scene = compositing_scene(width, height, "16", "PIZ")
image = bpy.data.images.load(src)
tree = scene.node_tree
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

with_node, without = node_seconds(scene, glare, dst)
print(f"blender glare ghosts: render {with_node:.2f} s, muted {without:.2f} s, node {with_node - without:.2f} s, "
      f"{width}x{height}, threshold {threshold}, quality {quality}")
