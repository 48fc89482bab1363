# What bench's Blender peer scripts (dof/blender_defocus.py, flare/blender_glare.py) share: a scene that only
# composites an EXR, saved as EXR, and a render timed from start to saved file. Imported from those scripts
# (their folder's parent is put on sys.path). Not run by CI.
import time

import bpy


def compositing_scene(width, height, color_depth, exr_codec):
    """The current scene, emptied of all but cameras, rendering a width x height composite (Cycles at one
    sample, no view transform) to EXR; its compositing node tree cleared and returned."""
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.device = "CPU"
    scene.render.use_compositing = True
    scene.render.use_sequencer = False
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = color_depth
    scene.render.image_settings.exr_codec = exr_codec
    for obj in list(scene.objects):
        if obj.type != "CAMERA":
            bpy.data.objects.remove(obj)
    scene.use_nodes = True
    scene.node_tree.nodes.clear()
    return scene


def timed_render(scene, path):
    """Seconds to render the scene and save it to path."""
    scene.render.filepath = path
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return time.perf_counter() - start


def node_seconds(scene, node, path):
    """The render with `node` and with it muted (the empty scene's render and the image's load and save are in
    both), saved to path and path + ".muted.exr": (with, without) seconds."""
    with_node = timed_render(scene, path)
    node.mute = True
    return with_node, timed_render(scene, path + ".muted.exr")
