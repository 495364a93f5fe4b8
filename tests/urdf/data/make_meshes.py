#!/usr/bin/env python3
"""Writes the test meshes of tests/urdf (run from this directory; the outputs are committed).

foot.stl (binary STL, millimetres; the URDF scales it by 0.001) and foot.dae (COLLADA with
<unit meter="0.001">, millimetres, so assimp's unit conversion gives metres): the same sole, a
frustum 120 x 70 mm at the bottom (z = -30 mm) and 100 x 50 mm at the top (z = -10 mm). The bottom
face is a fan around its centre (0, 0, -30), a vertex that is not on the hull: 9 mesh vertices,
8 hull vertices. flat.stl: one triangle (no volume, for the error test). broken.stl: 40 bytes of
noise (not a mesh).
"""
import struct

BOTTOM = [(60, 35, -30), (-60, 35, -30), (-60, -35, -30), (60, -35, -30)]  # counter-clockwise seen from above
TOP = [(50, 25, -10), (-50, 25, -10), (-50, -25, -10), (50, -25, -10)]
CENTRE = (0, 0, -30)


def triangles():
    tris = []
    for i in range(4):  # bottom: fan around the centre, facing down (clockwise seen from above)
        tris.append((CENTRE, BOTTOM[(i + 1) % 4], BOTTOM[i]))
    tris.append((TOP[0], TOP[1], TOP[2]))  # top, facing up
    tris.append((TOP[0], TOP[2], TOP[3]))
    for i in range(4):  # sides
        j = (i + 1) % 4
        tris.append((BOTTOM[i], BOTTOM[j], TOP[j]))
        tris.append((BOTTOM[i], TOP[j], TOP[i]))
    return tris


def normal(a, b, c):
    u = [b[k] - a[k] for k in range(3)]
    v = [c[k] - a[k] for k in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    length = sum(x * x for x in n) ** 0.5
    return [x / length for x in n]


def write_stl(path, tris):
    with open(path, "wb") as f:
        f.write(b"doppel test foot, millimetres".ljust(80, b" "))
        f.write(struct.pack("<I", len(tris)))
        for t in tris:
            f.write(struct.pack("<3f", *normal(*t)))
            for v in t:
                f.write(struct.pack("<3f", *v))
            f.write(struct.pack("<H", 0))


def write_dae(path, tris):
    verts = []
    for t in tris:
        for v in t:
            if v not in verts:
                verts.append(v)
    idx = " ".join(str(verts.index(v)) for t in tris for v in t)
    pos = " ".join("%g %g %g" % v for v in verts)
    with open(path, "w") as f:
        f.write(f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="millimeter" meter="0.001"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries>
    <geometry id="foot" name="foot">
      <mesh>
        <source id="foot-pos">
          <float_array id="foot-pos-array" count="{3 * len(verts)}">{pos}</float_array>
          <technique_common>
            <accessor source="#foot-pos-array" count="{len(verts)}" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="foot-vtx"><input semantic="POSITION" source="#foot-pos"/></vertices>
        <triangles count="{len(tris)}"><input semantic="VERTEX" source="#foot-vtx" offset="0"/><p>{idx}</p></triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene">
      <node id="foot-node"><instance_geometry url="#foot"/></node>
    </visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
""")


if __name__ == "__main__":
    write_stl("doppel_test_meshes/meshes/foot.stl", triangles())
    write_dae("meshes/foot.dae", triangles())
    write_stl("meshes/flat.stl", [((0, 0, 0), (10, 0, 0), (0, 10, 0))])
    with open("meshes/broken.stl", "wb") as f:
        f.write(bytes((i * 37 + 11) % 256 for i in range(40)))
