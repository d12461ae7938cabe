"""What the Blender scene scripts of scripts/blender/ share: Lambertian materials, boxes and
quads, Cycles settings that render physics rather than looks, saving renders, and the geometry
as OBJ files in the scene's frame (Blender's world axes: x east, y north, z up, metres)."""
import os

import bpy
import mathutils


def clear_scene():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o, do_unlink=True)


def material(name, albedo):
    """A Lambertian (Diffuse BSDF, roughness 0) material of linear albedo `albedo`."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nodes = m.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*albedo, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0
    output = nodes.new("ShaderNodeOutputMaterial")
    m.node_tree.links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    return m


def box(name, center, size, albedo):
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=center)
    o = bpy.context.active_object
    o.name = name
    o.scale = size
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    o.data.materials.append(material(name, albedo))
    return o


def sphere(name, center, radius, albedo, subdivisions=7):
    """A smooth-shaded icosphere (20 * 4^subdivisions triangles). Its vertices lie on the sphere,
    so the facets are inside it by about edge^2 / (8 radius): at 7 subdivisions (edges of
    radius / 122) by 1e-5 of the radius, far below a pixel."""
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions, radius=radius, location=center)
    o = bpy.context.active_object
    o.name = name
    o.data.polygons.foreach_set("use_smooth", [True] * len(o.data.polygons))
    o.data.update()
    o.data.materials.append(material(name, albedo))
    return o


def mesh_object(name, vertices, faces, materials, face_materials):
    """An object from polygons (vertex index lists) with a material per face; `materials` is a
    list of (name, albedo)."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    for material_name, albedo in materials:
        mesh.materials.append(material(material_name, albedo))
    for polygon, index in zip(mesh.polygons, face_materials):
        polygon.material_index = index
    mesh.update()
    o = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(o)
    return o


def camera(position, look_at, hfov_rad, width, height):
    """A pinhole camera at `position` looking at `look_at` with z up, centred principal point."""
    scene = bpy.context.scene
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "HORIZONTAL"
    data.angle = hfov_rad
    data.clip_start = 0.05
    data.clip_end = 1000.0
    o = bpy.data.objects.new("camera", data)
    scene.collection.objects.link(o)
    o.location = position
    o.rotation_euler = (mathutils.Vector(look_at) - mathutils.Vector(position)).to_track_quat("-Z", "Y").to_euler()
    scene.camera = o
    scene.render.resolution_x = width
    scene.render.resolution_y = height
    scene.render.resolution_percentage = 100
    return o


def cycles(samples, bounces):
    """Cycles on the CPU with nothing that trades physics for looks: no denoising, no adaptive
    sampling, no sample clamping, no light threshold; diffuse bounces only; a 0.01 px filter."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_denoising = False
    c.use_adaptive_sampling = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.max_bounces = bounces
    c.diffuse_bounces = bounces
    c.glossy_bounces = 0
    c.transmission_bounces = 0
    c.volume_bounces = 0
    c.transparent_max_bounces = 0
    c.filter_width = 0.01
    c.seed = 1
    scene.render.threads_mode = "AUTO"
    scene.display_settings.display_device = "sRGB"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.gamma = 1.0


def save_render(path, file_format, color_depth, color_mode="RGB", exposure=0.0, quality=97, linear=False):
    """Saves the last render: EXR as scene-linear float, JPEG/PNG/TIFF through the sRGB view at
    `exposure` EV, or with `linear` through no view transform (values proportional to radiance,
    clipped at 1: a raw converter's linear TIFF)."""
    scene = bpy.context.scene
    scene.view_settings.view_transform = "Raw" if linear else "Standard"
    settings = scene.render.image_settings
    settings.file_format = file_format
    settings.color_mode = color_mode
    settings.color_depth = color_depth
    if file_format == "JPEG":
        settings.quality = quality
    if file_format == "OPEN_EXR":
        settings.exr_codec = "ZIP"
    scene.view_settings.exposure = exposure
    bpy.data.images["Render Result"].save_render(filepath=path, scene=scene)
    scene.view_settings.view_transform = "Standard"


def write_objs(out, prefix):
    """Every mesh object as OUT/PREFIX_<object>.obj in world coordinates, triangles wound as
    Blender's faces, `usemtl` per material when an object has several."""
    for o in bpy.data.objects:
        if o.type != "MESH":
            continue
        mesh = o.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
        mesh.calc_loop_triangles()
        several = len(mesh.materials) > 1
        with open(os.path.join(out, "%s_%s.obj" % (prefix, o.name)), "w") as f:
            f.write("# %s: Blender scene object, metres in the scene's ENU frame\n" % o.name)
            for v in mesh.vertices:
                w = o.matrix_world @ v.co
                f.write("v %.6f %.6f %.6f\n" % (w.x, w.y, w.z))
            current = None
            for t in mesh.loop_triangles:
                if several and t.material_index != current:
                    current = t.material_index
                    f.write("usemtl %s\n" % mesh.materials[current].name)
                f.write("f %d %d %d\n" % tuple(i + 1 for i in t.vertices))
        o.to_mesh_clear()
